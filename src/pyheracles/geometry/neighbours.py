"""Shared KD-tree neighbourhoods, normals, curvature and local PCA features.

Every step that looks at local shape (region growing, beams, walls, supports)
uses the same ingredients: the ``k`` nearest neighbours of every point and the
eigen-decomposition of the neighbourhood covariance.  In M_HERACLES this was
the bottleneck (MATLAB ``pcnormals`` took more than half of 222 s for 100 k
points, Murtiyoso 2020, ch. 6.3).  Here:

- :func:`local_pca` and :func:`estimate_normals` run a compiled exact k-NN
  search on an implicit octree that accumulates each neighbourhood's
  covariance directly, without an ``(N, k)`` neighbour table
  (:func:`octree_pca`, :mod:`pyheracles.geometry.knn_kernels`: about 2x
  Open3D's ``estimate_normals`` on a 1 M-point scan on 2 cores, where a
  ``cKDTree`` query alone costs as much as Open3D);
- :func:`knn` (the neighbour table, for region growing) queries a
  :class:`scipy.spatial.cKDTree` built once (:func:`build_tree`) with
  ``workers=-1``; :func:`local_pca` with such precomputed ``indices`` gathers
  the moments with one sparse matrix product per block;
- the 3x3 symmetric eigenproblems are solved in closed form (trigonometric
  solution of the characteristic cubic, Smith 1961), with the normal taken as
  the best-conditioned cross product of two rows of ``C - lambda_min I``; the
  few ill-conditioned neighbourhoods fall back to an iterative solver.

Hand-written rather than Open3D because pyheracles keeps Open3D optional
(it is a benchmark extra) and needs the curvature and all three eigenvalues,
which ``open3d.geometry.PointCloud.estimate_normals`` does not return.

The curvature is the *surface variation* of Pauly et al. (2002),
``lambda_0 / (lambda_0 + lambda_1 + lambda_2)`` with ascending eigenvalues,
as in PCL's ``NormalEstimation`` (0 on a perfect plane, 1/3 when isotropic).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import cKDTree

from pyheracles.errors import InputError

__all__ = [
    "LocalPCA",
    "as_xyz",
    "build_tree",
    "estimate_normals",
    "knn",
    "local_pca",
    "octree_pca",
    "orient_normals",
    "pca_features",
    "point_spacing",
    "symmetric_eigen3",
]

#: Rows processed per block; bounds peak memory at about 250 MB for k = 16.
_BLOCK_ROWS = 1 << 19

#: A neighbourhood whose covariance trace is below this fraction of the cloud's
#: squared extent is degenerate (all neighbours at one location: duplicates).
_DEGENERATE_TRACE = 1e-20
#: From this many points on, :func:`local_pca` uses the compiled octree search.
#: Below it scipy's tree is about as fast and needs no compiled kernel, whose
#: first compilation on a new machine takes about 20 s (then it is cached).
_COMPILED_FROM = 100_000


def as_xyz(xyz: ArrayLike) -> NDArray[np.float64]:
    arr = np.ascontiguousarray(xyz, dtype=np.float64)
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise InputError(f"coordinates must have shape (N, 3), got {arr.shape}")
    if not np.isfinite(arr).all():
        raise InputError(
            "coordinates contain NaN or infinite values",
            hint="in Python: validate the cloud (PointCloud.validate) before computing neighbours",
        )
    return arr


def build_tree(xyz: ArrayLike) -> cKDTree:
    """Build the KD-tree shared by every neighbourhood query on ``xyz``.

    Built with the sliding-midpoint rule (``balanced_tree=False``) and without
    node compaction, which is 30-40 % faster to build than the defaults for
    laser scans and answers queries as fast.
    """
    arr = as_xyz(xyz)
    if len(arr) == 0:
        raise InputError("cannot build a KD-tree on an empty point set")
    return cKDTree(arr, balanced_tree=False, compact_nodes=False)


def knn(
    xyz: ArrayLike, k: int, tree: cKDTree | None = None
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """The ``k`` nearest neighbours of every point, the point itself included.

    Parameters
    ----------
    xyz
        ``(N, 3)`` coordinates, metres (local frame).
    k
        Neighbours per point including the point itself (column 0); clipped to
        ``N``.
    tree
        A tree built on the same ``xyz`` (:func:`build_tree`); built if omitted.

    Returns
    -------
    distances, indices
        ``(N, k)`` arrays sorted by distance; ``indices[i, 0]`` is ``i`` unless
        ``i`` has exact duplicates.
    """
    arr = as_xyz(xyz)
    if k < 1:
        raise InputError(f"k must be at least 1, got {k}")
    if tree is None:
        tree = build_tree(arr)
    if tree.n != len(arr):
        raise InputError(f"the KD-tree holds {tree.n} points but {len(arr)} were given")
    kk = int(min(k, len(arr)))
    dist = np.empty((len(arr), kk))
    idx = np.empty((len(arr), kk), dtype=np.int64)
    # Query in the tree's leaf order: consecutive queries then walk the same
    # branches, which is about twice as fast as the input order of a scan.
    order = tree.indices
    for start in range(0, len(arr), _BLOCK_ROWS):
        rows = order[start : start + _BLOCK_ROWS]
        d, i = tree.query(arr[rows], k=kk, workers=-1)
        dist[rows] = d.reshape(len(rows), kk)
        idx[rows] = i.reshape(len(rows), kk)
    return dist, idx


#: Above this many points, :func:`point_spacing` samples vertical strips.
_STRIP_ABOVE = 1_000_000


def _strips(
    pts: NDArray[np.float64], rng: np.random.Generator, *, target: int = 400_000, n_strips: int = 4
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Points of ``n_strips`` random X strips (about ``target`` in all), and the
    indices (into them) of the points a guard band away from the strip edges."""
    x = pts[:, 0]
    lo, hi = float(x.min()), float(x.max())
    width = (hi - lo) * target / len(pts) / n_strips
    guard = 0.1 * width
    keep = np.zeros(len(pts), dtype=bool)
    interior = np.zeros(len(pts), dtype=bool)
    for s0 in rng.uniform(lo, max(lo, hi - width), n_strips):
        keep |= (x >= s0) & (x < s0 + width)
        interior |= (x >= s0 + guard) & (x < s0 + width - guard)
    index = np.flatnonzero(keep)
    return pts[index], np.flatnonzero(interior[index])


def point_spacing(
    xyz: ArrayLike,
    tree: cKDTree | None = None,
    *,
    sample: int = 20000,
    rng: np.random.Generator | int | None = 0,
) -> float:
    """Median distance to the nearest other point, metres (on a random sample).

    Exact duplicates are ignored (distance 0), so the result is the spacing of
    the distinct positions.  Used to derive automatic thresholds.
    """
    arr = as_xyz(xyz)
    if len(arr) < 2:
        raise InputError("point spacing needs at least 2 points")
    gen = np.random.default_rng(rng)
    if tree is None and len(arr) > _STRIP_ABOVE:
        # Large cloud, no tree yet: a tree on a few random X strips gives the same
        # nearest neighbours for the points inside them at a fraction of the cost.
        strips, inner = _strips(arr, gen)
        if len(inner) >= 100:
            tree = build_tree(strips)
            arr = strips[inner]
    if tree is None:
        tree = build_tree(arr)
    pick = arr if len(arr) <= sample else arr[gen.choice(len(arr), sample, replace=False)]
    dist, _ = tree.query(pick, k=min(8, tree.n), workers=-1)
    d = dist[:, 1:]
    d = np.where(d > 0, d, np.inf).min(axis=1)
    d = d[np.isfinite(d)]
    if len(d) == 0:
        raise InputError("all points are at the same location", hint="check the input cloud")
    return float(np.median(d))


def symmetric_eigen3(
    cov: NDArray[np.float64], *, directions: bool = True
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64] | None]:
    """Closed-form eigen-decomposition of many symmetric 3x3 matrices.

    Parameters
    ----------
    cov
        ``(N, 6)`` upper triangles ``(xx, yy, zz, xy, xz, yz)``.

    Returns
    -------
    eigenvalues
        ``(N, 3)`` ascending, clipped at 0.
    smallest
        ``(N, 3)`` unit eigenvectors of the smallest eigenvalue (normals).
    largest
        ``(N, 3)`` unit eigenvectors of the largest eigenvalue (main directions);
        ``None`` when ``directions=False`` (saves a third of the time).

    Notes
    -----
    Eigenvalues from the trigonometric solution of the characteristic cubic;
    each eigenvector from the largest cross product of two rows of
    ``C - lambda I``.  Rows where that cross product is tiny relative to the
    matrix scale (two nearly equal eigenvalues) are recomputed with
    :func:`numpy.linalg.eigh`, so the result is always an orthonormal basis.
    """
    a, b, c, d, e, f = (cov[:, i] for i in range(6))
    n = len(cov)
    q = (a + b + c) / 3.0
    p1 = d * d + e * e + f * f
    aq, bq, cq = a - q, b - q, c - q
    p2 = aq * aq + bq * bq + cq * cq + 2.0 * p1
    p = np.sqrt(p2 / 6.0)
    safe = p > 0
    ps = np.where(safe, p, 1.0)
    # det(B) / 2 with B = (C - qI) / p
    det = aq * (bq * cq - f * f) - d * (d * cq - f * e) + e * (d * f - bq * e)
    r = np.clip(det / (2.0 * ps**3), -1.0, 1.0)
    phi = np.arccos(r) / 3.0
    l_max = q + 2.0 * p * np.cos(phi)
    l_min = q + 2.0 * p * np.cos(phi + 2.0 * np.pi / 3.0)
    l_mid = 3.0 * q - l_max - l_min
    vals = np.column_stack([l_min, l_mid, l_max])
    vals.sort(axis=1)
    np.maximum(vals, 0.0, out=vals)

    scale = np.maximum(np.abs(vals).max(axis=1), 1e-300)

    def _vector(lam: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
        r0 = np.column_stack([a - lam, d, e])
        r1 = np.column_stack([d, b - lam, f])
        r2 = np.column_stack([e, f, c - lam])
        cands = np.stack([np.cross(r0, r1), np.cross(r0, r2), np.cross(r1, r2)], axis=1)
        norms = np.einsum("nij,nij->ni", cands, cands)
        best = norms.argmax(axis=1)
        vec = cands[np.arange(n), best]
        nrm = np.sqrt(norms[np.arange(n), best])
        good = nrm > 1e-10 * scale * scale
        vec = vec / np.where(good, nrm, 1.0)[:, None]
        return vec, good

    v_min, ok_min = _vector(vals[:, 0])
    bad = ~(ok_min & safe)
    v_max = None
    if directions:
        v_max, ok_max = _vector(vals[:, 2])
        bad |= ~ok_max
        # Orthogonality check: closed-form vectors of nearly equal eigenvalues drift.
        bad |= np.abs(np.einsum("ij,ij->i", v_min, v_max)) > 1e-6
    else:
        # residual check of the normal alone: |C v - lambda v| small
        cv = np.column_stack(
            [
                a * v_min[:, 0] + d * v_min[:, 1] + e * v_min[:, 2],
                d * v_min[:, 0] + b * v_min[:, 1] + f * v_min[:, 2],
                e * v_min[:, 0] + f * v_min[:, 1] + c * v_min[:, 2],
            ]
        )
        resid = np.linalg.norm(cv - vals[:, :1] * v_min, axis=1)
        bad |= resid > 1e-6 * scale
    if bad.any():
        sub = cov[bad]
        mats = np.empty((len(sub), 3, 3))
        mats[:, 0, 0], mats[:, 1, 1], mats[:, 2, 2] = sub[:, 0], sub[:, 1], sub[:, 2]
        mats[:, 0, 1] = mats[:, 1, 0] = sub[:, 3]
        mats[:, 0, 2] = mats[:, 2, 0] = sub[:, 4]
        mats[:, 1, 2] = mats[:, 2, 1] = sub[:, 5]
        w, v = np.linalg.eigh(mats)
        vals[bad] = np.maximum(w, 0.0)
        v_min[bad] = v[:, :, 0]
        if v_max is not None:
            v_max[bad] = v[:, :, 2]
    return vals, v_min, v_max


def _point_moments(xyz: NDArray[np.float64]) -> NDArray[np.float64]:
    """Per-point ``(x, y, z, xx, yy, zz, xy, xz, yz)`` about the cloud centre.

    Shifting to the centre keeps the one-pass covariance formula
    ``E[pp^T] - E[p]E[p]^T`` precise (local frames are at most kilometres wide).
    """
    centre = 0.5 * (xyz.min(axis=0) + xyz.max(axis=0))
    x, y, z = (xyz - centre).T
    return np.column_stack([x, y, z, x * x, y * y, z * z, x * y, x * z, y * z])


def _moments(feats: NDArray[np.float64], idx: NDArray[np.int64]) -> NDArray[np.float64]:
    """Neighbourhood covariances ``(n, 6)`` of the rows of ``idx``.

    One sparse (n x N) averaging matrix times the per-point moments: this
    gathers 9 numbers per neighbour without building an ``(n, k, 3)`` array.
    """
    n, k = idx.shape
    rows = sp.csr_matrix(
        (np.full(n * k, 1.0 / k), idx.ravel(), np.arange(0, n * k + 1, k)),
        shape=(n, len(feats)),
    )
    m = np.asarray(rows @ feats)
    mx, my, mz = m[:, 0], m[:, 1], m[:, 2]
    cov = m[:, 3:] - np.column_stack([mx * mx, my * my, mz * mz, mx * my, mx * mz, my * mz])
    return cov


#: Work cells of the implicit octree hold at most this many points (tuned on
#: 1 M-point scans and uniform clouds: 8-32 are within 10 % of each other).
_MAX_LEAF = 32


def octree_pca(
    xyz: NDArray[np.float64],
    k: int,
    *,
    directions: bool = True,
    max_leaf: int = _MAX_LEAF,
    bounds: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64] | None]:
    """Exact ``k``-NN covariance eigen-decomposition of every point, compiled.

    Parameters
    ----------
    xyz
        ``(N, 3)`` finite coordinates, metres.
    k
        Neighbours per point, the point itself included (``1 <= k <= N``).
    directions
        Also return the eigenvectors of the largest eigenvalue.
    max_leaf
        Largest work cell of the implicit octree (a speed knob, not a result knob).
    bounds
        The cloud's ``(lower, upper)`` corners when the caller has them already;
        computed otherwise.

    Returns
    -------
    eigenvalues, smallest, largest
        As :func:`symmetric_eigen3` (``largest`` is ``None`` without ``directions``),
        in input order.  Ties at the ``k``-th distance are broken arbitrarily
        (but deterministically).

    Notes
    -----
    The algorithm, and why it is hand-written, is described in
    :mod:`pyheracles.geometry.knn_kernels`.
    """

    arr = np.ascontiguousarray(xyz, dtype=np.float64)
    n = len(arr)
    if not 1 <= k <= n:
        raise InputError(f"k must be between 1 and the number of points ({n}), got {k}")
    vals = np.empty((n, 3))
    vmin = np.empty((n, 3))
    vmax = np.empty((n, 3)) if directions else np.empty((0, 3))
    _octree_search(arr, k, max_leaf, bounds, directions, (vals, vmin, vmax), None)
    return vals, vmin, (vmax if directions else None)


def _octree_search(
    arr: NDArray[np.float64],
    k: int,
    max_leaf: int,
    bounds: tuple[NDArray[np.float64], NDArray[np.float64]] | None,
    directions: bool,
    pca: tuple[NDArray[np.float64], ...] | None,
    table: tuple[NDArray[np.float64], NDArray[np.int64]] | None,
) -> None:
    """Sort ``arr`` along its Morton curve, cut it into work cells and run the compiled
    search, writing either the PCA (``pca``: eigenvalues, smallest and largest
    eigenvectors) or the neighbour table (``table``: squared distances, indices)."""
    from pyheracles.geometry import knn_kernels as kern  # numba compiles on first import

    lo, hi = bounds if bounds is not None else kern.bounding_box(arr)
    side = float((hi - lo).max()) or 1.0
    h0 = side * (1.0 + 1e-9) / float(1 << kern.BITS)
    inv_h0 = 1.0 / h0
    fine_max = np.minimum(((hi - lo) * inv_h0).astype(np.int64), (1 << kern.BITS) - 1)
    keys = kern.morton_keys(arr, lo, inv_h0)
    order = kern.radix_argsort(keys, 3 * kern.BITS)
    spts, skeys = kern.gather_sorted(arr, keys, order)
    starts, levels, codes = kern.work_cells(skeys, max(int(max_leaf), 1))
    none = np.empty((0, 3))
    vals, vmin, vmax = pca if pca is not None else (none, none, none)
    d2, idx = table if table is not None else (np.empty((0, 0)), np.empty((0, 0), np.int64))
    kern.knn_covariance_pca(
        spts, skeys, order, starts, levels, codes, fine_max, lo, h0, int(k), directions,
        vals, vmin, vmax, d2, idx,
    )  # fmt: skip


def octree_knn(
    xyz: ArrayLike, k: int, *, max_leaf: int = _MAX_LEAF
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """The ``k`` nearest neighbours of every point by the compiled octree search.

    The table :func:`knn` gives (distances and indices, ``(N, k)``, by increasing
    distance, ties by index), 2-4x faster than the KD-tree query on 2 cores:
    the search of :func:`octree_pca` (see :mod:`pyheracles.geometry.knn_kernels`)
    writing the neighbours instead of their covariance.  Distances are the
    square roots of the same sums of squares as scipy's, so the table equals
    ``knn``'s wherever no two neighbours tie at the ``k``-th distance.
    """
    arr = as_xyz(xyz)
    n = len(arr)
    if not 1 <= k <= n:
        raise InputError(f"k must be between 1 and the number of points ({n}), got {k}")
    d2 = np.empty((n, k))
    idx = np.empty((n, k), np.int64)
    _octree_search(arr, k, max_leaf, None, False, None, (d2, idx))
    return np.sqrt(d2, out=d2), idx


@dataclass(frozen=True)
class LocalPCA:
    """Eigen-decomposition of every point's neighbourhood covariance.

    Attributes
    ----------
    eigenvalues
        ``(N, 3)`` ascending eigenvalues, square metres.
    normals
        ``(N, 3)`` unit eigenvectors of the smallest eigenvalue (surface
        normals); the zero vector where the neighbourhood is degenerate.
    directions
        ``(N, 3)`` unit eigenvectors of the largest eigenvalue (main direction);
        ``None`` if not asked for.
    curvature
        ``(N,)`` surface variation ``lambda_0 / sum(lambda)`` in ``[0, 1/3]``;
        ``1/3`` where the neighbourhood is degenerate (all duplicates).
    """

    eigenvalues: NDArray[np.float64]
    normals: NDArray[np.float64]
    directions: NDArray[np.float64] | None
    curvature: NDArray[np.float64]


def local_pca(
    xyz: ArrayLike,
    k: int = 16,
    tree: cKDTree | None = None,
    *,
    indices: NDArray[np.int64] | None = None,
    directions: bool = True,
) -> LocalPCA:
    """PCA of the ``k``-nearest-neighbour neighbourhood of every point.

    Parameters
    ----------
    xyz
        ``(N, 3)`` coordinates, metres.
    k
        Neighbourhood size including the point itself (at least 3).
    tree
        Shared KD-tree on ``xyz``; built if omitted.
    indices
        Precomputed ``(N, k)`` neighbour indices (from :func:`knn`); when given,
        no query is made.
    directions
        Also compute the main directions (largest eigenvectors); ``False``
        leaves ``LocalPCA.directions`` as ``None`` and is faster.

    Returns
    -------
    LocalPCA
    """
    arr = as_xyz(xyz)
    n = len(arr)
    if n < 3:
        raise InputError(f"local PCA needs at least 3 points, got {n}")
    if k < 3 and indices is None:
        raise InputError(f"k must be at least 3 for a covariance, got {k}")
    if indices is None and n < _COMPILED_FROM:
        _, indices = knn(arr, int(min(k, n)), tree)
    if indices is not None:
        lo, hi = arr.min(axis=0), arr.max(axis=0)
        vals = np.empty((n, 3))
        normals = np.empty((n, 3))
        dirs = np.empty((n, 3)) if directions else None
        idx_all = np.asarray(indices, dtype=np.int64)
        if idx_all.ndim != 2 or len(idx_all) != n or idx_all.shape[1] < 3:
            raise InputError(f"indices must have shape (N>=3 columns) for {n} points")
        feats = _point_moments(arr)
        for start in range(0, n, _BLOCK_ROWS):
            sl = slice(start, min(start + _BLOCK_ROWS, n))
            v, nrm, dr = symmetric_eigen3(_moments(feats, idx_all[sl]), directions=directions)
            vals[sl], normals[sl] = v, nrm
            if dirs is not None:
                dirs[sl] = dr
    else:
        if tree is not None and tree.n != n:
            raise InputError(f"the KD-tree holds {tree.n} points but {n} were given")
        # The compiled octree search is exact and 3-4x faster than querying even
        # a shared tree (see knn_kernels), so a given tree is only checked.
        from pyheracles.geometry.knn_kernels import bounding_box

        lo, hi = bounding_box(arr)
        vals, normals, dirs = octree_pca(
            arr, int(min(k, n)), directions=directions, bounds=(lo, hi)
        )
    extent2 = float(np.sum((hi - lo) ** 2)) or 1.0
    total = vals[:, 0] + vals[:, 1] + vals[:, 2]
    degenerate = total <= _DEGENERATE_TRACE * extent2
    curvature = np.where(degenerate, 1.0 / 3.0, vals[:, 0] / np.where(degenerate, 1.0, total))
    normals[degenerate] = 0.0
    if dirs is not None:
        dirs[degenerate] = 0.0
    return LocalPCA(eigenvalues=vals, normals=normals, directions=dirs, curvature=curvature)


def orient_normals(
    xyz: ArrayLike, normals: NDArray[np.float64], viewpoint: ArrayLike | None = None
) -> NDArray[np.float64]:
    """Give normals a consistent sign.

    With a ``viewpoint`` (scanner position, local frame) every normal points
    towards it, as in PCL's ``flipNormalTowardsViewpoint``.  Without one the
    sign is made deterministic: the largest-magnitude component is positive
    (unoriented normals; region growing compares them with ``|cos|``).
    """
    nrm = np.array(normals, dtype=np.float64, copy=True)
    if viewpoint is not None:
        vp = np.asarray(viewpoint, dtype=np.float64).reshape(3)
        flip = np.einsum("ij,ij->i", nrm, vp - np.asarray(xyz)) < 0
    else:
        big = np.abs(nrm).argmax(axis=1)
        flip = nrm[np.arange(len(nrm)), big] < 0
    nrm[flip] *= -1.0
    return nrm


def estimate_normals(
    xyz: ArrayLike,
    k: int = 16,
    tree: cKDTree | None = None,
    viewpoint: ArrayLike | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Unit normals and curvature (surface variation) of every point.

    Parameters
    ----------
    xyz
        ``(N, 3)`` coordinates, metres (local frame).
    k
        Neighbourhood size including the point itself.  16 is a common choice
        for terrestrial scans (PCL tutorials use 30 on denser clouds; MATLAB
        ``pcnormals``, used by M_HERACLES, defaults to 6 which is noisy at
        3 mm noise).
    tree
        Shared KD-tree on ``xyz``; built if omitted.
    viewpoint
        Scanner position in the local frame; normals are flipped towards it.
        Without it, see :func:`orient_normals`.

    Returns
    -------
    normals
        ``(N, 3)`` unit normals (zero vector for degenerate neighbourhoods).
    curvature
        ``(N,)`` surface variation in ``[0, 1/3]``.

    Examples
    --------
    >>> import numpy as np
    >>> g = np.stack(np.meshgrid(np.arange(10.0), np.arange(10.0)), -1).reshape(-1, 2)
    >>> plane = np.column_stack([g, np.zeros(len(g))])
    >>> n, c = estimate_normals(plane, k=8)
    >>> bool(np.allclose(np.abs(n[:, 2]), 1.0)), float(c.max()) < 1e-12
    (True, True)
    """
    pca = local_pca(xyz, k=k, tree=tree, directions=False)
    return orient_normals(xyz, pca.normals, viewpoint), pca.curvature


def pca_features(eigenvalues: ArrayLike) -> dict[str, NDArray[np.float64]]:
    """Dimensionality features of local neighbourhoods (Weinmann et al. 2015).

    Parameters
    ----------
    eigenvalues
        ``(N, 3)`` ascending eigenvalues (``LocalPCA.eigenvalues``).

    Returns
    -------
    dict
        ``linearity``, ``planarity``, ``scattering`` (sum to 1), ``omnivariance``,
        ``anisotropy``, ``eigenentropy`` and ``surface_variation``; NaN where
        all eigenvalues are 0.
    """
    ev = np.asarray(eigenvalues, dtype=np.float64)
    l3, l2, l1 = ev[:, 0], ev[:, 1], ev[:, 2]  # l1 >= l2 >= l3 in Weinmann's notation
    total = l1 + l2 + l3
    with np.errstate(divide="ignore", invalid="ignore"):
        e = ev / total[:, None]
        logs = np.where(e > 0, np.log(np.where(e > 0, e, 1.0)), 0.0)
        return {
            "linearity": (l1 - l2) / l1,
            "planarity": (l2 - l3) / l1,
            "scattering": l3 / l1,
            "omnivariance": np.cbrt(np.prod(e, axis=1)),
            "anisotropy": (l1 - l3) / l1,
            "eigenentropy": np.where(total > 0, -(e * logs).sum(axis=1), np.nan),
            "surface_variation": l3 / total,
        }
