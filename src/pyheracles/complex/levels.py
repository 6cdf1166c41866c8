"""Ground of step 1: the ground mask, platforms released from it, ground levels, layer order."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import geopandas as gpd
import numpy as np
import shapely
from numpy.typing import NDArray

from pyheracles.cloud import PointCloud
from pyheracles.complex.cookie import GridIndex, to_local
from pyheracles.complex.params import LEVEL_SAMPLE, ComplexParams
from pyheracles.complex.platforms import platform_tops
from pyheracles.errors import InputError
from pyheracles.groundfilters.footprints import FootprintGroundParams, raised_in_footprints

__all__ = [
    "auto_layer_order",
    "ground_level",
    "ground_mask",
    "raised_ground",
    "raised_ground_points",
]


def ground_mask(
    cloud: PointCloud,
    params: ComplexParams,
    max_object_size_m: float,
    pass_through: NDArray[np.bool_] | None = None,
) -> NDArray[np.bool_]:
    """The ground of step 1: the cloud's ASPRS class 2 (``ground="class"``), none, or a
    filter's (``pass_through``: the returns that are not their pulse's last, see
    :func:`pyheracles.ground.extract_ground`)."""
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
        cloud.xyz,
        method=params.ground,
        max_object_size_m=max_object_size_m,
        rng=params.seed,
        origin_m=cloud.offset[:2],
        pass_through=pass_through,
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
    return raised_ground(layers, cloud.xyz, ground, params, spacing_m, cloud)


def raised_ground(
    layers: Mapping[str, gpd.GeoDataFrame],
    xyz: NDArray[np.float64],
    ground: NDArray[np.bool_],
    params: ComplexParams,
    spacing_m: float,
    cloud: PointCloud,
) -> NDArray[np.bool_]:
    """Ground points on platforms, plinths, steps and low walls inside the buffered polygons.

    Those standing clearly above the terrain around the polygons (see
    :func:`~pyheracles.groundfilters.footprints.raised_in_footprints`), and with
    ``params.platform_tops`` the points continuing their tops (see
    :func:`~pyheracles.complex.platforms.platform_tops`).
    """
    geoms = [to_local(g.geometry.to_numpy(), cloud.offset) for g in layers.values() if len(g)]
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
    polygons = np.concatenate(geoms)
    released = raised_in_footprints(xyz, ground, polygons, fp)
    if params.platform_tops and released.any():
        # the points of a released top that its noise or a slope left under the cut
        released |= platform_tops(
            xyz, ground & ~released, released, polygons, fp.buffer_m,
            float(params.cluster_distance_m),  # type: ignore[arg-type]
        )  # fmt: skip
    return released


def ground_level(
    geoms: NDArray[Any],
    xyz: NDArray[np.float64],
    ground: NDArray[np.bool_],
    index: GridIndex,
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
            step = max(1, len(cand) // LEVEL_SAMPLE)  # a median needs no million points
            levels[k] = float(np.median(xyz[cand[::step], 2]))
    return levels


def auto_layer_order(
    layers: Mapping[str, gpd.GeoDataFrame],
    footprints: Mapping[str, Sequence[NDArray[np.int64]]],
    xyz: NDArray[np.float64],
    pool: NDArray[np.bool_],
    ground: NDArray[np.bool_],
    index: GridIndex,
    offset: NDArray[np.float64],
) -> tuple[str, ...]:
    """Lowest objects first: median over polygons of (90th percentile of z inside - ground)."""
    heights: dict[str, float] = {}
    for name, gdf in layers.items():
        geoms = to_local(gdf.geometry.to_numpy(), offset)
        levels = ground_level(geoms, xyz, ground, index, 5.0)
        per_poly = []
        for k, inside in enumerate(footprints[name]):
            cand = inside[pool[inside]]
            cand = cand[:: max(1, len(cand) // LEVEL_SAMPLE)]
            if len(cand) < 3:
                continue
            z90 = float(np.percentile(xyz[cand, 2], 90))
            base = levels[k] if np.isfinite(levels[k]) else float(xyz[cand, 2].min())
            per_poly.append(z90 - base)
        heights[name] = float(np.median(per_poly)) if per_poly else np.inf
    return tuple(sorted(layers, key=lambda n: (heights[n], n)))
