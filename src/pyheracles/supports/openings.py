"""Pier candidates inside a wall's opening: the reveals and jambs of doors and windows
in thick walls (supports issue 12, jambs found as piers)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pyheracles.supports.core import Array, Scales
from pyheracles.supports.piers import WALL_LINE_COVER_M, WALL_LINE_GAP_M, face_lines, rect_coords

#: Straight lines looked for beside a candidate (the wall's two faces among the other
#: walls', the floor's edge and the clutter's).
MAX_LINES = 6


@dataclass(frozen=True)
class OpeningParams:
    """Parameters of :func:`in_wall_opening`.

    Attributes
    ----------
    max_thickness_m
        The two faces of a wall lie at most this far apart, metres (the thickest walls of
        churches and ruins are about 1.5 m; a passage between two walls is wider).
    min_thickness_m
        ... and at least this far apart, metres (a fence's rails or a board's two faces
        are closer).
    parallel_deg
        A wall face runs along an axis of the candidate within this angle, degrees.
    margin_m
        The candidate lies between the two faces but for this much (and ``3 x tol``),
        metres: its outermost section points on a face's line stand off it by the noise.
    own_m
        Section points this close beyond the candidate's ends are its own (a reveal's
        face running on past the part cut as the candidate), metres.
    """

    max_thickness_m: float = 2.0
    min_thickness_m: float = 0.2
    parallel_deg: float = 10.0
    margin_m: float = 0.05
    own_m: float = 0.05


def in_wall_opening(
    xy: Array,
    centre: Array,
    angle: float,
    half: Array,
    tol: float,
    bin_m: float,
    rng: np.random.Generator,
    params: OpeningParams | None = None,
) -> bool:
    """Whether a pier candidate stands inside the thickness of a wall, in an opening.

    A door or a window in a thick wall has reveals: faces across the wall, from one of
    its faces to the other.  Cut by a section between the sill and the lintel, a reveal
    (with what is seen through the opening beside it) is an island like a pier's, and
    no wall runs on from it in the section: the faces of the wall stand off its ends by
    the reveal's unscanned part, at a right angle (supports draw 28: a window reveal of
    a 1.33 m wall, noise draws 0, 1 and 3).  But both faces of the wall run on beyond
    the opening on either side of it, on two straight lines, and the candidate lies
    between them: inside the wall.  A free pier has a wall on one side at most (a
    portico's cella wall, an aisle's wall), a respond stands out of its wall's face, an
    anta ends its wall (the wall runs on beyond one side only).

    Parameters
    ----------
    xy
        Plan points of the section slab the candidate was found in (metres).
    centre, angle, half
        The candidate's section rectangle: centre, angle of its first axis (radians)
        and half sizes along its axes (metres).
    tol, bin_m
        Surface tolerance and the bin of a face's cover, metres.
    rng
        Random generator of the line search.
    params
        :class:`OpeningParams`.

    Returns
    -------
    bool
        Whether, along one of its axes, two straight faces parallel to that axis, from
        ``min_thickness_m`` to ``max_thickness_m`` apart, each run on over
        :data:`~pyheracles.supports.piers.WALL_LINE_COVER_M` (in bins of ``bin_m``)
        beyond both of the candidate's ends within
        :data:`~pyheracles.supports.piers.WALL_LINE_GAP_M` of them (the widest opening),
        with the candidate between their lines.
    """
    params = params or OpeningParams()
    half = np.maximum(np.asarray(half, dtype=np.float64), 1e-6)
    uv = rect_coords(np.asarray(xy, dtype=np.float64), np.asarray(centre), angle)
    need = max(2, int(np.ceil(WALL_LINE_COVER_M / bin_m)))
    cos_par = float(np.cos(np.radians(params.parallel_deg)))
    margin = max(params.margin_m, 3.0 * tol)
    for k in (0, 1):
        s, t = uv[:, k], uv[:, 1 - k]
        h_s, h_t = float(half[k]), float(half[1 - k])
        beyond = np.abs(s) - h_s
        sel = (beyond > max(params.own_m, 2.0 * tol)) & (beyond <= WALL_LINE_GAP_M)
        sel &= np.abs(t) <= h_t + params.max_thickness_m
        if np.count_nonzero(sel) < 2 * need:
            continue
        q = np.c_[s[sel], t[sel]]
        offsets = []
        for d, off, inl in face_lines(q, tol, rng, n_lines=MAX_LINES):
            if abs(float(d[0])) < cos_par:
                continue  # not along this axis
            bins = np.unique(np.floor(q[inl, 0] / bin_m))
            if min(np.count_nonzero(bins < 0), np.count_nonzero(bins >= 0)) < need:
                continue  # not on both sides of the candidate
            offsets.append(off / float(d[0]))  # the line's offset across, at the centre
        for a in offsets:
            for b in offsets:
                gap = b - a
                if (
                    params.min_thickness_m <= gap <= params.max_thickness_m
                    and a <= -h_t + margin
                    and b >= h_t - margin
                ):
                    return True
    return False


def opening_piers(
    p: Array,
    order: NDArray[np.intp],
    z_sorted: Array,
    shapes: list[dict],
    h_sec: float,
    sc: Scales,
    params: OpeningParams | None = None,
) -> set[int]:
    """Indices of the pier shapes (no responds) standing inside a wall's opening
    (:func:`in_wall_opening`), each judged in the section slab it was found in
    (``sh["h_sec"]``, else ``h_sec``; ``order`` sorts ``p`` by height, ``z_sorted``);
    each with a generator of its own (seed 0): the other steps' random numbers stay."""
    bin_m = max(0.05, 3.0 * sc.spacing)
    out = set()
    slabs: dict[float, Array] = {}  # plan points of each section's slab, read once
    for k, sh in enumerate(shapes):
        if sh["class"] != "pier" or sh.get("respond", False):
            continue
        h = float(sh.get("h_sec", h_sec))
        if h not in slabs:
            a, b = np.searchsorted(z_sorted, [h - sc.thickness / 2, h + sc.thickness / 2])
            slabs[h] = p[order[a:b], :2]
        xy = slabs[h]
        reach = float(np.hypot(*sh["half"])) + WALL_LINE_GAP_M
        xy = xy[np.max(np.abs(xy - sh["centre"]), axis=1) <= reach]
        rng = np.random.default_rng(0)
        if in_wall_opening(xy, sh["centre"], sh["angle"], sh["half"], sc.tol, bin_m, rng, params):
            out.add(k)
    return out
