"""Walls: a mullion's column of cells broken by a few lost points is bridged, and only
such a column (:func:`pyheracles.walls.planes.bridge_mullions`)."""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from pyheracles.walls.planes import bridge_mullions


def _window() -> np.ndarray:
    """A wall (axis 0 along it, axis 1 up) with two lights 10 cells wide and 40 high
    either side of a mullion 3 cells wide."""
    occ = np.ones((40, 60), dtype=bool)
    occ[5:15, 10:50] = False
    occ[18:28, 10:50] = False
    return occ


def test_a_gap_in_a_mullion_is_bridged_and_the_lights_stay_two() -> None:
    occ = _window()
    occ[15:18, 30:37] = False  # 7 cells of the mullion lost: the lights join there
    assert ndimage.label(~occ)[1] == 1  # the two lights, joined
    out = occ | bridge_mullions(occ, 8, 5)
    assert ndimage.label(~out)[1] == 2
    assert np.array_equal(out, _window())


def test_a_gap_longer_than_allowed_or_a_small_window_stays_open() -> None:
    occ = _window()
    occ[15:18, 30:40] = False  # 10 cells: more than the 8 allowed
    assert not bridge_mullions(occ, 8, 5).any()
    small = np.ones((30, 30), dtype=bool)
    small[10:16, 10:16] = False  # 6 x 6: between its sill and head all across
    assert not bridge_mullions(small, 8, 5).any()


def test_scan_columns_of_a_sparse_face_are_no_mullion() -> None:
    """A face whose scan columns, 3 cells apart, stand beside a light: its columns have
    no hole an opening wide on both sides, and a gap in them is not bridged (it is the
    face's closing's to fill or not)."""
    occ = np.ones((40, 60), dtype=bool)
    occ[20:30, 10:50] = False  # a light
    occ[1:20:3, :] = False  # the face left of it: columns 2 cells wide, 1 apart
    occ[0:20, 30:35] = False  # a stretch no column returned
    assert not bridge_mullions(occ, 8, 5)[:20].any()


def test_returns_along_both_jambs_make_no_transom() -> None:
    """A light 14 cells wide with the reveals' returns standing 2 cells out from both
    jambs over 3 rows (the gap between them 10 cells, within the 12 allowed): a run is
    followed up columns only, and no transom joins them (church draw 10: a window
    split across, 1.28 m short, with rows bridged too)."""
    from pyheracles.walls.planes import bridge_runs

    occ = np.ones((40, 60), dtype=bool)
    occ[10:24, 10:50] = False
    occ[10:12, 30:33] = True
    occ[22:24, 30:33] = True
    assert not bridge_runs(occ, 12)[10:24].any()
