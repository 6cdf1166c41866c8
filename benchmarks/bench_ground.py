"""Ground filtering benchmark: ISPRS filter test, AHN3 Delft, CSF's sample, speed, bad input.

Run: ``python benchmarks/bench_ground.py [PART ...]`` (prints one JSON line per measurement;
parts: isprs, ahn3, speed, tiles, synthetic, csf_sample, bad_input; default all), or
``python benchmarks/bench_ground.py --sweep N [--first-seed S]`` for the terrain family sweep.

Targets (issue 7):

- ISPRS samples (../shared/data/isprs_filtertest): mean total error <= 5 % and mean Cohen's
  kappa >= 0.85 with the automatic setting; Type I / Type II / total / kappa per sample for
  CSF (package defaults), CSF with automatic parameters, SMRF (PDAL defaults) and auto,
  beside published figures (PUBLISHED below).
- AHN3 Delft tile 1: ground precision and recall >= 0.97 with auto (reference: class 2;
  water, class 9, and bridges, class 26, are left out of the score: neither is terrain nor
  an object on it; the second scoring counts water as ground and bridges as objects).
- Speed (AHN3 tile 1): ``extract_ground(method="smrf")`` (with its DTM and checks) >= 1 M
  points/s; auto no slower than the cloth-simulation-filter package alone with its defaults,
  both timed in this run (best of ``REPEATS`` interleaved rounds, wall and CPU time).
- Step 1's scale: auto on a 10 M point synthetic complex (time, ground precision / recall).
- CSF's own sample: the CSF wrapper reproduces CSF's published split.
- Bad input (building interior, walls only, single scan line): a clear result, no traceback.
- Tiles (issue 17): AHN3 tile 1 as 8 tiles side by side and on a diagonal, the diagonal
  within 2x of the row (hole filling and morphology must follow the data).

Sweep (issue 17): ``--sweep N`` draws seeds S..S+N-1 of the ``terrain`` scene family
(:mod:`pyheracles.synthetic.families.terrain`: slopes to 45 deg, crests, 1-4 m steps,
platforms, river cuts and bridges, dense vegetation and shrubs on slopes, buildings up to
60 m, low outlier clusters; airborne, 0.1-20 pulses/m^2) and runs ``extract_ground`` with
"auto", "smrf" and "csf" (package defaults) on each. Per draw: Type I, Type II, total
error (Sithole & Vosselman 2004) and Cohen's kappa per method, points/s, and where the
errors come from (ground rejected per landform tag, objects and outliers accepted per
class). Scoring: reference ground = class ``ground`` (terrain, also under vegetation and
bridges); every other point is an object, the OUTLIERS INCLUDED (as ISPRS scores them:
an outlier accepted as ground is a Type II error); water points are left out of the score
(neither terrain nor an object on it, as AHN3's class 9 in ``ahn3``) and reported apart.
Targets for auto, per draw: total error <= 4 %, kappa >= 0.85, and total error no more
than 0.5 points above plain SMRF's. The last line summarises: share of draws meeting every
target, pass share per target, mean errors per method and per density band, the worst
draw and its seed, and the error causes summed over the draws.
"""

from __future__ import annotations

import argparse
import os
import time
from dataclasses import asdict
from pathlib import Path

from _common import SHARED_DATA, emit, interruptible

import numpy as np

from pyheracles.ground import (
    CSFParams,
    auto_csf_params,
    extract_ground,
    measure_scene,
    pass_through_returns,
    refine_ground,
)
from pyheracles.groundfilters.csf import csf
from pyheracles.groundfilters.smrf import smrf

REPEATS = 3
ISPRS_SAMPLES = ("11", "12", "21", "22", "23", "24", "31")

# Published total errors (%) on the same samples, for comparison.
# Sithole, G., Vosselman, G. (2004). Experimental comparison of filter algorithms for
# bare-Earth extraction from airborne laser scanning point clouds. ISPRS Journal of
# Photogrammetry and Remote Sensing 59(1-2), 85-101, table of total errors per sample.
# CAVEAT: transcribed from memory of that table (it is reproduced in many later papers);
# the paper could not be opened in this session, so check the values before quoting them.
PUBLISHED_TOTAL_ERROR_PCT = {
    "source": "Sithole & Vosselman 2004, ISPRS J. 59:85-101 (total error %, UNVERIFIED "
    "transcription)",
    "verified": False,
    "filters": {
        "Axelsson": {
            "11": 10.76,
            "12": 3.25,
            "21": 4.25,
            "22": 3.63,
            "23": 4.00,
            "24": 4.42,
            "31": 4.78,
        },
        "Pfeifer": {
            "11": 17.35,
            "12": 4.50,
            "21": 2.57,
            "22": 6.71,
            "23": 8.22,
            "24": 8.64,
            "31": 1.80,
        },
        "Elmqvist": {
            "11": 22.40,
            "12": 8.18,
            "21": 8.53,
            "22": 8.93,
            "23": 12.28,
            "24": 13.83,
            "31": 5.34,
        },
        "Sohn": {
            "11": 20.49,
            "12": 8.39,
            "21": 8.80,
            "22": 7.54,
            "23": 9.84,
            "24": 13.33,
            "31": 6.39,
        },
    },
}
# Pingel, T.J., Clarke, K.C., McBride, W.A. (2013). An improved simple morphological filter
# for the terrain classification of airborne LIDAR data. ISPRS J. 77:21-30, abstract:
# mean Cohen's kappa over the 15 ISPRS samples (verified from the published abstract).
PUBLISHED_SMRF_KAPPA = {
    "source": "Pingel et al. 2013, ISPRS J. 77:21-30 (abstract; all 15 samples)",
    "verified": True,
    "mean_kappa_single_parameter_set": 0.854,
    "mean_kappa_optimised_per_sample": 0.9002,
}


def read_las(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Points in the cloud's local frame and ASPRS classes."""
    from pyheracles.io import read_cloud

    cloud = read_cloud(path)
    return cloud.xyz, np.asarray(cloud.attributes["classification"])


def scores(ref: np.ndarray, mask: np.ndarray) -> dict[str, float]:
    """Type I, Type II, total error (%) and Cohen's kappa (Sithole & Vosselman 2004)."""
    n = ref.size
    a = int(np.sum(ref & mask))  # ground kept
    b = int(np.sum(ref & ~mask))  # ground rejected (Type I)
    c = int(np.sum(~ref & mask))  # object accepted (Type II)
    d = n - a - b - c
    po = (a + d) / n
    pe = ((a + b) * (a + c) + (c + d) * (b + d)) / n**2
    return {
        "type1_pct": 100.0 * b / max(a + b, 1),
        "type2_pct": 100.0 * c / max(c + d, 1),
        "total_pct": 100.0 * (b + c) / n,
        "kappa": (po - pe) / (1 - pe) if pe < 1 else float("nan"),
        "precision": a / max(a + c, 1),
        "recall": a / max(a + b, 1),
    }


def csf_default(xyz: np.ndarray) -> np.ndarray:
    return csf(xyz, CSFParams())


def csf_auto(xyz: np.ndarray) -> np.ndarray:
    return csf(xyz, auto_csf_params(measure_scene(xyz)))


def csf_auto_refined(xyz: np.ndarray) -> np.ndarray:
    seeds = csf_auto(xyz)
    return refine_ground(xyz, seeds)[0] if seeds.any() else seeds


def smrf_default(xyz: np.ndarray) -> np.ndarray:
    return extract_ground(xyz, "smrf").mask


def auto(xyz: np.ndarray) -> np.ndarray:
    return extract_ground(xyz, "auto").mask


METHODS = {
    "csf_default": csf_default,
    "csf_auto": csf_auto,
    "csf_auto_refined": csf_auto_refined,
    "smrf_default": smrf_default,
    "auto": auto,
}


def timed(fn, xyz: np.ndarray, repeats: int = 1) -> tuple[np.ndarray, float]:
    best = float("inf")
    mask = None
    for _ in range(repeats):
        t = time.perf_counter()
        mask = fn(xyz)
        best = min(best, time.perf_counter() - t)
    return mask, best


def bench_isprs() -> None:
    folder = SHARED_DATA / "isprs_filtertest"
    per_method: dict[str, list[dict[str, float]]] = {m: [] for m in METHODS}
    times: dict[str, float] = dict.fromkeys(METHODS, 0.0)
    n_total = 0
    for sample in ISPRS_SAMPLES:
        path = folder / f"samp{sample}-utm.laz"
        if not path.exists():
            continue
        xyz, cls = read_las(path)
        ref = cls == 2
        n_total += len(xyz)
        for name, fn in METHODS.items():
            mask, t = timed(fn, xyz)  # one run: CSF takes seconds per sample
            s = scores(ref, mask)
            per_method[name].append(s)
            times[name] += t
            published = {
                f: v[sample] for f, v in PUBLISHED_TOTAL_ERROR_PCT["filters"].items() if sample in v
            }
            emit(
                dataset=f"isprs/samp{sample}",
                metric=f"{name}.total_error_pct",
                value=round(s["total_pct"], 2),
                time_s=round(t, 4),
                points_per_s=round(len(xyz) / t),
                type1_pct=round(s["type1_pct"], 2),
                type2_pct=round(s["type2_pct"], 2),
                kappa=round(s["kappa"], 4),
                n_points=len(xyz),
                published_total_error_pct=published,
            )
    for name, rows in per_method.items():
        mean_total = float(np.mean([r["total_pct"] for r in rows]))
        mean_kappa = float(np.mean([r["kappa"] for r in rows]))
        extra = {}
        if name == "auto":
            extra = {
                "target_total_pct": 5.0,
                "target_kappa": 0.85,
                "reached": bool(mean_total <= 5.0 and mean_kappa >= 0.85),
            }
        emit(
            dataset="isprs/mean",
            metric=f"{name}.mean_total_error_pct",
            value=round(mean_total, 2),
            time_s=round(times[name], 3),
            points_per_s=round(n_total / times[name]),
            mean_kappa=round(mean_kappa, 4),
            mean_type1_pct=round(float(np.mean([r["type1_pct"] for r in rows])), 2),
            mean_type2_pct=round(float(np.mean([r["type2_pct"] for r in rows])), 2),
            speed_ratio_vs_csf_default=round(times["csf_default"] / times[name], 2),
            **extra,
        )
    for filt, values in PUBLISHED_TOTAL_ERROR_PCT["filters"].items():
        emit(
            dataset="isprs/mean",
            metric=f"published.{filt}.mean_total_error_pct",
            value=round(float(np.mean(list(values.values()))), 2),
            time_s=None,
            points_per_s=None,
            source=PUBLISHED_TOTAL_ERROR_PCT["source"],
            verified=PUBLISHED_TOTAL_ERROR_PCT["verified"],
        )
    emit(
        dataset="isprs/all15",
        metric="published.SMRF.mean_kappa",
        value=PUBLISHED_SMRF_KAPPA["mean_kappa_single_parameter_set"],
        time_s=None,
        points_per_s=None,
        optimised=PUBLISHED_SMRF_KAPPA["mean_kappa_optimised_per_sample"],
        source=PUBLISHED_SMRF_KAPPA["source"],
        verified=True,
    )


def bench_ahn3() -> None:
    xyz, cls = read_las(SHARED_DATA / "delft_ahn3" / "ahn3_tile1.laz")
    scored = (cls != 9) & (cls != 26)
    for name, fn in METHODS.items():
        mask, t = timed(fn, xyz)  # one run; the speed targets are timed in bench_speed
        s = scores((cls == 2)[scored], mask[scored])
        alt = scores((cls == 2) | (cls == 9), mask)  # water as ground, bridges as objects
        extra = {}
        if name == "auto":
            extra = {
                "target": 0.97,
                "reached": bool(s["precision"] >= 0.97 and s["recall"] >= 0.97),
            }
        emit(
            dataset="delft_ahn3/tile1",
            metric=f"{name}.ground_precision",
            value=round(s["precision"], 4),
            recall=round(s["recall"], 4),
            time_s=round(t, 3),
            points_per_s=round(len(xyz) / t),
            kappa=round(s["kappa"], 4),
            total_error_pct=round(s["total_pct"], 2),
            alt_scoring_water_is_ground={
                "precision": round(alt["precision"], 4),
                "recall": round(alt["recall"], 4),
            },
            ground_on_water=int(mask[cls == 9].sum()),
            ground_on_bridges=int(mask[cls == 26].sum()),
            **extra,
        )


def best_of(fns: dict[str, object], xyz: np.ndarray, repeats: int = REPEATS) -> dict:
    """Best wall and CPU (process) time of each function over ``repeats`` interleaved rounds.

    Interleaving spreads the load of a shared machine over every contender; CPU time
    (``time.process_time``, all threads of this process) is reported beside the wall time
    because other jobs share the cores. CSF runs OpenMP threads: its CPU time can exceed
    its wall time, ours is single-threaded.
    """
    wall = dict.fromkeys(fns, float("inf"))
    cpu = dict.fromkeys(fns, float("inf"))
    out: dict[str, object] = {}
    for _ in range(repeats):
        for name, fn in fns.items():
            w, c = time.perf_counter(), time.process_time()
            out[name] = fn(xyz)  # type: ignore[operator]
            wall[name] = min(wall[name], time.perf_counter() - w)
            cpu[name] = min(cpu[name], time.process_time() - c)
    return {"wall": wall, "cpu": cpu, "out": out}


def bench_speed() -> None:
    """Speed targets on AHN3 tile 1: SMRF >= 1 M points/s; auto no slower than CSF alone."""
    xyz, _ = read_las(SHARED_DATA / "delft_ahn3" / "ahn3_tile1.laz")
    n = len(xyz)
    fns = {
        "smrf_filter": lambda p: smrf(p)[0],
        "extract_ground_smrf": lambda p: extract_ground(p, "smrf"),
        "extract_ground_auto": lambda p: extract_ground(p, "auto"),
        "csf_package_defaults": csf_default,
        "extract_ground_csf_auto": lambda p: extract_ground(
            p, "csf", auto_csf_params(measure_scene(p))
        ),
    }
    load = round(os.getloadavg()[0], 2)
    res = best_of(fns, xyz)
    wall, cpu = res["wall"], res["cpu"]
    for name in ("smrf_filter", "extract_ground_smrf"):
        emit(
            dataset="delft_ahn3/tile1",
            metric=f"{name}.points_per_s",
            value=round(n / wall[name]),
            time_s=round(wall[name], 3),
            points_per_s=round(n / wall[name]),
            cpu_s=round(cpu[name], 3),
            cpu_points_per_s=round(n / cpu[name]),
            repeats=REPEATS,
            target=1_000_000,
            reached=bool(n / wall[name] >= 1_000_000),
            load_average_1min_before=load,
            cpu_count=os.cpu_count(),
        )
    ratio = wall["extract_ground_auto"] / wall["csf_package_defaults"]
    emit(
        dataset="delft_ahn3/tile1",
        metric="auto_time_over_csf_default_time",
        value=round(ratio, 3),
        time_s=round(wall["extract_ground_auto"], 3),
        points_per_s=round(n / wall["extract_ground_auto"]),
        cpu_s=round(cpu["extract_ground_auto"], 3),
        csf_default_time_s=round(wall["csf_package_defaults"], 3),
        csf_default_cpu_s=round(cpu["csf_package_defaults"], 3),
        cpu_ratio=round(cpu["extract_ground_auto"] / cpu["csf_package_defaults"], 3),
        repeats=REPEATS,
        target="<= 1.0",
        reached=bool(ratio <= 1.0),
        load_average_1min_before=load,
        load_average_1min_after=round(os.getloadavg()[0], 2),
    )
    # the wording: automatic CSF (scene measured, parameters from it, low outliers
    # out, surface checks and DTM) against the package alone with its defaults; both wall
    # and CPU time must be no larger
    ratio = wall["extract_ground_csf_auto"] / wall["csf_package_defaults"]
    cpu_ratio = cpu["extract_ground_csf_auto"] / cpu["csf_package_defaults"]
    emit(
        dataset="delft_ahn3/tile1",
        metric="csf_auto_time_over_csf_default_time",
        value=round(ratio, 3),
        time_s=round(wall["extract_ground_csf_auto"], 3),
        points_per_s=round(n / wall["extract_ground_csf_auto"]),
        cpu_s=round(cpu["extract_ground_csf_auto"], 3),
        csf_default_time_s=round(wall["csf_package_defaults"], 3),
        csf_default_cpu_s=round(cpu["csf_package_defaults"], 3),
        cpu_ratio=round(cpu_ratio, 3),
        csf_auto_params=asdict(auto_csf_params(measure_scene(xyz))),
        repeats=REPEATS,
        target="<= 1.0 (wall and CPU)",
        reached=bool(ratio <= 1.0 and cpu_ratio <= 1.0),
        load_average_1min_after=round(os.getloadavg()[0], 2),
    )


def tile_mosaics(xyz: np.ndarray, n_tiles: int = 8) -> dict[str, np.ndarray]:
    """The same tile ``n_tiles`` times: side by side in a row, and corner to corner on a
    diagonal (the bounding box of the diagonal is ``n_tiles`` times larger)."""
    span = xyz.max(axis=0) - xyz.min(axis=0)
    shifts = np.arange(n_tiles)[:, None]
    row = np.concatenate([xyz + np.array([span[0], 0.0, 0.0]) * k for k in shifts])
    diagonal = np.concatenate([xyz + np.array([span[0], span[1], 0.0]) * k for k in shifts])
    return {"side_by_side": row, "diagonal": diagonal}


def bench_tiles() -> None:
    """Issue 17: the same points as 8 AHN3 tiles side by side or on a diagonal, time ratio
    <= 2 (the hole filling's cost must follow the filled area, not the bounding box)."""
    import resource

    xyz, _ = read_las(SHARED_DATA / "delft_ahn3" / "ahn3_tile1.laz")
    mosaics = tile_mosaics(xyz)
    for method in ("smrf", "auto"):
        wall, cpu = {}, {}
        for layout, pts in mosaics.items():
            t, c = time.perf_counter(), time.process_time()
            res = extract_ground(pts, method)
            wall[layout] = time.perf_counter() - t
            cpu[layout] = time.process_time() - c
            emit(
                dataset=f"delft_ahn3/8_tiles_{layout}",
                metric=f"extract_ground_{method}.time_s",
                value=round(wall[layout], 3),
                time_s=round(wall[layout], 3),
                cpu_s=round(cpu[layout], 3),
                points_per_s=round(len(pts) / wall[layout]),
                n_points=len(pts),
                n_ground=res.n_ground,
                dtm_cells=int(res.dtm.z_m.size) if res.dtm is not None else 0,
                max_rss_mb=round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024),
            )
        ratio = wall["diagonal"] / wall["side_by_side"]
        emit(
            dataset="delft_ahn3/8_tiles",
            metric=f"extract_ground_{method}.diagonal_over_side_by_side",
            value=round(ratio, 3),
            cpu_ratio=round(cpu["diagonal"] / cpu["side_by_side"], 3),
            time_s=None,
            points_per_s=None,
            target="<= 2.0",
            reached=bool(ratio <= 2.0),
            load_average_1min=round(os.getloadavg()[0], 2),
        )


def bench_synthetic_10m(n_points: int = 10_000_000) -> None:
    """Step 1's case: auto ground on a 10 M point synthetic complex, scored on its truth."""
    from pyheracles.synthetic.complex_scene import ComplexSceneParams, kasepuhan_scene

    scene = kasepuhan_scene(ComplexSceneParams(n_points=n_points))
    xyz = scene.cloud.xyz
    truth = np.asarray(scene.ground, dtype=bool)
    res = best_of({"auto": lambda p: extract_ground(p, "auto")}, xyz)
    s = scores(truth, res["out"]["auto"].mask)
    wall, cpu = res["wall"]["auto"], res["cpu"]["auto"]
    emit(
        dataset=f"synthetic/kasepuhan_{n_points // 1_000_000}M",
        metric="auto.time_s",
        value=round(wall, 3),
        time_s=round(wall, 3),
        points_per_s=round(len(xyz) / wall),
        cpu_s=round(cpu, 3),
        cpu_points_per_s=round(len(xyz) / cpu),
        repeats=REPEATS,
        ground_precision=round(s["precision"], 4),
        ground_recall=round(s["recall"], 4),
        n_points=len(xyz),
        load_average_1min=round(os.getloadavg()[0], 2),
    )


def bench_csf_sample() -> None:
    from scipy.spatial import cKDTree

    from pyheracles.io import read_cloud

    folder = SHARED_DATA / "csf_sample"
    cloud = read_cloud(folder / "sample.ply")
    world = cloud.world_xyz()
    dist, idx = cKDTree(world).query(np.loadtxt(folder / "groundPoints.txt"))
    ref = np.zeros(len(world), dtype=bool)
    ref[idx] = True
    for name in ("csf_default", "auto", "smrf_default"):
        mask, t = timed(METHODS[name], cloud.xyz)
        s = scores(ref, mask)
        emit(
            dataset="csf_sample",
            metric=f"{name}.agreement_with_csf_split",
            value=round(float(np.mean(mask == ref)), 4),
            time_s=round(t, 3),
            points_per_s=round(len(world) / t),
            kappa=round(s["kappa"], 4),
            max_match_distance_m=float(dist.max()),
        )


def bench_bad_input() -> None:
    rng = np.random.default_rng(7)
    m = 8000
    t = rng.uniform(0, 1, m)
    z = rng.uniform(0, 3, m)
    walls = np.concatenate(
        [
            np.c_[10 * t, np.zeros(m), z],
            np.c_[10 * t, np.full(m, 20.0), z],
            np.c_[np.zeros(m), 20 * t, z],
            np.c_[np.full(m, 10.0), 20 * t, z],
        ]
    )
    floor = np.c_[rng.uniform(0, 10, 20000), rng.uniform(0, 20, 20000), np.zeros(20000)]
    interior = np.concatenate([floor, floor + np.array([0.0, 0.0, 3.0]), walls])
    s = np.sort(rng.uniform(0, 200, 2000))
    line = np.c_[s, 0.3 * s, 0.02 * s]
    for scene, xyz in (("interior", interior), ("walls_only", walls), ("scan_line", line)):
        for method in ("auto", "smrf", "csf"):
            try:
                result = extract_ground(xyz, method)
                outcome = {"n_ground": result.n_ground, "note": result.note}
            except Exception as exc:  # the benchmark records, it does not crash
                outcome = {"error": f"{type(exc).__name__}: {exc}"}
            emit(
                dataset=f"bad_input/{scene}",
                metric=f"{method}.n_ground",
                value=outcome.get("n_ground"),
                time_s=None,
                points_per_s=None,
                **outcome,
            )


SWEEP_FAMILY = "terrain"
SWEEP_METHODS = ("auto", "smrf", "csf")
SWEEP_TARGETS = {"total_pct_max": 4.0, "kappa_min": 0.85, "vs_smrf_total_pct_max": 0.5}
#: Drawn parameters printed with each draw.
SWEEP_KEYS = (
    "side_m",
    "density_per_m2",
    "measured_density_per_m2",
    "n_points",
    "max_slope_deg",
    "regional_slope_deg",
    "terrace_step_m",
    "n_ridges",
    "n_embankments",
    "n_platforms",
    "river_depth_m",
    "n_bridges",
    "tree_cover",
    "shrub_cover",
    "canopy_core",
    "n_buildings",
    "building_max_size_m",
    "n_low_clusters",
    "low_cluster_depth_m",
    "outlier_share",
    "ground_share",
)
#: Landform tags in the order a rejected ground point is charged to (first that applies).
TAG_ORDER = (
    "breakline",
    "crest",
    "platform",
    "river_bank",
    "steep",
    "vegetated",
    "embankment",
    "terrace",
)


def point_tags(sim, xyz: np.ndarray) -> np.ndarray:
    """Landform bit flags of the true relief at each point (nearest grid vertex)."""
    t = sim.extras["terrain"]
    cell = float(t["x"][1] - t["x"][0])
    j = np.clip(np.round((xyz[:, 0] - t["x"][0]) / cell).astype(int), 0, len(t["x"]) - 1)
    i = np.clip(np.round((xyz[:, 1] - t["y"][0]) / cell).astype(int), 0, len(t["y"]) - 1)
    return t["tags"][i, j]


def error_causes(sim, ref, mask, scored, tags) -> dict[str, dict[str, float]]:
    """Where a method's errors come from.

    ``rejected``: per landform tag (and ``plain`` ground), the ground points there and the
    share rejected (%); ``accepted``: per object class and outlier part, the points and the
    share accepted as ground (%); ``charge``: the share of all scored errors charged to
    each cause (a rejected ground point to its first tag in :data:`TAG_ORDER`).
    """
    res = sim.clouds["cloud"]
    names = sim.extras["terrain"]["tag_names"]
    scene = sim.scene
    rejected: dict[str, dict[str, float]] = {}
    charge: dict[str, int] = {}
    g = ref & scored
    free = g.copy()
    for tag in TAG_ORDER:
        on = g & ((tags & names[tag]) > 0)
        if on.any():
            rejected[tag] = {"n": int(on.sum()), "pct": round(100 * float((~mask[on]).mean()), 2)}
        first = free & on
        charge[f"rejected_{tag}"] = int((first & ~mask).sum())
        free &= ~on
    if free.any():
        rejected["plain"] = {
            "n": int(free.sum()),
            "pct": round(100 * float((~mask[free]).mean()), 2),
        }
    charge["rejected_plain"] = int((free & ~mask).sum())
    accepted: dict[str, dict[str, float]] = {}
    objects = scored & ~ref
    kinds = {
        f"class:{scene.class_names[int(c)]}": (res.class_id == c) & ~res.outlier
        for c in np.unique(res.class_id[objects & ~res.outlier])
    }
    kinds |= {
        f"outlier:{scene.part_names[int(p)]}": (res.part == p) & res.outlier
        for p in np.unique(res.part[res.outlier])
    }
    for key, sel in kinds.items():
        sel = sel & objects
        if sel.any():
            accepted[key] = {"n": int(sel.sum()), "pct": round(100 * float(mask[sel].mean()), 2)}
            charge[f"accepted_{key}"] = int(mask[sel].sum())
    n_err = max(1, int(((ref != mask) & scored).sum()))
    return {
        "rejected": rejected,
        "accepted": accepted,
        "charge": {
            k: round(v / n_err, 4) for k, v in sorted(charge.items(), key=lambda kv: -kv[1]) if v
        },
    }


def sweep_draw(seed: int) -> dict:
    """One draw of the family, every method run and scored on it."""
    from pyheracles.synthetic.families import simulate

    t0 = time.perf_counter()
    sim = simulate(SWEEP_FAMILY, seed)
    gen_s = time.perf_counter() - t0
    res = sim.clouds["cloud"]
    xyz = res.xyz
    ref = (res.class_id == sim.scene.class_code("ground")) & ~res.outlier
    water = (res.class_id == sim.scene.class_code("water")) & ~res.outlier
    scored = ~water
    tags = point_tags(sim, xyz)
    # the echoes a LAS of the survey carries: "auto" uses them as `heracles ground` does
    # (returns that are not the last of their pulse are never ground); the peers run on
    # the coordinates alone, as PDAL's SMRF and the CSF package do by default
    through = pass_through_returns(res.return_number, res.number_of_returns)
    methods: dict[str, dict] = {}
    causes: dict[str, dict] = {}
    for name in SWEEP_METHODS:
        t = time.perf_counter()
        try:
            result = extract_ground(xyz, name, pass_through=through if name == "auto" else None)
        except Exception as exc:  # the benchmark records, it does not crash
            methods[name] = {"error": f"{type(exc).__name__}: {exc}"}
            continue
        dt = time.perf_counter() - t
        mask = result.mask
        s = scores(ref[scored], mask[scored])
        methods[name] = {
            "type1_pct": round(s["type1_pct"], 3),
            "type2_pct": round(s["type2_pct"], 3),
            "total_pct": round(s["total_pct"], 3),
            "kappa": round(s["kappa"], 4),
            "time_s": round(dt, 3),
            "points_per_s": round(len(xyz) / dt),
            "water_as_ground_pct": round(100 * float(mask[water].mean()), 2)
            if water.any()
            else None,
            "note": result.note or None,
        }
        causes[name] = error_causes(sim, ref, mask, scored, tags)
    a, m = methods.get("auto", {}), methods.get("smrf", {})
    ok = "total_pct" in a
    passed = {
        "total_pct": bool(ok and a["total_pct"] <= SWEEP_TARGETS["total_pct_max"]),
        "kappa": bool(ok and a["kappa"] >= SWEEP_TARGETS["kappa_min"]),
        "vs_smrf": bool(
            ok
            and "total_pct" in m
            and a["total_pct"] - m["total_pct"] <= SWEEP_TARGETS["vs_smrf_total_pct_max"]
        ),
    }
    charge = causes.get("auto", {}).get("charge", {})
    return {
        "dataset": f"sweep/{SWEEP_FAMILY}",
        "seed": seed,
        "params": {k: sim.params.get(k) for k in SWEEP_KEYS},
        "n_scored": int(scored.sum()),
        "n_water": int(water.sum()),
        "n_outliers": int(res.outlier.sum()),
        "generate_s": round(gen_s, 3),
        "methods": methods,
        "passed": passed,
        "all_passed": all(passed.values()),
        "auto_dominant_error": next(iter(charge), None),
        "causes": causes,
    }


def sweep_summary(rows: list[dict]) -> dict:
    """The last line of a sweep: pass shares, means, worst draw, error causes over the draws."""
    n = len(rows)
    mean = {}
    for name in SWEEP_METHODS:
        ok = [r["methods"][name] for r in rows if "total_pct" in r["methods"].get(name, {})]
        if ok:
            mean[name] = {
                k: round(float(np.mean([o[k] for o in ok])), 3)
                for k in ("type1_pct", "type2_pct", "total_pct", "kappa")
            }
            mean[name]["points_per_s"] = round(float(np.median([o["points_per_s"] for o in ok])))
            mean[name]["draws"] = len(ok)
    bands = {"<1": (0, 1), "1-5": (1, 5), ">=5": (5, np.inf)}
    by_density = {}
    for band, (lo, hi) in bands.items():
        sel = [
            r
            for r in rows
            if lo <= r["params"]["density_per_m2"] < hi
            and "total_pct" in r["methods"].get("auto", {})
        ]
        if sel:
            by_density[band] = {
                "draws": len(sel),
                **{
                    f"{m}_total_pct": round(
                        float(
                            np.mean(
                                [
                                    r["methods"][m]["total_pct"]
                                    for r in sel
                                    if "total_pct" in r["methods"][m]
                                ]
                            )
                        ),
                        3,
                    )
                    for m in SWEEP_METHODS
                },
            }

    def auto_total(r: dict) -> float:
        return r["methods"].get("auto", {}).get("total_pct", float("inf"))

    worst = max(rows, key=auto_total) if rows else None
    dominant: dict[str, int] = {}
    for r in rows:
        if r["auto_dominant_error"]:
            dominant[r["auto_dominant_error"]] = dominant.get(r["auto_dominant_error"], 0) + 1
    return {
        "dataset": f"sweep/{SWEEP_FAMILY}",
        "metric": "summary",
        "draws": n,
        "seeds": [rows[0]["seed"], rows[-1]["seed"]] if rows else [],
        "value": round(sum(r["all_passed"] for r in rows) / max(n, 1), 4),
        "all_targets_share": round(sum(r["all_passed"] for r in rows) / max(n, 1), 4),
        "pass_share": {
            k: round(sum(r["passed"][k] for r in rows) / max(n, 1), 4)
            for k in ("total_pct", "kappa", "vs_smrf")
        },
        "targets": SWEEP_TARGETS,
        "mean": mean,
        "by_density": by_density,
        "worst": {
            "seed": worst["seed"],
            "auto": worst["methods"].get("auto"),
            "dominant_error": worst["auto_dominant_error"],
        }
        if worst
        else None,
        "auto_dominant_error_count": dict(sorted(dominant.items(), key=lambda kv: -kv[1])),
        "generate_s_total": round(sum(r["generate_s"] for r in rows), 2),
        "generate_s_mean": round(float(np.mean([r["generate_s"] for r in rows])), 3)
        if rows
        else None,
        "outliers_scored_as": "objects (accepted outlier = Type II); water left out",
    }


def run_sweep(n: int, first_seed: int) -> None:
    """``--sweep N``: one JSON line per draw, then the summary line."""
    rows = []
    for seed in range(first_seed, first_seed + n):
        row = sweep_draw(seed)
        emit(**row)
        rows.append(row)
    emit(**sweep_summary(rows))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument(
        "parts",
        nargs="*",
        help="isprs, ahn3, speed, tiles, synthetic, csf_sample, bad_input (default all)",
    )
    parser.add_argument(
        "--sweep",
        type=int,
        metavar="N",
        help="run N draws of the terrain family instead of the parts",
    )
    parser.add_argument(
        "--first-seed", type=int, default=0, metavar="S", help="first seed of the sweep (default 0)"
    )
    args = parser.parse_args()
    if args.sweep is not None:
        if args.sweep < 1 or args.first_seed < 0:
            parser.error("--sweep needs N >= 1 and --first-seed S >= 0")
        run_sweep(args.sweep, args.first_seed)
        return
    if not SHARED_DATA.is_dir():
        emit(dataset="none", metric="skipped", value=None, reason=f"{SHARED_DATA} absent")
        return
    parts = {
        "isprs": bench_isprs,
        "ahn3": bench_ahn3,
        "speed": bench_speed,
        "tiles": bench_tiles,
        "synthetic": bench_synthetic_10m,
        "csf_sample": bench_csf_sample,
        "bad_input": bench_bad_input,
    }
    chosen = args.parts or list(parts)
    unknown = [c for c in chosen if c not in parts]
    if unknown:
        raise SystemExit(f"unknown part(s) {unknown}; choose from {', '.join(parts)}")
    for name in chosen:
        parts[name]()


if __name__ == "__main__":
    interruptible(main)
