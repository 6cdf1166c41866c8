"""Voxel downsampling, normals and FPFH descriptors for markerless registration.

The ingredients of feature-based global registration (Rusu, Blodow & Beetz 2009;
Zhou, Park & Koltun 2016, the pipeline behind Open3D's
``registration_ransac_based_on_feature_matching``), hand-written and vectorised
with numpy/scipy because Open3D is only a benchmark extra of pyheracles:

- :func:`choose_voxel` picks the voxel size from the occupied surface of the
  cloud (so that the downsampled cloud has a few thousand points whatever the
  scale) and never below a multiple of the measured point spacing;
- :func:`voxel_downsample` keeps one centroid per occupied voxel;
- :func:`fpfh_descriptors` computes Fast Point Feature Histograms of every
  downsampled point with *unoriented* normals: each point pair is put into a
  canonical sign (``n_s . d >= 0``, ``n_t . n_s >= 0``) before the Darboux-frame
  angles are taken, so the descriptor does not depend on the arbitrary sign of
  a PCA normal (scans seen from different sides, no known scanner position).
  The histograms are accumulated by a compiled kernel
  (:mod:`pyheracles.registration.fpfh_kernels`, numba) over the neighbourhoods
  of :func:`radius_neighbours` (the nearest points within the support radius,
  found on a grid of cells as wide as the radius).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from pyheracles.errors import InputError
from pyheracles.geometry.neighbours import local_pca

__all__ = [
    "choose_voxel",
    "fpfh_descriptors",
    "radius_neighbours",
    "unoriented_normals",
    "voxel_downsample",
]


def _voxel_keys(xyz: NDArray[np.float64], voxel: float) -> NDArray[np.int64]:
    ijk = np.floor((xyz - xyz.min(axis=0)) / voxel).astype(np.int64)
    span = ijk.max(axis=0) + 1
    return (ijk[:, 0] * span[1] + ijk[:, 1]) * span[2] + ijk[:, 2]


def occupied_voxels(xyz: NDArray[np.float64], voxel: float) -> int:
    """Number of voxels of size ``voxel`` (metres) holding at least one point."""
    return len(np.unique(_voxel_keys(xyz, voxel)))


def choose_voxel(
    xyz: NDArray[np.float64],
    spacing: float,
    target_points: int,
    *,
    min_spacing_factor: float = 2.0,
    sample: int = 400_000,
    rng: np.random.Generator | None = None,
) -> float:
    """Voxel size (metres) giving about ``target_points`` occupied voxels.

    A scanned surface of area ``A`` occupies about ``A / v**2`` voxels of size
    ``v``: the area is measured from the occupancy at a first guess (the extent
    divided by ``sqrt(target_points)``) and the size solved for, twice.  The
    result is at least ``min_spacing_factor`` times the point ``spacing``, so that
    every voxel centroid averages several points.

    Parameters
    ----------
    xyz
        ``(N, 3)`` local coordinates, metres.
    spacing
        Median point spacing, metres (:func:`pyheracles.geometry.neighbours.point_spacing`).
    target_points
        Wanted number of downsampled points.
    min_spacing_factor
        Lower bound of the voxel as a multiple of ``spacing``.
    sample
        Points used for the occupancy count on large clouds (random subset; the
        occupancy of a surface at a voxel much coarser than the spacing hardly
        changes when a subset is used).
    rng
        Random generator for the subset.
    """
    if len(xyz) < 3:
        raise InputError(f"a cloud for registration needs at least 3 points, got {len(xyz)}")
    if target_points < 10:
        raise InputError(f"target_points must be at least 10, got {target_points}")
    gen = rng or np.random.default_rng(0)
    pts = xyz if len(xyz) <= sample else xyz[gen.choice(len(xyz), sample, replace=False)]
    extent = float(np.linalg.norm(np.ptp(pts, axis=0)))
    floor = max(min_spacing_factor * spacing, extent * 1e-6, 1e-9)
    v = max(extent / np.sqrt(target_points), floor)
    for _ in range(2):
        area = occupied_voxels(pts, v) * v * v
        v = max(float(np.sqrt(area / target_points)), floor)
    return v


def voxel_downsample(
    xyz: NDArray[np.float64], voxel: float
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Centroids of the occupied voxels and the number of points in each.

    Parameters
    ----------
    xyz
        ``(N, 3)`` local coordinates, metres.
    voxel
        Voxel edge, metres.

    Returns
    -------
    centroids, counts
        ``(M, 3)`` centroids and ``(M,)`` point counts (summing to ``N``: every
        input point falls into exactly one voxel).
    """
    if voxel <= 0 or not np.isfinite(voxel):
        raise InputError(f"the voxel size must be a positive number, got {voxel}")
    _, inverse, counts = np.unique(_voxel_keys(xyz, voxel), return_inverse=True, return_counts=True)
    inverse = inverse.reshape(-1)
    sums = np.stack([np.bincount(inverse, weights=xyz[:, j]) for j in range(3)], axis=1)
    return sums / counts[:, None], counts.astype(np.int64)


def unoriented_normals(xyz: NDArray[np.float64], k: int) -> NDArray[np.float64]:
    """PCA normals of the ``k`` nearest neighbours (sign arbitrary, unit length)."""
    pca = local_pca(xyz, k=int(min(k, len(xyz))), directions=False)
    n = pca.normals
    norm = np.linalg.norm(n, axis=1)
    bad = norm < 0.5
    n[bad] = (0.0, 0.0, 1.0)  # degenerate neighbourhoods (duplicates): any unit vector
    return n / np.linalg.norm(n, axis=1, keepdims=True)


def radius_neighbours(
    xyz: NDArray[np.float64], radius: float, k: int
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """The (at most) ``k`` nearest points within ``radius`` of every point, itself included.

    What ``cKDTree(xyz).query(xyz, k, distance_upper_bound=radius)`` returns, in no
    particular order within a row, found by a compiled search of the 27 cells around
    each point on a grid of edge ``radius``
    (:func:`~pyheracles.registration.fpfh_kernels.radius_knn_kernel`).

    Parameters
    ----------
    xyz
        ``(N, 3)`` points, metres.
    radius
        Search radius, metres (points closer than it are neighbours).
    k
        Largest number of neighbours per point (the point itself counted).

    Returns
    -------
    distances, indices
        ``(N, k)``; missing neighbours have distance ``inf`` and index ``N``.
    """
    if not (radius > 0 and np.isfinite(radius)) or k < 1:
        raise InputError(f"radius must be positive and k at least 1, got {radius}, {k}")
    from pyheracles.registration.fpfh_kernels import radius_knn_kernel

    pts = np.ascontiguousarray(xyz, dtype=np.float64)
    k = int(min(k, len(pts)))
    if len(pts) == 0:
        return np.zeros((0, k)), np.zeros((0, k), dtype=np.int64)

    def by_tree() -> tuple[NDArray[np.float64], NDArray[np.int64]]:
        d, i = cKDTree(pts).query(pts, k=k, distance_upper_bound=radius, workers=-1)
        return d.reshape(len(pts), k), i.reshape(len(pts), k).astype(np.int64)

    if float(np.prod(np.floor(np.ptp(pts, axis=0) / radius) + 1)) >= 2.0**62:
        return by_tree()  # far outliers: the cell keys would not fit in int64
    cell = np.floor((pts - pts.min(axis=0)) / radius).astype(np.int64)
    span = cell.max(axis=0) + 1
    key = (cell[:, 0] * span[1] + cell[:, 1]) * span[2] + cell[:, 2]
    order = np.argsort(key, kind="stable")
    sorted_key = key[order]
    first = np.flatnonzero(np.r_[True, sorted_key[1:] != sorted_key[:-1]])
    start = np.r_[first, len(pts)]
    most = int(np.diff(start).max())
    if most > 20_000:
        return by_tree()  # a cell crowded with points: candidate buffers too large
    dist = np.empty((len(pts), k))
    nb = np.empty((len(pts), k), dtype=np.int64)
    radius_knn_kernel(
        pts, cell, span, order, sorted_key[first], start, float(radius), int(k), most, nb, dist
    )
    return dist, nb


def fpfh_descriptors(
    xyz: NDArray[np.float64],
    normals: NDArray[np.float64],
    radius: float,
    *,
    bins: int = 11,
    max_neighbours: int = 100,
    tree: cKDTree | None = None,
) -> NDArray[np.float64]:
    """Sign-invariant FPFH descriptors of every point.

    Parameters
    ----------
    xyz, normals
        ``(N, 3)`` points (a voxel-downsampled cloud) and unit normals of any sign.
    radius
        Support radius, metres (typically 5 voxels).
    bins
        Bins per angle (three angles: ``3 * bins`` values).
    max_neighbours
        At most this many nearest neighbours within ``radius`` are used (as
        Open3D's hybrid search), which bounds the cost on dense parts.
    tree
        cKDTree of ``xyz`` to search the neighbourhoods in; ``None``: a compiled
        search on a grid of cells of edge ``radius`` (:func:`radius_neighbours`, the
        same neighbourhoods, faster).

    Returns
    -------
    NDArray
        ``(N, 3 * bins)`` descriptors, each of unit L1 norm (rows of isolated
        points, without neighbours, are zero).
    """
    n = len(xyz)
    k = int(min(max_neighbours + 1, n))
    if tree is None:
        dist, nb = radius_neighbours(xyz, radius, k)
    else:
        dist, nb = tree.query(xyz, k=k, distance_upper_bound=radius, workers=-1)
    dist = dist.reshape(n, k)
    nb = nb.reshape(n, k)
    from pyheracles.registration.fpfh_kernels import fpfh_kernel, spfh_kernel

    xyz_c = np.ascontiguousarray(xyz, dtype=np.float64)
    nrm_c = np.ascontiguousarray(normals, dtype=np.float64)
    nb_c = np.ascontiguousarray(nb, dtype=np.int64)
    spfh, counts = spfh_kernel(xyz_c, nrm_c, nb_c, dist, int(bins))
    # FPFH = SPFH(p) + neighbours' SPFH weighted by 1 / |p - q| (Rusu et al. 2009),
    # the weights normalised to sum 1 so that both parts have the same scale
    return fpfh_kernel(spfh, counts, nb_c, dist, 0.05 * radius)
