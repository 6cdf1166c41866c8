"""Euclidean distance clustering (MATLAB ``clustering`` / ``pcsegdist``).

Two variants with the same contract -- labels aligned with the input, 1..K by
decreasing cluster size, 0 for points in clusters smaller than ``min_points``:

* :func:`euclidean_clusters` is exact: two points are in one cluster when a
  chain of points links them with every step ``<= distance_m`` (single
  linkage, as PCL's ``EuclideanClusterExtraction`` and MATLAB's
  ``pcsegdist``).  A compiled grid of cells joined by union-find
  (:mod:`pyheracles.segment.linkage_kernels`); KD-tree pairs +
  ``scipy.sparse.csgraph`` components on grids too large for its keys.
* :func:`voxel_clusters` links occupied voxels that touch (26-neighbourhood):
  linear time and memory, for clouds of tens of millions of points.  Two
  points in one cluster are linked by steps of at most ``2 * sqrt(3) *
  voxel_m``; points closer than ``voxel_m`` are always linked.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from pyheracles.errors import InputError
from pyheracles.segment.linkage_kernels import cell_components, forward_rows

__all__ = ["euclidean_clusters", "grid_components", "relabel_by_size", "voxel_clusters"]


def _check(xyz: NDArray[np.float64], distance: float, min_points: int) -> NDArray[np.float64]:
    pts = np.asarray(xyz, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] not in (2, 3):
        raise InputError(f"points must have shape (N, 2) or (N, 3), got {pts.shape}")
    if not distance > 0:
        raise InputError(f"clustering distance must be > 0 m, got {distance}")
    if min_points < 1:
        raise InputError(f"min_points must be >= 1, got {min_points}")
    return pts


def relabel_by_size(components: NDArray[np.integer], min_points: int) -> NDArray[np.int32]:
    """Turn component ids into labels 1..K by decreasing size; small components get 0."""
    comp = np.asarray(components)
    if comp.size == 0:
        return np.zeros(0, dtype=np.int32)
    sizes = np.bincount(comp)
    keep = np.flatnonzero(sizes >= min_points)
    order = keep[np.argsort(-sizes[keep], kind="stable")]
    lut = np.zeros(len(sizes), dtype=np.int32)
    lut[order] = np.arange(1, len(order) + 1, dtype=np.int32)
    return lut[comp]


def euclidean_clusters(
    xyz: NDArray[np.float64],
    distance_m: float,
    min_points: int = 1,
    *,
    tree: cKDTree | None = None,
) -> NDArray[np.int32]:
    """Single-linkage clusters of points closer than ``distance_m``.

    Parameters
    ----------
    xyz
        ``(N, 3)`` (or ``(N, 2)``) coordinates, metres, local frame.
    distance_m
        Largest gap inside a cluster, metres.
    min_points
        Clusters with fewer points are labelled 0 (noise).
    tree
        A KD-tree already built on ``xyz``, used only where the cell grid is too large
        for its keys (then shared to avoid rebuilding it).

    Returns
    -------
    ndarray of int32, shape (N,)
        1 for the largest cluster, 2 for the next ..., 0 for noise.

    Examples
    --------
    >>> import numpy as np
    >>> pts = np.array([[0, 0, 0], [0.5, 0, 0], [5, 0, 0.0]])
    >>> euclidean_clusters(pts, 1.0).tolist()
    [1, 1, 2]
    """
    pts = _check(xyz, distance_m, min_points)
    n = len(pts)
    if n == 0:
        return np.zeros(0, dtype=np.int32)
    comp = grid_components(pts, distance_m)
    if comp is None:  # a grid too large for 63-bit cell keys: list the pairs instead
        kd = tree if tree is not None else cKDTree(pts)
        pairs = kd.query_pairs(distance_m, output_type="ndarray")
        graph = coo_matrix(
            (np.ones(len(pairs), dtype=np.int8), (pairs[:, 0], pairs[:, 1])), shape=(n, n)
        )
        _, comp = connected_components(graph, directed=False)
    return relabel_by_size(comp, min_points)


def grid_components(pts: NDArray[np.float64], distance_m: float) -> NDArray[np.int64] | None:
    """Component of each point in the graph of pairs within ``distance_m``, numbered
    0, 1, ... in the order of each component's first point (scipy's
    ``connected_components`` numbering), from the compiled cell grid
    (:mod:`pyheracles.segment.linkage_kernels`); None when the grid's cell keys would
    not fit in 63 bits (an extent of more than about 10**6 cells along each of three
    axes) or a coordinate is not finite."""
    n, dim = pts.shape
    # a hair under d / sqrt(D): two points of one cell are within d despite rounding
    cell = distance_m / np.sqrt(dim) * (1.0 - 1e-9)
    lo = pts.min(axis=0)
    if not np.isfinite(lo).all():
        return None  # NaN or infinite coordinates: the pair list's own handling
    ijk = ((pts - lo) / cell).astype(np.int64) + 2  # 2 empty cells before the first
    dims = ijk.max(axis=0) + 3  # and after the last: no neighbour wraps to another row
    if float(np.prod(dims.astype(np.float64))) >= 2.0**62:
        return None
    strides = np.ones(dim, dtype=np.int64)
    for k in range(dim - 2, -1, -1):
        strides[k] = strides[k + 1] * dims[k + 1]
    keys = ijk @ strides
    order = np.argsort(keys, kind="stable")
    sorted_keys = keys[order]
    first = np.flatnonzero(np.r_[True, sorted_keys[1:] != sorted_keys[:-1]])
    starts = np.r_[first, n].astype(np.int64)
    rows = forward_rows(dim)  # (R, dim + 1): offsets of the other axes, first, last
    row_steps = (rows[:, : dim - 1] @ strides[:-1])[:, None] + rows[:, dim - 1 :]
    roots = cell_components(
        np.ascontiguousarray(pts[order]), starts, sorted_keys[first], row_steps,
        float(distance_m) ** 2,
    )  # fmt: skip
    root_of_point = np.empty(n, dtype=np.int64)
    root_of_point[order] = np.repeat(roots, np.diff(starts))
    # number the components by their first point, as a breadth-first search from point 0
    found, first_point, inverse = np.unique(root_of_point, return_index=True, return_inverse=True)
    rank = np.empty(len(found), dtype=np.int64)
    rank[np.argsort(first_point, kind="stable")] = np.arange(len(found))
    return rank[inverse]


# The 13 "forward" offsets of the 26-neighbourhood (the other 13 are their negatives).
_FORWARD = np.array(
    [(dx, dy, dz) for dx in (-1, 0, 1) for dy in (-1, 0, 1) for dz in (-1, 0, 1)
     if (dx, dy, dz) > (0, 0, 0)],
    dtype=np.int64,
)  # fmt: skip


def voxel_clusters(
    xyz: NDArray[np.float64], voxel_m: float, min_points: int = 1
) -> NDArray[np.int32]:
    """Connected components of touching occupied voxels (26-neighbourhood).

    Parameters
    ----------
    xyz
        ``(N, 3)`` coordinates, metres, local frame.
    voxel_m
        Voxel edge, metres.
    min_points
        Clusters with fewer points are labelled 0.

    Returns
    -------
    ndarray of int32, shape (N,)
        Labels as :func:`euclidean_clusters`.
    """
    pts = _check(xyz, voxel_m, min_points)
    n = len(pts)
    if n == 0:
        return np.zeros(0, dtype=np.int32)
    if pts.shape[1] == 2:
        pts = np.column_stack([pts, np.zeros(n)])
    ijk = np.floor((pts - pts.min(axis=0)) / voxel_m).astype(np.int64) + 1
    dims = ijk.max(axis=0) + 2
    keys = (ijk[:, 0] * dims[1] + ijk[:, 1]) * dims[2] + ijk[:, 2]
    vox, point_vox = np.unique(keys, return_inverse=True)
    nv = len(vox)
    strides = np.array([dims[1] * dims[2], dims[2], 1], dtype=np.int64)
    src, dst = [], []
    for off in _FORWARD:  # 13 vectorised look-ups, not a loop over points
        nb = vox + off @ strides
        pos = np.searchsorted(vox, nb)
        pos = np.minimum(pos, nv - 1)
        hit = vox[pos] == nb
        src.append(np.flatnonzero(hit))
        dst.append(pos[hit])
    s = np.concatenate(src)
    d = np.concatenate(dst)
    graph = coo_matrix((np.ones(len(s), dtype=np.int8), (s, d)), shape=(nv, nv))
    _, comp_vox = connected_components(graph, directed=False)
    return relabel_by_size(comp_vox[point_vox.ravel()], min_points)
