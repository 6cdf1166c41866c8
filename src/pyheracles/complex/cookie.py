"""The cookie-cutter of step 1: which points each (buffered) polygon claims.

A grid index of the pool replaces a point-in-polygon test of the whole cloud per polygon;
a point claimed by several polygons goes to one of them (containment, distance, roof gap,
continuity across crudely digitised overlaps).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import geopandas as gpd
import numpy as np
import shapely
from numpy.typing import NDArray

from pyheracles.complex.surfaces import face_choice
from pyheracles.progress import track

__all__ = [
    "GridIndex",
    "claims",
    "footprints_of",
    "nearest_layer",
    "overlaps_by_continuity",
    "to_local",
]


class GridIndex:
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


def claims(
    geoms: NDArray[Any],
    buffer_m: float,
    xy: NDArray[np.float64],  # (N, 3): XY for the tests, Z for party-wall ties
    index: GridIndex,
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
    points inside each polygon (see :func:`footprints_of`), so only points
    outside every polygon are tested against the buffered one.  A point inside
    several overlapping polygons goes by continuity (see
    :func:`overlaps_by_continuity`; ``link_m`` is the clustering distance).
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
    pts, poly, dist = overlaps_by_continuity(pts, poly, dist, xy, len(pool), link_m)
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


def overlaps_by_continuity(
    pts: NDArray[np.int64],
    poly: NDArray[np.int64],
    dist: NDArray[np.float64],
    xyz: NDArray[np.float64],
    n: int,
    link_m: float,
) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.float64]]:
    """Claims of the points inside several polygons (crudely digitised overlaps), resolved.

    Such a point goes to the polygon whose roof face it lies on, where one clearly
    carries it (see :func:`pyheracles.complex.surfaces.face_choice`: neighbouring roofs
    slope down to the strip of their overlap from either side); else to the polygon
    whose own points (those inside it alone) it is nearest to along chains of points
    no longer than ``link_m`` per step (multi-source Dijkstra over the contested
    points and the seeds beside them): the roof over an overlap continues the
    building it belongs to.  A point neither decides keeps all its claims (the
    caller's tie-break).
    """
    inside = dist == 0.0
    n_in = np.bincount(pts[inside], minlength=n)
    contested_row = inside & (n_in[pts] > 1)
    seed_row = inside & (n_in[pts] == 1)
    if not contested_row.any() or not seed_row.any():
        return pts, poly, dist
    seeds, seed_poly = pts[seed_row], poly[seed_row]
    chosen = np.full(n, -1, dtype=np.int64)
    contested = np.unique(pts[contested_row])
    chosen[contested] = _chains(contested, seeds, seed_poly, xyz, link_m)
    on_face, face = face_choice(
        xyz, pts[contested_row], poly[contested_row], seeds, seed_poly, link_m
    )
    chosen[on_face[face >= 0]] = face[face >= 0]
    # keep a contested point's claim by the chosen polygon only (if that one contains it)
    has_choice = np.zeros(n, dtype=bool)
    has_choice[pts[contested_row & (poly == chosen[pts])]] = True
    drop = has_choice[pts] & (poly != chosen[pts])
    return pts[~drop], poly[~drop], dist[~drop]


def _chains(
    contested: NDArray[np.int64],
    seeds: NDArray[np.int64],
    seed_poly: NDArray[np.int64],
    xyz: NDArray[np.float64],
    link_m: float,
) -> NDArray[np.int64]:
    """Polygon of the seed nearest to each contested point along chains of points no
    longer than ``link_m`` per step; -1 where none reaches it."""
    from scipy.sparse.csgraph import dijkstra
    from scipy.spatial import cKDTree

    out = np.full(len(contested), -1, dtype=np.int64)
    near, _ = cKDTree(xyz[contested]).query(xyz[seeds], k=1, distance_upper_bound=link_m)
    front = np.isfinite(near)
    if not front.any():
        return out
    nodes = np.concatenate([seeds[front], contested])
    tree = cKDTree(xyz[nodes])
    graph = tree.sparse_distance_matrix(tree, link_m, output_type="coo_matrix").tocsr()
    _, _, sources = dijkstra(
        graph, directed=False, indices=np.arange(int(front.sum())), min_only=True,
        return_predecessors=True,
    )  # fmt: skip
    src = sources[int(front.sum()) :]
    return np.where(src >= 0, seed_poly[front][np.maximum(src, 0)], -1)


def nearest_layer(
    layers: Mapping[str, NDArray[Any]],
    buffer_m: float,
    xy: NDArray[np.float64],
    index: GridIndex,
    outside: NDArray[np.bool_],
    tops: Mapping[str, NDArray[np.float64]],
) -> dict[str, NDArray[np.bool_]]:
    """Per layer, the points of its polygons' buffer rings nearer to another layer's polygon.

    The buffer ring absorbs digitising errors: a point outside every polygon belongs
    to the feature it lies nearest to.  Layers are processed one after the other, and
    the first layer's buffer took the points of the next layer's features beside it
    (complex draw 0: the end of a wall 0.15 m from its polygon and 0.5 m from the gate
    beside it went to the gate).  Step 1 leaves such points out of the first layer's
    objects (after their clustering, which they may still link).

    ``layers`` holds each layer's polygons (local frame); ``outside`` marks the
    candidate points, those outside every polygon.  A polygon
    counts for a point only where the point stands no higher than ``tops`` (per layer,
    per polygon; NaN: none): what rises above a feature's top beside it is not that
    feature's (an eave over a garden wall beside the house).  Ties stay with every
    layer at that distance.
    """
    n = len(xy)
    best = np.full(n, np.inf, dtype=np.float32)
    dist: dict[str, tuple[NDArray[np.int64], NDArray[np.float32]]] = {}
    for name, geoms in layers.items():
        buffered = shapely.buffer(geoms, buffer_m)
        shapely.prepare(buffered)
        idx_all, d_all = [], []
        for k in range(len(geoms)):
            cand = index.query_box(*shapely.bounds(buffered[k]))
            cand = cand[outside[cand]]
            cand = cand[shapely.contains_xy(buffered[k], xy[cand, 0], xy[cand, 1])]
            cand = cand[xy[cand, 2] <= tops[name][k]]  # NaN: no point inside, none
            if len(cand):
                idx_all.append(cand)
                d_all.append(
                    shapely.distance(geoms[k], shapely.points(xy[cand, 0], xy[cand, 1])).astype(
                        np.float32
                    )
                )
        if idx_all:
            idx, d = np.concatenate(idx_all), np.concatenate(d_all)
            np.minimum.at(best, idx, d)
            dist[name] = (idx, d)
    out: dict[str, NDArray[np.bool_]] = {}
    for name in layers:
        mine = np.full(n, np.inf, dtype=np.float32)
        if name in dist:
            np.minimum.at(mine, *dist[name])
        out[name] = np.isfinite(best) & (best < mine)
    return out


def footprints_of(
    layers: Mapping[str, gpd.GeoDataFrame],
    xyz: NDArray[np.float64],
    index: GridIndex,
    offset: NDArray[np.float64],
) -> dict[str, list[NDArray[np.int64]]]:
    """Indices of the points inside each (unbuffered) polygon, per layer.

    One point-in-polygon test per polygon, shared by the layer order, the
    inside-any mask and the cookie-cutter.
    """
    out: dict[str, list[NDArray[np.int64]]] = {}
    for name, gdf in layers.items():
        geoms = to_local(gdf.geometry.to_numpy(), offset)
        shapely.prepare(geoms)
        per_poly = []
        for geom in geoms:
            cand = index.query_box(*shapely.bounds(geom))
            per_poly.append(cand[shapely.contains_xy(geom, xyz[cand, 0], xyz[cand, 1])])
        out[name] = per_poly
    return out


def to_local(geoms: NDArray[Any], offset: NDArray[np.float64]) -> NDArray[Any]:
    """Polygons moved from world coordinates into the cloud's local frame."""
    shift = np.asarray(offset[:2], dtype=np.float64)
    return shapely.transform(geoms, lambda c: c - shift)
