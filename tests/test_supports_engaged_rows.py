"""Engaged columns told by their row: rings cut on one line, no floor seen behind it
(issue 12, step 2a: engaged columns classed free).

Supports draw 24 (a ruined hypostyle on a platform, all stations outside) has two rows
of 8 engaged columns (r 0.1 m, axis 0.023 m in front of the wall's face) whose ruin
walls end 0.5-1.2 m over the platform: at the section (2.3 m over it) there is no face
to find beside them, and all 16 were found as free columns.  Their rings stop on the
wall's plane at both ends of every arc, and the rings of a row on one line; through a
free colonnade seen from one side (draws 9 and 13: porticoes), whose arcs may stop on
one line too, the floor behind the line is seen
(:func:`pyheracles.supports.engaged_rows.row_cut_columns`).
"""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.supports.engaged_rows import RowCutParams, arc_cut, row_cut_columns
from supports_draws import scored_supports_draw

R, OFF, TOL = 0.1, 0.023, 0.03


def _arc(c: np.ndarray, lo: float, hi: float, rng: np.random.Generator, n: int = 150):
    """``n`` points of the circle of radius R about ``c`` between angles ``lo`` and
    ``hi`` (radians from +x), 3 mm noise."""
    a = rng.uniform(lo, hi, n)
    return c + R * np.c_[np.cos(a), np.sin(a)] + rng.normal(0, 0.003, (n, 2))


def _row(
    seed: int, lo: float, hi: float, n: int = 5, skew: float = 0.0
) -> tuple[np.ndarray, list[np.ndarray]]:
    """``n`` columns along x at y = 0, 2.7 m apart (as in draw 24), their rings seen
    between angles ``lo`` and ``hi``, turned by ``skew * k`` for the k-th column (the
    tangent rays of stations on one side turn from column to column)."""
    rng = np.random.default_rng(seed)
    centres = np.c_[2.7 * np.arange(n), np.zeros(n)]
    rings = [_arc(c, lo + skew * k, hi + skew * k, rng) for k, c in enumerate(centres)]
    return centres, rings


def _engaged_row(seed: int, n: int = 5):
    """Rings cut by a wall face OFF behind their centres (y = -OFF), room at +y."""
    back = np.arcsin(OFF / R)
    return _row(seed, -back, np.pi + back, n)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_row_of_rings_cut_on_one_line_is_engaged(seed: int) -> None:
    """Five rings stopping at y = -0.023 on both ends: engaged, the wall's face at the
    back of each ring (normal +y into the room)."""
    centres, rings = _engaged_row(seed)
    found = row_cut_columns(centres, np.full(5, R), rings, TOL, behind=lambda m, d, e: 0)
    assert sorted(found) == [0, 1, 2, 3, 4]
    for n, d in found.values():
        assert n @ np.array([0.0, 1.0]) > 0.99
        assert -OFF - 0.015 < d < -OFF + 0.015


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_floor_seen_behind_the_line_is_a_free_colonnade(seed: int) -> None:
    """The same arcs with the floor seen behind their line (2 points per metre of the
    row, a colonnade seen through): free."""
    centres, rings = _engaged_row(seed)
    length = float(np.ptp(centres[:, 0]))
    found = row_cut_columns(
        centres, np.full(5, R), rings, TOL, behind=lambda m, d, e: int(2 * length)
    )
    assert found == {}


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_full_rings_and_turning_arcs_are_free(seed: int) -> None:
    """Whole rings (seen from all round) and arcs whose ends turn from column to column
    (stations on one side, 25 degrees a column) are no cut rows."""
    centres, rings = _row(seed, 0.0, 2 * np.pi)
    assert row_cut_columns(centres, np.full(5, R), rings, TOL, behind=lambda m, d, e: 0) == {}
    centres, rings = _row(seed, -0.3, np.pi + 0.3, skew=np.radians(25))
    assert row_cut_columns(centres, np.full(5, R), rings, TOL, behind=lambda m, d, e: 0) == {}


def test_two_columns_are_no_row() -> None:
    """A row needs three columns."""
    centres, rings = _engaged_row(0, n=2)
    assert row_cut_columns(centres, np.full(2, R), rings, TOL, behind=lambda m, d, e: 0) == {}


def test_arc_cut_needs_both_ends_on_the_line() -> None:
    """An arc reaching the line at one end only (a ring seen from one oblique side) has
    no cut."""
    rng = np.random.default_rng(0)
    c = np.zeros(2)
    back = np.arcsin(OFF / R)
    both = _arc(c, -back, np.pi + back, rng)
    one = _arc(c, -back, np.pi - 0.6, rng)
    u, m = np.array([1.0, 0.0]), np.array([0.0, 1.0])
    b = arc_cut(both, c, R, u, m, TOL, RowCutParams())
    assert b is not None and -OFF - 0.015 < b < 0.0
    assert arc_cut(one, c, R, u, m, TOL, RowCutParams()) is None


@pytest.mark.slow
@pytest.mark.parametrize("noise_draw", [0, 1])
def test_draw_24_engaged_columns_of_a_ruin_are_engaged(noise_draw: int) -> None:
    """Draw 24: the engaged columns over the ruin walls are engaged (all 16 were found
    as free columns before: engaged_as_column 16)."""
    m = scored_supports_draw(24, noise_draw=noise_draw)
    eng = [f for f in m["failures"] if f["mode"] == "engaged_as_column"]
    assert len(eng) <= 5


@pytest.mark.slow
def test_draw_13_portico_seen_from_one_side_stays_free() -> None:
    """Draw 13: a portico whose arcs stop near one line (seen from one side), the floor
    seen behind it: every column stays free (25 of 25 classes right)."""
    m = scored_supports_draw(13)
    assert not any(f["mode"] == "wrong_class" for f in m["failures"])
    assert m["class_correct"] >= 25


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_rings_wrapping_far_behind_their_centres_are_free(seed: int) -> None:
    """A free row seen from one side whose arcs stop 0.6 r behind their centres, no
    floor seen behind it either (draw 24, noise draws 2 and 3: the free row beside the
    engaged one): no engaged column stands that far in front of its wall."""
    back = np.arcsin(0.6)
    centres, rings = _row(seed, -back, np.pi + back)
    assert row_cut_columns(centres, np.full(5, R), rings, TOL, behind=lambda m, d, e: 0) == {}
