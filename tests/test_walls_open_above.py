"""Walls: an empty band between a wall's top and a few returns above it, which raise the
envelope's top over a stretch, is open to the top and no window
(``pyheracles.walls.outlines``: a hole reaching the envelope's top over most of its
columns is not enclosed)."""

from __future__ import annotations

import numpy as np
import pytest

pytestmark = pytest.mark.slow  # simulates a church draw: about 20 s each


@pytest.mark.parametrize("noise_draw", [0, 2])
def test_church23_north_wall_has_no_window_over_its_top(noise_draw: int) -> None:
    """Church draw 23's north wall: a 0.3 x 0.46 m window stood between the wall's top
    (7.24 m) and a few returns 0.5 m above it; its eight lights (three of them 0.34 m
    wide, cut across by stray returns, :mod:`pyheracles.walls.bands`) are its eight
    openings, one each, on the draw's own scan and on noise draw 2."""
    from church_walls import openings_over, wall_crop
    from pyheracles.walls import segment_walls

    xyz, tw, ops = wall_crop(23, "north", noise_draw)
    n = np.asarray(tw["outer_plane"]["normal"])
    r = segment_walls(xyz)
    w = max(r.walls, key=lambda w: w.n_points if abs(w.normal @ n) > 0.99 else 0)
    assert openings_over(w, ops) == [1] * len(ops)
    assert len(w.openings) == len(ops)
    top = max(np.asarray(o["box_corners_m"])[:, 2].max() for o in ops)
    assert all(o.z_min < top for o in w.openings)
