"""Horizontal sections of a cloud: slices, per-slice hull areas, islands and circularity.

The MATLAB ``slices`` function of M_HERACLES (Murtiyoso 2020, ch. 6.2): the
cloud is cut into thin horizontal slabs at a regular interval, each slab is
flattened and described by the convex hull of its points.  The attic/body
split (:mod:`pyheracles.building`) watches how the hull area changes from slab
to slab; the support detection clusters one slab into islands and measures
how round each island is with the circularity ``P^2 / (4 pi A)`` of its hull
(1 for a disc, 4/pi = 1.27 for a square).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import ConvexHull, QhullError

from pyheracles.geometry.sort_kernels import PARALLEL_MIN, sorted_keys, split_keys
from pyheracles.threads import n_workers

__all__ = [
    "SliceParams",
    "SliceProfile",
    "circularity",
    "hull_area_perimeter",
    "robust_floor",
    "slab_mask",
    "slice_profile",
    "slices",
    "sort_order",
]


@dataclass(frozen=True)
class SliceParams:
    """Horizontal slicing.

    Attributes
    ----------
    interval_m
        Vertical distance between slice centres, metres (thesis: 0.2 m).
    thickness_m
        Thickness of each slab, metres (thesis: 5 cm).
    ground_tolerance_m
        Height above the lowest point below which no slice is taken, metres: keeps the
        ground / floor slab out of the profile.
    """

    interval_m: float = 0.2
    thickness_m: float = 0.05
    ground_tolerance_m: float = 0.1

    def __post_init__(self) -> None:
        for name in ("interval_m", "thickness_m"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")
        if self.ground_tolerance_m < 0:
            raise ValueError(f"ground_tolerance_m must be >= 0, got {self.ground_tolerance_m}")


@dataclass(frozen=True)
class SliceProfile:
    """Per-slice statistics, bottom to top.

    Attributes
    ----------
    heights
        ``(S,)`` slice centre heights (same frame as the input z).
    areas
        ``(S,)`` convex hull area of each slab, m^2 (0 for slabs with < 3 points).
    perimeters
        ``(S,)`` convex hull perimeter, m.
    counts
        ``(S,)`` number of points in each slab.
    """

    heights: NDArray[np.float64]
    areas: NDArray[np.float64]
    perimeters: NDArray[np.float64]
    counts: NDArray[np.int64]


def slices(
    z: NDArray[np.float64],
    centres: NDArray[np.float64],
    thickness_m: float,
    *,
    order: NDArray[np.intp] | None = None,
    z_sorted: NDArray[np.float64] | None = None,
) -> tuple[NDArray[np.intp], NDArray[np.intp], NDArray[np.intp]]:
    """Points of each slab ``|z - centre| <= thickness / 2`` without a loop over points.

    ``order`` is ``argsort(z)`` and ``z_sorted`` is ``z[order]`` when the caller already
    has them.

    Returns
    -------
    order, starts, ends
        ``order[starts[i]:ends[i]]`` are the indices of the points of slab ``i``.
    """
    if order is None:
        order, zs = sort_order(z)
    else:
        zs = z[order] if z_sorted is None else z_sorted
    starts = np.searchsorted(zs, centres - thickness_m / 2, side="left")
    ends = np.searchsorted(zs, centres + thickness_m / 2, side="right")
    return order, starts, ends


def sort_order(values: NDArray) -> tuple[NDArray[np.intp], NDArray]:
    """``argsort`` of a 1D float or integer array, and the sorted values.

    numpy sorts int64 values with SIMD instructions several times faster than it
    argsorts (x86-simd-sort, AVX2 / AVX-512), so the values are quantised to integers
    that keep their order, packed with their index into one int64 key and sorted with
    :func:`numpy.sort`.  Values closer than the quantisation step (range / 2**(62 - bits
    of N), about 1e-11 m for a 3.5 M point cloud 10 m tall) may come out swapped; a
    check on the sorted values finds them and a stable sort of the almost sorted array
    repairs them, so the result is always exactly sorted.

    Examples
    --------
    >>> import numpy as np
    >>> order, srt = sort_order(np.array([0.3, -1.0, 2.0, 0.3]))
    >>> srt.tolist()
    [-1.0, 0.3, 0.3, 2.0]
    """
    v = np.asarray(values)
    n = len(v)
    bits = max(1, (n - 1).bit_length())
    if n < 50_000 or bits > 40 or (v.dtype.kind == "f" and not np.isfinite(v).all()):
        order = np.argsort(v, kind="stable")
        return order, v[order]
    lo, hi = v.min(), v.max()
    exact = v.dtype.kind in "iu" and int(hi) - int(lo) < 2 ** (62 - bits)
    if not exact and n >= PARALLEL_MIN and n_workers() > 1:  # on threads, the same keys
        key = sorted_keys(v, lo, hi, bits)
        order, srt = split_keys(key, v, bits)
    else:
        key = _sort_keys(v, lo, hi, bits, exact)
        key.sort()
        order = (key & ((1 << bits) - 1)).astype(np.intp, copy=False)
        srt = v[order]
    if not exact:  # values that share a quantised key may be swapped
        bad = np.flatnonzero(srt[1:] < srt[:-1])
        if len(bad) > n // 1000:
            fix = np.argsort(srt, kind="stable")  # almost sorted: a few runs for timsort
            order, srt = order[fix], srt[fix]
        elif len(bad):  # re-sort only the groups of equal keys that hold a swap
            qs = key[bad] >> bits
            a = np.searchsorted(key, qs << bits)
            b = np.searchsorted(key, (qs + 1) << bits)
            pos = np.unique(np.concatenate([np.arange(i, j) for i, j in zip(a, b, strict=True)]))
            fix = pos[np.lexsort((srt[pos], key[pos] >> bits))]
            order[pos], srt[pos] = order[fix], srt[fix]
    return order, srt


def _sort_keys(
    v: NDArray, lo: np.generic, hi: np.generic, bits: int, exact: bool
) -> NDArray[np.int64]:
    """The int64 keys of :func:`sort_order`: each value quantised (order kept) in the
    high bits, its index in the low ``bits``.

    Computed in place in one int64 and at most one float64 array of ``len(v)``: on 10 M
    points each temporary of the plain expression (a float copy of the heights, the
    shifted keys) costs about as much CPU in allocation and page faults as its
    arithmetic.  The arithmetic is the same, so are the keys.
    """
    n = len(v)
    if exact:  # integers keep their order (and equal keys their input order)
        key = (v - lo).astype(np.int64, copy=False)
    else:
        span = float(hi) - float(lo)
        scale = (2.0 ** (62 - bits) - 1) / span if span > 0 else 0.0
        f = np.subtract(v, float(lo), dtype=np.float64)
        f *= scale
        key = f.astype(np.int64)
        del f
    key <<= bits
    key |= np.arange(n, dtype=np.int64)
    return key


#: A level holds the floor when its 5 cm bin has at least this share of the fullest bin.
_FLOOR_SHARE = 0.05


def robust_floor(z_sorted: NDArray[np.float64], bin_m: float = 0.05) -> float:
    """Lowest dense level of a cloud: its floor, not its lowest point.

    Scattered outliers below the floor (multipath, a reflection through a puddle, a
    point seen through a grating) must not move the floor, from which sections and
    slices are measured: the floor is the low end (0.1 % quantile) of the lowest
    ``bin_m`` level holding at least 5 % of the points of the fullest level, and of the
    level above it (a floor or a ground is a
    horizontal surface, one of the fullest levels; outliers spread over many levels).
    A clean cloud gives its lowest point.

    Parameters
    ----------
    z_sorted
        Heights sorted ascending, metres.
    bin_m
        Height of the levels compared, metres.
    """
    z = np.asarray(z_sorted, dtype=np.float64)
    if len(z) == 0:
        return float("nan")
    z0, z1 = float(z[0]), float(z[-1])
    nbins = int((z1 - z0) / bin_m) + 1
    if nbins < 2 or nbins > 1_000_000:  # flat, or not metres: the lowest point
        return z0
    edges = z0 + bin_m * np.arange(nbins + 1)
    counts = np.diff(np.searchsorted(z, edges, side="left"))
    counts[-1] += len(z) - int(counts.sum())  # the top point falls on the last edge
    k = int(np.argmax(counts >= _FLOOR_SHARE * counts.max()))
    if k == 0:
        return z0
    # the floor's own low end: a few outliers share its level
    s, e = np.searchsorted(z, [edges[k], edges[min(k + 2, nbins)]], side="left")
    return float(np.quantile(z[s:e], 0.001))


def slab_mask(z: NDArray[np.float64], centre: float, thickness_m: float) -> NDArray[np.bool_]:
    """Boolean mask of the points within ``thickness / 2`` of ``centre`` in z."""
    return np.abs(np.asarray(z) - centre) <= thickness_m / 2


def hull_area_perimeter(xy: NDArray[np.float64]) -> tuple[float, float]:
    """Area and perimeter of the 2D convex hull (0, 2 x length for collinear points).

    Examples
    --------
    >>> import numpy as np
    >>> hull_area_perimeter(np.array([[0, 0], [2, 0], [2, 1], [0, 1], [1, 0.5]]))
    (2.0, 6.0)
    """
    p = np.asarray(xy, dtype=np.float64)
    if len(p) < 3:
        length = float(np.linalg.norm(p[-1] - p[0])) if len(p) == 2 else 0.0
        return 0.0, 2 * length
    try:
        hull = ConvexHull(p)
    except QhullError:  # collinear or coincident: a segment
        span = p.max(axis=0) - p.min(axis=0)
        return 0.0, 2 * float(np.hypot(*span))
    # For 2D input qhull's "volume" is the area and "area" the perimeter.
    return float(hull.volume), float(hull.area)


def circularity(xy: NDArray[np.float64]) -> float:
    """Circularity ``P^2 / (4 pi A)`` of the convex hull of 2D points.

    1 for a disc, 4/pi ~ 1.27 for a square, larger for elongated shapes; ``inf`` for
    degenerate (collinear) input.  The thesis separates columns from piers at 1.12.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.linspace(0, 2 * np.pi, 720, endpoint=False)
    >>> round(circularity(np.c_[np.cos(t), np.sin(t)]), 3)
    1.0
    """
    area, perim = hull_area_perimeter(xy)
    return float(perim**2 / (4 * np.pi * area)) if area > 0 else float("inf")


def slice_profile(
    xyz: NDArray[np.float64],
    params: SliceParams | None = None,
    *,
    max_points_per_slice: int = 200_000,
    rng: np.random.Generator | int | None = 0,
    z_order: NDArray[np.intp] | None = None,
    z_sorted: NDArray[np.float64] | None = None,
) -> SliceProfile:
    """Convex hull area of horizontal slabs from the ground tolerance to the top.

    Parameters
    ----------
    xyz
        ``(N, 3)`` levelled coordinates, metres.
    params
        Interval, thickness, ground tolerance (thesis defaults).
    max_points_per_slice
        Larger slabs are randomly subsampled before the hull (the hull of a dense
        sample differs from the full hull by far less than the noise).
    rng
        Seed of that subsampling.
    z_order, z_sorted
        ``argsort(xyz[:, 2])`` and ``xyz[z_order, 2]`` if already computed.

    Returns
    -------
    SliceProfile
        Empty arrays for an empty cloud.
    """
    params = params or SliceParams()
    p = np.asarray(xyz, dtype=np.float64)
    if len(p) == 0:
        e = np.zeros(0)
        return SliceProfile(e, e, e, np.zeros(0, dtype=np.int64))
    gen = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
    if z_order is None:
        z_order, z_sorted = sort_order(p[:, 2])
    elif z_sorted is None:
        z_sorted = p[:, 2][z_order]
    # from the floor, not the lowest point: outliers below the floor make slices of
    # scattered points whose hull areas read as attic changes
    z0, z1 = robust_floor(z_sorted), float(z_sorted[-1])
    first = z0 + params.ground_tolerance_m + params.thickness_m / 2
    centres = np.arange(first, z1 + 1e-9, params.interval_m)
    order, starts, ends = slices(
        p[:, 2], centres, params.thickness_m, order=z_order, z_sorted=z_sorted
    )
    areas = np.zeros(len(centres))
    perims = np.zeros(len(centres))
    for i, (s, e) in enumerate(zip(starts, ends, strict=True)):  # loop over slices
        idx = order[s:e]
        if len(idx) > max_points_per_slice:
            idx = gen.choice(idx, max_points_per_slice, replace=False)
        areas[i], perims[i] = hull_area_perimeter(np.take(p, idx, axis=0)[:, :2])
    return SliceProfile(centres, areas, perims, (ends - starts).astype(np.int64))
