"""Faces of one pier joined into one box before they become supports (issue 12).

A pier seen face-on leaves a straight line in the section
(:func:`~pyheracles.supports.faceon.face_on_piers`); a pier seen from two sides leaves
two such lines, or one line beside the island of its other faces, and each would be a
support of its own (supports draw 12: the front and the back face of one 0.72 x 0.64 m
pier, 0.64 m apart, two supports; draw 11: a 2.0 x 1.15 m pier whose left face is a
line and whose top and right faces are an island).  A face line and another face or
island are one box when the rectangle spanning them is no larger than a support, holds
nothing inside, and its outline turns a corner at an end of the face: the side of the
rectangle through that end holds points from the face's line to the far side, with no
gap wider than ``corner_gap_m`` (a side seen at a graze).  Two neighbouring piers are
not: the passage between them leaves the side through a face's end open.  A face
joined with a wall island is judged with it as one pier island (draw 28: the end face of
a piece of a front wall between two doors, its front and back faces wall islands 1.05
and 1.29 m long, is a piece of that wall).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pyheracles.supports.core import Array, Island

__all__ = [
    "FaceBoxParams",
    "Part",
    "extent",
    "join_face_parts",
    "one_box",
    "section_parts",
    "turns_corner",
]


@dataclass(frozen=True)
class FaceBoxParams:
    """When a face line and another part of a section are one pier's box.

    Attributes
    ----------
    corner_gap_m
        The side through an end of the face holds points from the face's line to the
        far side of the box with no gap wider than this, metres (the corner of a pier
        seen at a graze; the passage between two piers is wider).
    side_points
        At least this many points on that side.
    angle_tol_deg
        The other part's sides are parallel or perpendicular to the face within this,
        degrees.
    inside_points
        At most this many section points lie inside the box (further than twice the
        surface tolerance from its outline).
    """

    corner_gap_m: float = 0.3
    side_points: int = 3
    angle_tol_deg: float = 5.0
    inside_points: int = 3


@dataclass
class Part:
    """A part of a section that a face may join: its section points (indices), the
    angle of its rectangle (radians), and what it is (``face``: a face line, ``shape``
    its index among the faces; ``shape``: a support shape, ``shape`` its index in the
    shape list; ``wall``: a wall island)."""

    index: NDArray[np.intp]
    angle: float
    kind: str
    shape: int = -1


def turns_corner(
    ts: Array, box: Array, face_t: tuple[float, float], tol: float, p: FaceBoxParams
) -> bool:
    """Whether the outline of a box turns a corner at an end of a face on its side
    ``s = 0``.

    ``ts`` are points in the face's frame (along, across), ``box`` is ``(t0, t1, s0,
    s1)`` with the face on ``s = 0`` (``s0 = 0`` or ``s1 = 0``), ``face_t`` the face's
    ends along it.  At an end within ``p.corner_gap_m`` of the box's corner, the
    points within ``tol`` of the box's side through that corner must run from the
    face's line to the far side with no gap wider than ``p.corner_gap_m``.
    """
    t0, t1, s0, s1 = box
    far = s1 if abs(s0) <= abs(s1) else s0
    depth = abs(far)
    for end, corner in ((face_t[0], t0), (face_t[1], t1)):
        if abs(end - corner) > p.corner_gap_m:
            continue
        on = np.abs(ts[:, 0] - corner) <= tol
        d = np.sort(
            np.abs(ts[on, 1])[(ts[on, 1] * np.sign(far) >= 0) & (np.abs(ts[on, 1]) <= depth + tol)]
        )
        if len(d) < p.side_points:
            continue
        steps = np.diff(np.r_[0.0, d, depth])
        if float(np.max(steps)) <= p.corner_gap_m:
            return True
    return False


def extent(xy: Array, angle: float) -> float:
    """The larger side of the bounding rectangle of points ``xy`` turned by ``angle``
    (radians), metres."""
    u = np.array([np.cos(angle), np.sin(angle)])
    q = np.c_[xy @ u, xy @ np.array([-u[1], u[0]])]
    return float(np.max(np.ptp(q, axis=0)))


def one_box(
    xy: Array,
    face: NDArray[np.intp],
    other: Part,
    angle: float,
    max_size_m: float,
    tol: float,
    p: FaceBoxParams,
) -> tuple[Array, float, Array] | None:
    """The box (centre, angle, size) of a face line (indices ``face`` into the section
    points ``xy``, its direction ``angle``) and another part, when they are one pier's
    box (see the module doc); else None."""
    turn = (other.angle - angle) % (np.pi / 2)
    if min(turn, np.pi / 2 - turn) > np.radians(p.angle_tol_deg):
        return None
    if extent(xy[other.index], other.angle) > extent(xy[face], angle):
        # the longer part's direction is the better known: the box is turned to it
        angle = other.angle + np.pi / 2 * round((angle - other.angle) / (np.pi / 2))
    u = np.array([np.cos(angle), np.sin(angle)])
    nrm = np.array([-u[1], u[0]])
    c = xy[face].mean(axis=0)
    mine = np.c_[(xy[face] - c) @ u, (xy[face] - c) @ nrm]
    theirs = np.c_[(xy[other.index] - c) @ u, (xy[other.index] - c) @ nrm]
    both = np.r_[mine, theirs]
    lo, hi = np.quantile(both, 0.01, axis=0), np.quantile(both, 0.99, axis=0)
    lo[1], hi[1] = min(lo[1], 0.0), max(hi[1], 0.0)
    if np.any(hi - lo > max_size_m) or min(-lo[1], hi[1]) > tol:
        return None  # too large, or the face is not on the box's outline
    ts = np.c_[(xy - c) @ u, (xy - c) @ nrm]
    near = np.all((ts >= lo - tol) & (ts <= hi + tol), axis=1)
    ts = ts[near]
    inside = np.all((ts > lo + 2 * tol) & (ts < hi - 2 * tol), axis=1)
    if np.count_nonzero(inside) > p.inside_points:
        return None
    face_t = (float(np.quantile(mine[:, 0], 0.01)), float(np.quantile(mine[:, 0], 0.99)))
    box = np.array([lo[0], hi[0], lo[1], hi[1]])
    if not turns_corner(ts, box, face_t, tol, p):
        return None
    mid = 0.5 * (lo + hi)
    return c + mid[0] * u + mid[1] * nrm, angle, hi - lo


def join_face_parts(
    xy: Array,
    faces: list[Island],
    parts: list[Part],
    max_size_m: float,
    tol: float,
    p: FaceBoxParams | None = None,
) -> tuple[list[Island], dict[int, tuple[Array, float, Array]]]:
    """Join each face line (``faces``, islands of the section points ``xy``) with the
    first part it is one box with (:func:`one_box`; with another face, turning at the
    ends of either): the parts ``parts`` (support shapes, wall islands) and the faces
    before it.

    Returns the faces left, a face joined with a face or a wall being one pier island
    of the joined box (judged as any face: a piece of a wall when it is one), and the
    new boxes of the support shapes joined (by shape index: centre,
    angle, size).
    """
    p = p or FaceBoxParams()
    out: list[Island] = []
    grown: dict[int, tuple[Array, float, Array]] = {}
    for face in faces:  # loop over faces
        pool = parts + [Part(f.index, f.angle, "face", k) for k, f in enumerate(out)]
        for part in pool:  # loop over parts, the first joined wins
            box = one_box(xy, face.index, part, face.angle, max_size_m, tol, p)
            if box is None and part.kind == "face":
                mine = Part(face.index, face.angle, "face")
                box = one_box(xy, part.index, mine, part.angle, max_size_m, tol, p)
            if box is None:
                continue
            if part.kind == "shape":
                grown[part.shape] = box
                break
            joined = Island(
                "pier", np.union1d(part.index, face.index), box[0], float("nan"), box[1],
                box[2], *[float("nan")] * 3,
            )  # fmt: skip
            if part.kind == "face":
                out[part.shape] = joined
            else:
                out.append(joined)
            break
        else:
            out.append(face)
    return out, grown


def section_parts(xy: Array, islands: list[Island], shapes: list[dict], tol: float) -> list[Part]:
    """The parts of a section a face may join: the pier shapes found (their section
    points ``xy`` within ``tol`` of their rectangles) and the wall islands."""
    parts = [Part(i.index, float(i.angle), "wall") for i in islands if i.kind == "wall"]
    for k, sh in enumerate(shapes):  # loop over shapes
        if sh["class"] != "pier":
            continue
        u = np.array([np.cos(sh["angle"]), np.sin(sh["angle"])])
        q = xy - sh["centre"]
        ts = np.abs(np.c_[q @ u, q @ np.array([-u[1], u[0]])])
        index = np.flatnonzero(np.all(ts <= np.asarray(sh["half"]) + tol, axis=1))
        if len(index):
            parts.append(Part(index, float(sh["angle"]), "shape", k))
    return parts
