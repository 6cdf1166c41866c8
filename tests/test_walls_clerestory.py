"""Walls: a clerestory window over an aisle's roof (church draws 12 and 15)."""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.walls import segment_walls

OUTER = (4.0, 5.0, 5.3, 7.3)  # the window's opening at the outer face: u0, u1, sill, head
SPLAY = 0.25  # the inner face's hole is this much wider on every side
ROOF = 5.35  # the outer face is seen from here up (the aisle's roof hides the rest)


def _face(rng: np.random.Generator, x: float, z0: float, hole: tuple[float, ...],
          spacing: float) -> np.ndarray:  # fmt: skip
    """A face ``x`` = const, 12 m long, from ``z0`` to 9 m, on a jittered grid, with a
    rectangular ``hole`` ``(u0, u1, z0, z1)``."""
    u, z = np.meshgrid(np.arange(0, 12, spacing), np.arange(z0, 9, spacing), indexing="ij")
    uz = np.c_[u.ravel(), z.ravel()] + rng.uniform(0, spacing, (u.size, 2))
    uz = uz[uz[:, 1] < 9]
    out = (uz[:, 0] > hole[0]) & (uz[:, 0] < hole[1]) & (uz[:, 1] > hole[2]) & (uz[:, 1] < hole[3])
    uz = uz[~out]
    return np.c_[np.full(len(uz), x) + rng.normal(0, 0.002, len(uz)), uz]


def _clerestory(n_glass: int) -> np.ndarray:
    rng = np.random.default_rng(12)
    u0, u1, s, h = OUTER
    inner_hole = (u0 - SPLAY, u1 + SPLAY, s - SPLAY, h + SPLAY)
    outer = _face(rng, 0.0, ROOF, OUTER, 0.08)  # scanned from afar, over the roof
    inner = _face(rng, 0.5, 0.0, inner_hole, 0.04)  # from the nave's floor up
    floor = np.c_[rng.uniform(0.6, 4.0, 20000), rng.uniform(0, 12, 20000),
                  rng.normal(0, 0.003, 20000)]  # fmt: skip
    # a few returns of the glass, 0.1 m behind the outer face, over the opening
    g = rng.uniform([u0, s], [u1, h], (n_glass, 2))
    glass = np.c_[0.1 + rng.normal(0, 0.004, n_glass), g]
    return np.vstack([outer, inner, floor, glass])


@pytest.mark.parametrize("n_glass", [150])
def test_clerestory_window_is_a_window_with_its_sill_measured(n_glass: int) -> None:
    """Church draws 12 and 15: a clerestory's outer face stands on the aisle's roof and
    is seen from a little above its windows' sills (the roof hides the rest), the
    inner face's holes are splayed 0.25 m wider.  The hole started at the outer face's
    foot and the windows were taken for doors, their sills the inner splay's (0.2-0.3 m
    low) and their jambs too (0.1-0.4 m wide).  A face whose foot stands 1.5 m over
    the wall's is on no floor; where it is open to its foot the glass spans the window."""
    r = segment_walls(_clerestory(n_glass))
    w = max(r.walls, key=lambda x: x.n_points)
    assert len(w.faces) == 2
    high = [o for o in w.openings if o.z_max > 6.0]
    assert len(high) == 1
    o = high[0]
    assert o.kind == "window"
    u0, u1, s, h = OUTER
    assert o.width_m == pytest.approx(u1 - u0, abs=0.05)
    assert o.z_min == pytest.approx(s, abs=0.05)
    assert o.height_m == pytest.approx(h - s, abs=0.05)
