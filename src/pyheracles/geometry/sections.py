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

__all__ = [
    "SliceParams",
    "SliceProfile",
    "circularity",
    "hull_area_perimeter",
    "slab_mask",
    "slice_profile",
    "slices",
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
) -> tuple[NDArray[np.intp], NDArray[np.intp], NDArray[np.intp]]:
    """Points of each slab ``|z - centre| <= thickness / 2`` without a loop over points.

    ``order`` is ``argsort(z)`` when the caller already has it.

    Returns
    -------
    order, starts, ends
        ``order[starts[i]:ends[i]]`` are the indices of the points of slab ``i``.
    """
    order = np.argsort(z) if order is None else order
    zs = z[order]
    starts = np.searchsorted(zs, centres - thickness_m / 2, side="left")
    ends = np.searchsorted(zs, centres + thickness_m / 2, side="right")
    return order, starts, ends


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
    z_order
        ``argsort(xyz[:, 2])`` if already computed.

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
    z0, z1 = float(p[:, 2].min()), float(p[:, 2].max())
    first = z0 + params.ground_tolerance_m + params.thickness_m / 2
    centres = np.arange(first, z1 + 1e-9, params.interval_m)
    order, starts, ends = slices(p[:, 2], centres, params.thickness_m, order=z_order)
    areas = np.zeros(len(centres))
    perims = np.zeros(len(centres))
    for i, (s, e) in enumerate(zip(starts, ends, strict=True)):  # loop over slices
        idx = order[s:e]
        if len(idx) > max_points_per_slice:
            idx = gen.choice(idx, max_points_per_slice, replace=False)
        areas[i], perims[i] = hull_area_perimeter(p[idx, :2])
    return SliceProfile(centres, areas, perims, (ends - starts).astype(np.int64))
