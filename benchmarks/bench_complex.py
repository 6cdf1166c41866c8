"""Step 1 benchmark: accuracy on Delft AHN3 + BGT and on the demo complex, speed on 10 M points.

Prints one JSON line per measurement.  Run from the repository root:

    python benchmarks/bench_complex.py                 # everything
    python benchmarks/bench_complex.py --only ahn3     # one part: ahn3 | demo | speed
    python benchmarks/bench_complex.py --only speed --points 10000000

Targets (issue 2): AHN3 tile 1 with default parameters, median per-building F1 >= 0.97
and >= 90 % of buildings with F1 >= 0.9 (reference: class-6 points inside the BGT
polygon or within 1 m, nearest polygon wins); demo median F1 >= 0.95 over buildings,
walls and gates; 10 M points end to end <= 60 s, >= 3x faster than the naive approach
(point-in-polygon of the whole cloud per polygon + DBSCAN per polygon), peak memory <= 4 GB.
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import resource
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import SHARED_DATA, emit, timer
from pyheracles.complex import ComplexParams, prepare_layers, segment_complex
from pyheracles.evaluate import (
    evaluate_by_feature,
    evaluate_objects,
    ground_scores,
    reference_from_polygons,
)


def _f1_summary(f1: np.ndarray) -> dict[str, float]:
    f1 = f1[np.isfinite(f1)]
    return {
        "median_f1": float(np.median(f1)),
        "mean_f1": float(np.mean(f1)),
        "share_f1_ge_0.9": float(np.mean(f1 >= 0.9)),
        "n_objects": len(f1),
    }


def bench_ahn3(ground: str) -> None:
    from pyheracles.io import read_cloud, read_layer

    data = SHARED_DATA / "delft_ahn3"
    if not data.is_dir():
        emit(dataset="delft_ahn3", metric="skipped", value=None, reason=f"{data} absent")
        return
    cloud = read_cloud(data / "ahn3_tile1.laz")
    layers = {
        "building": read_layer(data / "bgt" / "bgt_pand.sqlite"),
        "wall": read_layer(data / "bgt" / "bgt_scheiding.sqlite"),
    }
    cloud = replace(cloud, crs=layers["building"].crs)  # the LAZ carries no CRS
    layers = prepare_layers(layers, cloud)
    with timer() as t:
        res = segment_complex(cloud, layers, ComplexParams(ground=ground))
    seg = res.segmentation
    seg.check_balance()
    cls = np.asarray(cloud.attributes["classification"])
    ref = reference_from_polygons(
        cloud.world_xyz()[:, :2], cls == 6, layers["building"], buffer_m=1.0
    )
    b = seg.objects[seg.objects["class"] == "building"]
    lut = np.zeros(int(seg.instance.max()) + 1, dtype=np.int64)
    lut[b["instance"].to_numpy()] = b["source_fid"].to_numpy() + 1
    ev = evaluate_objects(lut[seg.instance], ref)
    f1 = ev.objects["f1"].to_numpy(dtype=float)
    g = ground_scores(seg.ground, cls == 2)
    emit(
        dataset="delft_ahn3_tile1+bgt_pand+bgt_scheiding",
        metric="per_building_f1",
        value=_f1_summary(f1)["median_f1"],
        **_f1_summary(f1),
        mean_precision=float(np.nanmean(ev.objects["precision"])),
        mean_recall=float(np.nanmean(ev.objects["recall"])),
        ground_method=ground,
        ground_precision=g["precision"],
        ground_recall=g["recall"],
        time_s=t.s,
        points_per_s=len(cloud) / t.s,
        targets={"median_f1": 0.97, "share_f1_ge_0.9": 0.9},
    )


def bench_demo(points: int) -> None:
    from pyheracles.synthetic.complex_scene import ComplexSceneParams, kasepuhan_scene

    scene = kasepuhan_scene(ComplexSceneParams(n_points=points))
    layers = prepare_layers(scene.layers, scene.cloud)
    with timer() as t:
        res = segment_complex(scene.cloud, layers)
    seg = res.segmentation
    seg.check_balance()
    ro = scene.reference_objects
    ev = evaluate_by_feature(seg.instance, seg.objects, scene.reference_instance, ro)
    table = ev.objects
    per_layer = {
        layer: _f1_summary(table.loc[table["layer"] == layer, "f1"].to_numpy(dtype=float))
        for layer in ("building", "wall", "gate")
    }
    g = ground_scores(seg.ground, scene.ground)
    emit(
        dataset=f"demo_kasepuhan_{points}",
        metric="per_object_f1",
        value=_f1_summary(table["f1"].to_numpy(dtype=float))["median_f1"],
        **_f1_summary(table["f1"].to_numpy(dtype=float)),
        per_layer=per_layer,
        ground_precision=g["precision"],
        ground_recall=g["recall"],
        time_s=t.s,
        points_per_s=points / t.s,
        target={"median_f1": 0.95},
    )


def _ours(cloud_path: str, specs: list[str], out: str, queue: mp.Queue) -> None:
    from pyheracles.pipeline import complex_from_files

    start = time.perf_counter()
    res, _, timings, _ = complex_from_files(
        Path(cloud_path), specs, Path(out), params=ComplexParams()
    )
    total = time.perf_counter() - start
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6
    queue.put(
        {
            "total": total,
            "timings": timings,
            "peak_gb": peak,
            "counts": res.segmentation.counts(),
            "params": res.params,
        }
    )


def _naive(
    cloud_path: str, specs: list[str], distance: float, buffer: float, budget_s: float
) -> tuple[float, int, int]:
    """Point-in-polygon of the whole cloud per polygon, then DBSCAN, largest cluster kept.

    Uses the same ground mask method (CSF/auto) as ours; only the segmentation is
    timed.  Stops after ``budget_s`` seconds and returns the polygons done.
    """
    import shapely
    from sklearn.cluster import DBSCAN

    from pyheracles.ground import extract_ground
    from pyheracles.io import read_cloud, read_layer
    from pyheracles.pipeline import parse_layer_spec

    cloud = read_cloud(cloud_path)
    pool = ~extract_ground(cloud.xyz, method="auto").mask
    w = cloud.world_xyz()
    polys = []
    for spec in specs:
        _, path, layer = parse_layer_spec(spec)
        polys.extend(read_layer(path, layer).geometry.to_numpy())
    start = time.perf_counter()
    done = 0
    for geom in polys:
        inside = shapely.contains_xy(shapely.buffer(geom, buffer), w[:, 0], w[:, 1]) & pool
        idx = np.flatnonzero(inside)
        if len(idx):
            labels = DBSCAN(eps=distance, min_samples=1).fit_predict(cloud.xyz[idx])
            best = np.bincount(labels).argmax()
            pool[idx[labels == best]] = False
        done += 1
        if time.perf_counter() - start > budget_s:
            break
    return time.perf_counter() - start, done, len(polys)


def bench_speed(points: int) -> None:
    from pyheracles.synthetic.complex_scene import ComplexSceneParams, kasepuhan_scene, write_scene

    with tempfile.TemporaryDirectory() as tmp:
        scene = kasepuhan_scene(ComplexSceneParams(n_points=points))
        files = write_scene(scene, Path(tmp) / "scene")
        del scene
        specs = [f"{k}={files[k]}" for k in ("building", "wall", "gate")]
        ctx = mp.get_context("spawn")
        queue = ctx.Queue()
        proc = ctx.Process(
            target=_ours, args=(str(files["cloud"]), specs, str(Path(tmp) / "out"), queue)
        )
        proc.start()
        ours = queue.get()
        proc.join()
        seg_s = ours["timings"]["segmentation"] + ours["timings"]["layer_order"]
        emit(
            dataset=f"generated_complex_{points}",
            metric="end_to_end_s",
            value=ours["total"],
            time_s=ours["total"],
            points_per_s=points / ours["total"],
            peak_rss_gb=ours["peak_gb"],
            stages_s=ours["timings"],
            counts=ours["counts"],
            target_s=60,
            target_peak_gb=4,
        )
        p = ours["params"]
        budget = 10 * seg_s
        naive_s, done, total = _naive(
            str(files["cloud"]), specs, p.cluster_distance_m, p.buffer_m, budget
        )
        complete = done == total
        emit(
            dataset=f"generated_complex_{points}",
            metric="speedup_vs_naive_segmentation",
            value=naive_s / seg_s,
            at_least=not complete,
            naive_s=naive_s,
            naive_polygons_done=done,
            polygons=total,
            ours_segmentation_s=seg_s,
            naive="contains_xy on the whole cloud per polygon + sklearn DBSCAN(min_samples=1)",
            target=3.0,
        )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", choices=["ahn3", "demo", "speed"])
    ap.add_argument("--points", type=int, default=10_000_000, help="points for --only speed")
    ap.add_argument("--demo-points", type=int, default=400_000)
    args = ap.parse_args()
    if args.only in (None, "ahn3"):
        bench_ahn3("auto")
        bench_ahn3("class")
    if args.only in (None, "demo"):
        bench_demo(args.demo_points)
    if args.only in (None, "speed"):
        bench_speed(args.points)


if __name__ == "__main__":
    main()
