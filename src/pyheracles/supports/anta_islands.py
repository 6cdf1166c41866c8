"""Antae in a section: a pier island that ends a wall is no piece of that wall.

An anta is a wall's end thickened into a pier (:mod:`pyheracles.supports.antae`).  In a
section its island is the pier's outline with the first decimetres of the wall's stub,
and the rest of the stub lies in line with it beyond its end: the wall-piece test of
:func:`~pyheracles.supports.piers.wall_fragment` (the wall goes on in the band of the
island's width) takes it for a piece of that wall (supports draw 34: an anta of 0.82 x
0.66 m ending a wall 0.62 m thick, its stub a wall piece of its own beyond it).  A piece
of a wall is as thick as the wall that goes on from it; an anta stands out of the
wall's faces: along one of its axes the outline steps in to a set-in wall beyond one
end only (:func:`~pyheracles.supports.antae.one_wall_end`, as the cookie-cutter cuts an
anta's stub off it in 3D).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from pyheracles.supports.antae import face_angle, one_wall_end
from pyheracles.supports.core import Array, Island
from pyheracles.supports.piers import CLEARANCE_M, rect_coords

__all__ = ["SIDE_COVER", "anta_islands", "ends_a_wall", "set_in_both"]

#: Both side faces of an anta's pier part are seen along this share of its length.
SIDE_COVER = 0.3


def ends_a_wall(
    xy: Array, isl: Island, tree: cKDTree, tol: float, band_m: float, bin_m: float
) -> bool:
    """Whether a pier island ``isl`` of the section points ``xy`` (``tree``: their
    KD-tree) ends a wall set in from its faces: the island's points and the section's
    others within :data:`~pyheracles.supports.piers.CLEARANCE_M` beyond it, in the
    band of its width (plus ``band_m``) across each axis and in the frame of its faces
    (:func:`~pyheracles.supports.antae.face_angle`: the stub of a wall turns the
    outline's rectangle), step in to a wall beyond one end
    (:func:`~pyheracles.supports.antae.one_wall_end`, surface tolerance ``tol``) set in
    from both of its sides (:func:`set_in_both`), and both side faces of the pier's part
    are seen along :data:`SIDE_COVER` of its length (in bins of ``bin_m``; supports
    draw 34: pieces of a wall between doors seen on one face and an end "step in" past
    the end's last point)."""
    half = np.maximum(np.asarray(isl.size, dtype=np.float64) / 2, 1e-6)
    near = np.asarray(tree.query_ball_point(isl.center, float(np.hypot(*half)) + CLEARANCE_M))
    if len(near) < 20 or len(isl.index) < 20:
        return False
    angle = face_angle(xy[isl.index], isl.angle, tol)
    uv = rect_coords(xy[near], isl.center, angle)
    reach = half + band_m
    end = one_wall_end(uv, tol, across_reach=reach)
    if end is None:
        return False
    axis, sign, cut = end
    if not set_in_both(sign * uv[:, axis], uv[:, 1 - axis], sign * cut, tol, reach[1 - axis]):
        return False
    own = np.isin(near, isl.index)
    along, across = sign * uv[own, axis], uv[own, 1 - axis]
    pier = along <= sign * cut + tol
    if np.count_nonzero(pier) < 10:
        return False
    a, c = along[pier], across[pier]
    n_bins = max(1, int(np.ceil(float(np.ptp(a)) / bin_m)))
    for side in np.quantile(c, [0.002, 0.998]):
        on = np.abs(c - side) <= tol
        if len(np.unique(np.floor((a[on] - a.min()) / bin_m))) < SIDE_COVER * n_bins:
            return False
    return True


def set_in_both(along: Array, across: Array, end: float, tol: float, reach: float) -> bool:
    """Whether the points beyond ``end`` (``along`` > ``end + tol``; within ``reach``
    across) are set in from both sides of the pier's part (the rest) by more than
    ``tol``: an anta stands out of both faces of its wall (a wall turning at a corner
    or a thinner wall going on from a thick one is flush with one of them: supports
    draw 6, a building's corner seen from outside)."""
    near = np.abs(across) <= reach
    along, across = along[near], across[near]
    beyond = along > end + tol
    if np.count_nonzero(beyond) < 10 or np.count_nonzero(~beyond) < 10:
        return False
    p_lo, p_hi = np.quantile(across[~beyond], [0.002, 0.998])
    w_lo, w_hi = np.quantile(across[beyond], [0.01, 0.99])
    return bool(w_lo > p_lo + tol and w_hi < p_hi - tol)


def anta_islands(
    xy: Array, islands: list[Island], tol: float, band_m: float, bin_m: float
) -> set[int]:
    """Indices of the pier islands of a section that end a wall (:func:`ends_a_wall`)."""
    piers = [k for k, i in enumerate(islands) if i.kind == "pier"]
    if not piers:
        return set()
    tree = cKDTree(xy)
    return {k for k in piers if ends_a_wall(xy, islands[k], tree, tol, band_m, bin_m)}
