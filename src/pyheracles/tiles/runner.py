"""The driver of a tiled run: the Dask client, the two phases, the merge.

Execution on Dask (``dask.distributed``): ``workers=N`` starts a LocalCluster of N
one-thread processes on this machine; ``scheduler=ADDRESS`` runs on an existing cluster
(Kubernetes, SLURM / dask-jobqueue, Coiled) without code changes.  A failed task is
retried (``retries``) and does not stop the others; finished tiles are never rewritten.
"""

from __future__ import annotations

import os
import shutil
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from pyheracles.errors import InputError
from pyheracles.tiles.catalog import TileCatalog, read_catalog
from pyheracles.tiles.merge import (
    class_ids,
    feature_ids,
    load_records,
    merged_objects,
    tile_counts,
    tile_index,
)
from pyheracles.tiles.plan import (
    CityParameters,
    assign_owners,
    auto_buffer,
    city_parameters,
    layers_near,
    read_box,
)
from pyheracles.tiles.worker import (
    SegmentJob,
    StripJob,
    WriteJob,
    load_record,
    save_record,
    segment_tile,
    strip_tile,
    write_tile,
)

__all__ = [
    "TiledResult",
    "boxes_meeting",
    "cached_city_parameters",
    "check_layers",
    "dask_client",
    "run_phase",
    "run_tiles",
    "why",
]


@dataclass
class TiledResult:
    """Result of :func:`run_tiles`.

    Attributes
    ----------
    catalog
        The tiles.
    status
        Tile name -> ``done``, ``resumed`` (done by an earlier run) or ``failed: <why>``.
    objects
        The merged objects table (global ``instance``, ``n_points`` over all tiles).
    paths
        ``objects``, ``tiles`` (the index), ``run``.
    timings, peak_rss_mb
        Seconds per stage (``parameters``, ``cluster``, ``strips``, ``segment``, ``write``,
        ``merge``, ``total``); the largest peak resident memory of a task's process, MB.
    """

    catalog: TileCatalog
    status: dict[str, str]
    objects: Any
    paths: dict[str, Path]
    timings: dict[str, float] = field(default_factory=dict)
    peak_rss_mb: float = 0.0
    points_per_s: float = 0.0
    dashboard: str | None = None

    @property
    def failed(self) -> dict[str, str]:
        """Tiles (and unreadable files) that did not finish, with the reason."""
        out = {k: v for k, v in self.status.items() if v.startswith("failed")}
        for path, reason in self.catalog.unreadable:
            out[Path(path).name] = f"failed: {reason}"
        return out


def dask_client(workers: int | None, scheduler: str | None) -> tuple[Any, Any]:
    """(client, cluster) for ``scheduler`` or a LocalCluster of ``workers`` processes."""
    try:
        from dask.distributed import Client, LocalCluster
    except ImportError as exc:  # pragma: no cover - the city extra is missing
        raise InputError(
            "running on tiles with --workers / --scheduler needs Dask",
            hint='pip install "pyheracles[city]"',
        ) from exc
    import logging

    if scheduler is not None:
        try:
            return Client(scheduler, timeout="5s", set_as_default=True), None
        except Exception as exc:
            raise InputError(
                f"cannot connect to the Dask scheduler at {scheduler!r} "
                f"({type(exc).__name__}: {exc})",
                hint="check the address (tcp://HOST:8786) and that the scheduler is running; "
                "or use --workers N for a cluster on this machine",
            ) from exc
    cluster = LocalCluster(
        n_workers=int(workers or 1), threads_per_worker=1, processes=True,
        dashboard_address=":0", silence_logs=logging.ERROR,
    )  # fmt: skip
    return Client(cluster, set_as_default=True), cluster


def run_tiles(
    source: str | os.PathLike[str] | TileCatalog,
    layers: Mapping[str, Any],
    outdir: str | os.PathLike[str],
    *,
    params: Any = None,
    buffer_m: float | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    retries: int = 2,
    cloud_crs: Any = None,
    reproject: bool = False,
    fix_invalid: bool = False,
    progress: Callable[[dict[str, Any]], None] | None = None,
) -> TiledResult:
    """Step 1 and ground over many tiles; see the module docstring for the rules.

    Parameters
    ----------
    source
        A glob, a folder, a tile index ``.gpkg`` or a :class:`TileCatalog`.
    layers
        Layer name -> GeoDataFrame (as for :func:`pyheracles.complex.segment_complex`).
    outdir
        Output folder; an earlier run's folder is resumed.
    params
        :class:`pyheracles.complex.ComplexParams`.
    buffer_m
        Tile buffer, metres (``None``: half the largest object + 5 m, at least 20 m, the
        ground window); each tile's read box is also widened to hold its owned features.
    workers, scheduler
        ``scheduler``: address of a running Dask scheduler; else ``workers`` processes of
        one thread in a LocalCluster; ``None`` / 0 runs the tasks here, one by one.
    retries
        Times a failed task is tried again (Dask ``retries=``).
    progress
        Called after every finished task with ``phase``, ``done``, ``total``, ``points``,
        ``seconds`` and ``dashboard``.

    Returns
    -------
    TiledResult
        Statuses per tile (a failing tile does not stop the others), merged objects.

    Raises
    ------
    InputError
        Bad catalogue (see :func:`read_catalog`), invalid layers, CRS mismatch, an
        unreachable scheduler.
    """
    import shapely

    from pyheracles.complex import ComplexParams
    from pyheracles.io.vector import write_gpkg
    from pyheracles.provenance import write_run_json

    t_start = time.perf_counter()
    p = params or ComplexParams()
    catalog = source if isinstance(source, TileCatalog) else read_catalog(source, crs=cloud_crs)
    if not layers:
        raise InputError("no GIS layer given", hint="add at least one --layer NAME=PATH")
    crs = catalog.crs
    if crs is None:
        crs = next((g.crs for g in layers.values() if g.crs is not None), None)
    checked = check_layers(layers, crs, reproject=reproject, fix_invalid=fix_invalid,
                           source=str(source))  # fmt: skip
    default_buffer, max_size = auto_buffer(checked)
    buffer = float(buffer_m) if buffer_m is not None else default_buffer
    if not buffer >= 0:
        raise InputError(f"the tile buffer must be >= 0 m, got {buffer_m}")
    out = Path(outdir)
    work = out / ".work"
    work.mkdir(parents=True, exist_ok=True)
    (out / "tiles").mkdir(exist_ok=True)
    t = time.perf_counter()
    city = cached_city_parameters(p, catalog, max_size, work)
    timings: dict[str, float] = {"parameters": time.perf_counter() - t}
    p = city.complex
    tiles = catalog.tiles
    numbers = {t.name: k for k, t in enumerate(tiles)}
    bounds = np.array([t.bounds for t in tiles], dtype=float)
    owners = {
        name: assign_owners(shapely.get_coordinates(shapely.point_on_surface(
            g.geometry.to_numpy())), bounds)
        for name, g in checked.items()
    }  # fmt: skip
    # an owned object is whole: its feature grown by twice the cookie-cutter buffer
    margin = 2.0 * (p.buffer_m if p.buffer_m is not None else 3.0) + 2.0
    feature_bounds = {n: shapely.bounds(g.geometry.to_numpy()) for n, g in checked.items()}
    ids = feature_ids(checked)
    jobs = []
    # the features of each tile, grouped once (not a tiles x features scan)
    by_owner = {n: np.split(np.argsort(o, kind="stable"),
                            np.searchsorted(np.sort(o), np.arange(1, len(tiles))))
                for n, o in owners.items()}  # fmt: skip
    # reach[t]: the tiles whose read box meets tile t (their objects may have points in it)
    reach: list[list[int]] = [[] for _ in tiles]
    for k, tile in enumerate(tiles):
        mine = [feature_bounds[n][by_owner[n][k]] for n in checked]
        box = read_box(tile, buffer, np.concatenate(mine) if mine else np.zeros((0, 4)), margin)
        met = boxes_meeting(bounds, box)
        for j in met:
            reach[j].append(k)
        near = layers_near(checked, box)
        jobs.append(SegmentJob(
            tile=tile, neighbours=tuple(tiles[j] for j in met if j != k), tile_index=numbers,
            layers={n: v[0] for n, v in near.items()},
            owned={n: owners[n][v[1]] == k for n, v in near.items()},
            params=p, box=box, max_object_size_m=max_size, crs=crs, work=work,
            ground_params=city.ground, feature_ids={n: ids[n][v[1]] for n, v in near.items()},
            spacing_m=city.spacing_m,
        ))  # fmt: skip
    status: dict[str, str] = {}
    client = cluster = None
    dashboard = None
    peak = 0.0
    try:
        t = time.perf_counter()
        if scheduler is not None or workers:
            client, cluster = dask_client(workers, scheduler)
            dashboard = getattr(client, "dashboard_link", None)
        timings["cluster"] = time.perf_counter() - t
        t = time.perf_counter()
        # phase 0: each tile read once for the strips its neighbours' buffers take from it
        # (a failed strip is no failure: phase 1 then reads that neighbour's file)
        strips = [StripJob(tile, tuple(jobs[k].box for k in reach[j] if k != j), work)
                  for j, tile in enumerate(tiles)]  # fmt: skip
        run_phase(client, strip_tile, strips, "strips", retries, progress, dashboard)
        timings["strips"] = time.perf_counter() - t
        t = time.perf_counter()
        first = run_phase(client, segment_tile, jobs, "segment", retries, progress, dashboard)
        timings["segment"] = time.perf_counter() - t
        if all(ok for ok, _ in first.values()):  # no tile needs them again
            shutil.rmtree(work / "strips", ignore_errors=True)
            shutil.rmtree(work / "own", ignore_errors=True)
        for name, (ok, info) in first.items():
            if not ok:
                status[name] = f"failed: {info}"
            else:
                peak = max(peak, float(info.get("peak_rss_mb", 0.0)))
        records = load_records(catalog, work, status)
        classes = class_ids(p.layer_order, checked)
        jobs2 = []
        for tile in tiles:
            if tile.name in status:
                continue
            # the tiles whose read box meets this tile may own objects with points in it
            near_tiles = [tiles[j] for j in reach[numbers[tile.name]]]
            missing = [o.name for o in near_tiles if o.name not in records]
            if missing:  # written without them it would lack their objects: not now
                status[tile.name] = f"failed: needs tile {', '.join(missing)}, which failed"
                continue
            sources = tuple((numbers[o.name], work / f"{o.name}.pkl") for o in near_tiles)
            jobs2.append(WriteJob(tile, numbers[tile.name], sources, classes, crs, out, p))
        t = time.perf_counter()
        second = run_phase(client, write_tile, jobs2, "write", retries, progress, dashboard)
        timings["write"] = time.perf_counter() - t
    finally:
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()
    t = time.perf_counter()
    totals: dict[int, int] = {}
    for name, (ok, info) in second.items():
        if not ok:
            status[name] = f"failed: {info}"
            continue
        peak = max(peak, float(info.get("peak_rss_mb", 0.0)))
        status[name] = (
            "resumed" if info.get("skipped") and first[name][1].get("skipped") else ("done")
        )
        counts = info.get("counts")
        if counts is None:  # a tile finished by an earlier run: its counts from its table
            counts = tile_counts(out / "tiles" / name)
        for i, c in counts.items():
            totals[int(i)] = totals.get(int(i), 0) + int(c)
    objects = merged_objects(records, classes, totals, crs)
    paths: dict[str, Path] = {}
    if len(objects) and crs is not None:
        paths["objects"] = write_gpkg(objects, out / "objects.gpkg", "objects")
    index = tile_index(catalog, status, "segmented.laz", crs)
    paths["tiles"] = write_gpkg(index, out / "tiles.gpkg", "tiles")
    timings["merge"] = time.perf_counter() - t
    total_time = time.perf_counter() - t_start
    timings["total"] = total_time
    n_done = sum(t.n_points for t in tiles if not status[t.name].startswith("failed"))
    rate = n_done / total_time if total_time > 0 else 0.0
    paths["run"] = write_run_json(
        out, step="complex-tiles", parameters=p,
        inputs=[g.attrs["source"] for g in layers.values() if g.attrs.get("source")],
        timings=timings,
        counts={"tiles": len(tiles), "points": catalog.n_points, "objects": len(objects)},
        extra={"tile_buffer_m": buffer, "max_object_size_m": max_size, "status": status,
               "spacing_m": city.spacing_m, "ground_spacing_m": city.ground_spacing_m,
               "parameter_sample": list(city.sample),
               "unreadable": [list(u) for u in catalog.unreadable], "notes": list(catalog.notes),
               "peak_rss_mb_per_worker": peak, "points_per_s": rate,
               "tiles": [str(t.path) for t in tiles], "classes": classes},
    )  # fmt: skip
    return TiledResult(catalog, status, objects, paths, timings, peak, rate, dashboard)


def boxes_meeting(bounds: np.ndarray, box: Sequence[float]) -> np.ndarray:
    """Indices (ascending) of the ``(T, 4)`` tile ``bounds`` meeting ``box`` (edges included),
    as :meth:`TileCatalog.neighbours` decides, without a Python loop over the tiles."""
    x0, y0, x1, y1 = box
    return np.flatnonzero((bounds[:, 0] <= x1) & (bounds[:, 2] >= x0)
                          & (bounds[:, 1] <= y1) & (bounds[:, 3] >= y0))  # fmt: skip


def check_layers(
    layers: Mapping[str, Any], crs: Any, *, reproject: bool, fix_invalid: bool, source: str
) -> dict[str, Any]:
    """The layers validated, in ``crs``, with a ``source_fid`` and a fresh index."""
    from pyheracles.io.vector import align_crs, validate_polygons

    checked: dict[str, Any] = {}
    for name, gdf in layers.items():
        src = gdf.attrs.get("source")
        g = validate_polygons(gdf, fix_invalid=fix_invalid, source=src)
        g = align_crs(g, crs, reproject=reproject, cloud_source=source)
        if "source_fid" not in g.columns:
            g = g.assign(source_fid=np.arange(len(g), dtype=np.int64))
        elif g["source_fid"].duplicated().any():
            # the tiles find an object's feature by it: a repeated one would take another's id
            dup = g["source_fid"][g["source_fid"].duplicated()].iloc[0]
            raise InputError(
                f"layer {name!r}: {int(g['source_fid'].duplicated().sum())} features repeat "
                f"another's source_fid (e.g. {dup!r})",
                path=src,
                hint="give each feature its own id in that column, or drop the column "
                "(the features are then numbered in file order)",
            )
        g = g.reset_index(drop=True)
        g.attrs.update(gdf.attrs)
        checked[name] = g
    return checked


def cached_city_parameters(
    params: Any, catalog: TileCatalog, max_object_size_m: float, work: Path
) -> CityParameters:
    """:func:`city_parameters`, measured on the first run and read back on a resume.

    The tiles finished by the first run used these values; the rest of a resumed run
    must use the same ones (a new measurement gives the same numbers anyway: the sample
    and the random draws are fixed, but reading the sample tiles costs time).
    """
    path = work / "parameters.pkl"
    key = (repr(params), tuple((t.name, t.n_points, t.bounds) for t in catalog.tiles),
           float(max_object_size_m))  # fmt: skip
    if path.is_file():
        stored = load_record(path)
        if stored.get("key") == key:
            return stored["city"]
    city = city_parameters(params, catalog, max_object_size_m)
    save_record({"key": key, "city": city}, path)
    return city


def run_phase(
    client: Any,
    fn: Callable[[Any], dict[str, Any]],
    jobs: Sequence[Any],
    phase: str,
    retries: int,
    progress: Callable[[dict[str, Any]], None] | None,
    dashboard: str | None,
) -> dict[str, tuple[bool, Any]]:
    """Run ``fn`` on every job; tile name -> (ok, task info or the error message)."""
    results: dict[str, tuple[bool, Any]] = {}
    t0 = time.perf_counter()
    points = 0

    def report() -> None:
        if progress is not None:
            progress({"phase": phase, "done": len(results), "total": len(jobs),
                      "points": points, "seconds": time.perf_counter() - t0,
                      "dashboard": dashboard})  # fmt: skip

    report()
    if client is None:
        for job in jobs:
            try:
                info = fn(job)
                results[job.tile.name] = (True, info)
                points += int(info.get("n_points", 0))
            except Exception as exc:  # one tile's failure must not stop the others
                results[job.tile.name] = (False, why(exc))
            report()
        return results
    from dask.distributed import as_completed

    futures = client.map(fn, jobs, retries=retries, pure=False,
                         key=[f"{phase}-{job.tile.name}" for job in jobs])  # fmt: skip
    names = {f.key: job.tile.name for f, job in zip(futures, jobs, strict=True)}
    for future in as_completed(futures):
        name = names[future.key]
        if future.status == "finished":
            info = future.result()
            results[name] = (True, info)
            points += int(info.get("n_points", 0))
        else:
            results[name] = (False, why(future.exception()))
        report()
    return results


def why(exc: BaseException | None) -> str:
    if exc is None:
        return "unknown error"
    return str(exc) if isinstance(exc, InputError) else f"{type(exc).__name__}: {exc}"
