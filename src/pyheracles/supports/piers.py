"""Rectangles in a section: the rectangle residual of an island, wall pieces that are no piers."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from pyheracles.supports.core import Array, Island, trimmed_rms


def rect_rms(xy: Array, centre: Array, angle: float, size: Array) -> tuple[float, Array]:
    """RMS distance to a rectangle whose edges are re-estimated as medians (2 rounds)."""
    c, s = np.cos(angle), np.sin(angle)
    q = xy - centre
    uv = np.c_[q @ [c, s], q @ [-s, c]]
    lo, hi = -size / 2, size / 2
    for _ in range(2):
        d = np.stack(
            [
                np.abs(uv[:, 0] - lo[0]),
                np.abs(uv[:, 0] - hi[0]),
                np.abs(uv[:, 1] - lo[1]),
                np.abs(uv[:, 1] - hi[1]),
            ],
            axis=1,
        )
        k = d.argmin(axis=1)
        for j, (arr, col) in enumerate(((lo, 0), (hi, 0), (lo, 1), (hi, 1))):
            sel = k == j
            if sel.sum() >= 2:
                arr[col] = np.median(uv[sel, col])
    d = np.stack(
        [
            np.abs(uv[:, 0] - lo[0]),
            np.abs(uv[:, 0] - hi[0]),
            np.abs(uv[:, 1] - lo[1]),
            np.abs(uv[:, 1] - hi[1]),
        ],
        axis=1,
    )
    mid = (lo + hi) / 2
    new_centre = centre + mid[0] * np.array([c, s]) + mid[1] * np.array([-s, c])
    return trimmed_rms(d.min(axis=1)), np.r_[new_centre, hi - lo]


#: No passage is narrower: section points this close around a pier belong to what it
#: stands in (metres).
CLEARANCE_M = 0.5


def wall_fragment(xy: Array, isl: Island, tree: cKDTree, band_m: float) -> bool:
    """A pier island is a piece of a wall when the wall goes on beside it.

    A pier stands free.  The pieces of a wall broken up in the section (gaps in sparse
    or occluded data, narrow slits) have the next pieces of the same wall in line with
    them: within :data:`CLEARANCE_M` beyond one of their sides, inside the band of
    their own width (plus ``band_m``), at least half as many section points as their
    own (as many in the middle of the wall, about half at its ends).  Clutter beside a
    pier (a fence, a bench, a scaffold) is not in line with it.
    """
    half = np.maximum(isl.size / 2, 1e-6)
    need = 0.5 * len(isl.index)
    near = tree.query_ball_point(isl.center, float(np.hypot(*half)) + CLEARANCE_M)
    others = np.setdiff1d(np.asarray(near, dtype=np.intp), isl.index, assume_unique=False)
    if len(others) < need:
        return False
    c, s = np.cos(isl.angle), np.sin(isl.angle)
    q = xy[others] - isl.center
    u, v = np.abs(q @ np.array([c, s])), np.abs(q @ np.array([-s, c]))
    beyond_u = (u > half[0]) & (u <= half[0] + CLEARANCE_M) & (v <= half[1] + band_m)
    beyond_v = (v > half[1]) & (v <= half[1] + CLEARANCE_M) & (u <= half[0] + band_m)
    return max(int(beyond_u.sum()), int(beyond_v.sum())) >= need


#: An opening or a breach in a wall is at most this wide: a wall face this far beyond a
#: pier candidate's side, on the line of that side, is the same wall (metres).
WALL_LINE_GAP_M = 3.0
#: A wall face on the line of a side covers at least this length (metres); a wall
#: crossing the line covers its own thickness there, two scanned faces of a few cm.
WALL_LINE_COVER_M = 0.5


def in_wall_line(isl: Island, wall_xy: Array, tol: float, bin_m: float) -> bool:
    """A pier candidate is a piece of a wall when one of its sides lies on a wall face.

    The piece of a wall between two openings (doors, windows, the breaches of a ruin)
    is cut off in the section like a pier, but its sides facing the room and the
    outside lie on the faces of the wall that goes on beyond the openings: wall points
    (``wall_xy``, the wall islands of the section) within ``tol`` of the line of one of
    its sides, beyond its ends and at most :data:`WALL_LINE_GAP_M` from them, that
    cover at least :data:`WALL_LINE_COVER_M` of that line in bins of ``bin_m``.  A free
    pier in front of a wall, or in a row of piers, has no wall on the lines of its
    sides (a fence between piers runs on their axis, not on a face).
    """
    if len(wall_xy) == 0:
        return False
    half = np.maximum(isl.size / 2, 1e-6)
    c, s = np.cos(isl.angle), np.sin(isl.angle)
    q = wall_xy - isl.center
    u, v = q @ np.array([c, s]), q @ np.array([-s, c])
    need = max(2, int(np.ceil(WALL_LINE_COVER_M / bin_m)))
    for across, along, h_across, h_along in ((v, u, half[1], half[0]), (u, v, half[0], half[1])):
        beyond = (np.abs(along) > h_along + tol) & (np.abs(along) <= h_along + WALL_LINE_GAP_M)
        for side in (-h_across, h_across):
            on = beyond & (np.abs(across - side) <= tol)
            if np.count_nonzero(on) >= need and len(np.unique(np.floor(along[on] / bin_m))) >= need:
                return True
    return False
