"""Region growing with the smoothness constraint, at point and at voxel level.

The algorithm of Rabbani et al. (2006) as implemented by PCL's
``pcl::RegionGrowing`` and by M_HERACLES's ``regiongrowingnormals`` /
``regiongrowingnormalsOct`` (Murtiyoso 2020, ch. 6.3): a region starts at the
unassigned point of lowest curvature and takes every neighbour whose normal is
within ``angle_deg`` of the current point's normal; a neighbour whose curvature
is below ``curvature_max`` and whose distance to the current point's tangent
plane is below ``residual_m`` becomes a seed itself and keeps growing the region.

Implementation choice (documented because it differs in form from PCL's
queue): the seed queue is replaced by connected components.  Call a point
*core* if its curvature is below ``curvature_max`` and a kNN edge *smooth* if
the normals agree within ``angle_deg`` and each end lies within ``residual_m``
of the other's tangent plane.  PCL's region grown from a core seed is exactly
the set of core points connected to it by smooth edges, plus the non-core
points that are smooth neighbours of one of them (up to boundary points, see
below).  So:

1. connected components (:func:`scipy.sparse.csgraph.connected_components`)
   of the graph of smooth core-core edges give the regions' cores;
2. each non-core point joins the region of its smooth core neighbour with the
   best-aligned normal.

Deliberate deviations from PCL, all making the result independent of the
processing order: the kNN graph is made symmetric; the residual is tested in
both directions (PCL tests the neighbour against the current point's plane
only); a non-core point claimed by two regions goes to the better-aligned one,
and a core point that passes another region's angle test but fails its
residual test stays in its own component (PCL gives such boundary points to
whichever region reaches them first).  ``tests/test_regiongrow.py`` checks
that the two agree on more than 99 % of the core points.  Everything is array
work on ``N * k`` edges: no Python loop over points.

The voxel variant runs the same graph algorithm on voxels (normal, curvature
and centroid from the points of each voxel, 26-connectivity), then gives each
point its voxel's region: the thesis's octree variant, about 10 times faster
because no per-point neighbourhood is computed.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Literal

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike, NDArray
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from pyheracles.errors import InputError
from pyheracles.geometry.neighbours import (
    as_xyz,
    local_pca,
    octree_knn,
    orient_normals,
    point_spacing,
    symmetric_eigen3,
)

__all__ = ["RegionGrowingParams", "Regions", "grow_on_graph", "region_growing"]

_LEVELS = ("point", "voxel")


@dataclass(frozen=True)
class RegionGrowingParams:
    """Parameters of smoothness-constraint region growing.

    Attributes
    ----------
    k
        Neighbours per point (point level) including the point itself, for the
        normals and for the growing graph.  PCL's tutorial uses 30 for normals;
        16 is enough on clouds with millimetre noise.
    angle_deg
        Largest angle between neighbouring normals inside a region, degrees.
        ``None``: automatic, 3 times the median angle between neighbouring
        normals (the normal noise), clipped to [3, 20] degrees.  PCL's tutorial
        uses 3 degrees on clean data.
    curvature_max
        Largest curvature (surface variation) of a point that keeps growing a
        region (a *seed*).  ``None``: automatic, 2 times the median curvature
        (the noise level of flat surfaces) clipped to [0.01, 0.1]; the cap keeps
        volumetric clutter (vegetation, noise; curvature near 1/3) out.
    residual_m
        Largest distance between a point and its neighbour's tangent plane for
        the point to keep growing, metres.  ``None``: automatic, 4 times the
        median neighbourhood thickness ``sqrt(lambda_0)``; ``0`` disables it.
    min_points
        Regions smaller than this are dissolved (their points go back to the
        pool, label 0).
    graph_k
        Point level: grow over the first ``graph_k`` of the ``k`` neighbours
        only (``None``: all ``k``, as PCL).  Fewer edges, same regions on
        dense scans, faster.
    level
        ``"point"`` (per-point normals) or ``"voxel"`` (per-voxel normals,
        M_HERACLES ``regiongrowingnormalsOct``; faster, coarser borders).
    voxel_m
        Voxel edge for ``level="voxel"``, metres; ``None``: 3 times the point
        spacing (normals are computed on 3x3x3 voxel blocks).
    """

    k: int = 16
    angle_deg: float | None = None
    curvature_max: float | None = None
    residual_m: float | None = None
    min_points: int = 50
    graph_k: int | None = None
    level: Literal["point", "voxel"] = "point"
    voxel_m: float | None = None

    def validate(self) -> RegionGrowingParams:
        if self.level not in _LEVELS:
            raise InputError(f"level must be one of {_LEVELS}, got {self.level!r}")
        if self.k < 4:
            raise InputError(f"k must be at least 4, got {self.k}")
        if self.angle_deg is not None and not 0 < self.angle_deg < 90:
            raise InputError(f"angle_deg must be in (0, 90), got {self.angle_deg}")
        if self.curvature_max is not None and self.curvature_max <= 0:
            raise InputError(f"curvature_max must be > 0, got {self.curvature_max}")
        if self.residual_m is not None and self.residual_m < 0:
            raise InputError(f"residual_m must be >= 0, got {self.residual_m}")
        if self.voxel_m is not None and self.voxel_m <= 0:
            raise InputError(f"voxel_m must be > 0, got {self.voxel_m}")
        if self.graph_k is not None and self.graph_k < 2:
            raise InputError(f"graph_k must be at least 2, got {self.graph_k}")
        if self.min_points < 1:
            raise InputError(f"min_points must be >= 1, got {self.min_points}")
        return self


@dataclass(frozen=True)
class Regions:
    """Result of region growing.

    Attributes
    ----------
    labels
        ``(N,)`` int32 region per point, 1..n by decreasing size, 0 = none.
    normals
        ``(N, 3)`` unit normals used (per voxel at voxel level), unoriented.
    curvature
        ``(N,)`` curvature used.
    params
        The parameters with every automatic value resolved.
    """

    labels: NDArray[np.int32]
    normals: NDArray[np.float64]
    curvature: NDArray[np.float64]
    params: RegionGrowingParams

    @property
    def n_regions(self) -> int:
        return int(self.labels.max(initial=0))


def _edge_terms(
    src: NDArray[np.int64],
    dst: NDArray[np.int64],
    positions: NDArray[np.float64],
    normals: NDArray[np.float64],
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``|cos|`` of the normal angle and the two-way plane residual of every edge."""
    ns, nd = normals[src], normals[dst]
    d = positions[dst] - positions[src]
    cosang = np.abs(ns[:, 0] * nd[:, 0] + ns[:, 1] * nd[:, 1] + ns[:, 2] * nd[:, 2])
    r1 = np.abs(ns[:, 0] * d[:, 0] + ns[:, 1] * d[:, 1] + ns[:, 2] * d[:, 2])
    r2 = np.abs(nd[:, 0] * d[:, 0] + nd[:, 1] * d[:, 1] + nd[:, 2] * d[:, 2])
    return cosang, np.maximum(r1, r2)


def grow_on_graph(
    src: NDArray[np.int64],
    dst: NDArray[np.int64],
    positions: NDArray[np.float64],
    normals: NDArray[np.float64],
    curvature: NDArray[np.float64],
    *,
    angle_deg: float,
    curvature_max: float,
    residual_m: float,
    weights: NDArray[np.float64] | None = None,
    min_size: float = 1,
) -> NDArray[np.int32]:
    """Smoothness-constraint region growing on an arbitrary neighbour graph.

    Parameters
    ----------
    src, dst
        Edges of the neighbour graph (either direction, duplicates allowed).
    positions, normals, curvature
        Node positions (metres), unit normals, curvature.
    angle_deg, curvature_max, residual_m
        Thresholds as in :class:`RegionGrowingParams` (``residual_m = 0``
        disables the residual test).
    weights
        Size of each node (points per voxel); default 1.
    min_size
        Regions whose total weight is below this get label 0.

    Returns
    -------
    labels
        ``(n_nodes,)`` int32, 1..R by decreasing weight, 0 = none.
    """
    keep = src != dst
    src, dst = src[keep], dst[keep]
    cosang, resid = _edge_terms(src, dst, positions, normals)
    return _grow(
        src,
        dst,
        cosang,
        resid,
        curvature,
        angle_deg=angle_deg,
        curvature_max=curvature_max,
        residual_m=residual_m,
        weights=weights,
        min_size=min_size,
    )


def _grow(
    src: NDArray[np.int64],
    dst: NDArray[np.int64],
    cosang: NDArray[np.float64],
    resid: NDArray[np.float64],
    curvature: NDArray[np.float64],
    *,
    angle_deg: float,
    curvature_max: float,
    residual_m: float,
    weights: NDArray[np.float64] | None,
    min_size: float,
) -> NDArray[np.int32]:
    n = len(curvature)
    smooth = cosang >= np.cos(np.radians(angle_deg))
    core = curvature < curvature_max
    core_edge = smooth & core[src] & core[dst]
    if residual_m > 0:
        core_edge &= resid <= residual_m
    graph = sp.csr_matrix(
        (np.ones(int(core_edge.sum()), dtype=np.int8), (src[core_edge], dst[core_edge])),
        shape=(n, n),
    )
    _, comp = connected_components(graph, directed=False)
    comp = comp.astype(np.int64)
    comp[~core] = -1
    # non-core nodes join the region of their best-aligned smooth core neighbour
    fwd = smooth & core[src] & ~core[dst]
    bwd = smooth & ~core[src] & core[dst]  # edges stored the other way round
    a_src = np.concatenate([src[fwd], dst[bwd]])
    a_dst = np.concatenate([dst[fwd], src[bwd]])
    a_cos = np.concatenate([cosang[fwd], cosang[bwd]])
    if len(a_dst):
        order = np.lexsort((-a_cos, a_dst))
        first = np.ones(len(order), dtype=bool)
        first[1:] = a_dst[order][1:] != a_dst[order][:-1]
        best = order[first]
        comp[a_dst[best]] = comp[a_src[best]]
    w = np.ones(n) if weights is None else np.asarray(weights, dtype=np.float64)
    labelled = comp >= 0
    size = np.bincount(comp[labelled], weights=w[labelled], minlength=int(comp.max()) + 1)
    big = np.flatnonzero(size >= min_size)
    order = big[np.argsort(-size[big], kind="stable")]
    remap = np.zeros(len(size), dtype=np.int32)
    remap[order] = np.arange(1, len(order) + 1, dtype=np.int32)
    out = np.zeros(n, dtype=np.int32)
    out[labelled] = remap[comp[labelled]]
    return out


def _auto_thresholds(
    params: RegionGrowingParams,
    valid: NDArray[np.bool_],
    curvature: NDArray[np.float64],
    thickness: NDArray[np.float64],
    cosang: NDArray[np.float64],
    edge_valid: NDArray[np.bool_],
) -> RegionGrowingParams:
    """Resolve the ``None`` thresholds from the data (see RegionGrowingParams)."""
    angle, curv, resid = params.angle_deg, params.curvature_max, params.residual_m
    if angle is None:
        c = cosang[edge_valid]
        med = np.degrees(np.arccos(np.clip(np.median(c), -1.0, 1.0))) if len(c) else 1.0
        angle = float(np.clip(3.0 * med, 3.0, 20.0))
    if curv is None:
        curv = float(np.clip(2.0 * np.median(curvature[valid]), 0.01, 0.1)) if valid.any() else 0.01
    if resid is None:
        resid = 4.0 * float(np.median(thickness[valid])) if valid.any() else 0.0
    return replace(params, angle_deg=angle, curvature_max=curv, residual_m=resid)


def _resolve_and_grow(
    params: RegionGrowingParams,
    src: NDArray[np.int64],
    dst: NDArray[np.int64],
    positions: NDArray[np.float64],
    normals: NDArray[np.float64],
    curvature: NDArray[np.float64],
    thickness: NDArray[np.float64],
    weights: NDArray[np.float64] | None,
) -> tuple[NDArray[np.int32], RegionGrowingParams]:
    keep = src != dst
    src, dst = src[keep], dst[keep]
    cosang, resid = _edge_terms(src, dst, positions, normals)
    valid = (normals * normals).sum(axis=1) > 0.25
    resolved = _auto_thresholds(
        params, valid, curvature, thickness, cosang, valid[src] & valid[dst]
    )
    labels = _grow(
        src,
        dst,
        cosang,
        resid,
        curvature,
        angle_deg=resolved.angle_deg,
        curvature_max=resolved.curvature_max,
        residual_m=resolved.residual_m,
        weights=weights,
        min_size=params.min_points,
    )
    return labels, resolved


def _knn_edge_terms(
    xyz: NDArray[np.float64], normals: NDArray[np.float64], nbr: NDArray[np.int64]
) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
    """:func:`_edge_terms` for a kNN graph ``(n, m)``, in float32, compiled.

    The kNN layout avoids gathering the source side; float32 halves the memory
    traffic (the values are cosines and centimetre residuals).  Written as a
    compiled loop (:func:`~pyheracles.segment.edge_kernels.knn_edge_terms`)
    because numpy's version made five ``(n, m, 3)`` temporaries: a third of the
    point-level growth on a 1 M-point roof.  The values are those of the numpy
    formulas to the bit (float32 products summed in the same order, no fused
    multiply-add).
    """
    from pyheracles.segment.edge_kernels import knn_edge_terms

    n, m = nbr.shape
    centre = 0.5 * (xyz.min(axis=0) + xyz.max(axis=0))
    pos = np.ascontiguousarray((xyz - centre).astype(np.float32))
    nrm = np.ascontiguousarray(normals.astype(np.float32))
    cosang = np.empty((n, m), dtype=np.float32)
    resid = np.empty((n, m), dtype=np.float32)
    knn_edge_terms(pos, nrm, np.ascontiguousarray(nbr), cosang, resid)
    return cosang.ravel(), resid.ravel()


def _point_level(
    xyz: NDArray[np.float64], params: RegionGrowingParams, tree: cKDTree | None
) -> Regions:
    del tree  # the compiled octree search is 2-4x faster than querying the tree
    _, idx = octree_knn(xyz, int(min(params.k, len(xyz))))
    pca = local_pca(xyz, indices=idx, directions=False)
    normals = orient_normals(xyz, pca.normals)
    n, k = idx.shape
    kg = k if params.graph_k is None else int(min(params.graph_k, k))
    nbr = idx[:, 1:kg]
    src = np.repeat(np.arange(n, dtype=np.int64), kg - 1)
    dst = nbr.ravel()
    cosang, resid = _knn_edge_terms(xyz, normals, nbr)
    keep = src != dst  # exact duplicates can take column 0
    if not keep.all():
        src, dst, cosang, resid = src[keep], dst[keep], cosang[keep], resid[keep]
    valid = (normals * normals).sum(axis=1) > 0.25
    resolved = _auto_thresholds(
        params,
        valid,
        pca.curvature,
        np.sqrt(pca.eigenvalues[:, 0]),
        cosang,
        valid[src] & valid[dst],
    )
    labels = _grow(
        src,
        dst,
        cosang,
        resid,
        pca.curvature,
        angle_deg=resolved.angle_deg,
        curvature_max=resolved.curvature_max,
        residual_m=resolved.residual_m,
        weights=None,
        min_size=params.min_points,
    )
    return Regions(labels=labels, normals=normals, curvature=pca.curvature, params=resolved)


_OFFSETS = np.array(
    [
        (dx, dy, dz)
        for dx in (-1, 0, 1)
        for dy in (-1, 0, 1)
        for dz in (-1, 0, 1)
        if (dx, dy, dz) > (0, 0, 0)
    ],
    dtype=np.int64,
)  # 13 half-space offsets: each of the 26 neighbour pairs once


def _voxel_level(
    xyz: NDArray[np.float64], params: RegionGrowingParams, tree: cKDTree | None
) -> Regions:
    size = params.voxel_m
    if size is None:
        size = 3.0 * point_spacing(xyz, tree)
    cell = np.floor((xyz - xyz.min(axis=0)) / size).astype(np.int64)
    dims = cell.max(axis=0) + 3
    key = ((cell[:, 0] + 1) * dims[1] + cell[:, 1] + 1) * dims[2] + cell[:, 2] + 1
    ukey, inverse, counts = np.unique(key, return_inverse=True, return_counts=True)
    m = len(ukey)
    # 26-connectivity by key arithmetic and a sorted-key lookup
    vcell = np.column_stack(
        [ukey // (dims[1] * dims[2]), (ukey // dims[2]) % dims[1], ukey % dims[2]]
    )
    srcs, dsts = [], []
    for off in _OFFSETS:
        nb = vcell + off
        nkey = (nb[:, 0] * dims[1] + nb[:, 1]) * dims[2] + nb[:, 2]
        pos = np.minimum(np.searchsorted(ukey, nkey), m - 1)
        found = ukey[pos] == nkey
        srcs.append(np.flatnonzero(found))
        dsts.append(pos[found])
    src = np.concatenate(srcs).astype(np.int64)
    dst = np.concatenate(dsts).astype(np.int64)
    # per-voxel moment sums about the cloud centre (one bincount per moment),
    # then summed over the 3x3x3 block: a voxel's normal comes from its own and
    # its 26 neighbours' points, which averages the noise like a kNN would.
    centre = 0.5 * (xyz.min(axis=0) + xyz.max(axis=0))
    x, y, z = (xyz - centre).T
    cols = (np.ones(len(x)), x, y, z, x * x, y * y, z * z, x * y, x * z, y * z)
    own = np.column_stack([np.bincount(inverse, weights=c, minlength=m) for c in cols])
    adj = sp.csr_matrix((np.ones(len(src)), (src, dst)), shape=(m, m))
    block = own + adj @ own + adj.T @ own
    mom = block[:, 1:] / block[:, :1]
    mx, my, mz = mom[:, 0], mom[:, 1], mom[:, 2]
    cov = mom[:, 3:] - np.column_stack([mx * mx, my * my, mz * mz, mx * my, mx * mz, my * mz])
    vals, vnormals, _ = symmetric_eigen3(cov)
    total = vals.sum(axis=1)
    sparse_vox = (block[:, 0] < 5) | (total <= 0)
    vcurv = np.where(sparse_vox, 1.0 / 3.0, vals[:, 0] / np.where(total > 0, total, 1.0))
    vnormals[sparse_vox] = 0.0
    centroid = own[:, 1:4] / own[:, :1] + centre
    vnormals = orient_normals(centroid, vnormals)
    vlabels, resolved = _resolve_and_grow(
        replace(params, voxel_m=float(size)),
        src,
        dst,
        centroid,
        vnormals,
        vcurv,
        np.sqrt(vals[:, 0]),
        counts.astype(np.float64),
    )
    return Regions(
        labels=vlabels[inverse].astype(np.int32),
        normals=vnormals[inverse],
        curvature=vcurv[inverse],
        params=resolved,
    )


def region_growing(
    xyz: ArrayLike,
    params: RegionGrowingParams | None = None,
    *,
    tree: cKDTree | None = None,
) -> Regions:
    """Segment a cloud into smooth regions (planar facets, smooth surfaces).

    Parameters
    ----------
    xyz
        ``(N, 3)`` coordinates, metres (local frame).
    params
        :class:`RegionGrowingParams`; automatic thresholds are resolved from the
        data and returned in ``Regions.params``.
    tree
        Shared KD-tree on ``xyz``, for the voxel level's point spacing (the point
        level's neighbours come from the compiled octree search,
        :func:`~pyheracles.geometry.neighbours.octree_knn`).

    Returns
    -------
    Regions
        Labels 1..R by decreasing size (0 = in no region), normals, curvature.

    Examples
    --------
    >>> import numpy as np
    >>> g = np.stack(np.meshgrid(np.arange(40.0), np.arange(40.0)), -1).reshape(-1, 2) * 0.01
    >>> floor = np.column_stack([g, np.zeros(len(g))])
    >>> wall = np.column_stack([g[:, 0], np.zeros(len(g)), g[:, 1] + 0.01])
    >>> r = region_growing(np.vstack([floor, wall]), RegionGrowingParams(angle_deg=5))
    >>> r.n_regions
    2
    """
    p = (params or RegionGrowingParams()).validate()
    arr = as_xyz(xyz)
    if len(arr) < max(p.k, 4):
        raise InputError(
            f"region growing needs at least {max(p.k, 4)} points, got {len(arr)}",
            hint="lower --k (heracles beams) or give a larger cloud",
        )
    if p.level == "point":
        return _point_level(arr, p, tree)
    return _voxel_level(arr, p, tree)
