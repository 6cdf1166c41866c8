"""Walls: a head nothing else measures is the top of the soffit between the faces
(church draws 17 and 18: pointed apexes closed in the grid, 6-13 cm short)."""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.walls.reveals import soffit_head

APEX, HALF_W = 9.594, 0.18  # church draw 17, east wall: a window 0.36 m wide


def _pointed_soffit(rng: np.random.Generator, splay: float = 0.0) -> tuple[np.ndarray, ...]:
    """Points of a pointed soffit (arcs of radius 0.3 m meeting at ``APEX``) between
    faces at depths -0.35 and +0.35 m, straight from -0.35 to +0.2 m and rising by
    ``splay`` from there to +0.35 m, and the glass at depth 0 below the head."""
    r = 0.3
    u = rng.uniform(-HALF_W, HALF_W, 4000)
    d = rng.uniform(-0.35, 0.35, 4000)
    centre = np.where(u < 0, r - HALF_W, HALF_W - r)  # each arc centred across the axis
    rise = np.sqrt(r**2 - (r - HALF_W) ** 2)
    z = APEX - rise + np.sqrt(np.maximum(r**2 - (u - centre) ** 2, 0.0))
    z += np.clip(d - 0.2, 0.0, None) / 0.15 * splay + rng.normal(0, 0.002, len(u))
    glass = np.c_[rng.uniform(-HALF_W, HALF_W, 300), rng.uniform(APEX - 1.0, APEX - 0.3, 300)]
    uz = np.r_[np.c_[u, z], glass]
    return uz, np.r_[d, np.zeros(len(glass))]


def test_the_soffits_top_is_the_apex() -> None:
    """The grid's head 12 cm under the apex (church draw 17): the soffit's top over the
    centre is the apex, and a splayed part rising 8 cm towards a face does not lift it;
    with nothing between the faces there is no head."""
    rng = np.random.default_rng(17)
    uz, depth = _pointed_soffit(rng)
    z1 = APEX - 0.12
    assert soffit_head(uz, depth, -HALF_W, HALF_W, z1, 0.05) == pytest.approx(APEX, abs=0.01)
    uz, depth = _pointed_soffit(rng, splay=0.08)
    assert soffit_head(uz, depth, -HALF_W, HALF_W, z1, 0.05) == pytest.approx(APEX, abs=0.01)
    assert np.isnan(soffit_head(uz[:0], depth[:0], -HALF_W, HALF_W, z1, 0.05))


@pytest.mark.slow
def test_pointed_heads_of_draw_17() -> None:
    """Church draw 17, windows 2 (south), 18 (north), 24 and 25 (east): pointed, in a
    0.69 m wall, both faces 6-13 cm between points; neither face nor the reveals
    measured the heads, and the grid's stood 6-10 cm under the apexes.  (Window 23,
    0.36 m wide, stays 12 cm short: among its few soffit points over the centre, one
    depth holds only points of the flanks.)"""
    from church_walls import church_walls, nearest_opening

    r, objs = church_walls(17)
    for inst in (2, 18, 24, 25):
        win = next(o for o in objs if o["class"] == "window" and o["instance"] == inst)
        best, dist = nearest_opening(r, win)
        assert best is not None and dist < 0.3
        assert best.height_m == pytest.approx(win["height_m"], abs=0.05)
        assert best.width_m == pytest.approx(win["width_m"], abs=0.05)
