"""A support reaches what it carries (issue 12, mode 8: clutter taken for supports).

Built from draws 12, 16, 25 and 32 of the supports family (standing buildings): the
post of a pulpit whose tub's underside went unseen, a fence's bars and a pew "carried"
the ceiling, the attic or the vault found 1-3 m above their own tops, and were judged
by that surface's height: they were supports.  In a standing building a column (or a
sparse pier) that ends short of what it carries, under something it holds up (the
tub's sides, the rails, the pew's back round its top), is judged by its own top
(:func:`~pyheracles.supports.carriers.low_carriers` with ``reaches`` and ``overhead``).
"""

from __future__ import annotations

import numpy as np

from pyheracles.supports import SupportParams, detect_supports
from pyheracles.supports.carriers import low_carriers


def _plate(x0: float, x1: float, y0: float, y1: float, z: float, step: float) -> np.ndarray:
    gx, gy = np.meshgrid(np.arange(x0, x1 + 1e-9, step), np.arange(y0, y1 + 1e-9, step))
    return np.c_[gx.ravel(), gy.ravel(), np.full(gx.size, z)]


def _tube(centre, radius: float, z0: float, z1: float, step: float) -> np.ndarray:
    n = max(8, int(2 * np.pi * radius / step))
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    tt, zz = np.meshgrid(t, np.arange(z0, z1 + 1e-9, step))
    return np.c_[
        centre[0] + radius * np.cos(tt.ravel()), centre[1] + radius * np.sin(tt.ravel()), zz.ravel()
    ]


def _tub_sides(centre, z: float, step: float) -> np.ndarray:
    """The four sides of a pulpit's 1.2 x 1.0 m tub, 1.05 m high from ``z`` (its
    underside, level with the scanners, unseen)."""
    cx, cy = centre
    out = []
    for x in (cx - 0.6, cx + 0.6):
        g = _plate(cy - 0.5, cy + 0.5, z, z + 1.05, 0.0, step)
        out.append(np.c_[np.full(len(g), x), g[:, 0], g[:, 1]])
    for y in (cy - 0.5, cy + 0.5):
        g = _plate(cx - 0.6, cx + 0.6, z, z + 1.05, 0.0, step)
        out.append(np.c_[g[:, 0], np.full(len(g), y), g[:, 1]])
    return np.vstack(out)


def test_pulpit_post_under_a_high_ceiling_is_no_column() -> None:
    """Draw 16 (a portico under a flat ceiling at 3.44 m): a pulpit post 0.12 m in
    radius, 1.93 m tall, its tub's underside unseen, "carried" the ceiling (0.56 of the
    way up to it) and was a column.  It ends short of what it carries: judged by its own
    top it stays in the body; the four columns carrying the ceiling are found."""
    step = 0.03
    parts = [_plate(0.0, 9.0, 0.0, 6.0, 0.0, step), _plate(0.0, 9.0, 0.0, 6.0, 3.44, step)]
    for x in (1.5, 3.5, 5.5, 7.5):
        parts.append(_tube((x, 1.5), 0.29, 0.0, 3.44, step))
    parts += [_tube((4.5, 4.0), 0.12, 0.0, 1.93, step), _tub_sides((4.5, 4.0), 1.93, step)]
    rng = np.random.default_rng(16)
    xyz = np.vstack(parts)
    xyz = xyz + rng.normal(0, 0.002, xyz.shape)
    found = detect_supports(xyz, SupportParams(section_height_m=1.0))
    assert list(found.objects["class"]) == ["column"] * 4, found.objects
    post = np.hypot(xyz[:, 0] - 4.5, xyz[:, 1] - 4.0) < 0.3
    assert not found.instance[post].any()


def test_short_carriers_judged_by_their_own_top() -> None:
    """Rows like those of draws 12, 16, 25, 32 and 33 (floor, top, what they carry and
    the cover round their tops; draw 12's post, on a podium 0.82 m high, ended 0.52 of
    the way up to the attic): in a standing building the columns and sparse piers that
    do not reach what they carry, with something round their tops, go when their own
    top lies below 0.8 of the way up to the carried level.  A column seen from 1.35 to
    2.58 m that reaches the ceiling stays (draw 36), and so do a column whose top is
    open, its upper part lost (draw 33), an arcade's pier that ends below the arches it
    was found under (draw 32: piers are judged by what they carry), and, in a ruin, a
    column under what it does not carry (judged by what stands over it:
    covered_free_columns)."""
    col = {"class": "column", "z_min": 0.0, "z_max": 3.43}
    rows = [col] * 5 + [
        {"class": "column", "z_min": 0.0, "z_max": 1.93},  # draw 16: a pulpit post
        {"class": "column", "z_min": 0.82, "z_max": 2.18},  # a post on a podium (draw 12)
        {"class": "pier", "z_min": 0.47, "z_max": 2.74},  # draw 25: a fence's bars (sparse)
        {"class": "column", "z_min": 0.66, "z_max": 2.25},  # draw 32: a pew
        {"class": "column", "z_min": 1.35, "z_max": 2.58},  # draw 36: foot unseen
        {"class": "pier", "z_min": 0.0, "z_max": 2.6},  # an arcade's pier
        {"class": "column", "z_min": 0.0, "z_max": 2.2},  # draw 33: its upper part lost
    ]
    carries = [True] * 12
    carried_z = [3.44] * 12
    sparse = [False] * 7 + [True] + [False] * 4
    reaches = [True] * 5 + [False] * 4 + [True, False, False]
    cover = [0.0] * 5 + [0.36, 0.28, 0.17, 0.17, 0.0, 0.0, 0.0]
    assert low_carriers(rows, carries, carried_z, sparse) == set()  # what they "carry"
    assert low_carriers(rows, carries, carried_z, sparse, reaches, cover) == {5, 6, 7, 8}
    ruin = [False] * 5 + [True] * 4 + [False] * 3  # most carry nothing: the old judgement
    assert low_carriers(rows, ruin, carried_z, sparse, reaches, cover) == low_carriers(
        rows, ruin, carried_z, sparse
    )
