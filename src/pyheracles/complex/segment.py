"""Step 1 itself: one object per GIS feature, plus ground and remainder (thesis chapter 5)."""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import geopandas as gpd
import numpy as np
import pandas as pd
import shapely
from numpy.typing import NDArray

from pyheracles.cloud import PointCloud
from pyheracles.complex.clusters import hull, object_points, porous_points, scattered_points
from pyheracles.complex.clutter import clutter_points, terrain_under, under_terrain
from pyheracles.complex.cookie import GridIndex, claims, footprints_of, nearest_layer, to_local
from pyheracles.complex.crowns import crown_points
from pyheracles.complex.levels import auto_layer_order, ground_level, ground_mask, raised_ground
from pyheracles.complex.params import LEVEL_SAMPLE, ComplexParams, ComplexResult, resolve_params
from pyheracles.errors import InputError
from pyheracles.geometry.neighbours import point_spacing
from pyheracles.ground import pass_through_of
from pyheracles.io.vector import align_crs, validate_polygons
from pyheracles.labels import Segmentation, merge_rows

__all__ = ["prepare_layers", "segment_complex"]


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


@dataclass(eq=False)
class _Site:
    """The state one run shares across layers: points, indexes, pool and labels."""

    xyz: NDArray[np.float64]
    offset: NDArray[np.float64]
    index: GridIndex
    ground: NDArray[np.bool_]
    pool: NDArray[np.bool_]
    inside_any: NDArray[np.bool_]
    footprints: dict[str, list[NDArray[np.int64]]]
    multi_echo: NDArray[np.bool_] | None
    pass_through: NDArray[np.bool_] | None
    instance: NDArray[np.int32]
    class_id: NDArray[np.uint8]
    elsewhere: dict[str, NDArray[np.bool_]]
    released: NDArray[np.bool_]

    def terrain(self, xy: NDArray[np.float64]) -> NDArray[np.float64]:
        """Terrain height under the positions ``xy`` (see :func:`terrain_under`), from the
        ground points within :data:`TERRAIN_REACH_M` of their bounding box."""
        if len(xy) == 0:
            return np.zeros(0)
        lo = xy.min(axis=0) - TERRAIN_REACH_M
        hi = xy.max(axis=0) + TERRAIN_REACH_M
        near = self.index.query_box(lo[0], lo[1], hi[0], hi[1])
        near = near[self.ground[near]]
        # a median of the nearest few needs no dense survey's every point
        return terrain_under(self.xyz[near[:: max(1, len(near) // TERRAIN_SAMPLE)]], xy)


#: Reach of the ground points that make the terrain under an object's points, metres
#: (as its ground level's, :func:`ground_level`, with a 1 m buffer).
TERRAIN_REACH_M = 6.0
#: Ground points used at most for the terrain under an object's points.
TERRAIN_SAMPLE = 4000


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
    geoms = to_local(gdf.geometry.to_numpy(), site.offset)
    pts, poly, offpoly = claims(
        geoms, buffer, xyz, site.index, site.pool, site.inside_any, site.footprints[name],
        float(rp.cluster_distance_m),  # type: ignore[arg-type]
    )  # fmt: skip
    by_poly = np.argsort(poly.astype(np.int32), kind="stable")
    pts, poly, offpoly = pts[by_poly], poly[by_poly], offpoly[by_poly]
    bounds = np.searchsorted(poly, np.arange(len(geoms) + 1))
    levels = ground_level(geoms, xyz, site.ground, site.index, buffer + 5.0)
    buffered = shapely.buffer(geoms, buffer)
    shapely.prepare(buffered)
    porous = (
        porous_points(xyz[pts], site.pass_through[pts], rp.porous_share)
        if site.pass_through is not None and rp.porous_echoes
        else None
    )
    scattered = scattered_points(xyz, pts, rp, site.multi_echo, porous)
    empty: list[Any] = []
    for k in range(len(geoms)):
        sl = slice(bounds[k], bounds[k + 1])
        cand, cand_dist = pts[sl], offpoly[sl]
        keep = object_points(
            xyz, cand, cand_dist, scattered[sl], rp, None if porous is None else porous[sl],
            solid=None if site.pass_through is None else ~site.pass_through[cand],
            terrain=site.terrain if site.ground.any() else None,
        )
        if rp.crown_rise_m is not None and keep.sum() >= 3:
            crown = _crowns(site, cand[keep], cand_dist[keep] > 0.0, buffered[k], rp)
            keep[np.flatnonzero(keep)[crown]] = False
        if rp.clutter_height_m is not None and keep.any():
            keep[_clutter(site, cand, cand_dist, keep, rp)] = False
        if rp.low_outlier_m is not None and keep.any():
            kept = np.flatnonzero(keep)
            keep[kept[_low_outliers(site, cand[kept], float(rp.low_outlier_m))]] = False
        # points of the buffer ring nearer to another layer's feature are left to it
        # (they linked the object's clusters all the same)
        keep &= ~site.elsewhere[name][cand]
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
                "footprint_area_m2": float(shapely.area(hull(xyz[members, :2]))),
                "gis_area_m2": float(shapely.area(geoms[k])),
                **{(f"attr_{a}" if a in _RESERVED else a): v for a, v in attrs.items()},
            }
        )
        geometries.append(gdf.geometry.iloc[k])
    return empty


def _crowns(
    site: _Site,
    members: NDArray[np.int64],
    outside: NDArray[np.bool_],
    buffered: Any,
    rp: ComplexParams,
) -> NDArray[np.bool_]:
    """Mask over ``members`` of a tree crown's points (see :func:`crown_points`).

    ``outside`` (over ``members``) marks those outside the polygon, in its buffer ring;
    the last returns of pulses with several returns are the surface under something
    (when the cloud has echoes).

    The points beside them that count are untaken, outside every polygon and
    beyond the object's buffer (``buffered``, prepared): its eaves and facades
    lie within the buffer, and so do all its points.
    """
    radius = float(rp.cluster_distance_m)  # type: ignore[arg-type]
    lo = site.xyz[members, :2].min(axis=0) - radius
    hi = site.xyz[members, :2].max(axis=0) + radius
    near = site.index.query_box(lo[0], lo[1], hi[0], hi[1])
    off = near[site.pool[near] & ~site.inside_any[near]]
    off = off[~shapely.contains_xy(buffered, site.xyz[off, 0], site.xyz[off, 1])]
    under = None
    if site.multi_echo is not None and site.pass_through is not None:
        under = site.multi_echo[members] & ~site.pass_through[members]
    return crown_points(
        site.xyz, members, off, radius, float(rp.crown_rise_m),  # type: ignore[arg-type]
        rp.crown_share, outside=outside, under=under,
    )  # fmt: skip


def _clutter(
    site: _Site,
    cand: NDArray[np.int64],
    cand_dist: NDArray[np.float64],
    keep: NDArray[np.bool_],
    rp: ComplexParams,
) -> NDArray[np.int64]:
    """Positions in ``cand`` of the kept points that are low clutter beside the object.

    See :func:`clutter_points`: the ring is beyond ``scatter_offset_m`` (the digitising
    tolerance), far is beyond half the buffer (as in
    :func:`pyheracles.complex.clusters.select_clusters`), the platforms are the ground
    points released in the footprints.
    """
    kept = np.flatnonzero(keep)
    members = cand[kept]
    dist = cand_dist[kept]
    ring = dist > float(rp.scatter_offset_m)  # type: ignore[arg-type]
    far = dist > 0.5 * float(rp.buffer_m)  # type: ignore[arg-type]
    if not far.any():
        return np.zeros(0, dtype=np.int64)
    clutter = clutter_points(
        site.xyz[members], ring, far, dist == 0.0, site.terrain, site.released[members],
        float(rp.cluster_distance_m), float(rp.clutter_height_m),  # type: ignore[arg-type]
    )  # fmt: skip
    return kept[clutter]


def _low_outliers(site: _Site, members: NDArray[np.int64], depth_m: float) -> NDArray[np.bool_]:
    """Mask over ``members`` of the points more than ``depth_m`` under the terrain
    (see :func:`under_terrain`; the ground near them as in :meth:`_Site.terrain`)."""
    xy = site.xyz[members, :2]
    lo = xy.min(axis=0) - TERRAIN_REACH_M
    hi = xy.max(axis=0) + TERRAIN_REACH_M
    near = site.index.query_box(lo[0], lo[1], hi[0], hi[1])
    return under_terrain(site.xyz[members], site.xyz[near[site.ground[near]], 2], site.terrain,
                         depth_m)  # fmt: skip


def _tops(
    xyz: NDArray[np.float64],
    footprints: Sequence[NDArray[np.int64]],
    pool: NDArray[np.bool_],
    rp: ComplexParams,
) -> NDArray[np.float64]:
    """Highest a point beside each polygon may stand and be its feature's, metres.

    The 99th percentile of the pool points inside it, plus ``outside_above_top_m``
    (what :func:`object_points` keeps outside a polygon); NaN where none is inside.
    """
    above = float(rp.outside_above_top_m) if rp.outside_above_top_m is not None else np.inf
    out = np.full(len(footprints), np.nan)
    for k, inside in enumerate(footprints):
        z = xyz[inside[pool[inside]], 2]
        if len(z):
            out[k] = float(np.percentile(z[:: max(1, len(z) // LEVEL_SAMPLE)], 99)) + above
    return out


# ----------------------------------------------------------------------------- main
def segment_complex(
    cloud: PointCloud,
    layers: Mapping[str, gpd.GeoDataFrame],
    params: ComplexParams | None = None,
    *,
    released: NDArray[np.bool_] | None = None,
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
    released
        With ``params.ground="class"``: the points the caller took off its ground as
        platforms, plinths and steps (see
        :func:`pyheracles.complex.raised_ground_points`), so that they are treated as
        step 1 treats the ground it releases itself (the clutter rule never takes them
        off a building).  Ignored when step 1 computes the ground.

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
    through = pass_through_of(cloud.attributes)  # the echoes, for the ground and foliage
    ground = ground_mask(cloud, rp, max(sizes) if sizes else 20.0, through)
    given = released
    released = np.zeros(n, dtype=bool)
    if rp.raised_ground_m is not None and rp.ground != "class" and ground.any():
        # platforms, plinths, steps and low walls are the features', not terrain
        released = ground & raised_ground(layers, xyz, ground, rp, spacing, cloud)
        ground = ground & ~released
    elif given is not None and rp.ground == "class":
        given = np.asarray(given, dtype=bool)
        if given.shape != (n,):
            raise InputError(f"released must be a mask of the {n} points, got {given.shape}")
        released = given & ~ground
    timings["ground"] = time.perf_counter() - t

    t = time.perf_counter()
    pool = ~ground
    index = GridIndex(xyz[:, :2], max(4.0 * float(rp.buffer_m), 5.0))  # type: ignore[arg-type]
    footprints = footprints_of(layers, xyz, index, cloud.offset)
    inside_any = np.zeros(n, dtype=bool)
    for per_poly in footprints.values():
        for inside in per_poly:
            inside_any[inside] = True
    if rp.layer_order is None:
        order = auto_layer_order(layers, footprints, xyz, pool, ground, index, cloud.offset)
    else:
        if sorted(rp.layer_order) != sorted(layers):
            raise InputError(
                f"layer_order {list(rp.layer_order)} must name each layer once; "
                f"layers are {sorted(layers)}"
            )
        order = tuple(rp.layer_order)
    timings["layer_order"] = time.perf_counter() - t

    t = time.perf_counter()
    local = {k: to_local(g.geometry.to_numpy(), cloud.offset) for k, g in layers.items()}
    buffer = float(rp.buffer_m)  # type: ignore[arg-type]
    tops = {k: _tops(xyz, footprints[k], pool, rp) for k in layers}
    elsewhere = nearest_layer(local, buffer, xyz, index, pool & ~inside_any, tops)
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
        pass_through=through,
        instance=np.zeros(n, dtype=np.int32),
        class_id=np.zeros(n, dtype=np.uint8),
        elsewhere=elsewhere,
        released=released,
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
