"""A face-on line on the line of a wall at the building's scale is a piece of that wall
(issue 12, missed piers seen face-on).

Supports draws 11, 30 and 33: the inner face of a portico's back wall (and of a nave's
side wall) seen only from outside, through the colonnade, is cut into pieces by the
shadows of the supports; a piece of pier width has free ends and rises from the floor
like a pier seen face-on, but the wall's other pieces lie on its line metres away.  A
face-on pier in a row of piers has only its neighbours' faces, each shorter than a
support, on its line.
"""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.supports.faceon import on_wall_line, run_bounds
from supports_draws import scored_supports_draw

TOL = 0.03  # surface tolerance, metres
RUN = 2.5  # max_support_size_m
GAP = 0.2  # run gap, metres


def _line(x0: float, x1: float, y: float, step: float = 0.02) -> np.ndarray:
    x = np.arange(x0, x1, step)
    return np.c_[x, np.full(x.size, y)]


def _turned(xy: np.ndarray, deg: float) -> np.ndarray:
    a = np.radians(deg)
    return xy @ np.array([[np.cos(a), np.sin(a)], [-np.sin(a), np.cos(a)]])


def test_run_bounds() -> None:
    assert run_bounds(np.array([0.9, 0.0, 0.1, 0.25, 1.0]), 0.2) == [(0.0, 0.25), (0.9, 1.0)]
    assert run_bounds(np.array([1.0]), 0.2) == []


@pytest.mark.parametrize("deg", [0.0, 0.5, 1.0])
def test_piece_of_a_wall_seen_through_a_colonnade(deg: float) -> None:
    # draw 30: a 1.8 m piece at the corner, the wall's next pieces 8-29 m away on its
    # line; the face's own direction off by up to a degree from the wall's
    rng = np.random.default_rng(int(deg * 10))
    wall = np.r_[_line(8.0, 9.0, 0.0), _line(11.0, 13.0, 0.0), _line(19.5, 22.0, 0.0)]
    wall = np.r_[wall, _line(24.0, 29.0, 0.0)]
    xy = np.r_[wall, _line(-0.9, 0.9, 0.0)] + rng.normal(0, 0.003, (len(wall) + 90, 2))
    u = np.array([np.cos(np.radians(deg)), np.sin(np.radians(deg))])
    assert on_wall_line(xy, np.zeros(2), u, 1.8, TOL, RUN, GAP)
    assert not on_wall_line(xy[: len(wall) - 250], np.zeros(2), u, 1.8, TOL, RUN, GAP)


@pytest.mark.parametrize("seed", range(3))
def test_face_in_a_row_of_piers(seed: int) -> None:
    # draw 27: 0.7 m faces of a row of piers 3 m apart on one line, each shorter than a
    # support; and a wall behind them, off their line by 0.3 m
    rng = np.random.default_rng(seed)
    row = np.vstack([_line(x - 0.35, x + 0.35, 0.0) for x in np.arange(-15.0, 16.0, 3.0)])
    back = _line(-16.0, 16.0, 0.3)
    xy = np.r_[row, back] + rng.normal(0, 0.003, (len(row) + len(back), 2))
    assert not on_wall_line(xy, np.zeros(2), np.array([1.0, 0.0]), 0.7, TOL, RUN, GAP)


@pytest.mark.slow
@pytest.mark.parametrize("noise_draw", [0])
def test_back_wall_of_a_portico_is_no_pier_draw_30(noise_draw: int) -> None:
    """Draw 30 of the supports family (a portico seen from outside): the 1.8 m piece of
    the back wall's inner face at its corner was a face-on pier; on the wall's line, no
    support."""
    m = scored_supports_draw(30, noise_draw=noise_draw)
    assert m["n_supports_found"] == m["n_matched"]
