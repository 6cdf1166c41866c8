"""Walls: a strip of face between a corner and a tower pairs with the wall's other face."""

from __future__ import annotations

import numpy as np

from church_walls import faces_along_x
from pyheracles.walls.model import WallParams
from pyheracles.walls.pairing import pair_faces


def test_strip_beside_a_tower_pairs_with_the_inner_face() -> None:
    """Church draw 3, west wall (0.87 m): its inner face runs 6.7 m between the side
    walls' inner faces; outside, the tower covers the middle and leaves a strip of
    outer face at each end, 1.2-1.3 m long, of which 0.8-0.9 m (the side walls'
    thickness) runs past the inner face's end at the corner.  The strips shared 39 %
    and 47 % of their cells with the inner face (half needed), never paired, and the
    wall was found on its inner face only.  Cells past the other face's end in their
    row, by up to the faces' separation, count as shared now."""
    rng = np.random.default_rng(3)
    inner = np.c_[np.full(60000, 0.866), rng.uniform(-3.33, 3.33, 60000),
                  rng.uniform(0.0, 13.5, 60000)]  # fmt: skip
    strip = np.c_[np.zeros(8000), rng.uniform(2.96, 4.15, 8000), rng.uniform(-0.3, 13.0, 8000)]
    tower = np.c_[np.zeros(8000), rng.uniform(-2.86, 2.86, 8000), rng.uniform(16.8, 24.5, 8000)]
    xyz, faces = faces_along_x(inner, strip, tower)
    assert pair_faces(xyz, faces, WallParams()) == [(0, 1), (2,)]  # the tower stays alone


def test_shared_cells_reach_past_the_end_in_the_row_only() -> None:
    """Cells past the big face's end count up to ``reach`` cells, in rows it has; cells
    in a row it lacks do not."""
    from pyheracles.walls.pairing import shared_cells

    key = lambda u, z: (np.int64(u) << 32) + np.int64(z)  # noqa: E731
    big = np.sort(np.array([key(u, z) for u in range(0, 10) for z in range(-3, 3)]))
    small = np.sort(np.array([key(u, z) for u in range(8, 15) for z in range(-3, 5)]))
    # rows -3..2 (6): u 8, 9 inside, 10-12 past within 3: 5 a row; rows 3, 4: none
    assert shared_cells(small, big, 3) == 30
    assert shared_cells(small, big, 0) == 12


def test_face_wholly_past_the_end_does_not_pair() -> None:
    """Church draw 8, east wall (1.03 m): a face 1.42 m inside the inner face and wholly
    past its end (u 5.95-6.92 m, the inner face ends at 5.9 m) shares no cell with it;
    counted as past the end, it took the inner face from the outer face's strip."""
    rng = np.random.default_rng(8)
    inner = np.c_[np.full(40000, 23.778), rng.uniform(-5.9, 5.9, 40000),
                  rng.uniform(0.3, 9.2, 40000)]  # fmt: skip
    strip = np.c_[np.full(3000, 24.805), rng.uniform(1.46, 2.6, 3000), rng.uniform(4.7, 8.2, 3000)]
    pier = np.c_[np.full(4000, 22.355), rng.uniform(5.95, 6.92, 4000), rng.uniform(1.8, 7.2, 4000)]
    xyz, faces = faces_along_x(inner, strip, pier)
    assert pair_faces(xyz, faces, WallParams()) == [(0, 1), (2,)]
