"""Objects from a polygon's candidate points: clusters, scattered points (foliage), hulls."""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np
import shapely
from numpy.typing import NDArray

from pyheracles.complex.params import EXACT_LIMIT, ComplexParams
from pyheracles.segment.euclidean import euclidean_clusters, voxel_clusters

__all__ = ["cluster", "hull", "object_points", "scattered_points", "select_clusters"]


def cluster(xyz: NDArray[np.float64], params: ComplexParams) -> NDArray[np.int32]:
    d = float(params.cluster_distance_m)  # type: ignore[arg-type]
    use_voxel = params.clustering == "voxel" or (
        params.clustering == "auto" and len(xyz) > EXACT_LIMIT
    )
    if use_voxel:
        return voxel_clusters(xyz, d / 2.0, 1)
    return euclidean_clusters(xyz, d, 1)


def scattered_points(
    xyz: NDArray[np.float64],
    pts: NDArray[np.int64],
    params: ComplexParams,
    multi_echo: NDArray[np.bool_] | None,
) -> NDArray[np.bool_]:
    """Flag scattered (foliage-like) points among a layer's candidates.

    The surface variation is computed on voxel centroids (voxel a third of the
    clustering distance) and given back to the voxel's points: the same scale
    whatever the density, and a 10-100x smaller neighbour search on dense
    photogrammetric clouds.
    """
    if params.scatter_max is None or len(pts) < 12:
        return np.zeros(len(pts), dtype=bool)
    from pyheracles.geometry.neighbours import estimate_normals

    p = xyz[pts]
    voxel = float(params.cluster_distance_m) / 3.0  # type: ignore[arg-type]
    ijk = np.floor((p - p.min(axis=0)) / voxel).astype(np.int64)
    dims = ijk.max(axis=0) + 1
    keys = (ijk[:, 0] * dims[1] + ijk[:, 1]) * dims[2] + ijk[:, 2]
    _, inverse, counts = np.unique(keys, return_inverse=True, return_counts=True)
    inverse = inverse.ravel()
    centroids = np.column_stack([np.bincount(inverse, weights=p[:, j]) / counts for j in range(3)])
    if len(centroids) < 12:
        return np.zeros(len(pts), dtype=bool)
    _, curvature_v = estimate_normals(centroids, k=12)
    curvature = curvature_v[inverse]
    flag = curvature > params.scatter_max
    if multi_echo is not None and params.multi_echo_scatter_max is not None:
        flag |= multi_echo[pts] & (curvature > params.multi_echo_scatter_max)
    return flag


def object_points(
    xyz: NDArray[np.float64],
    cand: NDArray[np.int64],
    cand_dist: NDArray[np.float64],
    scattered: NDArray[np.bool_],
    params: ComplexParams,
) -> NDArray[np.bool_]:
    """Mask over ``cand`` of the points that make the polygon's object.

    Clusters are grown from the smooth points; scattered points then join
    through chains of scattered points near the footprint (see below).
    """
    keep = np.zeros(len(cand), dtype=bool)
    cand_in = cand_dist == 0.0
    core = ~scattered
    if core.sum() == 0:
        return keep
    labels = cluster(xyz[cand[core]], params)
    near_poly = cand_dist <= 0.5 * float(params.buffer_m)  # type: ignore[arg-type]
    keep[core] = select_clusters(labels, cand_in[core], near_poly[core], params)
    loose = np.flatnonzero(scattered)
    if not keep.any() or len(loose) == 0:
        return keep
    # Scattered points join the object when they lie within ``scatter_offset_m``
    # of the footprint and below the object's top and are linked to it through
    # such points (a rough roof, the arrises of a thin wall).  A crown over a
    # roof rises above it, and one rooted outside lies off the footprint:
    # neither is taken, even where it touches the object.  Links are twice the
    # clustering distance: such points are sparse.
    reach = 2.0 * float(params.attach_distance_m)  # type: ignore[arg-type]
    top = float(np.percentile(xyz[cand[keep], 2], 99)) + 0.5 * reach
    near_edge = cand_dist[loose] <= float(params.scatter_offset_m)  # type: ignore[arg-type]
    eligible = loose[near_edge & (xyz[cand[loose], 2] <= top)]
    if len(eligible) == 0:
        return keep
    from scipy.spatial import cKDTree

    dist, _ = cKDTree(xyz[cand[keep]]).query(xyz[cand[eligible]], k=1, distance_upper_bound=reach)
    link = replace(params, cluster_distance_m=2.0 * float(params.cluster_distance_m))  # type: ignore[arg-type]
    sub = cluster(xyz[cand[eligible]], link)
    touching = np.bincount(sub, weights=np.isfinite(dist).astype(np.float64)) > 0
    keep[eligible[touching[sub]]] = True
    return keep


def select_clusters(
    labels: NDArray[np.int32],
    inside: NDArray[np.bool_],
    near: NDArray[np.bool_],
    params: ComplexParams,
) -> NDArray[np.bool_]:
    """Mask of the points in the clusters that belong to the polygon's feature.

    Kept: the cluster with most points inside the polygon; every cluster that
    lies mostly (>= 50 %) within half a buffer of it (``near``), however
    small (a chimney, sparse facade points, the far side of a thin wall
    digitised off its axis); every cluster with at least
    ``min_cluster_points`` inside and an inside fraction >= ``keep_fraction``.
    """
    if len(labels) == 0:
        return np.zeros(0, dtype=bool)
    n = np.bincount(labels)
    n_in = np.bincount(labels, weights=inside.astype(np.float64), minlength=len(n))
    n_near = np.bincount(labels, weights=near.astype(np.float64), minlength=len(n))
    frac = np.divide(n_in, n, out=np.zeros(len(n)), where=n > 0)
    keep = (n_near >= 0.5 * n) & (n > 0)
    keep |= (n_in >= params.min_cluster_points) & (frac >= params.keep_fraction)
    best = int(np.argmax(n_in))
    keep[best] = True
    return keep[labels]


def hull(xy: NDArray[np.float64]) -> Any:
    """2D convex hull polygon (qhull picks the vertices, shapely builds the polygon)."""
    from scipy.spatial import ConvexHull, QhullError

    try:
        return shapely.Polygon(xy[ConvexHull(xy).vertices])
    except (QhullError, ValueError):  # collinear or too few points
        return shapely.convex_hull(shapely.multipoints(xy))
