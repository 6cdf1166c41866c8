"""Step 1: GIS-aided segmentation and annotation of a heritage complex.

Thesis chapter 5 (MATLAB ``shapeseg``): the complex's point cloud is split into
one object per GIS feature.  For every layer (one layer = one class) and every
polygon, the points inside the polygon buffered by ``buffer_m`` (a 2.5D
cookie-cutter: XY only) are clustered by Euclidean distance; the clusters
that belong to the feature are kept, the others go back to the pool for the
following polygons and layers.  Ground is extracted first and labelled, never
deleted.  Layers are processed lowest objects first, which the thesis found
necessary for walls under roofs and roofs under tree crowns.

Beyond the thesis:

* polygons that touch or whose buffers overlap (row houses sharing walls)
  never claim the same point: a point in several buffered polygons goes to the
  polygon that contains it, or else to the nearest one;
* the candidate search uses a grid index of the cloud instead of a
  point-in-polygon test of the whole cloud for each polygon;
* parameters default to multiples of the measured point spacing.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import geopandas as gpd
import numpy as np
import pandas as pd
import shapely
from numpy.typing import NDArray

from pyheracles.cloud import PointCloud
from pyheracles.errors import InputError
from pyheracles.geometry.neighbours import point_spacing
from pyheracles.groundfilters.footprints import FootprintGroundParams, raised_in_footprints
from pyheracles.io.vector import align_crs, validate_polygons
from pyheracles.labels import Segmentation, merge_rows
from pyheracles.progress import track
from pyheracles.segment.euclidean import euclidean_clusters, voxel_clusters

__all__ = [
    "GROUND_METHODS",
    "ComplexParams",
    "ComplexResult",
    "prepare_layers",
    "resolve_params",
    "segment_complex",
]

#: Ground options of step 1 (``class`` keeps an existing ASPRS classification).
GROUND_METHODS = ("auto", "csf", "smrf", "none", "class")
_CLUSTERING = ("auto", "exact", "voxel")
#: Above this many candidate points, ``clustering="auto"`` uses voxels.
_EXACT_LIMIT = 20_000
#: Points used at most for a polygon's ground level or height percentile.
_LEVEL_SAMPLE = 20_000


@dataclass(frozen=True)
class ComplexParams:
    """Parameters of the GIS-aided segmentation (step 1).

    ``None`` means automatic, derived from the median point spacing ``s``
    (the thesis set these by hand for each data set; a multiple of the
    spacing travels between a drone survey and aerial LiDAR).

    Attributes
    ----------
    buffer_m
        Buffer around each polygon for the 2.5D cookie-cutter, metres.  It
        absorbs digitising errors and catches facade points outside the
        footprint.  Automatic: ``max(1.0, 3 s)``.
    cluster_distance_m
        Largest gap inside one object for the Euclidean clustering, metres.
        Automatic: ``max(0.3, 3 s)``.
    min_cluster_points
        Clusters with fewer points are noise and go back to the pool.
        Automatic: the number of points on about 1 m^2, at least 10.
    keep_fraction
        A cluster other than the main one is kept when at least this fraction
        of its points lies inside the (unbuffered) polygon.
    scatter_max
        Surface variation (smallest eigenvalue / sum, k = 12 neighbours) above
        which a point counts as scattered, like foliage.  Objects are grown
        from the other points only; scattered points join an object only when
        they lie near its footprint and below its top and are linked to it
        (roof edges, thin walls), so a tree crown touching a roof does not
        become part of it.  ``None``
        turns this off (the thesis's plain clustering).  Roofs and walls have
        a median near 0.007, foliage near 0.11 (measured on AHN3 tile 1).
    multi_echo_scatter_max
        Lower surface-variation threshold for points of multi-echo pulses
        (LAS ``number_of_returns > 1``; used only when the cloud has it):
        the laser went partly through, as in foliage.  ``None`` ignores echoes.
    attach_distance_m
        Scattered points are linked to an object by steps of up to twice
        this distance, and may rise this much above its top.  Automatic: the
        clustering distance.
    scatter_offset_m
        Scattered points join an object only within this XY distance of its
        polygon (inside counts as 0): roof edges and eaves, not the hedge or
        the crown beside a shed.  Automatic: a quarter of the buffer.  On
        AHN3 tile 1 (buffer 1 m) any value from 0.15 to 0.3 m gives the same
        quality; half the buffer let hedges beside small sheds in.
    ground
        One of ``auto``, ``csf``, ``smrf`` (see :mod:`pyheracles.ground`),
        ``class`` (keep ASPRS class 2 of the input) or ``none``.
    raised_ground_m
        Ground points within a polygon's buffer that stand more than this
        above the terrain around the polygon (the ground beyond every buffer,
        its holes filled with a membrane) are its platform, plinth,
        steps or the top of a low wall, not terrain: they go back to the pool
        (see :func:`pyheracles.groundfilters.footprints.raised_in_footprints`).
        Metres; ``None`` keeps the ground filter's answer.  A classification
        given with the input (``ground="class"``) is kept as it is.
    layer_order
        Names of the layers in processing order; ``None`` orders them
        automatically, lowest objects first (thesis section 5.2).
    clustering
        ``exact`` (KD-tree single linkage), ``voxel`` (touching voxels of
        ``cluster_distance_m / 2``) or ``auto`` (exact below 50 000
        candidate points).
    seed
        Seed for the random sample used to measure the spacing.
    """

    buffer_m: float | None = None
    cluster_distance_m: float | None = None
    min_cluster_points: int | None = None
    keep_fraction: float = 0.25
    scatter_max: float | None = 0.1
    multi_echo_scatter_max: float | None = 0.02
    attach_distance_m: float | None = None
    scatter_offset_m: float | None = None
    ground: str = "auto"
    raised_ground_m: float | None = 0.2
    layer_order: tuple[str, ...] | None = None
    clustering: str = "auto"
    seed: int = 0

    def __post_init__(self) -> None:
        if self.ground not in GROUND_METHODS:
            raise InputError(
                f"unknown ground method {self.ground!r}; choose one of {', '.join(GROUND_METHODS)}"
            )
        if self.clustering not in _CLUSTERING:
            raise InputError(
                f"unknown clustering {self.clustering!r}; choose one of {', '.join(_CLUSTERING)}"
            )
        for name in ("buffer_m", "cluster_distance_m", "attach_distance_m", "raised_ground_m"):
            value = getattr(self, name)
            if value is not None and not value > 0:
                raise InputError(f"{name} must be > 0, got {value}")
        if self.scatter_offset_m is not None and not self.scatter_offset_m >= 0:
            raise InputError(f"scatter_offset_m must be >= 0, got {self.scatter_offset_m}")
        if self.min_cluster_points is not None and self.min_cluster_points < 1:
            raise InputError(f"min_cluster_points must be >= 1, got {self.min_cluster_points}")
        if not 0.0 <= self.keep_fraction <= 1.0:
            raise InputError(f"keep_fraction must be in [0, 1], got {self.keep_fraction}")


def resolve_params(params: ComplexParams, spacing_m: float) -> ComplexParams:
    """Fill every automatic parameter from the point spacing (metres)."""
    s = float(spacing_m)
    return replace(
        params,
        buffer_m=params.buffer_m if params.buffer_m is not None else max(1.0, 3.0 * s),
        cluster_distance_m=(
            params.cluster_distance_m
            if params.cluster_distance_m is not None
            else max(0.3, 3.0 * s)
        ),
        attach_distance_m=(
            params.attach_distance_m if params.attach_distance_m is not None else max(0.3, 3.0 * s)
        ),
        scatter_offset_m=(
            params.scatter_offset_m
            if params.scatter_offset_m is not None
            else 0.25 * (params.buffer_m if params.buffer_m is not None else max(1.0, 3.0 * s))
        ),
        min_cluster_points=(
            params.min_cluster_points
            if params.min_cluster_points is not None
            else max(10, round(0.25 / max(s, 1e-3) ** 2))
        ),
    )


@dataclass(frozen=True, eq=False)
class ComplexResult:
    """Result of :func:`segment_complex`.

    Attributes
    ----------
    segmentation
        Per-point labels (``instance``, ``class_id``, ``ground``) and the
        objects table (a GeoDataFrame: one row per object with its feature's
        attributes and geometry).
    params
        The parameters actually used (automatic values filled in).
    spacing_m
        Measured median point spacing.
    layer_order
        Layers in the order they were processed.
    timings
        Seconds per stage.
    """

    segmentation: Segmentation
    params: ComplexParams
    spacing_m: float
    layer_order: tuple[str, ...]
    timings: dict[str, float] = field(default_factory=dict)


# ----------------------------------------------------------------------------- layers
def prepare_layers(
    layers: Mapping[str, gpd.GeoDataFrame],
    cloud: PointCloud,
    *,
    reproject: bool = False,
    fix_invalid: bool = False,
) -> dict[str, gpd.GeoDataFrame]:
    """Validate each layer, bring it into the cloud's CRS and check it overlaps the cloud.

    Raises
    ------
    InputError
        No layers, invalid polygons, CRS mismatch, or a layer entirely outside
        the cloud (the usual sign of a wrong CRS).
    """
    if not layers:
        raise InputError("no GIS layer given", hint="add at least one --layer NAME=PATH")
    cloud.validate(what="complex point cloud")
    lo, hi = cloud.bounds()[:, :2]
    cloud_box = shapely.box(lo[0], lo[1], hi[0], hi[1])
    out: dict[str, gpd.GeoDataFrame] = {}
    for name, gdf in layers.items():
        src = gdf.attrs.get("source")
        checked = validate_polygons(gdf, fix_invalid=fix_invalid, source=src)
        checked = align_crs(checked, cloud.crs, reproject=reproject, cloud_source=cloud.source)
        if "source_fid" not in checked.columns:
            checked = checked.assign(source_fid=np.arange(len(checked), dtype=np.int64))
        if not shapely.intersects(checked.geometry.to_numpy(), cloud_box).any():
            b = checked.total_bounds
            raise InputError(
                f"layer {name!r}: no polygon overlaps the cloud (layer extent "
                f"{b[0]:.1f},{b[1]:.1f} - {b[2]:.1f},{b[3]:.1f}; cloud extent "
                f"{lo[0]:.1f},{lo[1]:.1f} - {hi[0]:.1f},{hi[1]:.1f})",
                path=src,
                hint="check that the layer and the cloud are in the same CRS and area",
            )
        checked.attrs.update(gdf.attrs)
        out[name] = checked
    return out


# ----------------------------------------------------------------------------- grid index
class _GridIndex:
    """Points of the pool binned on a regular XY grid, sorted by cell.

    A polygon's candidates are the points of the cells its bounding box
    covers: one ``searchsorted`` per grid column instead of a point-in-polygon
    test of the whole cloud.
    """

    def __init__(self, xy: NDArray[np.float64], cell_m: float) -> None:
        self.cell = float(cell_m)
        self.origin = xy.min(axis=0) if len(xy) else np.zeros(2)
        ij = np.floor((xy - self.origin) / self.cell).astype(np.int64)
        self.ny = int(ij[:, 1].max()) + 1 if len(xy) else 1
        self.nx = int(ij[:, 0].max()) + 1 if len(xy) else 1
        keys = ij[:, 0] * self.ny + ij[:, 1]
        # Few cells: a 16-bit key lets numpy use its linear-time radix sort.
        small = self.nx * self.ny < np.iinfo(np.int16).max
        self.order = np.argsort(keys.astype(np.int16), kind="stable") if small else np.argsort(keys)
        self.keys = keys[self.order]

    def query_box(self, xmin: float, ymin: float, xmax: float, ymax: float) -> NDArray[np.int64]:
        """Indices (into the indexed array) of the points in cells meeting the box."""
        i0, j0 = np.floor((np.array([xmin, ymin]) - self.origin) / self.cell).astype(int)
        i1, j1 = np.floor((np.array([xmax, ymax]) - self.origin) / self.cell).astype(int)
        i0, i1 = max(i0, 0), min(i1, self.nx - 1)
        j0, j1 = max(j0, 0), min(j1, self.ny - 1)
        if i0 > i1 or j0 > j1:
            return np.zeros(0, dtype=np.int64)
        cols = np.arange(i0, i1 + 1, dtype=np.int64) * self.ny
        starts = np.searchsorted(self.keys, cols + j0, side="left")
        ends = np.searchsorted(self.keys, cols + j1, side="right")
        if not (ends > starts).any():
            return np.zeros(0, dtype=np.int64)
        return self.order[
            np.concatenate([np.arange(s, e) for s, e in zip(starts, ends, strict=True)])
        ]


def _claims(
    geoms: NDArray[Any],
    buffer_m: float,
    xy: NDArray[np.float64],  # (N, 3): XY for the tests, Z for party-wall ties
    index: _GridIndex,
    pool: NDArray[np.bool_],
    inside_any: NDArray[np.bool_],
    footprints: Sequence[NDArray[np.int64]],
    link_m: float,
) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.float64]]:
    """Which pool point goes to which polygon of one layer.

    Returns point indices, polygon positions and the XY distance to the
    unbuffered polygon (0 inside).  A point claimed by several buffered polygons
    goes to the one containing it, else to the nearest.  The buffer ring of a
    polygon never takes a point that lies inside another polygon of any
    layer (a wall's buffer must not eat the roof of the house beside it).
    A point on the shared edge of two polygons (a party wall) goes to the
    building whose roof is the lowest one above it: the upper part of a
    taller neighbour's facade is that neighbour's.  ``footprints`` holds the
    points inside each polygon (see :func:`_footprints`), so only points
    outside every polygon are tested against the buffered one.  A point inside
    several overlapping polygons goes by continuity (see
    :func:`_overlaps_by_continuity`; ``link_m`` is the clustering distance).
    """
    pts_all, poly_all, dist_all = [], [], []
    roof_z = np.full(len(geoms), np.inf)
    buffered = shapely.buffer(geoms, buffer_m)
    shapely.prepare(buffered)
    mark = np.zeros(len(pool), dtype=bool)
    for k in track(range(len(geoms)), "cookie-cutter", total=len(geoms)):
        cand = index.query_box(*shapely.bounds(buffered[k]))
        cand = cand[pool[cand]]
        if len(cand) == 0:
            continue
        mark[footprints[k]] = True
        inside = mark[cand]
        mark[footprints[k]] = False
        ring = cand[~inside & ~inside_any[cand]]
        ring = ring[shapely.contains_xy(buffered[k], xy[ring, 0], xy[ring, 1])]
        inside_pts = cand[inside]
        if len(inside_pts) + len(ring) == 0:
            continue
        if len(inside_pts):
            roof_z[k] = float(np.percentile(xy[inside_pts, 2], 95))
        cand = np.concatenate([inside_pts, ring])
        dist = np.zeros(len(cand))
        if len(ring):
            dist[len(inside_pts) :] = shapely.distance(
                geoms[k], shapely.points(xy[ring, 0], xy[ring, 1])
            )
        pts_all.append(cand)
        poly_all.append(np.full(len(cand), k, dtype=np.int64))
        dist_all.append(dist)
    if not pts_all:
        empty = np.zeros(0, dtype=np.int64)
        return empty, empty, np.zeros(0)
    pts = np.concatenate(pts_all)
    poly = np.concatenate(poly_all)
    dist = np.concatenate(dist_all)
    pts, poly, dist = _overlaps_by_continuity(pts, poly, dist, xy, len(pool), link_m)
    # Only points claimed by several polygons need a decision: sort just those.
    claims = np.bincount(pts, minlength=len(pool))
    shared = claims[pts] > 1
    if not shared.any():
        return pts, poly, dist
    sp, sq, sd = pts[shared], poly[shared], dist[shared]
    # tie-break for points at the same distance (on a shared edge): the gap
    # between the point and the polygon's roof, negative gaps (above the roof) last
    gap = roof_z[sq] - xy[sp, 2]
    gap = np.where(gap >= -0.1, gap, 1e9 - gap)
    order = np.lexsort((sq, gap, sd, sp))  # by point, distance, roof gap, polygon
    sp, sq, sd = sp[order], sq[order], sd[order]
    first = np.ones(len(sp), dtype=bool)
    first[1:] = sp[1:] != sp[:-1]
    keep = ~shared
    return (
        np.concatenate([pts[keep], sp[first]]),
        np.concatenate([poly[keep], sq[first]]),
        np.concatenate([dist[keep], sd[first]]),
    )


def _overlaps_by_continuity(
    pts: NDArray[np.int64],
    poly: NDArray[np.int64],
    dist: NDArray[np.float64],
    xyz: NDArray[np.float64],
    n: int,
    link_m: float,
) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.float64]]:
    """Claims of the points inside several polygons (crudely digitised overlaps), resolved.

    Such a point goes to the polygon whose own points (those inside it alone)
    it is nearest to along chains of points no longer than ``link_m`` per step
    (multi-source Dijkstra over the contested points and the seeds beside
    them): the roof over an overlap continues the building it belongs to.  A
    point no chain reaches keeps all its claims (the caller's tie-break).
    """
    inside = dist == 0.0
    n_in = np.bincount(pts[inside], minlength=n)
    contested_row = inside & (n_in[pts] > 1)
    seed_row = inside & (n_in[pts] == 1)
    if not contested_row.any() or not seed_row.any():
        return pts, poly, dist
    from scipy.sparse.csgraph import dijkstra
    from scipy.spatial import cKDTree

    contested = np.unique(pts[contested_row])
    seeds, seed_poly = pts[seed_row], poly[seed_row]
    near, _ = cKDTree(xyz[contested]).query(xyz[seeds], k=1, distance_upper_bound=link_m)
    front = np.isfinite(near)
    if not front.any():
        return pts, poly, dist
    nodes = np.concatenate([seeds[front], contested])
    tree = cKDTree(xyz[nodes])
    graph = tree.sparse_distance_matrix(tree, link_m, output_type="coo_matrix").tocsr()
    _, _, sources = dijkstra(
        graph, directed=False, indices=np.arange(int(front.sum())), min_only=True,
        return_predecessors=True,
    )  # fmt: skip
    src = sources[int(front.sum()) :]
    chosen = np.full(n, -1, dtype=np.int64)
    chosen[contested] = np.where(src >= 0, seed_poly[front][np.maximum(src, 0)], -1)
    # keep a contested point's claim by the chosen polygon only (if that one contains it)
    has_choice = np.zeros(n, dtype=bool)
    has_choice[pts[contested_row & (poly == chosen[pts])]] = True
    drop = has_choice[pts] & (poly != chosen[pts])
    return pts[~drop], poly[~drop], dist[~drop]


def _footprints(
    layers: Mapping[str, gpd.GeoDataFrame],
    xyz: NDArray[np.float64],
    index: _GridIndex,
    offset: NDArray[np.float64],
) -> dict[str, list[NDArray[np.int64]]]:
    """Indices of the points inside each (unbuffered) polygon, per layer.

    One point-in-polygon test per polygon, shared by the layer order, the
    inside-any mask and the cookie-cutter.
    """
    out: dict[str, list[NDArray[np.int64]]] = {}
    for name, gdf in layers.items():
        geoms = _to_local(gdf.geometry.to_numpy(), offset)
        shapely.prepare(geoms)
        per_poly = []
        for geom in geoms:
            cand = index.query_box(*shapely.bounds(geom))
            per_poly.append(cand[shapely.contains_xy(geom, xyz[cand, 0], xyz[cand, 1])])
        out[name] = per_poly
    return out


def _cluster(xyz: NDArray[np.float64], params: ComplexParams) -> NDArray[np.int32]:
    d = float(params.cluster_distance_m)  # type: ignore[arg-type]
    use_voxel = params.clustering == "voxel" or (
        params.clustering == "auto" and len(xyz) > _EXACT_LIMIT
    )
    if use_voxel:
        return voxel_clusters(xyz, d / 2.0, 1)
    return euclidean_clusters(xyz, d, 1)


def _scattered(
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


def _object_points(
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
    labels = _cluster(xyz[cand[core]], params)
    near_poly = cand_dist <= 0.5 * float(params.buffer_m)  # type: ignore[arg-type]
    keep[core] = _select_clusters(labels, cand_in[core], near_poly[core], params)
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
    sub = _cluster(xyz[cand[eligible]], link)
    touching = np.bincount(sub, weights=np.isfinite(dist).astype(np.float64)) > 0
    keep[eligible[touching[sub]]] = True
    return keep


def _select_clusters(
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


def _hull(xy: NDArray[np.float64]) -> Any:
    """2D convex hull polygon (qhull picks the vertices, shapely builds the polygon)."""
    from scipy.spatial import ConvexHull, QhullError

    try:
        return shapely.Polygon(xy[ConvexHull(xy).vertices])
    except (QhullError, ValueError):  # collinear or too few points
        return shapely.convex_hull(shapely.multipoints(xy))


def _to_local(geoms: NDArray[Any], offset: NDArray[np.float64]) -> NDArray[Any]:
    """Polygons moved from world coordinates into the cloud's local frame."""
    shift = np.asarray(offset[:2], dtype=np.float64)
    return shapely.transform(geoms, lambda c: c - shift)


# ----------------------------------------------------------------------------- ground
def _ground_mask(
    cloud: PointCloud, params: ComplexParams, max_object_size_m: float
) -> NDArray[np.bool_]:
    if params.ground == "none":
        return np.zeros(len(cloud), dtype=bool)
    if params.ground == "class":
        if "classification" not in cloud.attributes:
            raise InputError(
                "ground='class' needs an ASPRS classification in the cloud, and it has none",
                path=cloud.source,
                hint="use --ground auto (or csf / smrf) to extract the ground",
            )
        return np.asarray(cloud.attributes["classification"]) == 2
    from pyheracles.ground import extract_ground

    result = extract_ground(
        cloud.xyz, method=params.ground, max_object_size_m=max_object_size_m, rng=params.seed,
        origin_m=cloud.offset[:2],
    )
    return np.asarray(result.mask, dtype=bool)


def raised_ground_points(
    layers: Mapping[str, gpd.GeoDataFrame],
    cloud: PointCloud,
    ground: NDArray[np.bool_],
    params: ComplexParams,
    spacing_m: float,
) -> NDArray[np.bool_]:
    """The ground points :func:`segment_complex` takes off the ground (platforms, plinths,
    steps, low walls inside the buffered polygons), for callers that computed the ground
    themselves (:mod:`pyheracles.tiles`); ``params`` resolved, layers in world coordinates."""
    return _raised_ground(layers, cloud.xyz, ground, params, spacing_m, cloud)


def _raised_ground(
    layers: Mapping[str, gpd.GeoDataFrame],
    xyz: NDArray[np.float64],
    ground: NDArray[np.bool_],
    params: ComplexParams,
    spacing_m: float,
    cloud: PointCloud,
) -> NDArray[np.bool_]:
    """Ground points on platforms, plinths, steps and low walls inside the buffered polygons."""
    geoms = [_to_local(g.geometry.to_numpy(), cloud.offset) for g in layers.values() if len(g)]
    if not geoms:
        return np.zeros(len(xyz), dtype=bool)
    fp = FootprintGroundParams(
        # the digitising tolerance, not the whole buffer: at low density the buffer
        # (3 spacings) reaches terrace edges and crests the membrane cuts through
        # (complex family seeds 0-29: 1 m gave 9 draws meeting every target, 0.5 m 10)
        buffer_m=min(float(params.buffer_m), 0.5),  # type: ignore[arg-type]
        cell_m=max(0.5, spacing_m),
        min_height_m=float(params.raised_ground_m),  # type: ignore[arg-type]
    )
    return raised_in_footprints(xyz, ground, np.concatenate(geoms), fp)


def _ground_level(
    geoms: NDArray[Any],
    xyz: NDArray[np.float64],
    ground: NDArray[np.bool_],
    index: _GridIndex,
    radius_m: float,
) -> NDArray[np.float64]:
    """Median ground height around each polygon (NaN where no ground is near)."""
    levels = np.full(len(geoms), np.nan)
    for k, geom in enumerate(geoms):
        b = shapely.bounds(geom)
        cand = index.query_box(b[0] - radius_m, b[1] - radius_m, b[2] + radius_m,
                               b[3] + radius_m)  # fmt: skip
        cand = cand[ground[cand]]
        if len(cand):
            step = max(1, len(cand) // _LEVEL_SAMPLE)  # a median needs no million points
            levels[k] = float(np.median(xyz[cand[::step], 2]))
    return levels


def _auto_layer_order(
    layers: Mapping[str, gpd.GeoDataFrame],
    footprints: Mapping[str, Sequence[NDArray[np.int64]]],
    xyz: NDArray[np.float64],
    pool: NDArray[np.bool_],
    ground: NDArray[np.bool_],
    index: _GridIndex,
    offset: NDArray[np.float64],
) -> tuple[str, ...]:
    """Lowest objects first: median over polygons of (90th percentile of z inside - ground)."""
    heights: dict[str, float] = {}
    for name, gdf in layers.items():
        geoms = _to_local(gdf.geometry.to_numpy(), offset)
        levels = _ground_level(geoms, xyz, ground, index, 5.0)
        per_poly = []
        for k, inside in enumerate(footprints[name]):
            cand = inside[pool[inside]]
            cand = cand[:: max(1, len(cand) // _LEVEL_SAMPLE)]
            if len(cand) < 3:
                continue
            z90 = float(np.percentile(xyz[cand, 2], 90))
            base = levels[k] if np.isfinite(levels[k]) else float(xyz[cand, 2].min())
            per_poly.append(z90 - base)
        heights[name] = float(np.median(per_poly)) if per_poly else np.inf
    return tuple(sorted(layers, key=lambda n: (heights[n], n)))


@dataclass(eq=False)
class _Site:
    """The state one run shares across layers: points, indexes, pool and labels."""

    xyz: NDArray[np.float64]
    offset: NDArray[np.float64]
    index: _GridIndex
    ground: NDArray[np.bool_]
    pool: NDArray[np.bool_]
    inside_any: NDArray[np.bool_]
    footprints: dict[str, list[NDArray[np.int64]]]
    multi_echo: NDArray[np.bool_] | None
    instance: NDArray[np.int32]
    class_id: NDArray[np.uint8]


def _segment_layer(
    site: _Site,
    name: str,
    code: int,
    gdf: gpd.GeoDataFrame,
    rp: ComplexParams,
    rows: list[dict[str, Any]],
    geometries: list[Any],
) -> list[Any]:
    """One object per polygon of a layer; labels the site, appends table rows.

    Returns the ``source_fid`` of the features that got no object.
    """
    xyz = site.xyz
    buffer = float(rp.buffer_m)  # type: ignore[arg-type]
    geoms = _to_local(gdf.geometry.to_numpy(), site.offset)
    pts, poly, offpoly = _claims(
        geoms, buffer, xyz, site.index, site.pool, site.inside_any, site.footprints[name],
        float(rp.cluster_distance_m),  # type: ignore[arg-type]
    )  # fmt: skip
    by_poly = np.argsort(poly.astype(np.int32), kind="stable")
    pts, poly, offpoly = pts[by_poly], poly[by_poly], offpoly[by_poly]
    bounds = np.searchsorted(poly, np.arange(len(geoms) + 1))
    levels = _ground_level(geoms, xyz, site.ground, site.index, buffer + 5.0)
    scattered = _scattered(xyz, pts, rp, site.multi_echo)
    empty: list[Any] = []
    for k in range(len(geoms)):
        sl = slice(bounds[k], bounds[k + 1])
        cand, cand_dist = pts[sl], offpoly[sl]
        keep = _object_points(xyz, cand, cand_dist, scattered[sl], rp)
        if keep.sum() < int(rp.min_cluster_points):  # type: ignore[arg-type]
            empty.append(gdf["source_fid"].iloc[k])
            continue
        members = cand[keep]
        next_id = len(rows) + 1
        site.instance[members] = next_id
        site.class_id[members] = code
        site.pool[members] = False
        z = xyz[members, 2]
        base = levels[k] if np.isfinite(levels[k]) else float(z.min())
        attrs = gdf.iloc[k].drop(labels=[gdf.geometry.name]).to_dict()
        rows.append(
            {
                "instance": next_id,
                "class": name,
                "class_id": code,
                "n_points": len(members),
                "n_inside": int((cand_dist[keep] == 0.0).sum()),
                "z_min": float(z.min() + site.offset[2]),
                "z_max": float(z.max() + site.offset[2]),
                "ground_z": float(base + site.offset[2]),
                "height": float(z.max() - base),
                "footprint_area_m2": float(shapely.area(_hull(xyz[members, :2]))),
                "gis_area_m2": float(shapely.area(geoms[k])),
                **{(f"attr_{a}" if a in _RESERVED else a): v for a, v in attrs.items()},
            }
        )
        geometries.append(gdf.geometry.iloc[k])
    return empty


# ----------------------------------------------------------------------------- main
def segment_complex(
    cloud: PointCloud,
    layers: Mapping[str, gpd.GeoDataFrame],
    params: ComplexParams | None = None,
) -> ComplexResult:
    """Split a complex's cloud into one object per GIS feature, plus ground and remainder.

    Parameters
    ----------
    cloud
        The whole complex (aerial LiDAR, drone photogrammetry, TLS), any CRS.
    layers
        Layer name (= class of its objects) -> polygons with attributes, already
        in the cloud's CRS (see :func:`prepare_layers`).
    params
        Parameters; automatic values are derived from the point spacing.

    Returns
    -------
    ComplexResult
        Labels aligned with ``cloud`` and the objects table.  Class codes
        follow the processing order: the first layer processed is class 1.

    Raises
    ------
    InputError
        Empty cloud, NaN coordinates, unknown layer in ``layer_order``.

    References
    ----------
    Murtiyoso, A. (2020). Geospatial recording and point cloud classification
    of heritage buildings. PhD thesis, INSA Strasbourg, chapter 5.

    Examples
    --------
    >>> from pyheracles.synthetic.complex_scene import kasepuhan_scene, ComplexSceneParams
    >>> scene = kasepuhan_scene(ComplexSceneParams(n_points=60_000))
    >>> res = segment_complex(scene.cloud, scene.layers, ComplexParams(ground="none"))
    >>> res.segmentation.check_balance()["total"] == len(scene.cloud)
    True
    """
    p = params or ComplexParams()
    cloud.validate(what="complex point cloud")
    if len(cloud) < 10:
        raise InputError(
            f"the cloud has only {len(cloud)} points", path=cloud.source,
            hint="step 1 needs a survey of the whole complex",
        )  # fmt: skip
    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    xyz = cloud.xyz
    n = len(xyz)
    spacing = point_spacing(xyz, rng=p.seed)
    rp = resolve_params(p, spacing)
    timings["spacing"] = time.perf_counter() - t0

    t = time.perf_counter()
    sizes = [
        float(np.sqrt(shapely.area(g.geometry.to_numpy())).max()) for g in layers.values() if len(g)
    ]
    ground = _ground_mask(cloud, rp, max(sizes) if sizes else 20.0)
    if rp.raised_ground_m is not None and rp.ground != "class" and ground.any():
        # platforms, plinths, steps and low walls are the features', not terrain
        ground = ground & ~_raised_ground(layers, xyz, ground, rp, spacing, cloud)
    timings["ground"] = time.perf_counter() - t

    t = time.perf_counter()
    pool = ~ground
    index = _GridIndex(xyz[:, :2], max(4.0 * float(rp.buffer_m), 5.0))  # type: ignore[arg-type]
    footprints = _footprints(layers, xyz, index, cloud.offset)
    inside_any = np.zeros(n, dtype=bool)
    for per_poly in footprints.values():
        for inside in per_poly:
            inside_any[inside] = True
    if rp.layer_order is None:
        order = _auto_layer_order(layers, footprints, xyz, pool, ground, index, cloud.offset)
    else:
        if sorted(rp.layer_order) != sorted(layers):
            raise InputError(
                f"layer_order {list(rp.layer_order)} must name each layer once; "
                f"layers are {sorted(layers)}"
            )
        order = tuple(rp.layer_order)
    timings["layer_order"] = time.perf_counter() - t

    t = time.perf_counter()
    site = _Site(
        xyz=xyz,
        offset=cloud.offset,
        index=index,
        ground=ground,
        pool=pool,
        inside_any=inside_any,
        footprints=footprints,
        multi_echo=(
            np.asarray(cloud.attributes["number_of_returns"]) > 1
            if "number_of_returns" in cloud.attributes
            else None
        ),
        instance=np.zeros(n, dtype=np.int32),
        class_id=np.zeros(n, dtype=np.uint8),
    )
    classes: dict[int, str] = {}
    rows: list[dict[str, Any]] = []
    geometries: list[Any] = []
    warnings: list[str] = []
    for code, name in enumerate(order, start=1):
        classes[code] = name
        empty = _segment_layer(site, name, code, layers[name], rp, rows, geometries)
        if empty:
            warnings.append(
                f"layer {name!r}: {len(empty)} of {len(layers[name])} features got no points "
                f"(source_fid {', '.join(map(str, empty[:20]))}{' ...' if len(empty) > 20 else ''})"
            )
    timings["segmentation"] = time.perf_counter() - t

    objects = _objects_frame(rows, geometries, layers, order, cloud)
    seg = Segmentation(
        instance=site.instance, class_id=site.class_id, classes=classes, objects=objects,
        ground=ground, warnings=tuple(warnings),
    )  # fmt: skip
    seg.check_balance()
    return ComplexResult(seg, rp, spacing, order, timings)


_RESERVED = {
    "instance", "class", "class_id", "n_points", "n_inside", "z_min", "z_max", "ground_z",
    "height", "footprint_area_m2", "gis_area_m2",
}  # fmt: skip


def _objects_frame(
    rows: Sequence[dict[str, Any]],
    geometries: Sequence[Any],
    layers: Mapping[str, gpd.GeoDataFrame],
    order: Sequence[str],
    cloud: PointCloud,
) -> gpd.GeoDataFrame:
    crs = next((g.crs for g in layers.values() if g.crs is not None), None) or cloud.crs
    if not rows:
        return gpd.GeoDataFrame(
            {"instance": pd.Series(dtype=np.int32), "class": pd.Series(dtype=str),
             "n_points": pd.Series(dtype=np.int64)},
            geometry=gpd.GeoSeries([], crs=crs),
        )  # fmt: skip
    # attribute types of the layers kept (an integer id stays integer where other
    # layers lack it, instead of NaN-padded float)
    rename = lambda a: f"attr_{a}" if a in _RESERVED else a  # noqa: E731
    frame = merge_rows(rows, [layers[name] for name in order], rename=rename)
    frame["instance"] = frame["instance"].astype(np.int32)
    frame["n_points"] = frame["n_points"].astype(np.int64)
    return gpd.GeoDataFrame(frame, geometry=gpd.GeoSeries(list(geometries), crs=crs))
