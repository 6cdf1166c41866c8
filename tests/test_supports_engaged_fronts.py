"""Engaged columns told by the wall face line their ring meets and by the arc of their
front (:mod:`pyheracles.supports.engaged_fronts`).

Draw 38 of the supports family: engaged columns of 0.94 m radius, their axes 0.30 m in
front of the wall's face, were classed free-standing: beside the shafts the wall held
15-66 points within 1.9 m of the axis in the 0.6 m slab (shadowed by the shaft, a
window), its face seen over 0.89 m on one side only, less than the radius the local
test (:func:`~pyheracles.supports.rings.wall_face_beside`) asks for.  The wall's face is
a line of the slab over metres on both sides of the column.
"""

from __future__ import annotations

import numpy as np

from pyheracles.supports.core import Scales
from pyheracles.supports.engaged_faces import engage_on_wall_faces

SC = Scales(spacing=0.02, distance=0.08, thickness=0.1, tol=0.02)
R = 0.94  # draw 38's columns
OFFSET = 0.30  # the axis in front of the wall face (room on +y)
H = 1.0  # the section's height


def _grid(xs: np.ndarray, y: float, rng: np.random.Generator) -> np.ndarray:
    zs = np.arange(H - 0.3, H + 0.3, 0.05)
    x, z = np.meshgrid(xs, zs)
    return np.c_[x.ravel(), y + rng.normal(0.0, 0.002, x.size), z.ravel()]


def _ring(centre: np.ndarray, lo: float, hi: float, rng: np.random.Generator) -> np.ndarray:
    """The column's surface between the azimuths ``lo`` and ``hi`` (radians) over the slab."""
    a = np.linspace(lo, hi, 120)
    zs = np.arange(H - 0.3, H + 0.3, 0.02)
    aa, zz = np.meshgrid(a, zs)
    r = R + rng.normal(0.0, 0.002, aa.size)
    return np.c_[centre[0] + r * np.cos(aa.ravel()), centre[1] + r * np.sin(aa.ravel()), zz.ravel()]


def _engage(p: np.ndarray, centre: np.ndarray) -> dict:
    order = np.argsort(p[:, 2], kind="stable")
    sh = {"class": "column", "centre": centre.astype(float), "radius": R,
          "half": np.array([R, R]), "angle": 0.0}  # fmt: skip
    engage_on_wall_faces(p, order, p[order, 2], [sh], H, SC, np.random.default_rng(0))
    return sh


def _wall(rng: np.random.Generator, near_gap: float) -> np.ndarray:
    """The wall face y = 0 over 12 m, seen sparsely (9 cm along) beyond ``near_gap`` of
    the column's axis on one side and 2.5 m on the other (a window beside the column)."""
    xs = np.arange(-6.0, 6.0, 0.09)
    keep = (xs > near_gap) | (xs < -2.5)
    return _grid(xs[keep], 0.0, rng)


def test_ring_meeting_a_shadowed_wall_face_line_is_engaged() -> None:
    rng = np.random.default_rng(38)
    c = np.array([0.0, OFFSET])
    a = np.arcsin(OFFSET / R)
    ring = _ring(c, -a, np.pi + a, rng)  # the part of the ring in front of the face
    # the face beside the shaft is shadowed: seen from 1.1 m of the axis on, up to 1.94 m
    # (the local test's reach) only 0.84 m of it, less than the radius
    sh = _engage(np.vstack([ring, _wall(rng, 1.1)]), c)
    assert sh["class"] == "engaged_column"
    assert sh["normal"][1] > 0.99 and abs(sh["d"]) < 0.01


def test_ring_seen_from_one_side_in_front_of_a_wall_stays_free() -> None:
    rng = np.random.default_rng(39)
    # a free column 0.5 m clear of the wall, seen from the room side only
    c = np.array([0.0, R + 0.5])
    sh = _engage(np.vstack([_ring(c, 0.0, np.pi, rng), _wall(rng, 1.1)]), c)
    assert sh["class"] == "column"


def test_ring_on_the_line_of_a_wall_beyond_its_end_stays_free() -> None:
    rng = np.random.default_rng(40)
    # a column seen from the room side on the line of a wall face ending 3 m from it
    c = np.array([0.0, OFFSET])
    xs = np.arange(-9.0, -3.0, 0.09)
    sh = _engage(np.vstack([_ring(c, 0.0, np.pi, rng), _grid(xs, 0.0, rng)]), c)
    assert sh["class"] == "column"


def _bump_arc(r: float, offset: float, rng: np.random.Generator, n: int = 80) -> np.ndarray:
    """Section points of an engaged column's front out of the face y = 0 (room +y), its
    axis ``offset`` in front of the face."""
    a = np.arcsin(min(offset / r, 1.0))
    t = np.linspace(-a, np.pi + a, n)
    return np.c_[r * np.cos(t), offset + r * np.sin(t)] + rng.normal(0.0, 0.002, (n, 2))


def _bump_rect(width: float, depth: float, rng: np.random.Generator) -> np.ndarray:
    """Section points of a respond's outline out of the face y = 0: two sides, a front."""
    ys = np.arange(0.0, depth, 0.01)
    xs = np.arange(-width / 2, width / 2, 0.01)
    pts = np.vstack([np.c_[np.full(ys.size, -width / 2), ys], np.c_[xs, np.full(xs.size, depth)],
                     np.c_[np.full(ys.size, width / 2), ys]])  # fmt: skip
    return pts + rng.normal(0.0, 0.002, pts.shape)


def test_an_arc_front_is_an_engaged_column_a_flat_front_a_respond() -> None:
    """Draws 0 and 7: half columns of 0.2-0.3 m on a wall were outlined as responds (a
    rectangle of the arc's extent out of the face)."""
    from pyheracles.supports.responds import against_face, bump_on_face

    rng = np.random.default_rng(7)
    n, d = np.array([0.0, 1.0]), 0.0
    for r, offset in ((0.2, 0.0), (0.3, 0.1), (0.9, 0.3)):
        p = _bump_arc(r, offset, rng)
        bump = (1.0, float(p[:, 0].min()), float(p[:, 0].max()), float(p[:, 1].max()))
        sh = against_face(p, bump, n, d, 0.002, 0.02)
        assert sh["class"] == "engaged_column", (r, offset)
        assert abs(sh["radius"] - r) < 0.02 and abs(sh["centre"][1] - offset) < 0.02
        assert sh["normal"][1] > 0.99
    for width, depth in ((0.4, 0.3), (0.6, 0.2), (1.0, 0.5)):
        p = _bump_rect(width, depth, rng)
        bump = bump_on_face(p, n, d, 0.02, 0.04)
        assert bump is not None
        assert against_face(p, bump, n, d, 0.002, 0.02)["class"] == "pier", (width, depth)
