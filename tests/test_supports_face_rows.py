"""Engaged columns told by a neighbour's wall face: columns of a row standing as far in
front of the face an engaged column of that row found (issue 12, step 2a: engaged
columns classed free).

Supports draw 38 (a hypostyle, 0.94 m engaged columns 0.30 m in front of their walls,
stations in the room) found the wall faces beside two of its engaged columns (23, 24)
but not beside 20 (0.8 m of face in its window, less than its radius) nor 21 (found in
the low section, no face within 0.3 m of it): both were classed free.  Each stands as
far in front of the face its row's engaged column found, its circle crossing that face
(:func:`pyheracles.supports.face_rows.face_row_columns`).
"""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.supports.face_rows import face_row_columns
from supports_draws import scored_supports_draw

R, OFF, TOL = 0.94, 0.30, 0.03
UP = np.array([0.0, 1.0])


def _ring(c: np.ndarray, lo: float, hi: float, rng: np.random.Generator, n: int = 60):
    """``n`` points of the circle of radius R about ``c`` between angles ``lo`` and
    ``hi`` (radians from +x), 3 mm noise."""
    a = rng.uniform(lo, hi, n)
    return c + R * np.c_[np.cos(a), np.sin(a)] + rng.normal(0, 0.003, (n, 2))


def _face() -> list[tuple[np.ndarray, float, np.ndarray, float]]:
    """The face y = 0 (room at +y) found beside an engaged column at x = 0."""
    return [(np.array([0.0, OFF]), R, UP, 0.0)]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_column_as_far_in_front_of_the_face_is_engaged(seed: int) -> None:
    """A column of the same radius 5.35 m along the row, as far in front of the face,
    its ring seen from the room (its flanks shadowed short of the face): engaged."""
    rng = np.random.default_rng(seed)
    c = np.array([5.35, OFF])
    ring = _ring(c, 0.2, np.pi - 0.6, rng)
    found = face_row_columns(c[None], np.array([R]), [ring], _face(), TOL)
    assert found == {0: 0}


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_free_columns_are_not_engaged_by_a_face(seed: int) -> None:
    """Free: a column standing clear of the face (its ring in front of it), a ring going
    on behind the face line, a column of another radius."""
    rng = np.random.default_rng(seed)
    clear = np.array([5.35, R + 0.2])
    assert (
        face_row_columns(clear[None], np.array([R]), [_ring(clear, 0, np.pi, rng)], _face(), TOL)
        == {}
    )
    c = np.array([5.35, OFF])
    whole = _ring(c, 0.0, 2 * np.pi, rng)
    assert face_row_columns(c[None], np.array([R]), [whole], _face(), TOL) == {}
    small = np.array([5.35, OFF])
    ring = small + 0.5 * (_ring(np.zeros(2), 0.2, np.pi - 0.2, rng) / R)
    assert face_row_columns(small[None], np.array([0.5]), [ring], _face(), TOL) == {}


def test_faces_of_two_directions_leave_a_column_free() -> None:
    """A column as far in front of two faces of other directions (a corner): free."""
    rng = np.random.default_rng(0)
    c = np.array([OFF, OFF])
    faces = _face() + [(np.array([OFF, 5.0]), R, np.array([1.0, 0.0]), 0.0)]
    ring = _ring(c, 0.3, 1.3, rng)
    assert face_row_columns(c[None], np.array([R]), [ring], faces, TOL) == {}


@pytest.mark.slow
@pytest.mark.parametrize("noise_draw", [0, 1, 2, 3])
def test_draw_38_engaged_columns_of_a_row(noise_draw: int) -> None:
    """Draw 38: engaged columns 20 and 21 are engaged (before: free columns)."""
    m = scored_supports_draw(38, noise_draw=noise_draw)
    engaged_free = {f["instance"] for f in m["failures"] if f["mode"] == "engaged_as_column"}
    assert not engaged_free & {20, 21}
