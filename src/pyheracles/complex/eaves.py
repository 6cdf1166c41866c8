"""Eaves: the roof's own surface running on outward beyond the outline (issue 17).

A cadastral outline (BGT) follows the walls; the roof overhangs it by 0.3-1 m.  The
returns on an overhang are mostly pulses with several returns (the edge), so the surface
variation flags them scattered, and scattered points join an object only within
``scatter_offset_m`` of its polygon (a hedge or a crown beside a shed lies farther out).
Widening that reach took the neighbours' roofs and the trees' points too (AHN3 tile 1:
share of buildings at F1 >= 0.9 0.935 -> 0.914).  An eave is told from them by the roof
it continues: its points lie on the plane of the object's own roof points beside them,
no higher than they are; a neighbour's roof stands at another height or slope, a crown is
rough or above the roof.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "EAVE_LEAST",
    "EAVE_NEIGHBOURS",
    "RISE",
    "TOP_CELLS",
    "TOP_NEIGHBOURS",
    "TRIM_ROUNDS",
    "eave_points",
]

#: Object points (nearest in XY) from which the roof plane beside a point is fitted.
EAVE_NEIGHBOURS = 12
#: Cells across the fitting radius; the highest object point of each makes the roof.
TOP_CELLS = 6
#: Least number of them on the roof plane (the others stand under it: a facade).
EAVE_LEAST = 6
#: Object points nearest in XY whose highest is the roof beside a point.
TOP_NEIGHBOURS = 4
#: Highest an eave's points (a gutter) stand over the roof's plane, metres.
RISE = 0.5
#: Rounds dropping the points under the plane (a facade's) and fitting again.
TRIM_ROUNDS = 2


def eave_points(
    xyz: NDArray[np.float64],
    roof: NDArray[np.float64],
    others: NDArray[np.float64],
    radius_m: float,
    tolerance_m: float,
) -> NDArray[np.bool_]:
    """Mask over ``xyz`` of the points that continue the surface of ``roof`` outward.

    The roof is the object's top surface: the highest of its points in each XY cell of
    ``radius_m / TOP_CELLS`` (a facade under the roof's edge is not).  For each point,
    the :data:`EAVE_NEIGHBOURS` roof points nearest it (3D, within ``radius_m``) are
    fitted with a plane (least squares, ``z = a + b x + c y``), first the upper half of
    them, then every one at or over the plane found less ``tolerance_m``
    (:data:`TRIM_ROUNDS` times).  The point is an eave's when

    * at least :data:`EAVE_LEAST` of them lie on that plane with an RMS residual at most
      ``tolerance_m / 2`` (one roof face: not a ridge, a step or foliage);
    * they are the roof beside the point: their highest stands at least as high, less
      ``tolerance_m``, as the highest of the :data:`TOP_NEIGHBOURS` roof points nearest
      it in XY (not a platform or a low part under the roof);
    * the point lies between ``tolerance_m`` under the plane and ``tolerance_m`` over
      the band an eave fills: up to the roof's edge beside it (the lower of those two
      highest points) and at most :data:`RISE` over the plane (a gutter stands over the
      plane of a roof sloping down to it);
    * none of ``others`` within ``radius_m / 2`` in XY stands over that band plus
      ``tolerance_m``: an eave has nothing over it, a hedge's or a crown's rough top
      pokes out of it.

    Parameters
    ----------
    xyz
        (N, 3) points to test, metres.
    roof
        (M, 3) points of the object taken so far, metres.
    others
        (K, 3) points not taken (``xyz`` among them).
    radius_m
        Farthest roof point used, metres.
    tolerance_m
        Largest distance (vertical) from the roof plane, metres.

    Returns
    -------
    numpy.ndarray
        Boolean mask over ``xyz``.
    """
    out = np.zeros(len(xyz), dtype=bool)
    k = EAVE_NEIGHBOURS
    if len(xyz) == 0 or len(roof) < k:
        return out
    from scipy.spatial import cKDTree

    # the roof is the object's top surface: the highest point of each cell of a sixth of
    # the radius (a facade under its edge is not)
    cell = np.floor((roof[:, :2] - roof[:, :2].min(axis=0)) / (radius_m / TOP_CELLS))
    order = np.lexsort((-roof[:, 2], cell[:, 1], cell[:, 0]))
    c = cell[order]
    first = np.ones(len(c), dtype=bool)
    first[1:] = (c[1:] != c[:-1]).any(axis=1)
    roof = roof[order[first]]
    if len(roof) < k:
        return out
    _, idx = cKDTree(roof).query(xyz, k=k, distance_upper_bound=radius_m)
    full = (idx < len(roof)).sum(axis=1) >= EAVE_LEAST
    at = np.flatnonzero(full)
    if len(at) == 0:
        return out
    idx = idx[at]
    use = idx < len(roof)
    nb = np.concatenate([roof, np.zeros((1, 3))])[idx]  # (n, k, 3)
    d = nb[:, :, :2] - xyz[at, None, :2]  # relative to the point: the plane's a is z there
    a_mat = np.concatenate([np.ones((len(at), k, 1)), d], axis=2)
    coef = np.zeros((len(at), 3))
    # start from the upper half (a facade's points stand under the roof beside them),
    # then take every point at or over the plane found, and fit again
    zn = np.where(use, nb[:, :, 2], np.nan)
    use &= zn >= np.nanmedian(zn, axis=1)[:, None]
    for _ in range(TRIM_ROUNDS + 1):
        w = use.astype(np.float64)
        ata = np.einsum("nk,nki,nkj->nij", w, a_mat, a_mat)
        atb = np.einsum("nk,nki,nk->ni", w, a_mat, nb[:, :, 2])
        ok = (use.sum(axis=1) >= 3) & (
            np.abs(np.linalg.det(ata)) > 1e-6 * np.maximum(ata[:, 0, 0], 1.0)
        )
        coef[:] = 0.0
        coef[ok] = np.linalg.solve(ata[ok], atb[ok][:, :, None])[:, :, 0]
        resid = nb[:, :, 2] - np.einsum("nki,ni->nk", a_mat, coef)
        # the roof is the top surface
        use = (idx < len(roof)) & (resid >= -tolerance_m)
    w = use.astype(np.float64)
    rms = np.sqrt((w * resid**2).sum(axis=1) / np.maximum(w.sum(axis=1), 1.0))
    z = xyz[at, 2]
    # an eave (its gutter) stands at most RISE over the plane, and no higher than the roof
    top = np.where(use, nb[:, :, 2], -np.inf).max(axis=1)
    # the plane is the object's top surface beside the point (its roof), not a step or a
    # platform under it: the highest of the object's points nearest in XY stands no
    # higher than the plane's points
    _, near = cKDTree(roof[:, :2]).query(xyz[at, :2], k=min(TOP_NEIGHBOURS, len(roof)))
    beside = roof[np.asarray(near).reshape(len(at), -1), 2].max(axis=1)
    band = np.clip(np.minimum(top, beside) - coef[:, 0], 0.0, RISE)
    on = (
        ok
        & (use.sum(axis=1) >= EAVE_LEAST)
        & (rms <= 0.5 * tolerance_m)
        & (z >= coef[:, 0] - tolerance_m)
        & (z <= coef[:, 0] + band + tolerance_m)
        & (top >= beside - tolerance_m)
    )
    band = band[on]
    # nothing of the points not taken beside it stands over that plane: an eave has
    # nothing over it, a hedge's or a crown's rough top pokes out of it
    at, coef = at[on], coef[on]
    if len(at) and len(others):
        tree = cKDTree(others[:, :2])
        pairs = tree.query_ball_point(xyz[at, :2], r=0.5 * radius_m)
        lens = np.fromiter((len(q) for q in pairs), dtype=np.int64, count=len(at))
        row = np.repeat(np.arange(len(at)), lens)
        col = np.fromiter((j for q in pairs for j in q), dtype=np.int64, count=int(lens.sum()))
        d = others[col, :2] - xyz[at[row], :2]
        over = (
            others[col, 2] - (coef[row, 0] + (d * coef[row, 1:]).sum(axis=1))
            > band[row] + tolerance_m
        )
        clear = np.bincount(row, weights=over.astype(np.float64), minlength=len(at)) == 0
        at = at[clear]
    out[at] = True
    return out
