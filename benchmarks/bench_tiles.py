"""City scale: step 1 and ground over tiles on Dask (issue 19); one JSON line per measurement.

    python benchmarks/bench_tiles.py ahn3 [--n 2 3] [--workers 2]
    python benchmarks/bench_tiles.py ground [--n 2 3]
    python benchmarks/bench_tiles.py area --points 1e8 [--single-points 1e7] [--workers 2]
        [--sweep 8 --first-seed 0] [--side 200 --density 20] [--kill block] [--root DIR]

``ahn3``: AHN3 tile 1 + BGT cut into n x n tiles: per-point label and ground agreement with
the single-cloud run, objects found once, the buildings crossing a cut found once and
whole, time.  ``ground``: ``run_ground_tiles`` on the same cuts: ground agreement with
``extract_ground`` on the whole tile, and the DTM mosaic (``dtm.vrt``) against the single
DTM on the same world-aligned cells.  ``area``: a generated area written tile by tile to
disk (never the whole area in memory): ``--sweep`` complexes of the ``complex`` family
(seeds ``--first-seed`` ...), each on a ``--side`` m tile, repeated over a grid of tiles by
moving their LAS header offsets (the compressed points are the same bytes) with their GIS
layers moved alike, until ``--points``.  Then, in one invocation: the single-cloud run of a
``--single-points`` block (its first tiles merged into one file by chunks; step 1 alone and
end to end), the tiled run of that block and, with ``--kill block|area|both``, the same
tiled run again with one of the ``--workers`` Dask workers SIGKILLed mid-way (resumed if a
tile failed) and its outputs compared with the uninterrupted run's (sha256 of every tile's
point records and tables, the merged ``objects.gpkg``, the tile index); then the tiled run
of the whole area.  Peak memory per worker from the tasks (``ru_maxrss``) and from psutil
sampling, points/s, load averages; a final ``area summary`` JSON line.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import signal
import struct
import tempfile
import time
from dataclasses import replace
from pathlib import Path

from _common import SHARED_DATA, emit, interruptible, peak_rss_gb

import laspy
import numpy as np
import pyogrio

from pyheracles.complex import ComplexParams, prepare_layers, segment_complex
from pyheracles.io import read_cloud, read_layer
from pyheracles.tiles import run_ground_tiles, run_tiles, split_las

DATA = SHARED_DATA / "delft_ahn3"
RD = "EPSG:28992"
E0, N0 = 100_000.0, 450_000.0  # south-west corner of the generated area, RD New


# ----------------------------------------------------------------------------- AHN3
def _cells(world: np.ndarray, src: Path, n: int) -> tuple[np.ndarray, np.ndarray]:
    with laspy.open(src) as reader:
        h = reader.header
    w, d = (h.maxs[0] - h.mins[0]) / n, (h.maxs[1] - h.mins[1]) / n
    col = np.clip(((world[:, 0] - h.mins[0]) // w).astype(int), 0, n - 1)
    row = np.clip(((world[:, 1] - h.mins[1]) // d).astype(int), 0, n - 1)
    return col, row


def _compare(cloud, seg, tiles: list[Path], out: Path, n: int) -> dict:
    col, row = _cells(cloud.world_xyz(), DATA / "ahn3_tile1.laz", n)
    o = seg.objects
    lut = {int(i): (c, int(f))
           for i, c, f in zip(o["instance"], o["class"], o["source_fid"], strict=True)}  # fmt: skip
    agree = ground = 0
    tiled_instance = np.zeros(len(cloud), dtype=np.int64)
    for tile in tiles:
        c, r = map(int, tile.stem.split("_")[-2:])
        sel = np.flatnonzero((col == c) & (row == r))
        folder = out / "tiles" / tile.stem
        las = laspy.read(folder / "segmented.laz")
        gpkg = folder / "objects.gpkg"  # absent for a tile without objects
        objs = pyogrio.read_dataframe(gpkg, read_geometry=False) if gpkg.is_file() else None
        mine = {} if objs is None else {int(i): (cl, int(f)) for i, cl, f in
                zip(objs["instance"], objs["class"], objs["source_fid"], strict=True)}  # fmt: skip
        got = [mine.get(int(i)) for i in las.instance]
        agree += sum(a == lut.get(int(b)) for a, b in zip(got, seg.instance[sel], strict=True))
        ground += int(((np.asarray(las.classification) == 2) == seg.ground[sel]).sum())
        tiled_instance[sel] = np.asarray(las.instance)
    # buildings whose single-run points lie in more than one tile; "split": their points
    # carry more than one tiled label (another object's or none): not exactly the same set
    cell = col * n + row
    crossing = split = 0
    for inst in o["instance"][o["class"] == "building"]:
        members = seg.instance == inst
        if len(np.unique(cell[members])) > 1:
            crossing += 1
            split += int(len(np.unique(tiled_instance[members])) > 1)
    return {"label_agreement": agree / len(cloud), "ground_agreement": ground / len(cloud),
            "buildings_crossing_cuts": crossing, "crossing_buildings_split": split}  # fmt: skip


def _ahn3_inputs():
    cloud = read_cloud(DATA / "ahn3_tile1.laz")
    layers = {"building": read_layer(DATA / "bgt" / "bgt_pand.sqlite"),
              "wall": read_layer(DATA / "bgt" / "bgt_scheiding.sqlite")}  # fmt: skip
    return replace(cloud, crs=layers["building"].crs), layers


def ahn3(ns: list[int], workers: int | None) -> None:
    cloud, layers = _ahn3_inputs()
    t = time.perf_counter()
    seg = segment_complex(cloud, prepare_layers(layers, cloud), ComplexParams()).segmentation
    single_s = time.perf_counter() - t
    for n in ns:
        with tempfile.TemporaryDirectory() as tmp:
            tiles = split_las(DATA / "ahn3_tile1.laz", Path(tmp) / "in", n, n)
            res = run_tiles(Path(tmp) / "in", layers, Path(tmp) / "out", workers=workers)
            row = _compare(cloud, seg, tiles, Path(tmp) / "out", n)
            merged = res.objects
            emit(dataset="ahn3_tile1", tiles=n * n, workers=workers, **row,
                 objects_single=len(seg.objects), objects_tiled=len(merged),
                 duplicate_objects=int(merged.duplicated(["class", "source_fid"]).sum()),
                 time_s=res.timings["total"], single_time_s=single_s,
                 peak_rss_mb_per_worker=res.peak_rss_mb)  # fmt: skip


def ground(ns: list[int], workers: int | None) -> None:
    import rasterio

    from pyheracles.ground import extract_ground

    cloud = read_cloud(DATA / "ahn3_tile1.laz")
    t = time.perf_counter()
    single = extract_ground(cloud.xyz, "auto", origin_m=cloud.offset[:2])
    single_s = time.perf_counter() - t
    g = single.dtm.grid
    for n in ns:
        with tempfile.TemporaryDirectory() as tmp:
            tiles = split_las(DATA / "ahn3_tile1.laz", Path(tmp) / "in", n, n)
            res = run_ground_tiles(Path(tmp) / "in", Path(tmp) / "out", workers=workers)
            col, row = _cells(cloud.world_xyz(), DATA / "ahn3_tile1.laz", n)
            agree = 0
            for tile in tiles:
                c, r = map(int, tile.stem.split("_")[-2:])
                las = laspy.read(Path(tmp) / "out" / "tiles" / tile.stem / "ground.laz")
                sel = np.flatnonzero((col == c) & (row == r))
                agree += int(((np.asarray(las.classification) == 2) == single.mask[sel]).sum())
            with rasterio.open(res.paths["dtm"]) as vrt:
                mosaic = vrt.read(1)
                t_ = vrt.transform
            # the single DTM's cells in the mosaic (the same world lattice)
            c0 = round((g.x0_m + cloud.offset[0] - t_.c) / t_.a)
            r0 = round((t_.f - (g.y0_m + cloud.offset[1])) / t_.a)
            part = mosaic[r0 : r0 + g.shape[0], c0 : c0 + g.shape[1]]
            ref = single.dtm.z_m + cloud.offset[2]
            diff = np.abs(part - ref)[single.dtm.observed]
            emit(dataset="ahn3_tile1 ground", tiles=n * n, workers=workers,
                 ground_agreement=agree / len(cloud), mosaic_nodata=int((mosaic == -9999).sum()),
                 dtm_observed_cells=int(single.dtm.observed.sum()),
                 dtm_abs_diff_p99_m=float(np.percentile(diff, 99)),
                 dtm_abs_diff_max_m=float(diff.max()), time_s=res.timings["total"],
                 single_time_s=single_s, peak_rss_mb_per_worker=res.peak_rss_mb)  # fmt: skip


# ----------------------------------------------------------------------------- area
def _shift_header(src: Path, dst: Path, dx: float, dy: float) -> None:
    """Copy a LAS/LAZ file with its header's x / y offsets and bounds moved by dx, dy.

    The point records store integers relative to the offsets, so the (compressed) point
    bytes are unchanged; the header fields are at fixed positions (LAS 1.2-1.4: offsets
    at byte 155, max / min x, y, z at 179).
    """
    data = bytearray(src.read_bytes())
    ox, oy, oz = struct.unpack_from("<3d", data, 155)
    struct.pack_into("<3d", data, 155, ox + dx, oy + dy, oz)
    b = list(struct.unpack_from("<6d", data, 179))  # max x, min x, max y, min y, max z, min z
    b[0] += dx
    b[1] += dx
    b[2] += dy
    b[3] += dy
    struct.pack_into("<6d", data, 179, *b)
    tmp = dst.with_suffix(".part")
    tmp.write_bytes(bytes(data))
    os.replace(tmp, dst)


def generate_area(
    root: Path, n_points: float, side: float, density: float, distinct: int, first_seed: int
) -> tuple[Path, dict, list[tuple[int, int]]]:
    """Tiles of ``side`` m repeating ``distinct`` generated complexes, about ``n_points``."""
    import geopandas as gpd
    import pandas as pd
    import shapely

    from pyheracles.synthetic.families import simulate
    from pyheracles.synthetic.families.simulation import write_simulation

    src = root / "src"
    sources = []
    for k in range(distinct):
        folder = src / f"seed{first_seed + k}"
        if not (folder / "layers.gpkg").is_file():
            sim = simulate("complex", first_seed + k, width_m=side, depth_m=side,
                           density_per_m2=density, crs=RD, easting_m=E0, northing_m=N0,
                           height_m=0.0)  # fmt: skip
            write_simulation(sim, folder, preview=False)
            sim.extras["write_extras"](folder)
            del sim
        n = laspy.open(folder / "cloud.laz").header.point_count
        layers = {c: read_layer(folder / "layers.gpkg", c) for c in ("building", "wall")}
        sources.append((folder / "cloud.laz", n, layers))
    mean = np.mean([s[1] for s in sources])
    count = max(1, math.ceil(n_points / mean))
    nx = math.ceil(math.sqrt(count))
    tiles = root / "tiles"
    tiles.mkdir(parents=True, exist_ok=True)
    parts: dict[str, list] = {"building": [], "wall": []}
    cells = []
    for k in range(count):
        i, j = k % nx, k // nx
        path, _, layers = sources[(i + 2 * j) % distinct]  # neighbours differ
        dst = tiles / f"area_{i:03d}_{j:03d}.laz"
        if not dst.is_file():
            _shift_header(path, dst, i * side, j * side)
        cells.append((i, j))
        for c, gdf in layers.items():
            moved = gdf.rename(columns={"fid": "feature_fid"})  # a GPKG's own fid is unique
            shift = np.array([i * side, j * side])
            moved["geometry"] = shapely.transform(gdf.geometry.to_numpy(), lambda p, d=shift: p + d)
            moved["tile_source"] = f"{i}_{j}"
            parts[c].append(moved)
    # one layer for the whole area, its features numbered as read_layer numbers a file's
    layers = {c: gpd.GeoDataFrame(pd.concat(v, ignore_index=True), crs=v[0].crs)
              for c, v in parts.items()}  # fmt: skip
    for gdf in layers.values():
        gdf["source_fid"] = np.arange(len(gdf), dtype=np.int64)
    if not (root / "layers.gpkg").is_file():
        for c, gdf in layers.items():
            gdf.to_file(root / "layers.gpkg", layer=c, engine="pyogrio")
    return tiles, layers, cells


def merge_block(tiles: Path, cells: list[tuple[int, int]], dst: Path) -> int:
    """One LAZ of the tiles at ``cells``, written by chunks (for the single-cloud run).

    laspy re-quantises each chunk from its own file's offsets to the output header's.
    """
    paths = [tiles / f"area_{i:03d}_{j:03d}.laz" for i, j in cells]
    with laspy.open(paths[0]) as first:
        header = first.header
    n = 0
    with laspy.open(dst, mode="w", header=header) as writer:
        for p in paths:
            with laspy.open(p) as reader:
                for chunk in reader.chunk_iterator(1_000_000):
                    writer.write_points(chunk)
                    n += len(chunk)
    return n


class Watch:
    """Samples the resident memory of this process's Dask worker processes (psutil) in a
    thread; optionally SIGKILLs one worker once ``kill_after`` tiles of phase 1 are done."""

    def __init__(self, work: Path | None = None, kill_after: int | None = None) -> None:
        import threading

        self.work, self.kill_after = work, kill_after
        self.peak_mb: dict[int, float] = {}
        self.killed: dict | None = None
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, daemon=True)

    @staticmethod
    def workers() -> list:
        import psutil

        out = []
        for p in psutil.Process().children(recursive=True):
            try:
                cmd = " ".join(p.cmdline())
            except psutil.Error:
                continue
            if "spawn_main" in cmd or "forkserver" in cmd:
                out.append(p)
        return out

    def _done(self) -> int:
        if self.work is None or not self.work.is_dir():
            return 0
        return sum(1 for p in self.work.glob("*.pkl") if p.name != "parameters.pkl")

    def _loop(self) -> None:
        import psutil

        while not self._stop.wait(0.5):
            procs = self.workers()
            for p in procs:
                try:
                    rss = p.memory_info().rss / 2**20
                except psutil.Error:
                    continue
                self.peak_mb[p.pid] = max(self.peak_mb.get(p.pid, 0.0), rss)
            if (self.killed is None and self.kill_after is not None and len(procs) >= 2
                    and self._done() >= self.kill_after):  # fmt: skip
                victim = procs[0]
                self.killed = {"pid": victim.pid, "tiles_done_at_kill": self._done(),
                               "rss_mb_at_kill": self.peak_mb.get(victim.pid, 0.0)}  # fmt: skip
                os.kill(victim.pid, signal.SIGKILL)

    def __enter__(self) -> Watch:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join()


def digest(out: Path) -> dict[str, str]:
    """sha256 of every output a user reads: per tile the point records of
    ``segmented.laz`` (every dimension) and its ``objects.gpkg`` table; the merged
    ``objects.gpkg``; the tile index (name, points, output; not the status)."""
    import hashlib

    def table(path: Path, columns: list[str] | None = None) -> str:
        if not path.is_file():
            return "absent"
        t = pyogrio.read_dataframe(path, columns=columns)
        if "geometry" in t:
            t = t.to_wkb()
        return hashlib.sha256(t.to_csv(index=False).encode()).hexdigest()

    got = {}
    for folder in sorted((out / "tiles").iterdir()):
        if not folder.is_dir() or folder.name.startswith("."):
            continue
        h = hashlib.sha256()
        with laspy.open(folder / "segmented.laz") as reader:
            for chunk in reader.chunk_iterator(1_000_000):
                h.update(chunk.array.tobytes())
        got[folder.name] = h.hexdigest()
        got[folder.name + "/objects"] = table(folder / "objects.gpkg")
    got["objects.gpkg"] = table(out / "objects.gpkg")
    index = pyogrio.read_dataframe(out / "tiles.gpkg", read_geometry=False)
    got["tiles.gpkg"] = hashlib.sha256(
        index[["name", "n_points", "output"]].to_csv(index=False).encode()
    ).hexdigest()
    return got


def tiled_run(source: Path, layers: dict, out: Path, workers: int | None,
              kill_after: int | None = None) -> dict:  # fmt: skip
    """One tiled run with its workers' memory sampled; with ``kill_after``, one worker
    SIGKILLed mid-way (Dask retries its task elsewhere) and, if a tile failed for good,
    the same call again on the same folder (a resume).  ``out`` is emptied first: a folder
    left by an earlier invocation would be resumed, its finished tiles skipped and timed."""
    import shutil

    shutil.rmtree(out, ignore_errors=True)
    load0 = os.getloadavg()
    with Watch(out / ".work", kill_after) as w:
        res = run_tiles(source, layers, out, workers=workers)
    row = {"points": sum(t.n_points for t in res.catalog.tiles), "tiles": len(res.catalog.tiles),
           "workers": workers, "points_per_s": res.points_per_s, "time_s": res.timings["total"],
           "timings": res.timings, "objects": len(res.objects),
           "buildings": int((res.objects["class"] == "building").sum()),
           "peak_rss_mb_per_worker_tasks": res.peak_rss_mb,
           "peak_rss_mb_per_worker_sampled": max(w.peak_mb.values(), default=0.0),
           "worker_processes_seen": len(w.peak_mb), "status": sorted(set(res.status.values())),
           "load_avg_before": load0, "load_avg_after": os.getloadavg()}  # fmt: skip
    if kill_after is not None:
        row["killed"] = w.killed
        row["failed_after_kill"] = sorted(res.failed)
        if res.failed:
            t = time.perf_counter()
            again = run_tiles(source, layers, out, workers=workers)
            row["resume_time_s"] = time.perf_counter() - t
            row["status_after_resume"] = sorted(set(again.status.values()))
    return row


def area(a: argparse.Namespace) -> None:
    """Generate, single-cloud block, tiled block (reference and killed), tiled area."""
    root = Path(a.root) if a.root else Path(tempfile.mkdtemp(prefix="bench_tiles_"))
    t = time.perf_counter()
    tiles, layers, cells = generate_area(root, a.points, a.side, a.density, a.sweep,
                                         a.first_seed)  # fmt: skip
    gen_s = time.perf_counter() - t
    total = sum(laspy.open(p).header.point_count for p in sorted(tiles.glob("*.laz")))
    emit(dataset="area", stage="generated", points=total, tiles=len(cells), time_s=gen_s,
         buildings=len(layers["building"]), root=str(root))  # fmt: skip
    summary: dict = {"dataset": "area summary", "points": total, "tiles": len(cells),
                     "workers": a.workers, "gis_buildings": len(layers["building"])}  # fmt: skip
    # the block: the first tiles in row order up to --single-points
    m = max(1, min(len(cells), round(a.single_points / (total / len(cells)))))
    block = root / "block"
    block.mkdir(exist_ok=True)
    for i, j in cells[:m]:
        name = f"area_{i:03d}_{j:03d}.laz"
        if not (block / name).exists():
            os.link(tiles / name, block / name)
    whole = root / "block.laz"
    if not whole.is_file():
        merge_block(tiles, cells[:m], whole)
    import subprocess
    import sys

    # the single-cloud run in its own process: its own peak memory
    here = str(Path(__file__).parent)
    code = (f"import json, os, sys; sys.path.insert(0, {here!r}); "
            f"from bench_tiles import single_run; l0 = os.getloadavg(); "
            f"r = single_run({str(whole)!r}, {str(root)!r}); "
            f"r['load_avg_before'] = l0; r['load_avg_after'] = os.getloadavg(); "
            f"print(json.dumps(r))")  # fmt: skip
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.strip().splitlines()[-1]  # fmt: skip
    single = emit(dataset="area block", stage="single", **json.loads(out))
    summary["single_points"] = single["points"]
    summary["single_points_per_s"] = single["points_per_s"]
    summary["single_end_to_end_points_per_s"] = single["end_to_end_points_per_s"]
    summary["single_peak_rss_gb"] = single["peak_rss_gb"]
    if a.single_only:
        emit(**summary)
        return
    runs = {}
    if a.kill in ("block", "both"):
        ref = emit(dataset="area block", stage="tiled", **tiled_run(block, layers, root / "ob_ref",
                                                                     a.workers))  # fmt: skip
        killed = emit(dataset="area block", stage="tiled, one worker killed", **tiled_run(
            block, layers, root / "ob_kill", a.workers, kill_after=max(1, m // 2)))  # fmt: skip
        runs["block"] = (root / "ob_ref", root / "ob_kill", killed)
        summary["block_tiled_points_per_s"] = ref["points_per_s"]
    if not a.block_only:
        full = emit(dataset="area", stage="tiled", **tiled_run(tiles, layers, root / "oa_ref",
                                                               a.workers))  # fmt: skip
        summary.update(
            area_points_per_s=full["points_per_s"], area_time_s=full["time_s"],
            area_objects=full["objects"], area_buildings=full["buildings"],
            peak_rss_gb_per_worker=max(full["peak_rss_mb_per_worker_tasks"],
                                       full["peak_rss_mb_per_worker_sampled"]) / 1024,
            area_load_avg=[full["load_avg_before"], full["load_avg_after"]],
            single_over_tiled=single["points_per_s"] / full["points_per_s"],
            single_end_to_end_over_tiled=single["end_to_end_points_per_s"] / full["points_per_s"],
        )  # fmt: skip
        if a.kill in ("area", "both"):
            killed = emit(
                dataset="area",
                stage="tiled, one worker killed",
                **tiled_run(tiles, layers, root / "oa_kill", a.workers, kill_after=len(cells) // 2),
            )
            runs["area"] = (root / "oa_ref", root / "oa_kill", killed)
    for name, (ref_dir, kill_dir, killed) in runs.items():
        d_ref, d_kill = digest(ref_dir), digest(kill_dir)
        same = [k for k in d_ref if d_kill.get(k) == d_ref[k]]
        summary[f"{name}_killed_worker"] = killed.get("killed")
        summary[f"{name}_resumed"] = bool(killed.get("failed_after_kill"))
        summary[f"{name}_identical_outputs"] = len(same) == len(d_ref) == len(d_kill)
        summary[f"{name}_outputs_compared"] = len(d_ref)
    summary["bench_peak_rss_gb"] = peak_rss_gb()
    emit(**summary)


def single_run(path: str, root: str) -> dict:
    """Step 1 on one merged cloud (run in a child process by :func:`area`): the step alone
    (``points_per_s``) and, as ``heracles complex`` does it, with reading the LAZ and
    writing ``segmented.laz`` + tables (``end_to_end_points_per_s``)."""
    from pyheracles.io.results import write_segmentation

    t0 = time.perf_counter()
    cloud = read_cloud(path)
    cloud = replace(cloud, crs=RD) if cloud.crs is None else cloud
    layers = {c: read_layer(Path(root) / "layers.gpkg", c) for c in ("building", "wall")}
    t = time.perf_counter()
    res = segment_complex(cloud, prepare_layers(layers, cloud), ComplexParams())
    s = time.perf_counter() - t
    write_segmentation(cloud, res.segmentation, Path(root) / "single_out", step="complex",
                       parameters=res.params, inputs=[path])  # fmt: skip
    e2e = time.perf_counter() - t0
    return {"points": len(cloud), "time_s": s, "points_per_s": len(cloud) / s,
            "end_to_end_time_s": e2e, "end_to_end_points_per_s": len(cloud) / e2e,
            "objects": len(res.segmentation.objects), "peak_rss_gb": peak_rss_gb()}  # fmt: skip


def main() -> None:
    """Parse the command line and run the chosen benchmark."""
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("what", choices=["ahn3", "ground", "area"])
    ap.add_argument("--n", type=int, nargs="+", default=[2, 3])
    ap.add_argument("--workers", type=int, default=None)
    ap.add_argument("--points", type=float, default=1e8)
    ap.add_argument("--single-points", type=float, default=1e7)
    ap.add_argument("--side", type=float, default=200.0)
    ap.add_argument("--density", type=float, default=20.0)
    ap.add_argument("--sweep", type=int, default=4, help="distinct generated complexes")
    ap.add_argument("--first-seed", type=int, default=0)
    ap.add_argument("--root", default=None, help="folder for the generated area (reused)")
    ap.add_argument(
        "--kill",
        choices=["block", "area", "both", "none"],
        default="block",
        help="the tiled run(s) repeated with one worker SIGKILLed mid-way",
    )
    ap.add_argument("--block-only", action="store_true")
    ap.add_argument("--single-only", action="store_true")
    a = ap.parse_args()
    if a.what == "ahn3":
        ahn3(a.n, a.workers)
    elif a.what == "ground":
        ground(a.n, a.workers)
    else:
        area(a)


if __name__ == "__main__":
    interruptible(main)
