"""Tree crowns caught in an object: raised over it and running on off the polygons.

A tree beside a building spreads its crown over the roof.  On a sparse survey
(0.1-0.4 points/m^2) the crown's returns are few, mostly single returns on twigs
that look smooth, and the clustering distance (three spacings, 4-6 m) chains them
to the roof under them: the porosity vote and the surface variation cannot see
them.  Two things still set a crown apart from a dormer or a chimney: its points
stand above the object's points beside them, and the crown runs on beyond the
polygon at their height or higher (the tree stands outside the footprint).  A
dormer or a chimney stands inside the roof and nothing off the polygons rises
beside it.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "CROWN_DEPTH_M",
    "CROWN_NEIGHBOURS",
    "CROWN_PASSES",
    "CROWN_SLOPE",
    "crown_pass",
    "crown_points",
]

#: Object points nearest in XY whose median height is the surface beside a point.
CROWN_NEIGHBOURS = 8
#: Most passes of the peeling (:func:`crown_points`).
CROWN_PASSES = 8
#: Depth of the peeling, metres: about a crown's radius (as the porosity vote's,
#: :data:`pyheracles.complex.clusters.POROUS_RADIUS_M`).  One pass reaches the radius
#: (the clustering distance, 4-7 m on surveys of 0.1-0.4 points/m^2); going deeper there
#: peeled the roofs of small buildings (complex draws 9, 21).
CROWN_DEPTH_M = 3.0
#: Rise per metre of the slopes from the object's inside points that bound the surface
#: beside a point (see :func:`crown_pass`): 45 degrees.  On AHN3 tile 1 (roofs up to
#: 60 degrees, clustering distance about 1 m) it leaves every building's score as it was.
CROWN_SLOPE = 1.0


def crown_points(
    xyz: NDArray[np.float64],
    members: NDArray[np.int64],
    off: NDArray[np.int64],
    radius_m: float,
    rise_m: float,
    share: float,
    below_m: float = 0.5,
    outside: NDArray[np.bool_] | None = None,
    under: NDArray[np.bool_] | None = None,
) -> NDArray[np.bool_]:
    """Mask over ``members`` of a tree crown's points, peeled from off the polygons inwards.

    ``outside`` (over ``members``) marks the object's points outside its polygon (its
    buffer ring: eaves, facades, a plinth), ``under`` those where a pulse ended after
    going through something above them; see :func:`crown_pass`.

    Each pass (:func:`crown_pass`) finds the crown's points within ``radius_m`` of its
    part already known (off the polygons, then the points found before); passes repeat
    until none is found or the peeling reaches :data:`CROWN_DEPTH_M` in (at most
    :data:`CROWN_PASSES`): on a dense survey a pass reaches only a metre or two.
    """
    flag = np.zeros(len(members), dtype=bool)
    passes = max(1, int(np.ceil(CROWN_DEPTH_M / max(radius_m, 1e-6))))
    for _ in range(min(passes, CROWN_PASSES)):
        rest = np.flatnonzero(~flag)
        new = crown_pass(
            xyz, members[rest], np.concatenate([off, members[flag]]), radius_m, rise_m, share,
            below_m, None if outside is None else outside[rest],
            None if under is None else under[rest],
        )  # fmt: skip
        if not new.any():
            break
        flag[rest[new]] = True
    return flag


def crown_pass(
    xyz: NDArray[np.float64],
    members: NDArray[np.int64],
    off: NDArray[np.int64],
    radius_m: float,
    rise_m: float,
    share: float,
    below_m: float = 0.5,
    outside: NDArray[np.bool_] | None = None,
    under: NDArray[np.bool_] | None = None,
) -> NDArray[np.bool_]:
    """Mask over ``members`` of the points of a tree crown over the object.

    A member point is a crown's when it stands more than ``rise_m`` above the
    object's surface beside it, and at least ``share`` of the points around it
    (3D, within ``radius_m``: the other members and the ``off`` points) are
    ``off`` points no lower than ``below_m`` under it: the blob runs on off the
    polygons at its height.  For a point ``under`` something only the ``off``
    points within ``below_m`` of its height count: its pulse went through what stands
    over it, and a crown over a roof is no sign that the roof is a crown's (complex
    draw 9, B19: a pavilion's roof point, the last of three returns, 3.3 m over the
    platform beside it, was peeled for the crown 0.7-3.5 m over it off the polygon).
    Only the crown's points within ``radius_m`` of its
    part off the polygons are found: the clustering distance that chained them
    to the roof.

    The surface beside a point is the lower of two heights over its
    :data:`CROWN_NEIGHBOURS` nearest members in XY (within ``radius_m``; for a point
    inside the polygon, those inside it: the ring holds facades, plinths and whatever
    the buffer caught, a branch, and on a sparse wall up a slope its lower end, complex
    draw 5; none that near, not raised): their
    median, and the lowest of the slopes rising from those inside the polygon
    (``z_j + CROWN_SLOPE * d_xy``, 45 degrees).  The median alone is the crown's
    own height where a crown denser than the roof under it fills the neighbours
    (complex draw 18: a crown 3-5 m over a flat roof, its points inside the
    polygon never peeled); a roof point stands on the slope of the roof points
    beside it.  The facades and plinths of the buffer ring (``outside``), which
    stand under the roof's edge, are left out of the slopes, and the slopes do not
    bound the points ``under`` something (the last return of a pulse with several):
    such a point is the surface under a crown, and where a roof stands over a
    platform inside the polygon (a pavilion) the slopes from the platform would
    take the roof for a crown (complex draw 26, B18: its roof points under a crown).

    Parameters
    ----------
    xyz
        Coordinates of the whole cloud, metres.
    members
        Indices of the object's points.
    off
        Indices of the non-ground points outside every polygon that the object
        did not take (a crown's part beyond the footprint, clutter).
    radius_m
        Neighbourhood radius, metres (the clustering distance: a crown's
        points are linked to the roof at that reach).
    rise_m
        Height over the object's points beside it, metres.
    share
        Least share of ``off`` points (at the point's height or above) among
        the points around it.
    below_m
        An ``off`` point counts when it stands no lower than this under the
        point, metres (the crown runs on at its height; the ground and low
        clutter beside a facade do not).
    outside
        Mask over ``members`` of those outside the polygon; ``None``: all
        inside.
    under
        Mask over ``members`` of the last returns of pulses with several
        returns; ``None``: none.  The slopes do not bound them, and only the ``off``
        points at their height count for them.

    Returns
    -------
    numpy.ndarray
        Boolean mask over ``members``.
    """
    from scipy.spatial import cKDTree

    flag = np.zeros(len(members), dtype=bool)
    if len(members) < 3 or len(off) == 0:
        return flag
    p = xyz[members]
    q = xyz[off]
    off_tree = cKDTree(q)
    d, _ = off_tree.query(p, k=1, distance_upper_bound=radius_m)
    at = np.flatnonzero(np.isfinite(d))  # only these can have off points around
    if len(at) == 0:
        return flag
    # stand above the object's points beside them: for a point inside the polygon, those
    # inside it (the ring holds facades, plinths and what the buffer caught, a branch)
    xy_tree = cKDTree(p[:, :2])
    k = min(CROWN_NEIGHBOURS + 1, len(members))
    idx = np.full((len(at), k), len(p))
    dxy = np.full((len(at), k), np.inf)
    inner = np.zeros(len(at), dtype=bool) if outside is None else ~outside[at]
    for rows, bound in (
        (~inner, np.arange(len(p))),
        (inner, np.flatnonzero(np.ones(len(p), bool) if outside is None else ~outside)),
    ):
        if rows.any() and len(bound):
            idx[rows], dxy[rows] = beside_points(p[:, :2], at[rows], bound, k, radius_m)
    z = np.sort(np.append(p[:, 2], np.nan)[idx], axis=1)  # idx == len(p): none that near
    n = np.isfinite(z).sum(axis=1)  # NaN sorts last: the median of the first n
    rows = np.arange(len(at))
    lo, hi = np.maximum(n - 1, 0) // 2, n // 2
    beside = np.where(n > 0, 0.5 * (z[rows, lo] + z[rows, np.minimum(hi, k - 1)]), np.inf)
    z_in = p[:, 2] if outside is None else np.where(outside, np.inf, p[:, 2])
    slope = np.append(z_in, np.inf)[idx] + CROWN_SLOPE * np.where(np.isfinite(dxy), dxy, 0.0)
    slope = slope.min(axis=1)
    if under is not None:
        slope = np.where(under[at], np.inf, slope)
    beside = np.minimum(beside, slope)
    at = at[p[at, 2] > beside + rise_m]
    if len(at) == 0:
        return flag
    # the blob runs on off the polygons: enough of the points around are off points
    # at its height or higher; for a point under something, at its height only (the crown
    # over it is what its pulse went through)
    near_off = off_tree.query_ball_point(p[at], radius_m)
    near_mem = xy_tree.query_ball_point(p[at, :2], radius_m)
    reach = np.full(len(at), np.inf) if under is None else np.where(under[at], below_m, np.inf)
    for j, i in enumerate(at):
        dz = q[np.asarray(near_off[j], dtype=np.int64), 2] - p[i, 2]
        n_off = int(((dz >= -below_m) & (dz <= reach[j])).sum())
        around = p[np.asarray(near_mem[j], dtype=np.int64)]
        n_mem = int((((around - p[i]) ** 2).sum(axis=1) <= radius_m**2).sum()) - 1  # not itself
        flag[i] = n_off > 0 and n_off >= share * (n_off + n_mem)
    return flag


def beside_points(
    xy: NDArray[np.float64],
    at: NDArray[np.int64],
    bound: NDArray[np.int64],
    k: int,
    radius_m: float,
) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """The ``k - 1`` points of ``bound`` nearest each point ``at`` in XY, itself excluded.

    Returns their indices into ``xy`` (``len(xy)``: none within ``radius_m``) and their
    XY distances (inf: none), ``(len(at), k)`` each (one column stays empty).
    """
    from scipy.spatial import cKDTree

    kk = min(k, len(bound))
    dxy, nb = cKDTree(xy[bound]).query(xy[at], k=kk, distance_upper_bound=radius_m)
    dxy = np.asarray(dxy, dtype=np.float64).reshape(len(at), kk)
    nb = np.asarray(nb).reshape(len(at), kk)
    idx = np.where(nb < len(bound), bound[np.minimum(nb, len(bound) - 1)], len(xy))
    # the point itself is not beside it; the others, k - 1 at most
    gone = idx == at[:, None]
    gone[:, -1] |= ~gone.any(axis=1)
    idx = np.where(gone, len(xy), idx)
    dxy = np.where(gone, np.inf, dxy)
    if kk < k:
        idx = np.pad(idx, ((0, 0), (0, k - kk)), constant_values=len(xy))
        dxy = np.pad(dxy, ((0, 0), (0, k - kk)), constant_values=np.inf)
    return idx, dxy
