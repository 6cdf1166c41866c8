"""Planar facets: plane frames, half-density edges, splitting regions by normal direction."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage
from scipy.spatial import cKDTree

__all__ = [
    "disk_opening",
    "face_noise_thresholds",
    "half_max_edges",
    "on_own_plane",
    "planar_parts",
    "plane_frame",
    "plane_layers",
    "wide_surface_points",
]


def plane_frame(p: NDArray[np.float64]) -> tuple[NDArray, NDArray, NDArray]:
    """Centroid, normal and two in-plane unit vectors (PCA)."""
    c = p.mean(axis=0)
    _, _, vt = np.linalg.svd(p - c, full_matrices=False)
    return c, vt[2], vt[:2]


def face_noise_thresholds(
    xyz: NDArray[np.float64],
    tree: cKDTree,
    k: int,
    gen: np.random.Generator,
    *,
    n_sample: int = 5000,
    where: NDArray[np.int64] | None = None,
) -> tuple[float, float]:
    """Angle and curvature thresholds of region growing that cannot bridge an edge.

    Region growing's automatic angle (3 times the median angle between
    neighbouring normals, capped at 20 degrees) follows the noise of the
    normals.  On noisy narrow beam faces that median is large, and the cap
    is above the step between neighbouring normals across the band of
    blended normals along a beam's edge: the region then grows round the
    edge and joins perpendicular faces (and through them whole trusses).
    The normals of ``k``-neighbourhoods (radius ``r_k = s sqrt(k / pi)`` on a
    surface of spacing ``s``) turn by 90 degrees over about ``2 r_k`` across an
    edge, so nearest neighbours there differ by about
    ``90 / (2 sqrt(k / pi))`` degrees (16 for ``k = 24``), whatever the
    spacing; the angle is capped at half of that (8 degrees for ``k = 24``).

    The median is taken on a random sample of ``k``-neighbour pairs (edges of
    the growing graph) of the candidate points, with PCA normals and
    curvatures computed here.

    Parameters
    ----------
    xyz
        ``(N, 3)`` candidate points (not wide surfaces), metres.
    tree
        KD-tree on ``xyz``.
    k
        Neighbourhood size of the normals (as in region growing).
    gen
        Random generator of the sample.
    n_sample
        Pairs sampled.
    where
        Indices of the points to sample; ``None``: all.

    Returns
    -------
    angle_deg, curvature_max
        3 times the median angle between neighbouring normals, clipped to
        [3, cap] degrees; 2 times the median curvature, clipped to
        [0.01, 0.1] (region growing's own rule).
    """
    n = len(xyz)
    pool = np.arange(n) if where is None else np.asarray(where, dtype=np.int64)
    sample = gen.choice(pool, min(n_sample, len(pool)), replace=False)
    kk = min(k, n)
    _, nb = tree.query(xyz[sample], k=kk, workers=-1)
    # an edge of the growing graph: the point and one of its k neighbours
    pair = nb[np.arange(len(sample)), gen.integers(1, kk, len(sample))]
    _, nb_pair = tree.query(xyz[pair], k=kk, workers=-1)
    pts = xyz[np.vstack([nb, nb_pair])]
    pts = pts - pts.mean(axis=1, keepdims=True)
    cov = np.einsum("nki,nkj->nij", pts, pts)
    vals, vecs = np.linalg.eigh(cov)
    total = vals.sum(axis=1)
    curv = np.where(total > 0, vals[:, 0] / np.where(total > 0, total, 1.0), 1.0 / 3.0)
    nrm = vecs[:, :, 0]
    m = len(sample)
    cos = np.abs(np.einsum("ij,ij->i", nrm[:m], nrm[m:]))
    med_a = float(np.median(np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))))
    cap = 0.5 * 90.0 / (2.0 * np.sqrt(kk / np.pi))
    angle = float(np.clip(3.0 * med_a, 3.0, max(cap, 3.0)))
    return angle, float(np.clip(2.0 * float(np.median(curv)), 0.01, 0.1))


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


def plane_layers(
    xyz: NDArray[np.float64],
    index: NDArray[np.int64],
    min_points: int,
    *,
    bin_m: float = 0.005,
    peak_fraction: float = 0.2,
) -> list[NDArray[np.int64]]:
    """Split a planar part into the parallel layers it holds.

    Region growing can join parallel faces at different offsets through the
    sparse, noisy faces between them: the undersides of common rafters and the
    boarding strips between them are joined through the rafters' sides, with
    one normal.  Projected on their plane they interleave into one surface and
    no band can be cut.  Along the normal the layers are dense peaks of the
    offset histogram (``bin_m`` bins, 3-bin smoothing); the points between them
    (the sides) are sparse.  Bins above ``peak_fraction`` of the highest,
    joined across one-bin gaps, make the layers; points within three bins of a
    layer go to it, the others are left out.  A face bent or stepped by a few
    centimetres gives one contiguous run of bins: one layer.  With fewer than
    two layers of ``min_points`` the part comes back whole.
    """
    if len(index) < 2 * min_points:
        return [index]
    pts = xyz[index]
    c, n, _ = plane_frame(pts)
    h = (pts - c) @ n
    lo = float(h.min())
    nb = int(np.ceil((float(h.max()) - lo) / bin_m)) + 1
    if nb < 5:
        return [index]
    b = np.minimum(((h - lo) / bin_m).astype(np.int64), nb - 1)
    hist = np.convolve(np.bincount(b, minlength=nb).astype(float), np.ones(3) / 3.0, mode="same")
    dense = hist >= peak_fraction * hist.max()
    # one-bin gaps do not separate layers
    dense[1:-1] |= dense[:-2] & dense[2:]
    lab, n_lay = ndimage.label(dense)
    if n_lay < 2:
        return [index]
    # every bin to its nearest layer, within three bins
    bins = np.arange(nb)
    layer_bins = np.flatnonzero(lab > 0)
    nearest = layer_bins[np.abs(bins[:, None] - layer_bins[None, :]).argmin(axis=1)]
    owner = np.where(np.abs(bins - nearest) <= 3, lab[nearest], 0)
    parts = []
    for k in range(1, n_lay + 1):
        sel = index[owner[b] == k]
        if len(sel) >= min_points:
            parts.append(sel)
    return parts if len(parts) >= 2 else [index]


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


def disk_opening(grid: NDArray[np.bool_], rad: int) -> NDArray[np.bool_]:
    """Binary opening of ``grid`` by the disk ``dx**2 + dy**2 <= rad**2`` (cells).

    The same cells as ``ndimage.binary_opening(grid, structure=disk)`` (cells
    outside the grid are empty), from two exact Euclidean distance transforms
    instead of one pass of the disk per cell: a cell survives the erosion when
    its nearest empty cell is further than ``rad``, and the dilation of the
    survivors takes every cell within ``rad`` of one of them.  The squared
    distances are whole numbers, so comparing their square roots with ``rad``
    is exact.  The time does not grow with the disk's area.

    Parameters
    ----------
    grid
        ``(H, W)`` occupied cells.
    rad
        Disk radius, cells (>= 0).

    Returns
    -------
    ``(H, W)`` cells of the opened set.
    """
    pad = np.pad(np.asarray(grid, dtype=bool), rad + 1)
    eroded = ndimage.distance_transform_edt(pad) > rad
    if not eroded.any():
        return np.zeros(np.shape(grid), dtype=bool)
    dilated = ndimage.distance_transform_edt(~eroded) <= rad
    return dilated[rad + 1 : -rad - 1, rad + 1 : -rad - 1]


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
        grid = ndimage.binary_closing(grid, structure=np.ones((3, 3), bool))  # scan-line gaps
        opened = disk_opening(grid, rad)
        out[idx[opened[cells[:, 0], cells[:, 1]]]] = True
    return out
