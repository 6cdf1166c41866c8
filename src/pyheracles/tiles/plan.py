"""The plan of a tiled run: owners, buffers, read boxes and the city's parameters.

Ownership rule
    Each GIS feature belongs to exactly ONE tile: the tile whose box contains the
    feature's representative point (``shapely.point_on_surface``, always inside the
    polygon, unlike the centroid of an L-shaped building); on a shared edge, or where
    boxes overlap, the tile whose centre is nearest; a point in no box goes to the
    nearest box (:func:`assign_owners`).

Buffer
    A tile is processed with the points of the other tiles inside its read box
    (:func:`read_box`): the tile's box grown by the buffer, widened to hold every feature
    the tile owns grown by twice the cookie-cutter buffer (so an owned object is always
    whole, however large).  The automatic buffer (:func:`auto_buffer`) is half the
    largest object plus 5 m, at least 20 m: the ground filter's window (half the largest
    object plus a cell) around the tile, so the DTM has no seam.

Parameters measured once
    Every automatic parameter that depends on the data (step 1's distances and cluster
    size from the point spacing, the ground filter's cell and window from the spacing
    and the largest object) is measured once for the whole city on a sample of tiles
    (:func:`city_parameters`) and given to every tile, so that no tile decides
    differently from its neighbours (or from a single-cloud run of the same area).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pyheracles.tiles.catalog import Tile, TileCatalog, read_points

__all__ = [
    "CityParameters",
    "assign_owners",
    "auto_buffer",
    "city_ground_params",
    "city_noise",
    "city_parameters",
    "layers_near",
    "measure_spacings",
    "read_box",
    "sample_tiles",
    "weighted_median",
]

#: Tiles read to measure the city's point spacing (spread over the catalogue's densities).
SAMPLE_TILES = 16


def assign_owners(points_xy: NDArray[np.float64], bounds: NDArray[np.float64]) -> NDArray[np.int64]:
    """Index of the tile owning each point (see the module's ownership rule).

    Parameters
    ----------
    points_xy
        ``(M, 2)`` representative points of the features, world coordinates.
    bounds
        ``(T, 4)`` tile boxes ``xmin, ymin, xmax, ymax``.

    Examples
    --------
    >>> b = np.array([[0, 0, 10, 10], [10, 0, 20, 10]], dtype=float)
    >>> assign_owners(np.array([[2.0, 5.0], [10.0, 5.0], [10.5, 5.0], [30.0, 5.0]]), b).tolist()
    [0, 0, 1, 1]
    """
    import shapely

    p = np.asarray(points_xy, dtype=float).reshape(-1, 2)
    b = np.asarray(bounds, dtype=float).reshape(-1, 4)
    owner = np.zeros(len(p), dtype=np.int64)
    if not len(p) or not len(b):
        return owner
    # candidate (feature, tile) pairs from a tree of the boxes, never a features x tiles
    # array (a city has 1e5 features and 1e4 tiles): the boxes holding the point (edges
    # included), else the boxes at the smallest distance
    tree = shapely.STRtree(shapely.box(b[:, 0], b[:, 1], b[:, 2], b[:, 3]))
    points = shapely.points(p)
    fi, ti = tree.query(points, predicate="intersects")
    rest = np.setdiff1d(np.flatnonzero(np.isfinite(p).all(axis=1)), fi)
    if len(rest):
        qi, qt = tree.query_nearest(points[rest], all_matches=True)
        fi, ti = np.concatenate([fi, rest[qi]]), np.concatenate([ti, qt])
    if not len(fi):
        return owner
    # the nearest centre among the candidates, then the first tile
    centre = np.hypot(p[fi, 0] - (b[ti, 0] + b[ti, 2]) / 2, p[fi, 1] - (b[ti, 1] + b[ti, 3]) / 2)
    order = np.lexsort((ti, centre, fi))
    fi, ti = fi[order], ti[order]
    first = np.r_[True, fi[1:] != fi[:-1]]
    owner[fi[first]] = ti[first]
    return owner


def auto_buffer(layers: Mapping[str, Any]) -> tuple[float, float]:
    """(tile buffer, largest object size), metres.

    The size is the one step 1 gives its ground filter: ``sqrt`` of the largest footprint
    area of all layers (20 m without any feature).  The buffer is the ground filter's
    window around a tile, half the size plus 5 m, at least 20 m.
    """
    import shapely

    sizes = [float(np.sqrt(shapely.area(g.geometry.to_numpy())).max())
             for g in layers.values() if len(g)]  # fmt: skip
    size = max(sizes) if sizes else 20.0
    return max(size / 2.0 + 5.0, 20.0), size


@dataclass(frozen=True)
class CityParameters:
    """The automatic parameters of a tiled run, measured once and given to every tile.

    Attributes
    ----------
    complex
        :class:`pyheracles.complex.ComplexParams` with every automatic value filled in.
    ground
        :class:`pyheracles.ground.AutoParams` of the ``"auto"`` ground filter; None for
        the other methods (their defaults do not depend on the data).
    spacing_m
        Step 1's point spacing (median nearest-neighbour distance), metres.
    ground_spacing_m
        The ground filter's spacing (from the occupied area), metres.
    max_object_size_m
        Largest object, metres (the ground window's size).
    sample
        Names of the tiles measured.
    """

    complex: Any
    ground: Any
    spacing_m: float
    ground_spacing_m: float
    max_object_size_m: float
    sample: tuple[str, ...]


def sample_tiles(tiles: Sequence[Tile], k: int = SAMPLE_TILES) -> list[Tile]:
    """Up to ``k`` tiles spread over the catalogue's point counts (smallest to largest)."""
    by_size = sorted(tiles, key=lambda t: (t.n_points, t.name))
    if len(by_size) <= k:
        return by_size
    picks = np.unique(np.round(np.linspace(0, len(by_size) - 1, k)).astype(int))
    return [by_size[int(i)] for i in picks]


def measure_spacings(
    catalog: TileCatalog, *, nearest: bool = True, seed: int | None = 0, sample: int = 20000
) -> tuple[float, float, tuple[str, ...]]:
    """(step 1's spacing, the ground filter's spacing, the tiles measured), metres.

    Step 1's spacing is the statistic :func:`pyheracles.geometry.neighbours.point_spacing`
    takes on one cloud, the median distance of random points to their nearest other
    point, on the city: ``sample`` points drawn from the sampled tiles
    (:func:`sample_tiles`) in proportion to their point counts, each distance taken in
    its own tile, pooled, and their median taken (a median of per-tile medians would
    follow the number of sparse tiles, water or parks, not the number of points).  The
    ground filter's spacing (from the occupied area) is the median over the tiles
    weighted by their point counts.  Each tile is read whole: memory is one tile.
    ``nearest=False`` skips step 1's spacing (NaN then).
    """
    from scipy.spatial import cKDTree

    from pyheracles.groundfilters.auto import point_spacing_m

    picked = sample_tiles(catalog.tiles)
    total = max(sum(t.n_points for t in picked), 1)
    rng = np.random.default_rng(seed)
    distances, ground_spacings, weights = [], [], []
    for tile in picked:
        xyz, _, _ = read_points(tile.path, None, ())
        if len(xyz) < 2:
            continue
        xyz -= xyz.min(axis=0)
        if nearest:
            tree = cKDTree(xyz)
            k = min(len(xyz), max(100, round(sample * len(xyz) / total)))
            pick = xyz[rng.choice(len(xyz), k, replace=False)]
            d, _ = tree.query(pick, k=min(8, len(xyz)))
            d = np.where(d[:, 1:] > 0, d[:, 1:], np.inf).min(axis=1)  # duplicates ignored
            distances.append(d[np.isfinite(d)])
            del tree
        ground_spacings.append(point_spacing_m(xyz[:, :2]))
        weights.append(len(xyz))
        del xyz
    w = np.asarray(weights, dtype=float)
    pooled = np.concatenate(distances) if distances else np.zeros(0)
    spacing = float(np.median(pooled)) if len(pooled) else float("nan")
    return spacing, weighted_median(np.asarray(ground_spacings), w), tuple(t.name for t in picked)


def city_ground_params(
    method: str,
    ground_spacing_m: float,
    max_object_size_m: float,
    catalog: TileCatalog | None = None,
) -> Any:
    """:class:`pyheracles.ground.AutoParams` for ``"auto"`` from the city's measures, else
    None (the other filters' defaults do not depend on the data).

    With a ``catalog``, the refinement's noise (the robust standard deviation of the seed
    residuals, one per pass) is also measured once for the city (:func:`city_noise`):
    measured per tile it follows each tile's terrain, and neighbouring tiles would test
    the same points against different thresholds.
    """
    from pyheracles.ground import SceneMeasures, auto_params

    if method != "auto":
        return None
    params = auto_params(SceneMeasures(ground_spacing_m, float("nan"), max_object_size_m))
    if catalog is None:
        return params
    return replace(params, refine=replace(params.refine, sigma_m=city_noise(catalog, params)))


def city_noise(catalog: TileCatalog, params: Any) -> tuple[float, ...]:
    """The refinement's noise of each pass, pooled over the sampled tiles, metres.

    Pass by pass, the seed residuals of every sampled tile (its own points, world-aligned
    cells, the city's noise of the earlier passes) are pooled and their robust standard
    deviation (1.4826 x the median absolute deviation) taken: the statistic the
    single-cloud run computes over the whole cloud, on a sample of it.  A tile is read
    once per pass (memory: one tile); its SMRF seeds are kept (a mask).
    """
    from pyheracles.cloud import PointCloud
    from pyheracles.ground import aligned_grid
    from pyheracles.groundfilters.refine import refine_ground
    from pyheracles.groundfilters.smrf import smrf
    from pyheracles.groundfilters.surface import RasterSampler

    picked = sample_tiles(catalog.tiles)
    seeds: dict[str, NDArray[np.bool_]] = {}
    sigmas: list[float] = []
    for k in range(int(params.refine.iterations)):
        pooled = []
        for tile in picked:
            world, _, _ = read_points(tile.path, None, ())
            if len(world) < 3:
                continue
            cloud = PointCloud.from_world(world)
            del world
            xy = cloud.xyz[:, :2]
            grid = aligned_grid(xy, params.seed.cell_m, cloud.offset[:2])
            sampler = RasterSampler(grid, xy, dtype=np.float32)
            if tile.name not in seeds:
                seeds[tile.name] = smrf(cloud.xyz, params.seed, sampler=sampler)[0]
            s = seeds[tile.name]
            if not s.any():
                continue
            before = s
            if k:  # the ground after pass k (the city's noise in passes 1..k)
                fixed = replace(params.refine, iterations=k, sigma_m=tuple(sigmas))
                before, _, _ = refine_ground(cloud.xyz, s, fixed, sampler=sampler)
            if not before.any():
                continue
            # pass k + 1's surface is built from ``before``; its residuals are the statistic
            step = replace(params.refine, iterations=k + 1, sigma_m=tuple(sigmas) + (0.0,))
            _, dtm, _ = refine_ground(cloud.xyz, s, step, sampler=sampler)
            z = cloud.xyz[before, 2]
            pooled.append((z - RasterSampler(grid, xy[before])(dtm.z_m)).astype(np.float32))
        if not pooled:
            break
        r = np.concatenate(pooled)
        med = np.median(r)
        sigmas.append(float(1.4826 * np.median(np.abs(r - med))))
    return tuple(sigmas)


def city_parameters(params: Any, catalog: TileCatalog, max_object_size_m: float) -> CityParameters:
    """Measure the automatic parameters once for the whole city (see the module docstring)."""
    from pyheracles.complex import resolve_params

    spacing, ground_spacing, sample = measure_spacings(catalog, seed=params.seed)
    return CityParameters(
        resolve_params(params, spacing),
        city_ground_params(params.ground, ground_spacing, max_object_size_m, catalog),
        spacing, ground_spacing, float(max_object_size_m), sample,
    )  # fmt: skip


def weighted_median(values: NDArray[np.float64], weights: NDArray[np.float64]) -> float:
    """The value below which half the total weight lies.

    Examples
    --------
    >>> weighted_median(np.array([3.0, 1.0, 2.0]), np.array([1.0, 1.0, 5.0]))
    2.0
    """
    order = np.argsort(values)
    cum = np.cumsum(weights[order])
    return float(values[order][np.searchsorted(cum, 0.5 * cum[-1])])


def read_box(
    tile: Tile, buffer_m: float, owned_bounds: NDArray[np.float64], margin_m: float
) -> tuple[float, float, float, float]:
    """The tile's box + ``buffer_m``, widened to the owned features' bounds + ``margin_m``."""
    x0, y0, x1, y1 = tile.box(buffer_m)
    if len(owned_bounds):
        x0 = min(x0, float(owned_bounds[:, 0].min()) - margin_m)
        y0 = min(y0, float(owned_bounds[:, 1].min()) - margin_m)
        x1 = max(x1, float(owned_bounds[:, 2].max()) + margin_m)
        y1 = max(y1, float(owned_bounds[:, 3].max()) + margin_m)
    return (x0, y0, x1, y1)


def layers_near(
    layers: Mapping[str, Any], box: tuple[float, float, float, float]
) -> dict[str, tuple[Any, NDArray[np.intp]]]:
    """Layer name -> (the features meeting ``box``, their row numbers in the layer)."""
    import shapely

    out = {}
    region = shapely.box(*box)
    for name, gdf in layers.items():
        hit = np.sort(gdf.sindex.query(region, predicate="intersects"))
        part = gdf.iloc[hit]
        part.attrs.update(gdf.attrs)
        out[name] = (part, hit)
    return out
