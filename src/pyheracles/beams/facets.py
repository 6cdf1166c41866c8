"""Planar facets: plane frames, half-density edges, splitting regions by normal direction."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage
from scipy.spatial import cKDTree

__all__ = [
    "half_max_edges",
    "on_own_plane",
    "planar_parts",
    "plane_frame",
    "wide_surface_points",
]


def plane_frame(p: NDArray[np.float64]) -> tuple[NDArray, NDArray, NDArray]:
    """Centroid, normal and two in-plane unit vectors (PCA)."""
    c = p.mean(axis=0)
    _, _, vt = np.linalg.svd(p - c, full_matrices=False)
    return c, vt[2], vt[:2]


def half_max_edges(
    values: NDArray[np.float64], bin_m: float, level_fraction: float = 0.5
) -> tuple[float, float]:
    """Edges of the dense part of a 1-D distribution, at half its plateau density.

    For points uniform on an interval plus Gaussian noise the half-density points
    are the interval's ends whatever the noise, which quantiles are not.  A lower
    ``level_fraction`` reaches further out where part of a face is shadowed (the
    bias outwards is about ``0.5 sigma`` of the noise at 0.3).
    """
    lo, hi = float(values.min()), float(values.max())
    nb = max(int(np.ceil((hi - lo) / bin_m)), 1)
    hist = np.bincount(
        np.minimum(((values - lo) / bin_m).astype(np.int64), nb - 1), minlength=nb
    ).astype(float)
    if nb >= 3:
        hist = np.convolve(hist, np.ones(3) / 3.0, mode="same")
    peak = int(hist.argmax())
    # plateau level: median of the bins above a quarter of the peak (robust to spikes)
    level = float(np.median(hist[hist >= 0.25 * hist[peak]]))
    half = level_fraction * level
    i = peak
    while i > 0 and hist[i - 1] >= half:
        i -= 1
    j = peak
    while j < nb - 1 and hist[j + 1] >= half:
        j += 1

    # linear interpolation of the half crossing between bin centres
    def _cross(a: int, b: int) -> float:
        ha, hb = hist[a], hist[b]
        frac = 0.5 if ha == hb else (half - ha) / (hb - ha)
        return lo + (a + 0.5 + frac * (b - a)) * bin_m

    left = _cross(i - 1, i) if i > 0 else lo
    right = _cross(j, j + 1) if j < nb - 1 else hi
    return left, right


def planar_parts(
    normals: NDArray[np.float64],
    index: NDArray[np.int64],
    min_points: int,
    gen: np.random.Generator,
    *,
    angle_deg: float = 20.0,
) -> list[NDArray[np.int64]]:
    """Split a region into its dominant normal directions.

    Region growing can bridge two perpendicular faces of a beam through the
    rounded band of blended normals along their edge; such a region is not
    planar and cannot be cut into bands.  Greedy dominant directions (the
    candidate normal with most points within ``angle_deg``, refined by the mean
    of those points) separate the faces; blended edge points stay out.  A
    planar region comes back whole.
    """
    n = normals[index]
    cos_t = np.cos(np.radians(angle_deg))
    live = np.ones(len(index), dtype=bool)
    parts: list[NDArray[np.int64]] = []
    for _ in range(6):
        alive = np.flatnonzero(live)
        if len(alive) < min_points:
            break
        sample = alive if len(alive) <= 2000 else gen.choice(alive, 2000, replace=False)
        cands = n[sample[:: max(1, len(sample) // 100)]]
        votes = (np.abs(n[sample] @ cands.T) >= cos_t).sum(axis=0)
        c = cands[int(votes.argmax())]
        inl = alive[np.abs(n[alive] @ c) >= cos_t]
        signs = np.sign(n[inl] @ c)[:, None]
        c = (n[inl] * signs).mean(axis=0)
        c /= np.linalg.norm(c)
        inl = alive[np.abs(n[alive] @ c) >= cos_t]
        if len(inl) < min_points:
            break
        if not parts and len(inl) >= 0.9 * len(alive):
            return [index]  # planar: keep the region whole, edge points included
        parts.append(index[inl])
        live[inl] = False
    return parts


def on_own_plane(p: NDArray[np.float64], n_sigma: float = 3.0) -> NDArray[np.bool_]:
    """Points within ``n_sigma`` robust deviations (at least 6 mm) of the dominant plane.

    Least trimmed squares by concentration steps (Rousseeuw's C-steps, started
    from the least-squares plane): the plane is refitted on the 75 % of points
    closest to the previous one, which a minority of points on a parallel face
    a couple of centimetres away does not tilt, unlike a least-squares plane.
    The deviation is the MAD of all residuals to the final plane.
    """
    on = np.ones(len(p), dtype=bool)
    n_keep = max(int(0.75 * len(p)), 3)
    for _ in range(4):
        c, n, _ = plane_frame(p[on])
        r = np.abs((p - c) @ n)
        on = np.zeros(len(p), dtype=bool)
        on[np.argpartition(r, n_keep - 1)[:n_keep]] = True
    c, n, _ = plane_frame(p[on])
    h = (p - c) @ n
    sig = 1.4826 * float(np.median(np.abs(h)))
    return np.abs(h) <= max(n_sigma * sig, 0.006)


def wide_surface_points(
    xyz: NDArray[np.float64],
    labels: NDArray[np.int32],
    tree: cKDTree,
    *,
    max_width_m: float,
    min_points: int = 200,
) -> NDArray[np.bool_]:
    """Points of wide planar surfaces (floor, walls, boarding), found by their extent.

    Each region of a first, coarse region growing (``labels``) is drawn on a
    grid in its own plane (cell: twice the region's point spacing, at least
    2 cm) and opened (eroded, then dilated) by a disk of radius
    ``max_width_m / 2`` plus one cell: a band at most ``max_width_m`` wide
    (a beam face, or a truss of beam faces in one plane) vanishes, a surface
    wider than that in every direction (a floor, a wall, boarding) survives.
    The points of the surviving cells are returned.

    Parameters
    ----------
    xyz
        ``(N, 3)`` points, metres.
    labels
        ``(N,)`` region per point (0 = none).
    tree
        KD-tree on ``xyz``.
    max_width_m
        Widest beam face, metres.
    min_points
        Regions with fewer points are not examined.
    """
    out = np.zeros(len(xyz), dtype=bool)
    n_reg = int(labels.max(initial=0))
    if n_reg == 0:
        return out
    order = np.argsort(labels, kind="stable")
    bounds = np.searchsorted(labels[order], np.arange(n_reg + 2))
    for r in range(1, n_reg + 1):
        idx = order[bounds[r] : bounds[r + 1]]
        if len(idx) < min_points:
            continue
        pts = xyz[idx]
        c, _, inplane = plane_frame(pts)
        q = (pts - c) @ inplane.T
        extent = np.ptp(q, axis=0)
        if extent.min() <= max_width_m:
            continue  # a band: no direction in which it is wider than a beam
        sample = pts[:: max(1, len(pts) // 300)]
        d, _ = tree.query(sample, k=2, workers=1)
        cell = max(2.0 * float(np.median(d[:, 1])), 0.02)
        cells = np.floor((q - q.min(axis=0)) / cell).astype(np.int64)
        shape = cells.max(axis=0) + 1
        if shape.prod() > 4_000_000:
            cell *= float(np.sqrt(shape.prod() / 4_000_000))
            cells = np.floor((q - q.min(axis=0)) / cell).astype(np.int64)
            shape = cells.max(axis=0) + 1
        grid = np.zeros(shape, dtype=bool)
        grid[cells[:, 0], cells[:, 1]] = True
        rad = int(np.ceil(0.5 * max_width_m / cell)) + 1
        yy, xx = np.mgrid[-rad : rad + 1, -rad : rad + 1]
        disk = xx**2 + yy**2 <= rad**2
        grid = ndimage.binary_closing(grid, structure=np.ones((3, 3), bool))  # scan-line gaps
        opened = ndimage.binary_opening(grid, structure=disk)
        out[idx[opened[cells[:, 0], cells[:, 1]]]] = True
    return out
