"""Piers seen face-on (issue 12, missed supports: sparse piers seen face-on).

A pier scanned from straight in front leaves one straight line of points in a section,
as a piece of wall does, and no island of a support (supports draw 27: a hypostyle
whose piers far from the one station inside are lines 0.15-1.0 m long; draw 37 alike).
A line of pier width whose ends are free and whose face rises from the floor is a pier
candidate (:func:`~pyheracles.supports.faceon.face_on_piers`) unless a wall goes on
from one of its ends: in line within the section (the pieces of an end wall between its
doors, draw 37), round a corner, in line below the section (a jamb's wall under the
sill) or the line is on the building's outline (nothing behind it).
"""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.supports.faceon import FaceOnParams, runs_on_in_line, wall_from_ends
from supports_draws import scored_supports_draw

TOL = 0.03  # surface tolerance, metres
BIN = 0.05  # cover bins, metres


def _line(x0: float, x1: float, y: float, step: float = 0.01) -> np.ndarray:
    x = np.arange(x0, x1, step)
    return np.c_[x, np.full(x.size, y)]


def _room(rng: np.random.Generator) -> np.ndarray:
    """Section points on both sides of the line y = 0 (the rest of a hall)."""
    return np.r_[_line(-6.0, 6.0, 4.0), _line(-6.0, 6.0, -3.0), rng.uniform(-5, 5, (200, 2))]


def _wall_from_ends(extra: np.ndarray, rng: np.random.Generator) -> bool:
    face = _line(-0.2, 0.2, 0.0) + rng.normal(0, 0.003, (40, 2))
    room = _room(rng)
    room = room[(np.abs(room[:, 1]) > 0.1) | (np.abs(room[:, 0]) > 2.0)]
    xy = np.r_[face, room, extra]
    own = np.arange(len(face))
    return wall_from_ends(xy, own, np.zeros(2), np.array([1.0, 0.0]), 0.4, TOL, BIN, FaceOnParams())


@pytest.mark.parametrize("seed", range(3))
def test_free_face_has_no_wall_at_its_ends(seed: int) -> None:
    rng = np.random.default_rng(seed)
    graze = np.c_[np.full(20, 0.2), np.linspace(-0.02, -0.35, 20)]  # a side seen at a graze
    assert not _wall_from_ends(graze, rng)


@pytest.mark.parametrize("seed", range(3))
def test_wall_piece_between_doors_is_walled_in_line(seed: int) -> None:
    # draw 37: the next piece of the end wall 0.55 m past the door, 1.2 m long, its line
    # off by one degree from the short face's
    rng = np.random.default_rng(seed)
    piece = _line(0.75, 1.95, 0.0)
    piece[:, 1] += np.tan(np.radians(1.0)) * piece[:, 0]
    assert _wall_from_ends(piece, rng)


@pytest.mark.parametrize("seed", range(3))
def test_wall_round_a_corner(seed: int) -> None:
    rng = np.random.default_rng(seed)
    side = np.c_[np.full(150, -0.2), np.linspace(0.05, 1.5, 150)]  # a side wall, 1.5 m seen
    assert _wall_from_ends(side, rng)


def test_face_on_the_outline() -> None:
    rng = np.random.default_rng(0)
    face = _line(-0.2, 0.2, 0.0)
    inside = np.c_[rng.uniform(-5, 5, 2000), rng.uniform(0.2, 8, 2000)]  # all in front
    xy = np.r_[face, inside]
    own = np.arange(len(face))
    assert wall_from_ends(xy, own, np.zeros(2), np.array([1.0, 0.0]), 0.4, TOL, BIN, FaceOnParams())


def test_jamb_walled_below_the_sill() -> None:
    """A jamb: the wall runs on from its end in the layers under the sill."""
    face = _line(-0.2, 0.2, 0.0, 0.005)
    below = np.r_[face, _line(0.23, 1.0, 0.0, 0.005)]  # under the sill: the wall goes on
    above = face  # beside the window: nothing in line
    runs = runs_on_in_line(
        [below] * 4 + [above] * 4, np.zeros(2), np.array([1.0, 0.0]), 0.4, TOL, 0.3, 0.5
    )
    assert runs.tolist() == [0, 4]
    free = runs_on_in_line([face] * 8, np.zeros(2), np.array([1.0, 0.0]), 0.4, TOL, 0.3, 0.5)
    assert free.tolist() == [0, 0]


@pytest.mark.slow
@pytest.mark.parametrize("noise_draw", [0])
def test_face_on_piers_draw_27(noise_draw: int) -> None:
    """Draw 27 of the supports family: 19 of 33 piers matched with 2 false supports
    before the face-on piers; with them at least 24, still 2 false at most."""
    m = scored_supports_draw(27, noise_draw=noise_draw)
    assert m["n_matched"] >= 24
    assert m["n_supports_found"] - m["n_matched"] <= 2
