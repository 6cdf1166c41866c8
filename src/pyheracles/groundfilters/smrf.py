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
from pyheracles.groundfilters.grow import grow_smooth, smooth_components
from pyheracles.groundfilters.morphology import repeated_cross_filter, square_filter
from pyheracles.groundfilters.surface import (
    DTM,
    Grid,
    RasterSampler,
    inpaint,
    inpaint_update,
    rasterise,
    rasterise_cells,
)

__all__ = [
    "SMRFParams",
    "joined_patches",
    "low_clusters",
    "low_outliers",
    "opening",
    "plane_misfit",
    "progressive_filter",
    "progressive_filters",
    "smrf",
    "terrain_slope_raster",
]


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
    terrain_slope_weight
        Slope-aware seed stage (0 = off, Pingel et al. 2013 as published): the slope
        allowed in step 3 becomes ``slope + terrain_slope_weight * local terrain slope``,
        the local slope being that of the surface opened with the largest window (every
        object removed) smoothed over the window. Convex ground on steep slopes (crests,
        the edges of terraces and embankments) is lowered by every opening by about its
        slope per cell of radius; with a fixed 0.15 it is rejected, with the local slope
        it is kept, while objects on flat ground meet the published threshold. The
        allowance applies to the openings up to ``terrain_slope_radius_m``: convex ground
        is lost at the small radii, buildings at the radius of their half width, so a
        building wider than twice that radius meets the published test on any slope.
    terrain_slope_radius_m
        Largest opening radius given the terrain slope allowance, metres, at least two
        cells (3.0; on the terrain family 3 m against 5 m and no limit: the same mean
        total error on 1-3 m cells, while on ISPRS sample 11 (buildings on a steep
        slope) no limit raised it from 8.6 to 12.7 %).
    join_share
        Object test of the slope-aware seed stage (0 = off: every cell the slope allowance
        keeps is kept). With it, the cells kept only thanks to the allowance form patches
        (8-neighbour), and a patch is kept when at least this share of its border cells
        lie within ``threshold_m`` of the plane fitted to the published-test ground
        within ``join_radius_m`` around them (:func:`joined_patches`): crest and
        terrace-edge ground continues the slope around it, a roof on a slope or a shrub
        does not. Only used with ``terrain_slope_weight`` > 0.
    join_radius_m
        Half width of the window of that plane fit, metres, at least one cell (2.0).
    edge_slope_allowance
        Edge-of-raster allowance (False = off, as published). Beyond the raster's edges
        the openings see the edge cells replicated, so terrain rising towards an edge at
        slope ``s`` is lowered by an opening of radius ``r`` by ``s (r - d)`` at ``d``
        cells from the edge and rejected as an object (ISPRS sample 23: 19 % of the
        ground within 12 m of its east edge). With the allowance that drop is allowed on
        top, ``s`` being the local terrain slope measured with the surface continued
        beyond the edge by point reflection; the cells it keeps go through the object
        test of ``join_share`` like those of ``terrain_slope_weight``.
    low_cluster_window_m
        Low outliers in clusters (0 = off: the published one-cell test only): cells of the
        minimum surface that a closing of radius up to this many metres raises by more
        than ``low_cluster_drop_m`` in one step of one cell (a pit with vertical walls:
        multipath clusters several metres under the terrain; a real depression rises a
        little at every step) are low outliers, whatever the cluster's size up to the
        window.
    low_cluster_drop_m
        Height of that one-step jump, metres (2.0).
    grow_steps
        Smooth-continuation recovery (0 = off, as published): at most this many rings of
        rejected cells grown from the ground the published test keeps
        (:func:`pyheracles.groundfilters.grow.grow_smooth`). A cell joins when its lowest
        point lies within the tolerance of the plane fitted to the ground (kept or grown)
        within ``join_radius_m`` around it, and that ground fits its plane within the
        tolerance too (a window mixing the ground and a roof beside it does not). The
        openings lower the top of every crest sharper than about ``2 slope / window``
        (curvature, 1/m), however low it stands: continuity tells it from an object,
        which stands on a step.
    grow_tolerance_m
        That tolerance on flat ground, metres (0.2; 0.3 let wall feet and low objects of
        AHN3 tile 1 in: ground precision 0.981 -> 0.979).
    grow_slope_scalar
        The tolerance grows by this many times the plane's rise over one cell (the
        lowest point of a cell on a slope lies anywhere in the cell) (0.5).
    grow_max_slope
        Steepest slope counted in that tolerance, rise over run (1.0 = 45 deg).
    grow_source_m2
        The growth starts only from kept ground in components of at least this area,
        square metres (0 = from all): components of cells linked to a neighbour less than
        ``threshold_m`` plus ``grow_max_slope`` times the cell apart in height, so the
        few cells of a roof the openings keep (a roof at the raster's edge, ISPRS sample
        21) are not sources, while terrain is one large component.
    """

    cell_m: float = 1.0
    slope: float = 0.15
    window_m: float = 18.0
    scalar: float = 1.25
    threshold_m: float = 0.5
    terrain_slope_weight: float = 0.0
    low_cluster_window_m: float = 0.0
    low_cluster_drop_m: float = 2.0
    terrain_slope_radius_m: float = 3.0
    join_share: float = 0.0
    join_radius_m: float = 2.0
    edge_slope_allowance: bool = False
    grow_steps: int = 0
    grow_tolerance_m: float = 0.2
    grow_slope_scalar: float = 0.5
    grow_source_m2: float = 0.0
    grow_max_slope: float = 1.0

    def __post_init__(self) -> None:
        for name in ("cell_m", "window_m"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise InputError(f"SMRFParams.{name} must be > 0 metres, got {value!r}")
        for name in (
            "slope",
            "scalar",
            "threshold_m",
            "terrain_slope_weight",
            "low_cluster_window_m",
            "low_cluster_drop_m",
            "terrain_slope_radius_m",
            "join_share",
            "join_radius_m",
            "grow_steps",
            "grow_tolerance_m",
            "grow_slope_scalar",
            "grow_source_m2",
            "grow_max_slope",
        ):
            value = getattr(self, name)
            if not (np.isfinite(value) and value >= 0):
                raise InputError(f"SMRFParams.{name} must be >= 0, got {value!r}")
        if self.join_share > 1:
            raise InputError(f"SMRFParams.join_share must be <= 1, got {self.join_share!r}")


def _disk_filter(surface: NDArray[np.float64], radius: int, op: str) -> NDArray[np.float64]:
    """Grey erosion ('min') or dilation ('max') with an octagonal disk of ``radius`` cells."""
    if radius <= 0:
        return surface
    # octagon = square (half-width a) (+) diamond (radius b), a + b = r and a + b/2 = r/sqrt(2)
    b = round(2.0 * radius * (1.0 - 1.0 / np.sqrt(2.0)))
    a = radius - b
    # the square, then the diamond (b passes of the 3 x 3 cross), edges replicated
    return repeated_cross_filter(square_filter(surface, a, op), b, op)


def opening(surface: NDArray[np.float64], radius: int) -> NDArray[np.float64]:
    """Morphological opening (erosion then dilation) of a raster by a disk of ``radius`` cells.

    The building block of SMRF (Pingel et al. 2013): it removes objects narrower
    than the disk and keeps the terrain under them.
    """
    return _disk_filter(_disk_filter(surface, radius, "min"), radius, "max")


def progressive_filter(
    surface: NDArray[np.float64],
    *,
    slope: float,
    max_radius: int,
    cell_m: float,
    extra_slope: NDArray[np.float64] | None = None,
    extra_max_radius: int = 0,
    active: NDArray[np.bool_] | None = None,
    edge_slope: NDArray[np.float64] | None = None,
    edge_distance: NDArray[np.float64] | None = None,
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
    extra_slope, extra_max_radius
        A slope per cell (raster of the surface's shape) added to ``slope`` at the radii
        up to ``extra_max_radius`` (the slope-aware seed stage, see
        :attr:`SMRFParams.terrain_slope_weight`).
    active
        Cells whose result is wanted (e.g. those near data); None = all. When they cover
        a small part of the raster, the filter runs on boxes around them only (with a
        halo of twice the largest radius, :func:`_active_blocks`), so that its cost
        follows the data, not the bounding box (tiles on a diagonal); cells outside the
        boxes are not objects.
    edge_slope, edge_distance
        Terrain slope per cell (rise over run) for the raster's edges, and each cell's
        distance to the nearest edge in cells (None = of this raster). Beyond the edge
        the surface is replicated, so terrain rising towards an edge at slope ``s`` is
        lowered by an opening of radius ``r`` by ``s (r - d)`` at ``d`` cells from the
        edge, as if it were an object; with ``edge_slope`` that drop is allowed on top.
    """
    codes = _progressive_codes(
        surface, slope=slope, max_radius=max_radius, cell_m=cell_m, extra_slope=extra_slope,
        extra_max_radius=extra_max_radius, active=active, edge_slope=edge_slope,
        edge_distance=edge_distance, published=False,
    )  # fmt: skip
    return codes.astype(bool)


def progressive_filters(
    surface: NDArray[np.float64],
    *,
    slope: float,
    max_radius: int,
    cell_m: float,
    extra_slope: NDArray[np.float64] | None = None,
    extra_max_radius: int = 0,
    active: NDArray[np.bool_] | None = None,
    edge_slope: NDArray[np.float64] | None = None,
    edge_distance: NDArray[np.float64] | None = None,
) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
    """:func:`progressive_filter` with its allowances and as published, from one run.

    Both tests compare the same openings (the whole cost of the filter) with different
    allowed drops, so the pair costs one filter pass instead of two. The parameters are
    those of :func:`progressive_filter`.

    Returns
    -------
    with_allowances
        Objects with ``extra_slope`` and ``edge_slope`` allowed on top of ``slope``.
    published
        Objects with ``slope`` only (Pingel et al. 2013).
    """
    codes = _progressive_codes(
        surface, slope=slope, max_radius=max_radius, cell_m=cell_m, extra_slope=extra_slope,
        extra_max_radius=extra_max_radius, active=active, edge_slope=edge_slope,
        edge_distance=edge_distance, published=True,
    )  # fmt: skip
    return (codes & 1).astype(bool), (codes & 2).astype(bool)


def _progressive_codes(
    surface: NDArray[np.float64],
    *,
    slope: float,
    max_radius: int,
    cell_m: float,
    extra_slope: NDArray[np.float64] | None,
    extra_max_radius: int,
    active: NDArray[np.bool_] | None,
    edge_slope: NDArray[np.float64] | None,
    edge_distance: NDArray[np.float64] | None,
    published: bool,
) -> NDArray[np.uint8]:
    """Bit 0: objects with the allowances; bit 1 (with ``published``): objects as published."""
    if edge_slope is not None and edge_distance is None:
        rows, cols = surface.shape
        dr = np.minimum(np.arange(rows), np.arange(rows)[::-1]).astype(np.float64)
        dc = np.minimum(np.arange(cols), np.arange(cols)[::-1]).astype(np.float64)
        edge_distance = np.minimum.outer(dr, dc)
    if active is not None and active.mean() < _BLOCKWISE_MAX_SHARE:

        def run(window):
            sub_extra = None if extra_slope is None else extra_slope[window]
            sub_edge = None if edge_slope is None else edge_slope[window]
            sub_dist = None if edge_distance is None else edge_distance[window]
            return _progressive_codes(
                surface[window], slope=slope, max_radius=max_radius, cell_m=cell_m,
                extra_slope=sub_extra, extra_max_radius=extra_max_radius, active=None,
                edge_slope=sub_edge, edge_distance=sub_dist, published=published,
            )  # fmt: skip

        out = np.zeros(surface.shape, dtype=np.uint8)
        return _boxwise(run, active, 2 * max_radius + 2, out)
    is_object = np.zeros(surface.shape, dtype=bool)
    plain = np.zeros(surface.shape, dtype=bool) if published else None
    last = surface
    for radius in range(1, max_radius + 1):
        opened = opening(last, radius)
        drop = last - opened
        allowed = slope * radius * cell_m
        if plain is not None:
            plain |= drop > allowed
        if extra_slope is not None and radius <= extra_max_radius:
            allowed = allowed + extra_slope * (radius * cell_m)
        if edge_slope is not None and edge_distance is not None:
            near = np.maximum(0.0, radius - edge_distance)
            if near.any():
                allowed = allowed + edge_slope * (near * cell_m)
        is_object |= drop > allowed
        last = opened
    codes = is_object.astype(np.uint8)
    if plain is not None:
        codes |= plain.astype(np.uint8) << 1
    return codes


#: Share of the raster's cells near data below which the morphology runs box by box.
_BLOCKWISE_MAX_SHARE = 0.5


def _boxwise(run, active: NDArray[np.bool_], halo: int, out: NDArray) -> NDArray:
    """``out`` with ``run(window)`` written at the core of every box of
    :func:`_active_blocks` (``run`` takes a window of slices, returns the window's raster).

    Boxes whose windows overlap are run together when one window over both costs fewer
    cells (:func:`_merged_windows`); each box's core is still written from a window that
    holds it with its halo, so the result is the same."""
    boxes = list(_active_blocks(active, halo))
    for window, cores in _merged_windows(boxes, halo, active.shape):
        res = run(window)
        for core in cores:
            inner = tuple(
                slice(c.start - w.start, c.stop - w.start)
                for c, w in zip(core, window, strict=True)
            )
            out[core] = res[inner]
    return out


#: Most boxes merged (each greedy step scores every pair of groups).
_MERGE_MAX_BOXES = 256


def _merged_windows(boxes, halo: int, shape: tuple[int, int]):
    """Groups of boxes run in one window: (window, [cores]) pairs.

    Greedy: the pair of groups whose joint window (the bounding box of their cores grown
    by ``halo``) saves the most cells against their two windows is merged, until no pair
    saves any. A tile cut by :func:`_active_blocks` into slivers, each with its own halo,
    goes back to one window (8 AHN3 tiles on a diagonal: 18 windows of 1.18 M cells in
    all, 8 of 0.91 M).
    """
    rows, cols = shape
    ext = np.array(
        [(c[0].start, c[0].stop, c[1].start, c[1].stop) for c, _ in boxes], dtype=np.int64
    ).reshape(-1, 4)
    cores = [[c] for c, _ in boxes]

    def area(r0, r1, c0, c1):
        h = np.minimum(rows, r1 + halo) - np.maximum(0, r0 - halo)
        w = np.minimum(cols, c1 + halo) - np.maximum(0, c0 - halo)
        return h * w

    while 1 < len(cores) <= _MERGE_MAX_BOXES:
        own = area(*ext.T)
        lo_r, hi_r = np.minimum.outer(ext[:, 0], ext[:, 0]), np.maximum.outer(ext[:, 1], ext[:, 1])
        lo_c, hi_c = np.minimum.outer(ext[:, 2], ext[:, 2]), np.maximum.outer(ext[:, 3], ext[:, 3])
        gain = own[:, None] + own[None, :] - area(lo_r, hi_r, lo_c, hi_c)
        np.fill_diagonal(gain, 0)
        i, j = np.unravel_index(int(np.argmax(gain)), gain.shape)
        if gain[i, j] <= 0:
            break
        joint = [lo_r[i, j], hi_r[i, j], lo_c[i, j], hi_c[i, j]]
        keep = [k for k in range(len(cores)) if k not in (i, j)]
        cores = [cores[k] for k in keep] + [cores[i] + cores[j]]
        ext = np.vstack([ext[keep], np.array(joint, dtype=np.int64)[None, :]])
    windows = [
        (
            slice(max(0, r0 - halo), min(rows, r1 + halo)),
            slice(max(0, c0 - halo), min(cols, c1 + halo)),
        )
        for r0, r1, c0, c1 in ext.tolist()
    ]
    return list(zip(windows, cores, strict=True))


def _active_blocks(active: NDArray[np.bool_], halo: int):
    """(core, window) slice pairs of boxes that partition the active cells; window = core
    grown by ``halo`` cells (clipped to the raster).

    The bounding box of the active cells is split in two along its longer side, each half
    shrunk to its own active cells, until a box is at least half active or no larger than
    four halos: tiles on a diagonal end as one box each, not as their bounding box.
    """
    rows, cols = active.shape

    def shrink(r0: int, r1: int, c0: int, c1: int):
        sub = active[r0:r1, c0:c1]
        rr = np.flatnonzero(sub.any(axis=1))
        if rr.size == 0:
            return None
        cc = np.flatnonzero(sub.any(axis=0))
        return r0 + rr[0], r0 + rr[-1] + 1, c0 + cc[0], c0 + cc[-1] + 1

    stack = [shrink(0, rows, 0, cols)]
    while stack:
        box = stack.pop()
        if box is None:
            continue
        r0, r1, c0, c1 = box
        h, w = r1 - r0, c1 - c0
        fill = active[r0:r1, c0:c1].mean()
        if fill >= _BLOCKWISE_MAX_SHARE or max(h, w) <= 4 * halo:
            core = (slice(r0, r1), slice(c0, c1))
            window = (
                slice(max(0, r0 - halo), min(rows, r1 + halo)),
                slice(max(0, c0 - halo), min(cols, c1 + halo)),
            )
            yield core, window
        elif h >= w:
            mid = r0 + h // 2
            stack += [shrink(r0, mid, c0, c1), shrink(mid, r1, c0, c1)]
        else:
            mid = c0 + w // 2
            stack += [shrink(r0, r1, c0, mid), shrink(r0, r1, mid, c1)]


def low_clusters(
    surface: NDArray[np.float64], *, max_radius: int, drop_m: float
) -> NDArray[np.bool_]:
    """Cells of pits with near-vertical walls: clusters of low outliers of any size.

    Closings (the opening of the inverted surface) with disks of radius 1 .. ``max_radius``
    cells; a cell is low where one step of the sequence raises it by more than ``drop_m``.
    A pit with vertical walls (a multipath cluster metres under the terrain) is filled in
    one step, once the disk no longer fits into it; a real depression (a valley, a ditch,
    a river cut with sloping banks) rises a little at every step.
    """
    low = np.zeros(surface.shape, dtype=bool)
    last = -surface
    for radius in range(1, max_radius + 1):
        opened = opening(last, radius)
        low |= (last - opened) > drop_m
        last = opened
    return low


def terrain_slope_raster(
    surface: NDArray[np.float64], *, max_radius: int, cell_m: float, extrapolate: bool = False
) -> NDArray[np.float64]:
    """Local terrain slope (rise over run) per cell, objects removed.

    The gap-free minimum surface opened with the largest window (what no object survives)
    is smoothed with a box of that window and its gradient taken. With ``extrapolate``
    the surface is first continued beyond the raster's edges by point reflection
    (``2 z(edge) - z(edge - k)``); otherwise the edge cells are replicated and terrain
    rising towards an edge measures nearly flat there.
    """
    pad = 2 * max_radius + 1 if extrapolate else 0  # the reach of the opening
    rows, cols = surface.shape
    # beyond the raster's edges the surface is continued by point reflection: replicated
    # edge cells would make terrain rising towards an edge look flat there
    padded = np.pad(surface, pad, mode="reflect", reflect_type="odd") if pad else surface
    trend = opening(padded, max_radius)
    trend = ndimage.uniform_filter(trend, size=max_radius + 1, mode="nearest")
    trend = trend[pad : pad + rows, pad : pad + cols]
    rows, cols = trend.shape
    gx = np.gradient(trend, cell_m, axis=1) if cols > 1 else np.zeros_like(trend)
    gy = np.gradient(trend, cell_m, axis=0) if rows > 1 else np.zeros_like(trend)
    return np.hypot(gx, gy)


def plane_misfit(
    zmin: NDArray[np.float64], kept: NDArray[np.bool_], radius: int = 2
) -> NDArray[np.float64]:
    """Height of every cell above the plane fitted to the kept cells around it, metres.

    The plane is the least-squares fit to the kept cells of the ``(2 radius + 1)``-cell
    square window (box sums of the moments, so the cost is a few filters per raster);
    NaN where the window holds fewer than three kept cells or they are collinear.
    """
    size = 2 * radius + 1
    w = kept.astype(np.float64)
    z = np.where(kept, zmin, 0.0)
    z0 = float(np.mean(zmin[kept])) if kept.any() else 0.0
    z = np.where(kept, z - z0, 0.0)  # small numbers for the moments
    rows, cols = zmin.shape
    r = np.arange(rows, dtype=np.float64)[:, None] - 0.5 * rows
    c = np.arange(cols, dtype=np.float64)[None, :] - 0.5 * cols

    def box(values: NDArray[np.float64]) -> NDArray[np.float64]:
        return ndimage.uniform_filter(values, size=size, mode="constant") * float(size * size)

    # moments about the centre cell: sum w (r - r0)^i (c - c0)^j from the raw sums
    n, sr, sc = box(w), box(w * r), box(w * c)
    srr, scc, src = box(w * r * r), box(w * c * c), box(w * r * c)
    sz, szr, szc = box(z), box(z * r), box(z * c)
    mr, mc = sr - r * n, sc - c * n
    mrr = srr - 2 * r * sr + r * r * n
    mcc = scc - 2 * c * sc + c * c * n
    mrc = src - r * sc - c * sr + r * c * n
    mzr, mzc = szr - r * sz, szc - c * sz
    # Cramer's rule for the plane's value at the centre (the intercept)
    det = n * (mrr * mcc - mrc * mrc) - mr * (mr * mcc - mrc * mc) + mc * (mr * mrc - mrr * mc)
    num = sz * (mrr * mcc - mrc * mrc) - mr * (mzr * mcc - mrc * mzc) + mc * (mzr * mrc - mrr * mzc)
    good = (n >= 3) & (np.abs(det) > 1e-6 * np.maximum(n, 1.0) ** 3)
    with np.errstate(divide="ignore", invalid="ignore"):
        plane = np.where(good, num / np.where(good, det, 1.0), np.nan)
    return (zmin - z0) - plane


def joined_patches(
    misfit: NDArray[np.float64],
    candidates: NDArray[np.bool_],
    tolerance_m: float,
    share: float,
) -> NDArray[np.bool_]:
    """Candidate cells in patches that continue the plane of the kept ground around them.

    A patch is a connected (8-neighbour) set of ``candidates``; its border cells are those
    with a finite ``misfit`` (:func:`plane_misfit`: kept ground around them). A border
    cell joins the ground when it lies within ``tolerance_m`` of the plane of that
    ground, and a patch is kept when at least ``share`` of its border cells join: the
    convex ground of a crest or a terrace edge continues the slope around it, while a
    roof (even one whose uphill edge meets the slope) stands on a step along most of its
    outline and a shrub stands above the slope's plane. A patch with no border cell is
    not kept.
    """
    labels, n_labels = ndimage.label(candidates, structure=np.ones((3, 3), dtype=bool))
    if n_labels == 0:
        return np.zeros(candidates.shape, dtype=bool)
    border = candidates & np.isfinite(misfit)
    joins = border & (np.abs(np.where(border, misfit, 0.0)) <= tolerance_m)
    n_border = np.bincount(labels[border], minlength=n_labels + 1)
    n_joins = np.bincount(labels[joins], minlength=n_labels + 1)
    accept = (n_border > 0) & (n_joins >= share * n_border)
    accept[0] = False
    return accept[labels]


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


def _recovered(
    zmin: NDArray[np.float64],
    keep: NDArray[np.bool_],
    sources: NDArray[np.bool_],
    rejected: NDArray[np.bool_],
    p: SMRFParams,
) -> NDArray[np.bool_]:
    """Rejected cells recovered by :func:`grow_smooth`, grown from ``sources`` (kept
    cells) into ``rejected`` cells (see :attr:`SMRFParams.grow_steps`)."""
    candidates = rejected & ~keep
    if not candidates.any():
        return candidates
    radius = max(1, int(np.ceil(p.join_radius_m / p.cell_m)))
    if p.grow_source_m2 > 0 and sources.any():
        labels, sizes = smooth_components(
            zmin, sources, p.threshold_m, rise_m=p.grow_max_slope * p.cell_m
        )
        big = sizes * p.cell_m**2 >= p.grow_source_m2
        sources = sources & big[np.maximum(labels, 0)]
    grown = grow_smooth(
        zmin, sources, candidates, radius=radius, tolerance_m=p.grow_tolerance_m,
        slope_scalar=p.grow_slope_scalar, max_rise=p.grow_max_slope * p.cell_m,
        max_steps=int(p.grow_steps),
    )  # fmt: skip
    return grown


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

    def local_slope(extrapolate: bool) -> NDArray[np.float64]:
        def trend(window):
            return terrain_slope_raster(
                zfilled[window], max_radius=max_radius, cell_m=p.cell_m, extrapolate=extrapolate
            )

        if empty.mean() > 1.0 - _BLOCKWISE_MAX_SHARE:
            halo = 3 * max_radius + 2  # the opening and the smoothing box
            return _boxwise(trend, ~empty, halo, np.zeros(zfilled.shape))
        return trend((slice(None), slice(None)))

    extra = local = edge = None
    if p.terrain_slope_weight > 0:
        local = local_slope(False)
        extra = local * p.terrain_slope_weight
    if p.edge_slope_allowance:
        edge = local_slope(True)
    extra_radius = max(2, int(np.floor(p.terrain_slope_radius_m / p.cell_m)))
    object_test = (extra is not None or edge is not None) and p.join_share > 0
    filter_args = dict(
        slope=p.slope, max_radius=max_radius, cell_m=p.cell_m, extra_slope=extra,
        extra_max_radius=extra_radius, active=~empty, edge_slope=edge,
    )  # fmt: skip
    if not object_test:
        is_object = progressive_filter(zfilled, **filter_args)
        published = is_object
    else:
        # the slope allowance is kept only in patches that continue the ground around them;
        # the published test comes from the same openings
        is_object, published = progressive_filters(zfilled, **filter_args)
        kept = ~(empty | low | published)
        recovered = published & ~is_object & ~empty & ~low
        if recovered.any():
            radius = max(1, int(np.ceil(p.join_radius_m / p.cell_m)))

            def misfit(window):
                return plane_misfit(zmin[window], kept[window], radius)

            if empty.mean() > 1.0 - _BLOCKWISE_MAX_SHARE:
                fit = _boxwise(misfit, ~empty, radius + 1, np.full(zmin.shape, np.nan))
            else:
                fit = misfit((slice(None), slice(None)))
            is_object = published & ~joined_patches(fit, recovered, p.threshold_m, p.join_share)
        else:
            is_object = published
    keep = ~(empty | low | is_object)
    if p.grow_steps > 0 and keep.any():
        # the growth starts from the cells the published test keeps: the allowances'
        # own cells may be the edge of a roof met at the level of the slope
        keep |= _recovered(zmin, keep, keep & ~published, is_object & ~(empty | low), p)
    surface_of_keep = None  # the inpainted surface of ``keep`` while it is that one
    if p.low_cluster_window_m > 0 and keep.any():
        # pits in the terrain with the objects taken out (between buildings the minimum
        # surface has pits too: streets)
        radius = max(1, int(np.ceil(p.low_cluster_window_m / p.cell_m)))
        terrain = inpaint(np.where(keep, zmin, np.nan))

        def pits(window):
            return low_clusters(terrain[window], max_radius=radius, drop_m=p.low_cluster_drop_m)

        if keep.mean() < _BLOCKWISE_MAX_SHARE:
            found = _boxwise(pits, keep, 2 * radius + 2, np.zeros(keep.shape, dtype=bool))
        else:
            found = pits((slice(None), slice(None)))
        found &= keep
        if found.any():
            keep &= ~found
            surface_of_keep = inpaint_update(terrain, ~keep, found)  # refilled at the pits
        else:
            surface_of_keep = terrain  # no pit: the provisional DTM is this surface
    if not keep.any():
        # every cell is an object: no ground surface can be formed
        return np.zeros(xyz.shape[0], dtype=bool), DTM(zfilled, grid, keep)
    if surface_of_keep is None:
        surface_of_keep = inpaint(np.where(keep, zmin, np.nan))
    provisional = DTM(surface_of_keep, grid, keep)
    # heights relative to the lowest kept cell: float32 samplers stay at µm resolution
    zref = float(zmin[keep].min())
    residual = sampler(provisional.z_m - zref)
    np.subtract(_relative_heights(z, zref, sampler.dtype), residual, out=residual)
    np.abs(residual, out=residual)
    tolerance = sampler(provisional.slope())
    tolerance *= p.scalar
    tolerance += p.threshold_m
    return residual <= tolerance, provisional
