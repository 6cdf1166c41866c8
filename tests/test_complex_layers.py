"""A point of the buffer ring goes to the nearest feature of any layer (issue 17).

Built from complex-family draw 0: the gate layer was processed before the walls, and the
gate's buffer took the end of the wall beside it (a point 0.15 m from the wall's polygon
and 0.5 m from the gate's); the gate G01 scored F1 0.895.
"""

from __future__ import annotations

import numpy as np
import shapely

from pyheracles.complex.cookie import GridIndex, nearest_layer
from test_complex_foliage import run_complex_draw


def _layers():
    gate = np.array([shapely.box(0.0, 0.0, 2.0, 2.0)], dtype=object)
    wall = np.array([shapely.box(2.5, 0.5, 10.0, 1.0)], dtype=object)
    return {"gate": gate, "wall": wall}


def test_a_ring_point_is_left_to_the_nearer_feature_of_another_layer() -> None:
    xyz = np.array(
        [
            [2.35, 0.7, 1.5],  # 0.35 from the gate, 0.15 from the wall: the wall's
            [2.05, 0.7, 1.5],  # 0.05 from the gate, 0.45 from the wall: the gate's
            [2.35, 0.8, 4.0],  # as the first, but above the wall's top: the gate's
            [2.25, 0.7, 1.5],  # as far from both: each may take it
            [1.0, 1.0, 3.0],  # inside the gate
            [6.0, 0.7, 2.0],  # inside the wall
        ]
    )
    outside = np.array([True, True, True, True, False, False])
    tops = {"gate": np.array([4.0]), "wall": np.array([2.5])}
    got = nearest_layer(_layers(), 1.0, xyz, GridIndex(xyz[:, :2], 5.0), outside, tops)
    assert got["gate"].tolist() == [True, False, False, False, False, False]
    assert got["wall"].tolist() == [False, True, True, False, False, False]
    # a polygon with no point inside has no top: it claims nothing, the gate all four
    tops["wall"] = np.array([np.nan])
    got = nearest_layer(_layers(), 1.0, xyz, GridIndex(xyz[:, :2], 5.0), outside, tops)
    assert not got["gate"].any() and got["wall"].tolist() == outside.tolist()


def test_draw_0_gate_leaves_the_wall_end_to_the_wall() -> None:
    _, f1 = run_complex_draw(0)
    assert f1["gate/G01"] >= 0.9, f1["gate/G01"]
