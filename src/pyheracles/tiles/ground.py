"""``heracles ground`` over tiles: the ground filter per tile with a buffer, a DTM mosaic.

Each tile is filtered with the points of its neighbours inside its box grown by the
buffer (the ground filter's window, half the largest object plus 5 m, at least 20 m;
its points taken from the strips each tile is read once for,
:func:`pyheracles.tiles.worker.strip_tile`, not from the neighbours' whole files), on
world-aligned cells (:func:`pyheracles.ground.aligned_grid`) with parameters measured
once for the whole city (:func:`pyheracles.tiles.plan.measure_spacings`), so the ground
of a tile is that of a single run over the whole area and neighbouring DTMs meet on the
same cells.  Per tile, ``tiles/<tile>/`` holds ``ground.laz`` (the tile's own points, in
file order, every dimension kept; class 2 = ground, former ground points now off-ground
become 1; ``height_above_ground``), ``dtm.tif`` (the DTM cells meeting the tile's own
box; the layout of ``heracles ground``) and ``run.json``.  ``dtm.vrt`` is a GDAL virtual
mosaic of every tile's ``dtm.tif`` (written as XML: GDAL reads it, QGIS opens it, and
``gdal_translate -of COG dtm.vrt dtm.tif`` makes one Cloud-Optimized GeoTIFF of it);
``tiles.gpkg`` is the tile index with each tile's status.
"""

from __future__ import annotations

import os
import shutil
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any
from xml.sax.saxutils import escape

import numpy as np

from pyheracles.errors import InputError
from pyheracles.tiles.catalog import Tile, TileCatalog, peak_rss_mb, read_catalog
from pyheracles.tiles.merge import tile_index
from pyheracles.tiles.plan import SampleCache, city_ground_params, measure_spacings
from pyheracles.tiles.worker import (
    StripJob,
    neighbour_buffers,
    read_tile_cloud,
    skipped,
    strip_tile,
)

__all__ = ["GroundJob", "GroundTilesResult", "ground_tile", "run_ground_tiles", "write_vrt"]


@dataclass(frozen=True)
class GroundJob:
    """What one ground task needs: its tile, the neighbours in its box, the parameters."""

    tile: Tile
    neighbours: tuple[Tile, ...]
    box: tuple[float, float, float, float]
    method: str
    params: Any  # AutoParams measured for the city ("auto"), else None: the defaults
    max_object_size_m: float
    dtm_cell_m: float | None
    crs: Any
    outdir: Path


def _clip_dtm(dtm: Any, offset: np.ndarray, bounds: Sequence[float]) -> Any:
    """The cells of ``dtm`` meeting the world box ``bounds`` (xmin, ymin, xmax, ymax)."""
    from pyheracles.groundfilters.surface import DTM, Grid

    g = dtm.grid
    c = g.cell_m
    rows, cols = g.shape
    c0 = int(np.clip(np.floor((bounds[0] - offset[0] - g.x0_m) / c), 0, cols - 1))
    c1 = int(np.clip(np.floor((bounds[2] - offset[0] - g.x0_m) / c), c0, cols - 1))
    r0 = int(np.clip(np.floor((g.y0_m - (bounds[3] - offset[1])) / c), 0, rows - 1))
    r1 = int(np.clip(np.floor((g.y0_m - (bounds[1] - offset[1])) / c), r0, rows - 1))
    grid = Grid(g.x0_m + c0 * c, g.y0_m - r0 * c, c, (r1 - r0 + 1, c1 - c0 + 1))
    return DTM(dtm.z_m[r0 : r1 + 1, c0 : c1 + 1].copy(), grid,
               dtm.observed[r0 : r1 + 1, c0 : c1 + 1].copy())  # fmt: skip


def ground_tile(job: GroundJob) -> dict[str, Any]:
    """Ground filter of one tile with its buffer; writes ``tiles/<tile>/`` atomically."""
    from pyheracles.cli.ground import write_dtm_geotiff
    from pyheracles.cloud import PointCloud
    from pyheracles.ground import extract_ground, height_above_ground, pass_through_of
    from pyheracles.io import write_cloud
    from pyheracles.provenance import write_run_json

    t0 = time.perf_counter()
    final = job.outdir / "tiles" / job.tile.name
    if (final / "run.json").is_file():
        return skipped(job.tile)
    own = read_tile_cloud(job.tile, job.crs)
    warnings: list[str] = []
    buffers = neighbour_buffers(job.neighbours, job.box, job.outdir / ".work", warnings)
    parts = [own.world_xyz(), *(b[1] for b in buffers)]
    # the echoes of the tile and its buffers (returns that are not their pulse's last are
    # no ground): when every part has them, as the single-cloud run does
    echoes = [pass_through_of(own.attributes), *(pass_through_of(b[3]) for b in buffers)]
    through = None if any(e is None for e in echoes) else np.concatenate(echoes)
    del buffers
    n = len(own)
    cloud = PointCloud.from_world(np.concatenate(parts), source=str(job.tile.path))
    del parts
    result = extract_ground(
        cloud.xyz, job.method, job.params, max_object_size_m=job.max_object_size_m,
        dtm_cell_m=job.dtm_cell_m, source=str(job.tile.path), origin_m=cloud.offset[:2],
        pass_through=through,
    )  # fmt: skip
    mask = result.mask[:n]
    old = own.attributes.get("classification")
    classification = np.ones(n, np.uint8) if old is None else np.asarray(old, np.uint8).copy()
    classification[classification == 2] = 1
    classification[mask] = 2
    extra: dict[str, np.ndarray] = {"classification": classification}
    staging = Path(tempfile.mkdtemp(prefix=f".{job.tile.name}.", suffix=".part",
                                    dir=final.parent))  # fmt: skip
    try:
        outputs = {"cloud": "ground.laz"}
        if result.dtm is not None:
            extra["height_above_ground"] = height_above_ground(
                cloud.xyz[:n], result.dtm).astype(np.float32)  # fmt: skip
            dtm = _clip_dtm(result.dtm, cloud.offset, job.tile.bounds)
            write_dtm_geotiff(dtm, staging / "dtm.tif", offset=cloud.offset, crs=own.crs)
            outputs["dtm"] = "dtm.tif"
        write_cloud(own, staging / "ground.laz", extra_dims=extra)
        counts = {"ground": int(mask.sum()), "off_ground": int(n - mask.sum()), "total": n}
        write_run_json(
            staging, step="ground-tile", parameters={"method": job.method, "params": result.params},
            inputs=[job.tile.path], timings={"total": time.perf_counter() - t0}, counts=counts,
            extra={"tile": job.tile.name, "read_points": len(cloud), "note": result.note,
                   "warnings": warnings, "outputs": outputs,
                   "dtm_cell_m": None if result.dtm is None else result.dtm.cell_m},
        )  # fmt: skip
        if final.exists():  # a stale, unfinished folder (no run.json): replace it
            shutil.rmtree(final)
        os.replace(staging, final)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
    return {"tile": job.tile.name, "skipped": False, "n_points": n, "n_read": len(cloud),
            "seconds": time.perf_counter() - t0, "peak_rss_mb": peak_rss_mb()}  # fmt: skip


def write_vrt(rasters: Sequence[Path], path: Path) -> Path | None:
    """A GDAL VRT mosaic of GeoTIFFs on one lattice (same cell, edges on its multiples).

    Paths inside are relative to the VRT.  The first raster's bands, nodata and CRS are
    used; None when ``rasters`` is empty.

    Raises
    ------
    InputError
        Rasters with different cell sizes, band counts or CRSs, or off the shared lattice.
    """
    import rasterio

    from pyheracles.io.atomic import atomic_path

    infos = []
    for r in rasters:
        with rasterio.open(r) as src:
            infos.append((Path(r), src.transform, src.width, src.height, src.count,
                          src.crs, src.nodata, src.dtypes[0],
                          [src.descriptions[i] for i in range(src.count)]))  # fmt: skip
    if not infos:
        return None
    first = infos[0]
    cell, count, crs = first[1].a, first[4], first[5]
    x0 = min(i[1].c for i in infos)
    y1 = max(i[1].f for i in infos)
    x1 = max(i[1].c + i[2] * cell for i in infos)
    y0 = min(i[1].f - i[3] * cell for i in infos)
    width, height = round((x1 - x0) / cell), round((y1 - y0) / cell)
    sources: list[list[str]] = [[] for _ in range(count)]
    for name, t, w, h, k, c, _, _, _ in infos:
        dx, dy = (t.c - x0) / cell, (y1 - t.f) / cell
        if (
            abs(t.a - cell) > 1e-9 * cell
            or k != count
            or c != crs
            or (abs(dx - round(dx)) > 1e-3 or abs(dy - round(dy)) > 1e-3)
        ):
            raise InputError(
                f"{name.name} is not on the mosaic's grid (cell {t.a:g} m at "
                f"{t.c:.3f}, {t.f:.3f}; bands {k}, CRS {c})", path=name,
                hint="the tiles' DTMs must share the cell size, the CRS and the cell edges",
            )  # fmt: skip
        rel = os.path.relpath(name, path.parent)
        for b in range(count):
            sources[b].append(
                f'    <ComplexSource><SourceFilename relativeToVRT="1">{escape(rel)}'
                f"</SourceFilename><SourceBand>{b + 1}</SourceBand>"
                f'<SrcRect xOff="0" yOff="0" xSize="{w}" ySize="{h}"/>'
                f'<DstRect xOff="{round(dx)}" yOff="{round(dy)}" xSize="{w}" ySize="{h}"/>'
                + (f"<NODATA>{first[6]:g}</NODATA>" if first[6] is not None else "")
                + "</ComplexSource>"
            )
    dtype = {"float32": "Float32", "float64": "Float64"}.get(first[7], "Float32")
    lines = [f'<VRTDataset rasterXSize="{width}" rasterYSize="{height}">']
    if crs is not None:
        lines.append(f"  <SRS>{escape(crs.to_wkt())}</SRS>")
    lines.append(f"  <GeoTransform>{x0!r}, {cell!r}, 0.0, {y1!r}, 0.0, {-cell!r}</GeoTransform>")
    for b in range(count):
        lines.append(f'  <VRTRasterBand dataType="{dtype}" band="{b + 1}">')
        if first[6] is not None:
            lines.append(f"    <NoDataValue>{first[6]:g}</NoDataValue>")
        if first[8][b]:
            lines.append(f"    <Description>{escape(first[8][b])}</Description>")
        lines.extend(sources[b])
        lines.append("  </VRTRasterBand>")
    lines.append("</VRTDataset>")
    with atomic_path(path) as tmp:
        Path(tmp).write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


@dataclass
class GroundTilesResult:
    """Result of :func:`run_ground_tiles`: statuses, output paths, timings, memory."""

    catalog: TileCatalog
    status: dict[str, str]
    paths: dict[str, Path]
    timings: dict[str, float]
    peak_rss_mb: float
    points_per_s: float
    dashboard: str | None = None

    @property
    def failed(self) -> dict[str, str]:
        """Tiles (and unreadable files) that did not finish, with the reason."""
        out = {k: v for k, v in self.status.items() if v.startswith("failed")}
        for p, reason in self.catalog.unreadable:
            out[Path(p).name] = f"failed: {reason}"
        return out


def run_ground_tiles(
    source: str | os.PathLike[str] | TileCatalog,
    outdir: str | os.PathLike[str],
    *,
    method: str = "auto",
    max_object_size_m: float | None = None,
    dtm_cell_m: float | None = None,
    buffer_m: float | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    retries: int = 2,
    cloud_crs: Any = None,
    progress: Callable[[dict[str, Any]], None] | None = None,
) -> GroundTilesResult:
    """The ground of many tiles and a seamless DTM mosaic (see the module docstring).

    Parameters
    ----------
    source
        A glob, a folder, a tile index ``.gpkg`` or a :class:`TileCatalog`.
    outdir
        Output folder; an earlier run's folder is resumed.
    method
        ``"auto"``, ``"csf"`` or ``"smrf"`` (:func:`pyheracles.ground.extract_ground`).
    max_object_size_m
        Largest building, metres (None: 34 m, as ``heracles ground``).
    dtm_cell_m
        DTM cell, metres (None: the filter's cell).
    buffer_m
        Tile buffer, metres (None: half the largest object + 5 m, at least 20 m).
    workers, scheduler, retries, progress
        As :func:`pyheracles.tiles.run_tiles`.

    Raises
    ------
    InputError
        Bad catalogue, unknown method, a negative buffer, an unreachable scheduler.
    """

    from pyheracles.ground import DEFAULT_MAX_OBJECT_SIZE_M
    from pyheracles.io.vector import write_gpkg
    from pyheracles.provenance import write_run_json
    from pyheracles.tiles.runner import dask_client, run_phase

    t_start = time.perf_counter()
    if method not in ("auto", "csf", "smrf"):
        raise InputError(f"unknown ground method {method!r}; expected one of auto, csf, smrf")
    catalog = source if isinstance(source, TileCatalog) else read_catalog(source, crs=cloud_crs)
    size = float(max_object_size_m or DEFAULT_MAX_OBJECT_SIZE_M)
    buffer = float(buffer_m) if buffer_m is not None else max(size / 2.0 + 5.0, 20.0)
    if not buffer >= 0:
        raise InputError(f"the tile buffer must be >= 0 m, got {buffer_m}")
    out = Path(outdir)
    (out / "tiles").mkdir(parents=True, exist_ok=True)
    with SampleCache() as cache:  # the sampled tiles decompressed once for both measures
        _, ground_spacing, sample = measure_spacings(catalog, nearest=False, cache=cache)
        params = city_ground_params(method, ground_spacing, size, catalog, cache)
    jobs = [
        GroundJob(tile, tuple(catalog.neighbours(tile, buffer)), tile.box(buffer), method,
                  params, size, dtm_cell_m, catalog.crs, out)
        for tile in catalog.tiles
    ]  # fmt: skip
    client = cluster = dashboard = None
    try:
        if scheduler is not None or workers:
            client, cluster = dask_client(workers, scheduler)
            dashboard = getattr(client, "dashboard_link", None)
        # each tile read once for the strips its neighbours' buffers take from it (a
        # failed strip is no failure: the neighbour's file is read instead)
        reach: dict[str, list[tuple[float, float, float, float]]] = {
            t.name: [] for t in catalog.tiles
        }
        for job in jobs:
            if (out / "tiles" / job.tile.name / "run.json").is_file():
                continue  # finished (a resume): its buffer is not read again
            for other in job.neighbours:
                reach[other.name].append(job.box)
        strips = [StripJob(t, tuple(reach[t.name]), out / ".work", keep_own=False)
                  for t in catalog.tiles]  # fmt: skip
        run_phase(client, strip_tile, strips, "strips", retries, progress, dashboard)
        done = run_phase(client, ground_tile, jobs, "ground", retries, progress, dashboard)
        if all(ok for ok, _ in done.values()):  # no tile needs them again
            shutil.rmtree(out / ".work", ignore_errors=True)
    finally:
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()
    status, peak = {}, 0.0
    for name, (ok, info) in done.items():
        status[name] = ("resumed" if info.get("skipped") else "done") if ok else f"failed: {info}"
        if ok:
            peak = max(peak, float(info.get("peak_rss_mb", 0.0)))
    paths: dict[str, Path] = {}
    rasters = [out / "tiles" / t.name / "dtm.tif" for t in catalog.tiles
               if not status[t.name].startswith("failed")]  # fmt: skip
    vrt = write_vrt([r for r in rasters if r.is_file()], out / "dtm.vrt")
    if vrt is not None:
        paths["dtm"] = vrt
    paths["tiles"] = write_gpkg(tile_index(catalog, status, "ground.laz", catalog.crs),
                                out / "tiles.gpkg", "tiles")  # fmt: skip
    total = time.perf_counter() - t_start
    n_done = sum(t.n_points for t in catalog.tiles if not status[t.name].startswith("failed"))
    rate = n_done / total if total > 0 else 0.0
    paths["run"] = write_run_json(
        out, step="ground-tiles", parameters={"method": method, "params": params},
        inputs=[str(t.path) for t in catalog.tiles], timings={"total": total},
        counts={"tiles": len(catalog.tiles), "points": catalog.n_points},
        extra={"tile_buffer_m": buffer, "max_object_size_m": size, "status": status,
               "ground_spacing_m": ground_spacing, "parameter_sample": list(sample),
               "unreadable": [list(u) for u in catalog.unreadable],
               "peak_rss_mb_per_worker": peak, "points_per_s": rate},
    )  # fmt: skip
    return GroundTilesResult(catalog, status, paths, {"total": total}, peak, rate, dashboard)
