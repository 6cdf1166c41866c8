"""Euclidean distance clustering (MATLAB ``clustering`` / ``pcsegdist``).

Two variants with the same contract -- labels aligned with the input, 1..K by
decreasing cluster size, 0 for points in clusters smaller than ``min_points``:

* :func:`euclidean_clusters` is exact: two points are in one cluster when a
  chain of points links them with every step ``<= distance_m`` (single
  linkage, as PCL's ``EuclideanClusterExtraction`` and MATLAB's
  ``pcsegdist``).  KD-tree pairs + ``scipy.sparse.csgraph`` components.
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

__all__ = ["euclidean_clusters", "relabel_by_size", "voxel_clusters"]


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
        A KD-tree already built on ``xyz`` (shared to avoid rebuilding it).

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
    kd = tree if tree is not None else cKDTree(pts)
    pairs = kd.query_pairs(distance_m, output_type="ndarray")
    graph = coo_matrix(
        (np.ones(len(pairs), dtype=np.int8), (pairs[:, 0], pairs[:, 1])), shape=(n, n)
    )
    _, comp = connected_components(graph, directed=False)
    return relabel_by_size(comp, min_points)


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
