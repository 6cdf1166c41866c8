"""Walls: a window's sill at the glass's foot where the sill's splay is seen under it
(church draw 1: sills of a splayed face's hole and of a sparse face 6-27 cm low)."""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.walls.outlines import sill_faces, sill_reach
from pyheracles.walls.reveals import glass_sill

U0, U1, SILL, HEAD = -3.73, -2.97, 2.27, 5.22  # church draw 1, north window 14
HALF, GLASS = 0.58, -0.375  # half the wall's thickness; the glass's depth (m)
HOLE = (-3.86, -2.96, 2.017, 5.267)  # the grid's: the splayed inner face's hole


def _window(rng: np.random.Generator, splay: float, seen: tuple[float, float] = (0.0, 1.0),
            hidden_m: float = 0.0) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """Points ``(u, z)`` and depth between the faces of a window in a 1.16 m wall:
    glass at depth ``GLASS`` from ``hidden_m`` over the sill up, straight reveals from
    the glass to the outer face and reveals splayed by ``splay`` from it to the inner
    face (depth -``HALF``), the sill's splay seen over the share ``seen`` of its depth
    from the glass; with no splay, mixed pixels on rays grazing the inner edge of the
    sill on their way to the glass's lowest returns."""
    n = 400
    glass = np.c_[rng.uniform(U0, U1, n), rng.uniform(SILL + hidden_m, HEAD, n)]
    d_glass = GLASS + rng.normal(0, 0.003, n)
    t = rng.uniform(0.0, 1.0, 2 * n)  # 0 at the glass, 1 at the inner face
    z = rng.uniform(SILL, HEAD - 0.5, 2 * n)
    jambs = np.c_[np.where(np.arange(2 * n) < n, U0 - splay * t, U1 + splay * t), z]
    d_jambs = GLASS - t * (HALF - 0.03 + GLASS)
    straight = np.c_[np.where(np.arange(n) < n // 2, U0, U1), rng.uniform(SILL, HEAD - 0.5, n)]
    d_straight = rng.uniform(GLASS + 0.03, HALF - 0.03, n)
    s = rng.uniform(*seen, 60)
    if splay > 0:
        sill = np.c_[rng.uniform(U0, U1, 60), SILL - splay * s]
    else:  # the mixed pixels of rays from the sill's inner edge to the glass's foot
        sill = np.c_[rng.uniform(U0, U1, 60), SILL + hidden_m * (1 - s)]
    d_sill = GLASS - s * (HALF - 0.03 + GLASS)
    uz = np.r_[glass, jambs, straight, sill]
    return uz, np.r_[d_glass, d_jambs, d_straight, d_sill]


def test_the_glass_foot_over_a_seen_splay_is_the_sill() -> None:
    """Church draw 1, north window 14 (a 1.16 m wall, glass 0.95 m deep, reveals splayed
    by 0.27 m to the inner face): the inner face's hole put the sill 27 cm low; the
    splay is seen under the glass, whose lowest returns are the sill (within the
    splay's fall over ``pane_m`` from the glass: its points there read as glass)."""
    rng = np.random.default_rng(1)
    uz, depth = _window(rng, 0.267)
    assert glass_sill(uz, depth, HOLE, (U0, U1)) == pytest.approx(SILL, abs=0.04)


def test_no_sill_from_the_glass_without_a_seen_splay() -> None:
    """Straight reveals (church draw 2: glass seen from 12 cm over its sill, and mixed
    pixels under it on rays grazing the sill's edge), a splay seen only at its foot,
    25 cm under glass seen from 15 cm over the sill (church draw 4's south window 6),
    and a splay not seen: no sill."""
    rng = np.random.default_rng(2)
    uz, depth = _window(rng, 0.0, hidden_m=0.12)
    assert np.isnan(glass_sill(uz, depth, HOLE, (U0, U1)))
    uz, depth = _window(rng, 0.2, seen=(0.6, 1.0), hidden_m=0.15)
    assert np.isnan(glass_sill(uz, depth, HOLE, (U0, U1)))
    uz, depth = _window(rng, 0.2, seen=(0.0, 0.0), hidden_m=0.15)
    keep = depth > GLASS - 0.01  # nothing of the sill's splay
    assert np.isnan(glass_sill(uz[keep], depth[keep], HOLE, (U0, U1)))


def test_a_straight_faces_sill_is_lifted_by_its_spacing_only() -> None:
    """Church draw 7, south window 9: the outer face (3.6 cm between points, its jambs
    the window's) measured the sill; the glass's lowest returns, 8 cm over it, may not
    lift it; nor a splayed face's (its splay measured, it was moved in by it).  A face
    whose jambs are not measured and the grid may be a splay low."""
    faces = np.array([[-14.579, -13.915, np.nan, 12.221], [-14.496, -14.002, 7.836, 12.149],
                      [np.nan, np.nan, 7.7, np.nan]])  # fmt: skip
    spacing = np.array([0.045, 0.036, 0.05])
    edges = (-14.496, -14.002, 7.836, 12.149)
    assert sill_reach([1], faces, spacing, edges) == pytest.approx(0.036)
    assert sill_reach([0], faces, spacing, edges) == pytest.approx(0.045)
    assert sill_reach([2], faces, spacing, edges) == pytest.approx(0.4)
    assert sill_reach([], faces, spacing, edges) == pytest.approx(0.4)
    assert sill_reach([2, 1], faces, spacing, edges) == pytest.approx(0.036)


def test_the_faces_under_a_grids_sill() -> None:
    """Church draw 22, north window 18: the grid's sill 4.5 cm low, set by the outer
    face (12.5 cm between points, its jambs the window's) whose points stand under it;
    the glass 9 cm over the sill may not lift it by more than that face's spacing.  The
    inner face, open a splay lower, does not set it."""
    rng = np.random.default_rng(22)
    u0, u1, z0 = -19.62, -18.45, 4.445
    outer = np.c_[rng.uniform(u0 - 0.5, u1 + 0.5, 400), rng.uniform(z0 - 1.5, z0 - 0.01, 400)]
    inner = np.c_[rng.uniform(u0 - 0.5, u1 + 0.5, 400), rng.uniform(z0 - 1.5, z0 - 0.2, 400)]
    uz = np.r_[outer, inner]
    face_of = np.repeat([1, 0], 400)
    spacing = np.array([0.05, 0.125])  # rows: face 0 (inner), face 1 (outer)
    assert sill_faces(uz, face_of, (u0, u1, z0, 6.34), spacing, 0.05) == [1]


@pytest.mark.slow
def test_sills_of_draw_1() -> None:
    """Church draw 1, north windows 13 and 14: round, in a 1.16 m wall, splayed by
    0.27 m to the inner face; a sparse outer face and the inner face's hole put the
    sills 6 and 27 cm low."""
    from church_walls import church_walls, nearest_opening

    r, objs = church_walls(1)
    for inst in (13, 14):
        win = next(o for o in objs if o["class"] == "window" and o["instance"] == inst)
        best, dist = nearest_opening(r, win)
        assert best is not None and dist < 0.6  # centres: the wall's, the glass's 0.37 m off
        assert best.z_min == pytest.approx(win["sill_z_m"], abs=0.05)
