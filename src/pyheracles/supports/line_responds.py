"""Responds on the building's wall face lines: piers standing against a wall whose
section holds no wall island beside them.

A wall face seen at a grazing angle, or from far, is broken in a section into pieces
shorter than a support (scan lines further apart than the clustering distance): no wall
island forms there, the respond's own outline is broken into its faces, and the respond
stage on wall islands (:func:`~pyheracles.supports.responds.responds_on_wall`) never sees
it (supports draw 37: eleven responds of 0.39 x 0.3 m on the two long walls of a nave
scanned from inside).  The wall's face is still a line of the section over metres: its
plane is found on all the slab's points, and the points standing out of it into the
room are grouped along it with a gap of a few scan lines, and judged by the tests of
the respond stage (:mod:`pyheracles.supports.responds`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pyheracles.segment.euclidean import euclidean_clusters
from pyheracles.supports.core import Array, Scales, SupportParams
from pyheracles.supports.responds import (
    RESPONDS,
    RespondParams,
    against_face,
    back_open,
    bump_on_face,
    face_both_sides,
)
from pyheracles.supports.rings import pair_line_inliers, refit_line


@dataclass(frozen=True)
class LineRespondParams:
    """The building's wall face lines, and the responds grouped along them.

    Attributes
    ----------
    min_cover_m
        A wall face line holds points over at least this length (bins of
        ``cover_bin_m``), metres.
    min_fill
        Share of the bins between its ends that hold points: the fronts of a row of
        responds, or of piers, are on one line too, over a small share of it.
    cover_bin_m
        Bin along a face line, metres.
    max_lines
        Most face lines searched.
    trials
        Random point pairs per line search.
    gap_m
        The points of one respond standing out of a face are grouped with this gap,
        metres (its side faces, seen at a grazing angle, hold a few scan lines each).
    """

    min_cover_m: float = 2.0
    min_fill: float = 0.5
    cover_bin_m: float = 0.25
    max_lines: int = 16
    trials: int = 400
    gap_m: float = 0.2


LINE_RESPONDS = LineRespondParams()
#: Two face lines whose normals make a cosine above this are parallel (within 8 deg).
PARALLEL_COS = 0.99


def face_lines(
    xy: Array, tol: float, rng: np.random.Generator, lp: LineRespondParams = LINE_RESPONDS
) -> list[tuple[Array, float, float, Array]]:
    """Long straight faces among the plan points ``xy`` (a sequential line search):
    ``(n, d, rms, inliers)`` per face (``n . x = d``, a boolean mask over ``xy``),
    each holding points over ``min_cover_m`` and ``min_fill`` of its span."""
    rest = np.arange(len(xy))
    lines: list[tuple[Array, float, float, Array]] = []
    for _ in range(lp.max_lines):
        if len(rest) < 50:
            break
        p = xy[rest]
        inl = pair_line_inliers(p, tol, lp.trials, 4000, rng)
        if inl.sum() < 50:
            break
        n, d, _ = refit_line(p[inl])
        inl = np.abs(p @ n - d) <= tol
        along = p[inl] @ np.array([-n[1], n[0]])
        bins = np.unique(np.floor(along / lp.cover_bin_m))
        cover = len(bins) * lp.cover_bin_m
        if cover >= lp.min_cover_m and cover >= lp.min_fill * (np.ptp(bins) + 1) * lp.cover_bin_m:
            mask = np.zeros(len(xy), dtype=bool)
            mask[rest[inl]] = True
            lines.append((n, d, float(np.sqrt(np.mean((p[inl] @ n - d) ** 2))), mask))
        rest = rest[~inl]  # a line that is no face (a row's fronts) is searched no more
    return lines


def line_responds(
    xy: Array,
    inside: Array,
    params: SupportParams,
    sc: Scales,
    rp: RespondParams = RESPONDS,
    lp: LineRespondParams = LINE_RESPONDS,
) -> list[dict]:
    """Respond shapes (:func:`~pyheracles.supports.responds.respond_shape`) standing
    out of the wall face lines of a slab's plan points ``xy`` into the building
    (towards ``inside``, a plan point inside it).

    Per face line (:func:`face_lines`) the points on its inside within the largest
    respond depth, and on no face line, are grouped with a gap of ``gap_m``; a group
    that outlines a bump out of the face (:func:`bump_on_face`) no more elongated than
    ``params.wall_min_aspect`` (a wall's end crossing the face is), whose face runs on
    beyond both its ends (:func:`face_both_sides`) and not behind it
    (:func:`back_open`), and that stands between no parallel face running on beyond
    both its ends in front of it (within a thick wall's thickness: the reveals and the
    frame of a window, supports draw 28) is a respond.  The face lines are drawn with a
    generator of their own (seeded with ``params.seed``): the detection's is not moved."""
    rng = np.random.default_rng(params.seed)
    lines = face_lines(xy, sc.tol, rng, lp)
    if not lines:
        return []
    on_any = np.logical_or.reduce([m for *_, m in lines])
    bin_m = max(0.05, 3.0 * sc.spacing)
    found: list[dict] = []
    for n, d, rms, on in lines:
        off = xy @ n - d
        side = float(np.sign(inside @ n - d))
        front = side * off
        near = np.flatnonzero(~on_any & (front > sc.tol) & (front <= rp.depth_m[1]))
        if len(near) < params.min_points:
            continue
        labels = euclidean_clusters(xy[near], lp.gap_m, params.min_points)
        face = xy[on]
        # the faces parallel to this one in front of it: a bump between them is within
        # a wall's thickness (a reveal and a window's frame in a thick wall's opening)
        ahead = np.logical_or.reduce([m for n2, *_, m in lines if abs(n2 @ n) > PARALLEL_COS])
        ahead &= ~on & (front > sc.tol) & (front <= rp.depth_m[1])
        for lab in range(1, int(labels.max(initial=0)) + 1):
            p = xy[near[labels == lab]]
            bump = bump_on_face(p, n, d, sc.tol, sc.distance, rp)
            if bump is None or bump[0] != side:
                continue
            width, depth = bump[2] - bump[1], bump[3]
            if max(width, depth) > params.wall_min_aspect * min(width, depth):
                continue  # a wall's end crossing the face, no pier
            if face_both_sides(xy[ahead], n, bump[1], bump[2], bin_m, rp):
                continue
            if face_both_sides(face, n, bump[1], bump[2], bin_m, rp) and back_open(
                face, n, d, bump[1], bump[2], sc.tol, bin_m
            ):
                found.append(against_face(p, bump, n, d, rms, sc.tol))
    return found
