"""Ground under mapped footprints: the terrain around a polygon, not the top of its platform.

A ground filter sees a building's raised platform, plinth or steps (0.3-1.5 m of flat,
wide surface) or the top of a low, thick wall as terrain: they are as smooth as the
ground and wider than its thresholds allow for.  Where a GIS polygon says an object
stands, the terrain under it is the terrain *around* it.  The ground points farther
than a buffer from every polygon give a terrain model (a raster whose holes under the
footprints are filled with a harmonic membrane, as SMRF fills its DTM), and the ground
points within the buffered polygons that stand clearly above it are released: they
belong to the object, not to the terrain.

Used by step 1 (:mod:`pyheracles.complex`) before the cookie-cutter.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import shapely
from numpy.typing import NDArray

from pyheracles.errors import InputError

__all__ = ["FootprintGroundParams", "raised_in_footprints"]


@dataclass(frozen=True)
class FootprintGroundParams:
    """Parameters of the ground release under mapped footprints.

    Attributes
    ----------
    buffer_m
        Ground points within this XY distance of a polygon (inside counts as 0) are tested,
        metres: the step 1 buffer, which absorbs the digitising error.
    cell_m
        Cell of the terrain model built from the ground beyond the buffers, metres
        (step 1 uses the point spacing, at least 0.5 m).
    min_height_m
        A tested ground point higher than this above the terrain model is released,
        metres (0.2: platforms and plinths start near 0.3 m, airborne ground noise and
        interpolation over a few metres stay within 0.1 m).
    noise_factor
        The threshold is at least this many robust standard deviations of the terrain
        model's error (rough or curved ground needs more than pavement).
    min_support_points
        With fewer ground points beyond the buffers there is no terrain to compare
        with, and the filter's answer is kept.
    """

    buffer_m: float = 1.0
    cell_m: float = 1.0
    min_height_m: float = 0.2
    noise_factor: float = 3.0
    min_support_points: int = 10

    def __post_init__(self) -> None:
        for name in ("buffer_m", "cell_m", "min_height_m"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise InputError(f"{name} must be a finite number > 0, got {value}")
        if self.min_support_points < 3:
            raise InputError(f"min_support_points must be >= 3, got {self.min_support_points}")
        if not (np.isfinite(self.noise_factor) and self.noise_factor >= 0):
            raise InputError(f"noise_factor must be a finite number >= 0, got {self.noise_factor}")


class _Bins:
    """Indices of a point subset binned on a square XY grid (box queries)."""

    def __init__(self, xy: NDArray[np.float64], cell_m: float) -> None:
        self.cell = float(cell_m)
        self.origin = xy.min(axis=0) if len(xy) else np.zeros(2)
        ij = np.floor((xy - self.origin) / self.cell).astype(np.int64)
        self.nx = int(ij[:, 0].max()) + 1 if len(xy) else 1
        self.ny = int(ij[:, 1].max()) + 1 if len(xy) else 1
        keys = ij[:, 0] * self.ny + ij[:, 1]
        self.order = np.argsort(keys, kind="stable")
        self.keys = keys[self.order]

    def box(self, b: NDArray[np.float64]) -> NDArray[np.int64]:
        i0, j0 = np.floor((b[:2] - self.origin) / self.cell).astype(np.int64)
        i1, j1 = np.floor((b[2:] - self.origin) / self.cell).astype(np.int64)
        i0, j0, i1, j1 = max(i0, 0), max(j0, 0), min(i1, self.nx - 1), min(j1, self.ny - 1)
        if i0 > i1 or j0 > j1:
            return np.zeros(0, dtype=np.int64)
        cols = np.arange(i0, i1 + 1, dtype=np.int64) * self.ny
        starts = np.searchsorted(self.keys, cols + j0, side="left")
        ends = np.searchsorted(self.keys, cols + j1, side="right")
        parts = [self.order[s:e] for s, e in zip(starts, ends, strict=True) if e > s]
        return np.concatenate(parts) if parts else np.zeros(0, dtype=np.int64)


def raised_in_footprints(
    xyz: NDArray[np.float64],
    ground: NDArray[np.bool_],
    polygons: Sequence[Any],
    params: FootprintGroundParams | None = None,
) -> NDArray[np.bool_]:
    """Ground points that stand above the terrain around the polygons they lie near.

    The terrain model is built from the ground points farther than ``buffer_m`` from
    every polygon (cells of ``cell_m``, holes filled with the harmonic membrane of
    :func:`~pyheracles.groundfilters.surface.inpaint`: exact on planar slopes, smooth
    over terraces); a ground point within ``buffer_m`` of a polygon is released when it
    stands above that model by more than ``min_height_m`` or ``noise_factor`` robust
    standard deviations of the model's error, whichever is larger.  That error is the
    larger of the support points' scatter about the model and the depth of the tested
    points below it (nothing stands below the terrain).

    Parameters
    ----------
    xyz
        (N, 3) points, the polygons' frame.
    ground
        (N,) ground mask of a filter.
    polygons
        Shapely polygons (every layer), same frame as ``xyz``.
    params
        Buffer, cell and height threshold.

    Returns
    -------
    numpy.ndarray
        (N,) bool, True for the ground points to release (a subset of ``ground``).

    Examples
    --------
    >>> import shapely
    >>> x, y = np.meshgrid(np.arange(0.0, 40.0, 0.5), np.arange(0.0, 40.0, 0.5))
    >>> xy = np.column_stack([x.ravel(), y.ravel()])
    >>> slab = shapely.box(10, 10, 30, 30)
    >>> on = shapely.contains_xy(slab, xy[:, 0], xy[:, 1])
    >>> xyz = np.column_stack([xy, 0.1 * xy[:, 0] + 0.6 * on])   # a 0.6 m platform on a slope
    >>> rel = raised_in_footprints(xyz, np.ones(len(xyz), bool), [slab])
    >>> bool((rel == on).all())
    True
    """
    from pyheracles.groundfilters.surface import dtm_from_ground, height_above_ground

    p = params or FootprintGroundParams()
    xyz = np.asarray(xyz, dtype=np.float64)
    ground = np.asarray(ground, dtype=bool)
    n = len(xyz)
    if xyz.ndim != 2 or xyz.shape[1] != 3 or ground.shape != (n,):
        raise InputError(f"xyz must be (N, 3) and ground (N,), got {xyz.shape} and {ground.shape}")
    release = np.zeros(n, dtype=bool)
    gidx = np.flatnonzero(ground)
    geoms = np.asarray(list(polygons), dtype=object)
    if len(gidx) == 0 or len(geoms) == 0:
        return release
    near = shapely.buffer(geoms, p.buffer_m)
    shapely.prepare(near)
    bins = _Bins(xyz[gidx, :2], max(5.0, 4.0 * p.buffer_m))
    tested = np.zeros(n, dtype=bool)
    for k in range(len(geoms)):
        if shapely.is_empty(near[k]):
            continue
        cand = gidx[bins.box(np.asarray(shapely.bounds(near[k])))]
        cand = cand[~tested[cand]]
        if len(cand):
            tested[cand[shapely.contains_xy(near[k], xyz[cand, 0], xyz[cand, 1])]] = True
    support = ground & ~tested
    if not tested.any() or support.sum() < p.min_support_points:
        return release
    dtm = dtm_from_ground(xyz, support, p.cell_m)
    own = height_above_ground(xyz[support], dtm)
    spread = 1.4826 * float(np.median(np.abs(own - np.median(own))))
    t = np.flatnonzero(tested)
    h = height_above_ground(xyz[t], dtm)
    # The membrane's own error under the footprints: nothing stands below the terrain,
    # so the tested points below the model measure it (half-normal: sigma = 1.4826 x
    # their median depth).  It grows on curved terrain and with wide, sparse gaps.
    below = -h[h < 0]
    if len(below) >= p.min_support_points:
        spread = max(spread, 1.4826 * float(np.median(below)))
    threshold = max(p.min_height_m, p.noise_factor * spread)
    release[t[h > threshold]] = True
    return release
