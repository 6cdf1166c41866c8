"""Simple Morphological Filter (SMRF, Pingel, Clarke & McBride 2013), rasterised and vectorised.

Steps (Pingel et al. 2013, section 2; the same as PDAL's ``filters.smrf``):

1. minimum surface: lowest point per ``cell_m`` cell, empty cells inpainted;
2. low outliers: cells far below their neighbours (the filter run on the inverted
   surface with a one-cell window and a slope of 5) are dropped;
3. progressive morphological opening with disks of radius 1 .. ``window_m / cell_m``
   cells; a cell is an object where the opening lowers it by more than
   ``slope * radius_m``;
4. provisional DTM: the minimum surface without object / low cells, inpainted;
5. a point is ground when ``|z - DTM(x, y)| <= threshold_m + scalar * slope_of_DTM(x, y)``.

The morphology is hand-written on ``scipy.ndimage`` because scikit-image is not a hard
dependency here and because a disk opening of radius r costs O(r^2) per cell; we use
the usual octagon decomposition of the disk (a square followed by repeated 3x3
crosses, as skimage's ``disk(..., decomposition="sequence")``) which costs O(r).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from pyheracles.errors import InputError
from pyheracles.groundfilters.surface import (
    DTM,
    Grid,
    RasterSampler,
    inpaint,
    rasterise,
    rasterise_cells,
)

__all__ = ["SMRFParams", "low_outliers", "progressive_filter", "smrf"]


@dataclass(frozen=True)
class SMRFParams:
    """Parameters of the Simple Morphological Filter.

    Defaults are those of PDAL ``filters.smrf``, which are the values Pingel et al.
    (2013) found to work across the ISPRS filter test samples.

    Attributes
    ----------
    cell_m
        Raster cell size, metres (1.0).
    slope
        Terrain slope allowed by the morphological step, rise over run (0.15 = 8.5°).
    window_m
        Largest opening window radius, metres: must exceed half the size of the
        largest building (18.0).
    scalar
        Elevation scalar: the ground threshold grows by ``scalar * local DTM slope``
        (rise over run) (1.25).
    threshold_m
        Elevation threshold: largest distance of a ground point from the DTM, metres (0.5).
    """

    cell_m: float = 1.0
    slope: float = 0.15
    window_m: float = 18.0
    scalar: float = 1.25
    threshold_m: float = 0.5

    def __post_init__(self) -> None:
        for name in ("cell_m", "window_m"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise InputError(f"SMRFParams.{name} must be > 0 metres, got {value!r}")
        for name in ("slope", "scalar", "threshold_m"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value >= 0):
                raise InputError(f"SMRFParams.{name} must be >= 0, got {value!r}")


def _disk_filter(surface: NDArray[np.float64], radius: int, op: str) -> NDArray[np.float64]:
    """Grey erosion ('min') or dilation ('max') with an octagonal disk of ``radius`` cells."""
    if radius <= 0:
        return surface
    # octagon = square (half-width a) (+) diamond (radius b), a + b = r and a + b/2 = r/sqrt(2)
    b = round(2.0 * radius * (1.0 - 1.0 / np.sqrt(2.0)))
    a = radius - b
    filt = ndimage.minimum_filter if op == "min" else ndimage.maximum_filter
    out = filt(surface, size=2 * a + 1, mode="nearest") if a > 0 else surface
    ufunc = np.minimum if op == "min" else np.maximum
    for _ in range(b):
        out = _cross_filter(out, ufunc)
    return out


def _cross_filter(values: NDArray[np.float64], ufunc: np.ufunc) -> NDArray[np.float64]:
    """Grey erosion / dilation with the 3x3 cross, edges replicated (``mode="nearest"``).

    Four shifted in-place ``np.minimum`` / ``np.maximum`` on slices: the same result as
    ``ndimage.minimum_filter(values, footprint=cross, mode="nearest")`` (a replicated edge
    neighbour is the cell itself) at a third of the cost; the opening loop calls it
    ~200 times per SMRF run.
    """
    out = np.empty_like(values)
    ufunc(values[1:], values[:-1], out=out[1:])
    out[0] = values[0]
    ufunc(out[:-1], values[1:], out=out[:-1])
    ufunc(out[:, 1:], values[:, :-1], out=out[:, 1:])
    ufunc(out[:, :-1], values[:, 1:], out=out[:, :-1])
    return out


def _opening(surface: NDArray[np.float64], radius: int) -> NDArray[np.float64]:
    return _disk_filter(_disk_filter(surface, radius, "min"), radius, "max")


def progressive_filter(
    surface: NDArray[np.float64], *, slope: float, max_radius: int, cell_m: float
) -> NDArray[np.bool_]:
    """Cells flagged as objects by openings with growing disks (Pingel et al. 2013, eq. 1).

    Parameters
    ----------
    surface
        Gap-free raster of heights, metres.
    slope
        Rise over run; at radius r (cells) a cell is an object if the opening lowers
        it by more than ``slope * r * cell_m``.
    max_radius
        Largest disk radius, cells.
    cell_m
        Cell size, metres.
    """
    is_object = np.zeros(surface.shape, dtype=bool)
    last = surface
    for radius in range(1, max_radius + 1):
        opened = _opening(last, radius)
        is_object |= (last - opened) > slope * radius * cell_m
        last = opened
    return is_object


def low_outliers(
    xyz: NDArray[np.float64], *, cell_m: float = 1.0, drop_m: float = 5.0
) -> NDArray[np.bool_]:
    """Points far below the terrain (multipath, "negative blunders").

    A point is a low outlier when it lies more than ``drop_m`` below the lowest point of
    every occupied neighbouring cell (the 8 cells around its own, ``cell_m`` wide). Ground
    beside a wall or in a one-cell alley keeps a neighbour at its own level and is not
    flagged; an isolated pit is. The ISPRS samples hold such points down to 98 m below the
    ground; for the Cloth Simulation Filter each one is a tent pole that holds the inverted
    cloth away from the ground around it.

    Returns
    -------
    numpy.ndarray
        (N,) bool, True for low outliers.
    """
    xy = xyz[:, :2]
    grid = Grid.covering(xy, cell_m)
    zmin = rasterise(grid, xy, xyz[:, 2], "min")
    ring = np.ones((3, 3), dtype=bool)
    ring[1, 1] = False
    neighbour_min = ndimage.minimum_filter(
        np.where(np.isnan(zmin), np.inf, zmin), footprint=ring, mode="constant", cval=np.inf
    )
    row, col = grid.index(xy)
    floor = neighbour_min[row, col]
    return np.isfinite(floor) & (xyz[:, 2] < floor - drop_m)


def _relative_heights(z: NDArray[np.float64], zref: float, dtype: np.dtype) -> NDArray:
    """``z - zref`` in ``dtype`` (the sampler's precision)."""
    out = np.subtract(z, zref)
    return out.astype(dtype, copy=False)


def smrf(
    xyz: NDArray[np.float64],
    params: SMRFParams | None = None,
    *,
    sampler: RasterSampler | None = None,
) -> tuple[NDArray[np.bool_], DTM]:
    """Classify ground with the Simple Morphological Filter.

    Parameters
    ----------
    xyz
        (N, 3) float64 points, local frame, metres.
    params
        :class:`SMRFParams`; None = defaults.
    sampler
        ``RasterSampler(Grid.covering(xyz[:, :2], params.cell_m), xyz[:, :2])`` when the
        caller already built it (shared with a refinement or a DTM); built here otherwise.

    Returns
    -------
    mask
        (N,) bool, True for ground.
    surface
        The provisional DTM the points were tested against (``observed`` = cells
        holding a point that is neither an object nor a low outlier).

    References
    ----------
    Pingel, T. J., Clarke, K. C., McBride, W. A. (2013). An improved simple morphological
    filter for the terrain classification of airborne LIDAR data. ISPRS Journal of
    Photogrammetry and Remote Sensing 77, 21-30.
    """
    p = SMRFParams() if params is None else params
    xy = xyz[:, :2]
    if sampler is None or sampler.grid.cell_m != p.cell_m:
        sampler = RasterSampler(Grid.covering(xy, p.cell_m), xy, dtype=np.float32)
    grid = sampler.grid
    z = xyz[:, 2]
    zmin = rasterise_cells(grid, sampler.flat, z, "min")
    empty = np.isnan(zmin)
    zfilled = inpaint(zmin)
    # low outliers: the filter run on the inverted surface, window of one cell, slope 5
    low = progressive_filter(-zfilled, slope=5.0, max_radius=1, cell_m=p.cell_m) & ~empty
    if low.any():
        zfilled = inpaint(np.where(low | empty, np.nan, zmin))
    max_radius = max(1, int(np.ceil(p.window_m / p.cell_m)))
    is_object = progressive_filter(zfilled, slope=p.slope, max_radius=max_radius, cell_m=p.cell_m)
    keep = ~(empty | low | is_object)
    if not keep.any():
        # every cell is an object: no ground surface can be formed
        return np.zeros(xyz.shape[0], dtype=bool), DTM(zfilled, grid, keep)
    provisional = DTM(inpaint(np.where(keep, zmin, np.nan)), grid, keep)
    # heights relative to the lowest kept cell: float32 samplers stay at µm resolution
    zref = float(zmin[keep].min())
    residual = sampler(provisional.z_m - zref)
    np.subtract(_relative_heights(z, zref, sampler.dtype), residual, out=residual)
    np.abs(residual, out=residual)
    tolerance = sampler(provisional.slope())
    tolerance *= p.scalar
    tolerance += p.threshold_m
    return residual <= tolerance, provisional
