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
from contextlib import nullcontext
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pyheracles.groundfilters.refine import refine_ground
from pyheracles.groundfilters.surface import Grid, RasterSampler
from pyheracles.tiles.catalog import Tile, TileCatalog, read_points

__all__ = [
    "CityParameters",
    "SampleCache",
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


class SampleCache:
    """The world xyz of the tiles measured for the city's parameters, decompressed once.

    The first :meth:`world` of a tile reads its file and keeps the points uncompressed in
    a temporary folder; later calls load them (the spacing and every pass of the noise
    measure the same tiles).  Memory: one tile.  Use it as a context manager (the folder
    is deleted on exit).
    """

    def __init__(self) -> None:
        import tempfile

        self._dir = tempfile.TemporaryDirectory(prefix="pyheracles_sample_")
        self._paths: dict[str, Path] = {}

    def world(self, tile: Tile) -> NDArray[np.float64]:
        """Every point of ``tile``, world coordinates, file order."""
        path = self._paths.get(tile.name)
        if path is not None:
            return np.load(path)
        xyz = read_points(tile.path, None, ())[0]
        path = Path(self._dir.name) / f"{len(self._paths)}.npy"
        np.save(path, xyz)
        self._paths[tile.name] = path
        return xyz

    def close(self) -> None:
        """Delete the kept points."""
        self._dir.cleanup()
        self._paths.clear()

    def __enter__(self) -> SampleCache:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def measure_spacings(
    catalog: TileCatalog,
    *,
    nearest: bool = True,
    seed: int | None = 0,
    sample: int = 20000,
    cache: SampleCache | None = None,
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
    ``nearest=False`` skips step 1's spacing (NaN then).  With a ``cache`` the tiles
    read are kept for the next measure (:func:`city_noise`).
    """
    from scipy.spatial import cKDTree

    from pyheracles.groundfilters.auto import point_spacing_m

    picked = sample_tiles(catalog.tiles)
    total = max(sum(t.n_points for t in picked), 1)
    rng = np.random.default_rng(seed)
    distances, ground_spacings, weights = [], [], []
    for tile in picked:
        xyz = read_points(tile.path, None, ())[0] if cache is None else cache.world(tile)
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
    cache: SampleCache | None = None,
) -> Any:
    """:class:`pyheracles.ground.AutoParams` for ``"auto"`` from the city's measures, else
    None (the other filters' defaults do not depend on the data).

    With a ``catalog``, the refinement's noise (the robust standard deviation of the seed
    residuals, one per pass) is also measured once for the city (:func:`city_noise`):
    measured per tile it follows each tile's terrain, and neighbouring tiles would test
    the same points against different thresholds.  ``cache``: the sampled tiles' points
    kept by :func:`measure_spacings`.
    """
    from pyheracles.ground import SceneMeasures, auto_params

    if method != "auto":
        return None
    params = auto_params(SceneMeasures(ground_spacing_m, float("nan"), max_object_size_m))
    if catalog is None:
        return params
    sigma = city_noise(catalog, params, cache)
    return replace(params, refine=replace(params.refine, sigma_m=sigma))


def city_noise(
    catalog: TileCatalog, params: Any, cache: SampleCache | None = None
) -> tuple[float, ...]:
    """The refinement's noise of each pass, pooled over the sampled tiles, metres.

    Pass by pass, the seed residuals of every sampled tile (its own points, world-aligned
    cells, the city's noise of the earlier passes) are pooled and their robust standard
    deviation (1.4826 x the median absolute deviation) taken: the statistic the
    single-cloud run computes over the whole cloud, on a sample of it.

    Each tile's ground is carried from pass to pass (its SMRF seeds, then the ground of
    each pass, retested against the pass's surface with the city's noise as
    :func:`pyheracles.groundfilters.refine.refine_ground` retests it), so every pass costs
    one surface per tile, not a rerun of the passes before it.  A tile is decompressed
    once: its points are kept uncompressed between passes (``cache``, or a
    :class:`SampleCache` of its own; memory: one tile).
    """
    from pyheracles.cloud import PointCloud
    from pyheracles.groundfilters.smrf import smrf

    picked = sample_tiles(catalog.tiles)
    refine = params.refine
    sigmas: list[float] = []
    with SampleCache() if cache is None else nullcontext(cache) as kept:
        states: list[_NoiseState] = []
        for tile in picked:
            world = kept.world(tile)
            if len(world) < 3:
                continue
            cloud = PointCloud.from_world(world)
            del world
            samplers = _noise_samplers(cloud.xyz, params, cloud.offset[:2])
            seeds = smrf(cloud.xyz, params.seed, sampler=samplers[0])[0]
            if not seeds.any():
                continue
            zref = float(cloud.xyz[seeds, 2].min())  # as refine_ground: the lowest seed
            states.append(_NoiseState(tile, zref, seeds))
            del cloud, samplers
        for k in range(int(refine.iterations)):
            pooled = []
            for st in states:
                if not st.ground.any():
                    continue
                cloud = PointCloud.from_world(kept.world(st.tile))
                xyz = cloud.xyz
                seed_sampler, sampler = _noise_samplers(xyz, params, cloud.offset[:2])
                if st.dtm is not None:  # the ground after pass k, with the city's noise
                    st.ground = _retest(xyz, st.dtm, sampler, st.zref, sigmas[k - 1], refine)
                    st.dtm = None
                    if not st.ground.any():
                        continue
                # pass k + 1's surface is built from the ground after pass k; its
                # residuals there are the statistic
                one = replace(refine, iterations=1, sigma_m=(0.0,))
                _, st.dtm, _ = refine_ground(xyz, st.ground, one, sampler=sampler)
                z = xyz[st.ground, 2]
                sample = RasterSampler(seed_sampler.grid, xyz[st.ground, :2])
                pooled.append((z - sample(st.dtm.z_m)).astype(np.float32))
                del xyz, cloud
            if not pooled:
                break
            r = np.concatenate(pooled)
            med = np.median(r)
            sigmas.append(float(1.4826 * np.median(np.abs(r - med))))
    return tuple(sigmas)


@dataclass
class _NoiseState:
    """One sampled tile between the passes of :func:`city_noise`."""

    tile: Tile
    zref: float  # the lowest SMRF seed (refine_ground's reference height)
    ground: NDArray[np.bool_]  # the ground after the passes so far (the seeds at first)
    dtm: Any = None  # the surface of the last pass, not yet used to retest the ground


def _noise_samplers(
    xyz: NDArray[np.float64], params: Any, origin: NDArray[np.float64]
) -> tuple[RasterSampler, RasterSampler]:
    """(the SMRF seeds' sampler on world-aligned cells, the refinement's sampler): the
    refinement reuses the first when its cell is the same, as refine_ground does."""
    from pyheracles.ground import aligned_grid

    xy = xyz[:, :2]
    seed = RasterSampler(aligned_grid(xy, params.seed.cell_m, origin), xy, dtype=np.float32)
    if seed.grid.cell_m == params.refine.cell_m:
        return seed, seed
    cover = Grid.covering(xy, params.refine.cell_m)
    return seed, RasterSampler(cover, xy, dtype=np.float32)


def _retest(
    xyz: NDArray[np.float64], dtm: Any, sampler: RasterSampler, zref: float, sigma: float,
    p: Any,
) -> NDArray[np.bool_]:  # fmt: skip
    """The ground after one pass of refine_ground: every point retested against ``dtm``
    with the noise ``sigma`` (the same arithmetic, in the sampler's precision, so the
    mask is bit for bit the one refine_ground gives; tests/test_tiles.py checks it)."""
    from pyheracles.groundfilters.refine import surface_residual, within_threshold

    zrel = (np.ascontiguousarray(xyz[:, 2]) - zref).astype(sampler.dtype, copy=False)
    residual = surface_residual(zrel, dtm, zref, sampler)
    return within_threshold(residual, sampler(dtm.slope()), sigma, p)


def city_parameters(params: Any, catalog: TileCatalog, max_object_size_m: float) -> CityParameters:
    """Measure the automatic parameters once for the whole city (see the module docstring)."""
    from pyheracles.complex import resolve_params

    with SampleCache() as cache:  # the sampled tiles decompressed once for both measures
        spacing, ground_spacing, sample = measure_spacings(catalog, seed=params.seed,
                                                           cache=cache)  # fmt: skip
        ground = city_ground_params(params.ground, ground_spacing, max_object_size_m, catalog,
                                    cache)  # fmt: skip
    return CityParameters(
        resolve_params(params, spacing), ground, spacing, ground_spacing,
        float(max_object_size_m), sample,
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
