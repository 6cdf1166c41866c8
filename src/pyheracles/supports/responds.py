"""Responds: piers standing against a wall, read from the wall's section as bumps out of
its face (a jamb or a reveal is the wall's end at an opening, no bump)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pyheracles.segment.euclidean import euclidean_clusters
from pyheracles.supports.core import Array, SupportParams
from pyheracles.supports.engaged_fronts import arc_front, engaged_shape
from pyheracles.supports.piers import WALL_LINE_COVER_M, WALL_LINE_GAP_M, rect_coords
from pyheracles.supports.rings import refit_line


@dataclass(frozen=True)
class RespondParams:
    """What a respond's section looks like on its wall's face line.

    Attributes
    ----------
    depth_m
        Smallest and largest depth out of the face, metres (a moulding, a door frame or
        a cornice stands out a few centimetres; a pier by a pier's depth).
    width_m
        Smallest and largest width along the face, metres (a fin, a frame's sliver is
        narrower than a pier).
    face_each_side_m
        The wall face runs on beyond each of its two ends over at least this length
        (within :data:`~pyheracles.supports.piers.WALL_LINE_GAP_M`), metres: a respond
        stands in a wall's face, not at its end or its corner.
    front_fill
        Share of its width over which its front face (parallel to the wall face, at its
        depth) holds points: a bump has a front, the wall's end at an opening (a reveal
        perpendicular to the face) has none.
    on_outline_share
        Share of its points within ``2 x tol`` of its outline (the front and the two
        sides): clutter against a wall is no prism.
    """

    depth_m: tuple[float, float] = (0.15, 1.5)
    width_m: tuple[float, float] = (0.15, 3.0)
    face_each_side_m: float = 0.25
    front_fill: float = 0.7
    on_outline_share: float = 0.8


RESPONDS = RespondParams()


def bump_on_face(
    p: Array, n: Array, d: float, tol: float, distance: float, rp: RespondParams = RESPONDS
) -> tuple[float, float, float, float] | None:
    """The rectangle a cluster of section points ``p`` outlines out of the face line
    ``n . x = d``, or None: ``(side, t_lo, t_hi, depth)`` with ``side`` the sign of the
    room side of the face (``side x (n . x - d)`` > 0 out of it), the extent along the
    face's tangent ``(-n_y, n_x)`` and the depth out of it (metres).

    A respond touches the face (its sides start on it), stands out of it by a pier's
    depth, has a front face over ``front_fill`` of its width and its points lie on
    that outline."""
    off = p @ n - d
    side = float(np.sign(np.median(off)))
    if side == 0:
        return None
    front = side * off
    depth = float(np.quantile(front, 0.95))
    touch = max(3.0 * tol, 0.25 * depth)
    if not rp.depth_m[0] <= depth <= rp.depth_m[1] or float(front.min()) > touch:
        return None
    t = p @ np.array([-n[1], n[0]])
    t_lo, t_hi = float(np.quantile(t, 0.02)), float(np.quantile(t, 0.98))
    width = t_hi - t_lo
    if not rp.width_m[0] <= width <= rp.width_m[1]:
        return None
    at_front = np.abs(front - depth) <= 2.0 * tol
    bins = np.unique(np.floor(t[at_front] / (2.0 * distance)))
    if len(bins) * 2.0 * distance < rp.front_fill * width:
        return None  # no front: a reveal or the end of a wall
    on = at_front | (np.minimum(np.abs(t - t_lo), np.abs(t - t_hi)) <= 2.0 * tol)
    if np.mean(on & (front >= -tol)) < rp.on_outline_share:
        return None
    return side, t_lo, t_hi, depth


def responds_on_wall(
    xy: Array,
    faces: tuple[list[tuple[Array, float, float]], NDArray[np.intp]],
    params: SupportParams,
    tol: float,
    distance: float,
    bin_m: float,
    section_xy: Array | None = None,
    rp: RespondParams = RESPONDS,
) -> list[dict]:
    """Section shapes of the responds on a wall island (``xy``: its section points,
    ``faces``: its face lines and the points on none,
    :func:`~pyheracles.supports.rings.wall_face_lines`; ``section_xy``: every point of
    the section, where the face is looked for beyond a bump's ends, ``xy`` if None: a
    wall broken up in a sparse section goes on in islands of its own).

    The points off the faces are clustered; a cluster that outlines a rectangle standing
    out of a face (:func:`bump_on_face`) whose face runs on beyond both its ends
    (:func:`face_both_sides`, bins of ``bin_m``) and not behind it (:func:`back_open`:
    a respond's back is one with the wall, in no scanner's view; the piece of a wall
    between two windows, its far face the wall island's long face and its near face
    and reveal a cluster off it, has that face behind it: supports draw 13, a bump as
    deep as the wall) is a pier against the wall, with that face's normal (into the
    room), offset and noise, as an engaged column has (its wall is cut off its cookie
    by them).  The rule of
    :func:`~pyheracles.supports.rings.engaged_on_wall` for a rectangle instead of an arc.
    """
    lines, rest = faces
    if not lines or len(rest) < params.min_points:
        return []
    labels = euclidean_clusters(xy[rest], distance, params.min_points)
    found: list[dict] = []
    for lab in range(1, int(labels.max()) + 1 if len(labels) else 1):
        p = xy[rest[labels == lab]]
        for n, d, face_rms in lines:
            bump = bump_on_face(p, n, d, tol, distance, rp)
            if bump is None:
                continue
            around = xy if section_xy is None else section_xy
            face = around[np.abs(around @ n - d) <= tol]
            if face_both_sides(face, n, bump[1], bump[2], bin_m, rp) and back_open(
                xy, n, d, bump[1], bump[2], tol, bin_m
            ):
                found.append(against_face(p, bump, n, d, face_rms, tol))
            break
    return found


def face_both_sides(
    face: Array, n: Array, t_lo: float, t_hi: float, bin_m: float, rp: RespondParams = RESPONDS
) -> bool:
    """Whether the face points ``face`` (on the line of normal ``n``) run on beyond both
    ends ``t_lo``, ``t_hi`` of a bump along it, over ``face_each_side_m`` each, within
    :data:`~pyheracles.supports.piers.WALL_LINE_GAP_M` of them."""
    t = face @ np.array([-n[1], n[0]])
    need = max(1, int(np.ceil(rp.face_each_side_m / bin_m)))
    for beyond in (
        (t < t_lo) & (t >= t_lo - WALL_LINE_GAP_M),
        (t > t_hi) & (t <= t_hi + WALL_LINE_GAP_M),
    ):
        if len(np.unique(np.floor(t[beyond] / bin_m))) < need:
            return False
    return True


def respond_shape(
    side: float, t_lo: float, t_hi: float, depth: float, n: Array, d: float, face_rms: float
) -> dict:
    """The section shape of a respond outlined out of the face ``n . x = d`` (see
    :func:`bump_on_face`): a pier from the face out to its depth, with the face's
    normal into the room, offset and noise."""
    tangent = np.array([-n[1], n[0]])
    half = np.array([0.5 * (t_hi - t_lo), 0.5 * depth])
    return {
        "class": "pier",
        "centre": n * d + tangent * 0.5 * (t_lo + t_hi) + side * n * 0.5 * depth,
        "radius": float(np.hypot(*half)),
        "half": half,
        "angle": float(np.arctan2(tangent[1], tangent[0])),
        "circularity": float("nan"),
        "normal": side * n,
        "d": side * d,
        "face_gap": max(0.01, 3.0 * face_rms),
        "respond": True,
    }


def against_face(
    p: Array,
    bump: tuple[float, float, float, float],
    n: Array,
    d: float,
    face_rms: float,
    tol: float,
) -> dict:
    """The section shape of a support standing out of the wall face ``n . x = d``
    (``p``: its points, ``bump``: its outline, :func:`bump_on_face`), told by its front:
    an engaged column when its front is an arc of a column's ring
    (:func:`~pyheracles.supports.engaged_fronts.arc_front`), else a respond pier
    (:func:`respond_shape`).  The rectangle of a half column's arc stands out of the
    face as a respond's does (supports draw 0's noise draws: half columns of 0.2 m
    found as piers)."""
    side = bump[0]
    arc = arc_front(p, n, d, side, tol)
    if arc is not None:
        return engaged_shape(arc[0], arc[1], side * n, side * d, face_rms)
    return respond_shape(*bump, n, d, face_rms)


def back_open(
    p: Array, n: Array, d: float, t_lo: float, t_hi: float, tol: float, bin_m: float
) -> bool:
    """Whether a bump's back, on the face line ``n . x = d`` between ``t_lo`` and
    ``t_hi``, holds no face of its own: its points there cover less than half of it
    (a respond's sides meet the wall at its two ends, the wall behind it is in its
    shadow; a piece of wall between two openings has its own face on that line)."""
    t = p @ np.array([-n[1], n[0]])
    inner = (np.abs(p @ n - d) <= 2.0 * tol) & (t > t_lo + 3.0 * tol) & (t < t_hi - 3.0 * tol)
    span = t_hi - t_lo - 6.0 * tol
    if span <= bin_m:
        return True
    return len(np.unique(np.floor(t[inner] / bin_m))) * bin_m < 0.5 * span


def respond_island(
    p: Array,
    centre: Array,
    angle: float,
    size: Array,
    others: Array,
    tol: float,
    distance: float,
    bin_m: float,
    rp: RespondParams = RESPONDS,
) -> dict | None:
    """The section shape of a pier island that is a respond, or None.

    ``p``: the island's points, ``centre``, ``angle``, ``size``: its rectangle,
    ``others``: the section's other points near it.  A side of the rectangle lies on a
    wall face that goes on beyond its ends (points of ``others`` within ``tol`` of that
    line, beyond its ends and at most :data:`~pyheracles.supports.piers.WALL_LINE_GAP_M`
    from them, over :data:`~pyheracles.supports.piers.WALL_LINE_COVER_M`: the test that
    makes a pier island a piece of a wall, :func:`~pyheracles.supports.piers.in_wall_line`);
    the island is a respond when it outlines a bump out of that face
    (:func:`bump_on_face`) whose back is open (:func:`back_open`): the piece of a wall
    between two openings, or its end at one, has no front standing out of the face, or
    has its own face on it.
    """
    half = np.maximum(np.asarray(size) / 2, 1e-6)
    uv = rect_coords(others, centre, angle)
    need = max(2, int(np.ceil(WALL_LINE_COVER_M / bin_m)))
    for ax in (0, 1):
        along, across = uv[:, ax], uv[:, 1 - ax]
        beyond = (np.abs(along) > half[ax] + tol) & (np.abs(along) <= half[ax] + WALL_LINE_GAP_M)
        for side in (-half[1 - ax], half[1 - ax]):
            on = beyond & (np.abs(across - side) <= tol)
            back_bins = len(np.unique(np.floor(along[on] / bin_m)))
            if np.count_nonzero(on) < need or back_bins < need:
                continue
            n, d, _ = refit_line(others[on])
            bump = bump_on_face(p, n, d, tol, distance, rp)
            if (
                bump is None
                or not back_open(p, n, d, bump[1], bump[2], tol, bin_m)
                or not face_both_sides(others[on], n, bump[1], bump[2], bin_m, rp)
            ):
                continue
            # the wall goes on from its back, not from its front (a piece of a wall
            # between openings, seen from one side only, is a bump out of the line of
            # the face not seen, open there, with the seen face going on from its front)
            front = np.abs(across - (side - np.sign(side) * bump[3])) <= tol
            front_bins = len(np.unique(np.floor(along[beyond & front] / bin_m)))
            if front_bins >= 0.5 * back_bins:
                continue
            rms = float(np.sqrt(np.mean((others[on] @ n - d) ** 2)))
            return against_face(p, bump, n, d, rms, tol)
    return None
