"""City scale: step 1 over tiles on Dask (issue 19); prints one JSON line per measurement.

    python benchmarks/bench_tiles.py ahn3 [--n 2 3] [--workers 2]
    python benchmarks/bench_tiles.py area [--side 400] [--workers 2]

``ahn3``: AHN3 tile 1 + BGT cut into n x n tiles; per-point label and ground agreement with
the single-cloud run, objects found once, time.  ``area``: a generated complex
(``pyheracles.synthetic.families.simulate("complex", ...)``) cut into tiles; peak resident
memory per worker and points/s against the single-cloud run.
"""

from __future__ import annotations

import argparse
import json
import resource
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import laspy
import numpy as np
import pyogrio

from pyheracles.complex import ComplexParams, prepare_layers, segment_complex
from pyheracles.io import read_cloud, read_layer
from pyheracles.tiles import run_tiles, split_las

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "delft_ahn3"


def _labels(folder: Path) -> tuple[list, np.ndarray]:
    las = laspy.read(folder / "segmented.laz")
    objs = pyogrio.read_dataframe(folder / "objects.gpkg", read_geometry=False)
    lut = {int(i): (c, int(f)) for i, c, f in zip(objs["instance"], objs["class"],
                                                  objs["source_fid"], strict=True)}  # fmt: skip
    return [lut.get(int(i)) for i in las.instance], np.asarray(las.classification) == 2


def _compare(cloud, seg, src: Path, tiles: list[Path], out: Path, n: int) -> dict:
    h = laspy.open(src).header
    world = cloud.world_xyz()
    w, d = (h.maxs[0] - h.mins[0]) / n, (h.maxs[1] - h.mins[1]) / n
    col = np.clip(((world[:, 0] - h.mins[0]) // w).astype(int), 0, n - 1)
    row = np.clip(((world[:, 1] - h.mins[1]) // d).astype(int), 0, n - 1)
    o = seg.objects
    lut = {int(i): (c, int(f))
           for i, c, f in zip(o["instance"], o["class"], o["source_fid"], strict=True)}  # fmt: skip
    agree = ground = 0
    for tile in tiles:
        c, r = map(int, tile.stem.split("_")[-2:])
        sel = np.flatnonzero((col == c) & (row == r))
        got, g = _labels(out / "tiles" / tile.stem)
        agree += sum(a == lut.get(int(b)) for a, b in zip(got, seg.instance[sel], strict=True))
        ground += int((g == seg.ground[sel]).sum())
    return {"label_agreement": agree / len(cloud), "ground_agreement": ground / len(cloud)}


def ahn3(ns: list[int], workers: int | None) -> None:
    cloud = read_cloud(DATA / "ahn3_tile1.laz")
    layers = {"building": read_layer(DATA / "bgt" / "bgt_pand.sqlite"),
              "wall": read_layer(DATA / "bgt" / "bgt_scheiding.sqlite")}  # fmt: skip
    cloud = replace(cloud, crs=layers["building"].crs)
    t = time.perf_counter()
    seg = segment_complex(cloud, prepare_layers(layers, cloud), ComplexParams()).segmentation
    single_s = time.perf_counter() - t
    for n in ns:
        with tempfile.TemporaryDirectory() as tmp:
            tiles = split_las(DATA / "ahn3_tile1.laz", Path(tmp) / "in", n, n)
            res = run_tiles(Path(tmp) / "in", layers, Path(tmp) / "out", workers=workers)
            row = _compare(cloud, seg, DATA / "ahn3_tile1.laz", tiles, Path(tmp) / "out", n)
            merged = res.objects
            print(json.dumps({
                "dataset": "ahn3_tile1", "tiles": n * n, "workers": workers, **row,
                "objects_single": len(seg.objects), "objects_tiled": len(merged),
                "duplicate_objects": int(merged.duplicated(["class", "source_fid"]).sum()),
                "time_s": res.timings["total"], "single_time_s": single_s,
                "peak_rss_mb_per_worker": res.peak_rss_mb,
            }))  # fmt: skip


def area(side_m: float, n: int, workers: int | None) -> None:
    from pyheracles.synthetic.families import simulate
    from pyheracles.synthetic.families.simulation import write_simulation

    sim = simulate("complex", 0, width_m=side_m, depth_m=side_m)
    with tempfile.TemporaryDirectory() as tmp:
        whole = write_simulation(sim, tmp, preview=False)["cloud"]
        sim.extras["write_extras"](tmp)
        layers = {k: read_layer(Path(tmp) / "layers.gpkg", k) for k in ("building", "wall")}
        c = read_cloud(whole)
        c = replace(c, crs=layers["building"].crs) if c.crs is None else c
        t = time.perf_counter()
        segment_complex(c, prepare_layers(layers, c), ComplexParams())
        single_s = time.perf_counter() - t
        single_rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        split_las(whole, Path(tmp) / "in", n, n)
        res = run_tiles(Path(tmp) / "in", layers, Path(tmp) / "out", workers=workers)
        print(json.dumps({
            "dataset": f"complex seed 0, {side_m:.0f} m", "points": len(c), "tiles": n * n,
            "workers": workers, "single_points_per_s": len(c) / single_s,
            "tiled_points_per_s": res.points_per_s,
            "throughput_ratio": (len(c) / single_s) / max(res.points_per_s, 1e-9),
            "peak_rss_mb_per_worker": res.peak_rss_mb, "single_peak_rss_mb": single_rss,
            "status": sorted(set(res.status.values())),
        }))  # fmt: skip


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("what", choices=["ahn3", "area"])
    ap.add_argument("--n", type=int, nargs="+", default=[2, 3])
    ap.add_argument("--side", type=float, default=400.0)
    ap.add_argument("--workers", type=int, default=None)
    a = ap.parse_args()
    if a.what == "ahn3":
        ahn3(a.n, a.workers)
    else:
        area(a.side, a.n[0], a.workers)
