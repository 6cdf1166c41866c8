"""Walls: a grid's head above the opening (a splayed or sparse face's hole) comes down
to the soffit's narrowest section (church draw 4: pointed heads 8-17 cm high)."""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.walls.reveals import soffit_head

HEAD, HALF_W = 12.29, 0.94  # church draw 4, south window 3: 1.88 m wide, pointed
GLASS, HALF = 0.0, 0.232  # the glass's depth, half the wall's thickness (m)


def _soffit(rng: np.random.Generator, splay: float = 0.2) -> tuple[np.ndarray, np.ndarray]:
    """Points ``(u, z)`` and depth of a soffit over the centre of a window: straight
    at ``HEAD`` from the outer face (depth +``HALF``) to the glass, rising by
    ``splay`` from there to the inner face; the glass under it."""
    d = rng.uniform(-HALF + 0.03, HALF - 0.03, 300)
    u = rng.uniform(-0.05, 0.05, 300)
    z = HEAD + np.clip(GLASS - d, 0.0, None) / HALF * splay + rng.normal(0, 0.003, 300)
    glass = np.c_[rng.uniform(-0.05, 0.05, 100), rng.uniform(HEAD - 0.6, HEAD - 0.005, 100)]
    return np.r_[np.c_[u, z], glass], np.r_[d, np.full(len(glass), GLASS)]


def test_the_soffit_under_a_high_grid_head() -> None:
    """Church draw 4, south window 3: the grid's head 13 cm over the true one (the
    inner face's hole, splayed by 0.2 m; the outer face 18 cm between points).  Over
    the grid's head only the splayed soffit stands, rising to the inner face (12.45 m,
    the head 16 cm high); searched from a splay under it, the lowest top over the
    depths is the straight soffit's, the head.  (No lower than the glass's highest
    returns: ``test_walls_clerestory``, a window lined by its glass only, a few returns
    over the centre, the highest 20 cm under the head.)"""
    rng = np.random.default_rng(4)
    uz, depth = _soffit(rng)
    z1 = HEAD + 0.13
    assert soffit_head(uz, depth, -HALF_W, HALF_W, z1, 0.05) > HEAD + 0.05
    below = soffit_head(uz, depth, -HALF_W, HALF_W, z1, 0.05, below_m=0.4)
    assert below == pytest.approx(HEAD, abs=0.01)


@pytest.mark.slow
def test_heads_of_draw_4() -> None:
    """Church draw 4, south windows 3, 4 and 5: pointed, 1.84-1.88 m wide, in a 0.46 m
    wall splayed by 0.2 m inside; both faces 6-18 cm between points, and the grid's
    heads 8-17 cm over the apexes."""
    from church_walls import church_walls, nearest_opening

    r, objs = church_walls(4)
    for inst in (3, 4, 5):
        win = next(o for o in objs if o["class"] == "window" and o["instance"] == inst)
        best, dist = nearest_opening(r, win)
        assert best is not None and dist < 0.3
        assert best.z_max == pytest.approx(win["sill_z_m"] + win["height_m"], abs=0.05)
