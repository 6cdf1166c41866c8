"""IFC export on the supports and roof families (issue 18); prints JSON.

Per draw: ``heracles simulate`` of the family, the step on its cloud (``heracles
supports`` or ``heracles beams``), :func:`pyheracles.export.ifc.export_ifc` of the
output folder, then against the issue's targets:

* ``nonempty``: the model holds at least one element (a draw where the step found
  nothing meets the other targets vacuously; it is counted as a miss);
* ``count_ok``: one IFC element per objects-table row of an exported class (column,
  pier, engaged_column; every beam), found by the GUID the export reports;
* ``max_dim_err_m`` <= 1 mm: dimensions read back from each element's solid (the
  ``IfcExtrudedAreaSolid`` / ``IfcRevolvedAreaSolid`` parameters and its placement's
  axis; the body's first item is the shaft, further items are slabs of the plinth /
  base and capital / abacus bands) against the table: radius and axial length of a
  column (for a solid of revolution its mean station radius), length and width and
  height of a pier box and of a member;
* ``validate_errors`` == 0 (``ifcopenshell.validate``, errors only);
* surface RMS <= 1 cm: the reopened element triangulated with ``ifcopenshell.geom``
  (world coordinates), its triangles sampled by area, and for each labelled point of
  the element the exact distance to the triangles of its nearest samples; per draw the
  median and the worst element.  ``rms_all`` uses every point the step labelled with
  the element (this is the target); ``rms_modelled`` only those the primitive models
  (supports: true part ``shaft``, i.e. without plinth, base and capital mouldings;
  roof: true class ``beam`` or ``loose_timber``), both without the simulator's
  outliers; an element without such points (a false detection) is listed under
  ``no_modelled_points`` and not judged on them.  An element whose
  ``rms_all`` misses while its ``rms_modelled`` meets is a limit of the primitive (a
  cylinder has no capital), listed under ``unmodelled_parts``.

Summary per family: share of draws meeting every target, the worst seed; also the share
meeting them with the RMS of the modelled points (``all_targets_modelled``).

    python benchmarks/bench_ifc.py --family both --sweep 10
    python benchmarks/bench_ifc.py --family roof --sweep 2 --seed-start 5
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import math
import os
import tempfile
import time
from pathlib import Path
from typing import Any

from _common import interruptible

import numpy as np
import pandas as pd

SUPPORT_CLASSES = ("column", "pier", "engaged_column")
DIM_TOL_M = 0.001
RMS_TOL_M = 0.01


def point_triangle_distance(p: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """Distance of points ``p`` (N, 3) to triangles ``tri`` (N, 3, 3), pairwise.

    Closest point on a triangle by its Voronoi regions (vertices, edges, face).
    """
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    ab, ac, ap = b - a, c - a, p - a

    def dot(u: np.ndarray, v: np.ndarray) -> np.ndarray:
        return np.einsum("ij,ij->i", u, v)

    d1, d2 = dot(ab, ap), dot(ac, ap)
    bp, cp = p - b, p - c
    d3, d4 = dot(ab, bp), dot(ac, bp)
    d5, d6 = dot(ab, cp), dot(ac, cp)
    va = d3 * d6 - d5 * d4
    vb = d5 * d2 - d1 * d6
    vc = d1 * d4 - d3 * d2
    with np.errstate(divide="ignore", invalid="ignore"):
        denom = va + vb + vc
        v = vb / denom
        w = vc / denom
        q = a + v[:, None] * ab + w[:, None] * ac  # face region
        t_ab = d1 / (d1 - d3)
        t_ac = d2 / (d2 - d6)
        t_bc = (d4 - d3) / ((d4 - d3) + (d5 - d6))
    reg = [
        (d1 <= 0) & (d2 <= 0),
        (d3 >= 0) & (d4 <= d3),
        (d6 >= 0) & (d5 <= d6),
        (vc <= 0) & (d1 >= 0) & (d3 <= 0),
        (vb <= 0) & (d2 >= 0) & (d6 <= 0),
        (va <= 0) & ((d4 - d3) >= 0) & ((d5 - d6) >= 0),
    ]
    cand = [a, b, c, a + t_ab[:, None] * ab, a + t_ac[:, None] * ac,
            b + t_bc[:, None] * (c - b)]  # fmt: skip
    done = np.zeros(len(p), dtype=bool)
    for m, x in zip(reg, cand, strict=True):
        m = m & ~done
        q[m] = x[m]
        done |= m
    return np.linalg.norm(p - q, axis=1)


def surface_distances(verts: np.ndarray, faces: np.ndarray, pts: np.ndarray,
                      rng: np.random.Generator, k: int = 8) -> np.ndarray:  # fmt: skip
    """Distance of each point to a triangulated surface: nearest samples, then exact."""
    from scipy.spatial import cKDTree

    tri = verts[faces]
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    keep = area > 0
    tri, area = tri[keep], area[keep]
    n = int(min(400_000, max(20_000, area.sum() / 0.01**2)))  # about one per cm^2
    idx = np.r_[np.arange(len(tri)), rng.choice(len(tri), n, p=area / area.sum())]
    a, b = rng.random((2, len(idx)))
    flip = a + b > 1
    a[flip], b[flip] = 1 - a[flip], 1 - b[flip]
    a[: len(tri)], b[: len(tri)] = 1 / 3, 1 / 3  # every triangle's centroid too
    s = tri[idx, 0] + a[:, None] * (tri[idx, 1] - tri[idx, 0]) + b[:, None] * (
        tri[idx, 2] - tri[idx, 0])  # fmt: skip
    _, nn = cKDTree(s).query(pts, k=min(k, len(s)))
    nn = nn.reshape(len(pts), -1)
    best = np.full(len(pts), np.inf)
    for j in range(nn.shape[1]):
        best = np.minimum(best, point_triangle_distance(pts, tri[idx[nn[:, j]]]))
    return best


def _rms(d: np.ndarray) -> float | None:
    return float(np.sqrt(np.mean(d**2))) if len(d) else None


def solid_dimensions(el: Any) -> dict[str, Any]:
    """Dimensions of an element's first body solid, read from the IFC.

    Extruded circle: ``radius``, ``length`` (depth); extruded rectangle: ``x``, ``y``
    (profile XDim, YDim), ``length``; solid of revolution: ``radius`` (mean of the
    profile's interior stations; the bench takes it at the table's ``radius_height_m``
    when there is one), ``radius_base``, ``radius_top``, ``length`` (the profile's
    height), ``profile`` (its stations); a fluted shaft's face set: the same from the mean
    radius of each ring of its outline.  ``axis_z``: z of the placement's axis (world, unit).
    """
    item = el.Representation.Representations[0].Items[0]
    out: dict[str, Any] = {}
    if item.is_a("IfcExtrudedAreaSolid"):
        area = item.SweptArea
        out["length"] = float(item.Depth)
        if area.is_a("IfcCircleProfileDef"):
            out["radius"] = float(area.Radius)
        elif area.is_a("IfcRectangleProfileDef"):
            out["x"], out["y"] = float(area.XDim), float(area.YDim)
    elif item.is_a("IfcRevolvedAreaSolid"):
        ring = np.array([p.Coordinates for p in item.SweptArea.OuterCurve.Points], dtype=float)
        prof = ring[1:-2]  # closing point and the two axis points dropped
        out["radius"] = float(np.mean(prof[1:-1, 0]))
        out["profile"] = prof  # (radius, height) stations: the radius at a table height
        out["radius_base"], out["radius_top"] = float(prof[0, 0]), float(prof[-1, 0])
        out["length"] = float(np.ptp(prof[:, 1]))
    elif item.is_a("IfcPolygonalFaceSet"):  # a fluted shaft: rings of its outline
        xyz = np.array(item.Coordinates.CoordList, dtype=float)
        heights, ring = np.unique(np.round(xyz[:, 2], 9), return_inverse=True)
        radii = np.bincount(ring, np.hypot(xyz[:, 0], xyz[:, 1])) / np.bincount(ring)
        prof = np.column_stack([radii, heights])
        out["radius"] = float(np.mean(prof[1:-1, 0] if len(prof) > 2 else prof[:, 0]))
        out["length"] = float(np.ptp(heights))
        if len(prof) > 2:  # stations of a measured profile, as a solid of revolution's
            out["profile"] = prof
            out["radius_base"], out["radius_top"] = float(prof[0, 0]), float(prof[-1, 0])
    ax = el.ObjectPlacement.RelativePlacement.Axis
    out["axis_z"] = float(ax.DirectionRatios[2]) if ax is not None else 1.0
    return out


def expected_dimensions(row: pd.Series, family: str) -> dict[str, float]:
    """The same dimensions from an objects-table row (NaN where the table has none)."""
    if family == "roof":
        return {"length": row["length_m"], "x": row["width_m"], "y": row["height_m"]}
    if row["class"] == "pier":
        return {"x": row["box_length_m"], "y": row["box_width_m"], "length": row["box_height_m"]}
    az = abs(float(row["axis_z"]))
    return {"radius": row["radius_m"], "length": row["height_m"] / max(az, 1e-6)}


def _table(folder: Path) -> pd.DataFrame:
    if (folder / "objects.csv").exists():
        return pd.read_csv(folder / "objects.csv")
    import geopandas as gpd

    return pd.DataFrame(gpd.read_file(folder / "objects.gpkg").drop(columns="geometry"))


def run_draw(family: str, seed: int, keep: Path | None = None) -> dict:
    """Simulate, run the step, export and score one draw (see the module docstring).

    With ``keep``, the simulation and the step's output stay in ``keep/<family><seed>``
    (to score them again with :func:`score_draw` after a change of the export).
    """
    from pyheracles.cli import main as cli

    step = "supports" if family == "supports" else "beams"

    def heracles(argv: list[str]) -> int:
        with contextlib.redirect_stdout(io.StringIO()):  # the CLI's tables: not our JSON
            return cli(argv)

    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp) if keep is None else keep / f"{family}{seed}"
        q = ["-q", "--no-report"]
        t0 = time.perf_counter()
        if heracles([*q, "simulate", "-f", family, "--seed", str(seed), "-o", str(d / "sim")]):
            return {"seed": seed, "error": "simulate failed", "all_targets": False}
        t1 = time.perf_counter()
        if heracles([*q, step, str(d / "sim" / "cloud.laz"), "-o", str(d / "res")]):
            return {"seed": seed, "error": f"{step} failed", "all_targets": False}
        t2 = time.perf_counter()
        out = score_draw(family, seed, d)
    return {**out, "simulate_s": round(t1 - t0, 1), "step_s": round(t2 - t1, 1)}


def score_draw(family: str, seed: int, d: Path) -> dict:
    """Export ``d/res`` to IFC and score it against ``d/sim`` (see the module docstring)."""
    import ifcopenshell
    import ifcopenshell.geom
    import ifcopenshell.validate

    from pyheracles.export.ifc import export_ifc
    from pyheracles.io import read_cloud

    t2 = time.perf_counter()
    rep = export_ifc(d / "res", d / "model.ifc")
    t3 = time.perf_counter()
    ifc = ifcopenshell.open(str(d / "model.ifc"))
    log = ifcopenshell.validate.json_logger()
    ifcopenshell.validate.validate(ifc, log)
    errors = [s for s in log.statements if s.get("level", "error") == "error"]
    table = _table(d / "res")
    if family == "supports":
        table = table[table["class"].isin(SUPPORT_CLASSES)]
    cloud = read_cloud(d / "res" / "segmented.laz")
    truth = np.load(d / "sim" / "truth.npz")
    scene = json.loads((d / "sim" / "scene.json").read_text())
    parts = {v: int(k) for k, v in scene["parts"].items()}
    classes = {v: int(k) for k, v in scene["classes"].items()}
    inst = np.asarray(cloud.attributes["instance"])
    ok_pts = ~truth["outlier"].astype(bool)
    timber = [classes.get("beam", -1), classes.get("loose_timber", -1)]
    modelled = (truth["part"] == parts["shaft"] if family == "supports"
                else np.isin(truth["class_id"], timber))  # fmt: skip
    settings = ifcopenshell.geom.settings()
    settings.set("use-world-coords", True)
    mc = ifc.by_type("IfcMapConversion")
    # the model's origin is the map conversion's, else the cloud's offset (a local model)
    origin = (np.array([mc[0].Eastings, mc[0].Northings, mc[0].OrthogonalHeight])
              if mc else np.asarray(cloud.offset, dtype=np.float64))  # fmt: skip
    shift = np.asarray(cloud.offset, dtype=np.float64) - origin
    rng = np.random.default_rng(seed)
    elements = []
    for _, row in table.iterrows():
        i = int(row["instance"])
        e: dict[str, Any] = {"instance": i, "class": str(row["class"])}
        if family == "roof":
            e["role"] = str(row.get("role", ""))
        guid = rep.guids.get(i)
        if guid is None:
            e["missing"] = True
            elements.append(e)
            continue
        el = ifc.by_guid(guid)
        got, want = solid_dimensions(el), expected_dimensions(row, family)
        at = float(row.get("radius_height_m", np.nan))
        if "profile" in got and math.isfinite(at):  # the table's radius holds at that height
            prof = got.pop("profile")
            t_at = at / max(abs(float(row["axis_z"])), 1e-6)
            got["radius"] = float(np.interp(t_at, prof[:, 1], prof[:, 0]))
        got.pop("profile", None)
        e["ifc"] = el.is_a() + ("/revolved" if "radius_base" in got else "")
        errs = {k: abs(got[k] - float(v)) if k in got and math.isfinite(float(v))
                else float("inf") for k, v in want.items()}  # fmt: skip
        e["dim_err_m"] = max(errs.values())
        e["dim_errs"] = {k: round(v, 5) for k, v in errs.items()}
        if family == "supports" and row["class"] != "pier":
            e["axis_z_err"] = abs(got["axis_z"] - abs(float(row["axis_z"])))
        shape = ifcopenshell.geom.create_shape(settings, el)
        v = np.asarray(shape.geometry.verts, dtype=np.float64).reshape(-1, 3)
        f = np.asarray(shape.geometry.faces, dtype=np.int64).reshape(-1, 3)
        mine = (inst == i) & ok_pts
        dist = surface_distances(v, f, cloud.xyz[mine] + shift, rng)
        e["n_points"] = int(mine.sum())
        e["rms_all_m"] = _rms(dist)
        e["rms_modelled_m"] = _rms(dist[modelled[mine]])
        e["share_unmodelled"] = float(1 - modelled[mine].mean()) if mine.any() else 0.0
        elements.append(e)
    t4 = time.perf_counter()
    n_el = sum(v for k, v in rep.elements.items() if k != "IfcOpeningElement")
    found = [e for e in elements if not e.get("missing")]
    rms = [e["rms_all_m"] for e in found if e["rms_all_m"] is not None]
    dim = max((e["dim_err_m"] for e in found), default=0.0)
    bad_rms = sorted((e for e in found if (e["rms_all_m"] or 0.0) > RMS_TOL_M),
                     key=lambda e: -e["rms_all_m"])  # fmt: skip
    count_ok = len(found) == len(table) == n_el
    # a model with no element meets the other targets vacuously: it is no pass
    targets = {"nonempty": n_el > 0, "count": count_ok, "dims_1mm": dim <= DIM_TOL_M,
               "valid": not errors, "rms_1cm": not bad_rms}  # fmt: skip
    worst = max(found, key=lambda e: e["rms_all_m"] or 0.0, default=None)
    # the same with the RMS of the modelled points only (no plinth / capital / foreign)
    mod = [e["rms_modelled_m"] for e in found]
    rms_mod_ok = all(m <= RMS_TOL_M for m in mod if m is not None)  # None: no such points
    return {
        "seed": seed, "family": family, "all_targets": all(targets.values()),
        "all_targets_modelled": rms_mod_ok and all(v for k, v in targets.items() if k != "rms_1cm"),
        "worst_rms_modelled_m": max((m for m in mod if m is not None), default=None),
        "median_rms_modelled_m": float(np.median([m for m in mod if m is not None]))
        if any(m is not None for m in mod) else None,
        "targets": targets, "misses": sum(not v for v in targets.values()),
        "rows": len(table), "elements": n_el, "by_class": rep.elements,
        "missing": [e["instance"] for e in elements if e.get("missing")],
        "n_rms_fail": len(bad_rms),
        "no_modelled_points": [e["instance"] for e in found if e["rms_modelled_m"] is None],
        "validate_errors": len(errors), "validate_first": [str(s)[:200] for s in errors[:2]],
        "max_dim_err_m": dim,
        "max_axis_z_err": max((e.get("axis_z_err", 0.0) for e in found), default=0.0),
        "dim_fail": [{k: e[k] for k in ("instance", "class", "ifc", "dim_errs")}
                     for e in found if e["dim_err_m"] > DIM_TOL_M][:6],
        "median_rms_m": float(np.median(rms)) if rms else None,
        "worst_rms_m": worst["rms_all_m"] if worst else None,
        "worst_rms_element": {k: worst.get(k) for k in ("instance", "class", "ifc",
                              "rms_all_m", "rms_modelled_m", "share_unmodelled")}
        if worst else None,
        "rms_fail": [{k: e.get(k) for k in ("instance", "class", "role", "ifc", "rms_all_m",
                      "rms_modelled_m", "share_unmodelled")} for e in bad_rms][:8],
        "unmodelled_parts": [e["instance"] for e in bad_rms
                             if (e["rms_modelled_m"] or 0.0) <= RMS_TOL_M],
        "revolved": sum(e.get("ifc", "").endswith("/revolved") for e in found),
        "notes": rep.notes[:5],
        "elements_detail": elements,
        "export_s": round(t3 - t2, 2), "check_s": round(t4 - t3, 1),
    }  # fmt: skip


def summary(draws: list[dict]) -> dict:
    """Share of draws meeting every target, per-target shares, the worst seed."""
    if not draws:
        return {}
    worst = max(draws, key=lambda r: (r.get("misses", 5), r.get("worst_rms_m") or 0.0))
    keys = ("nonempty", "count", "dims_1mm", "valid", "rms_1cm")
    return {
        "draws": len(draws),
        "share_all_targets": sum(r["all_targets"] for r in draws) / len(draws),
        "share_all_targets_modelled_points": sum(
            r.get("all_targets_modelled", False) for r in draws
        )
        / len(draws),
        "worst_rms_modelled_m": max(r.get("worst_rms_modelled_m") or 0.0 for r in draws),
        "share_per_target": {
            k: sum(r.get("targets", {}).get(k, False) for r in draws) / len(draws) for k in keys
        },
        "worst_seed": worst["seed"],
        "worst_misses": worst.get("misses"),
        "max_dim_err_m": max(r.get("max_dim_err_m", math.inf) for r in draws),
        "worst_rms_m": max(r.get("worst_rms_m") or 0.0 for r in draws),
        "median_of_median_rms_m": float(
            np.median(
                [r["median_rms_m"] for r in draws if r.get("median_rms_m") is not None] or [np.nan]
            )
        ),
        "elements_rms_over_1cm": sum(r.get("n_rms_fail", 0) for r in draws),
        "of_which_unmodelled_parts": sum(len(r.get("unmodelled_parts", [])) for r in draws),
        "load_average": os.getloadavg()[0],
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--family", choices=("supports", "roof", "both"), default="both")
    ap.add_argument("--sweep", type=int, default=1, metavar="N", help="draws per family")
    ap.add_argument("--seed-start", type=int, default=0, metavar="S", help="first seed")
    ap.add_argument(
        "--keep",
        type=Path,
        default=None,
        metavar="DIR",
        help="keep each draw's simulation and step output in DIR/<family><seed>",
    )
    ap.add_argument(
        "--rescore",
        action="store_true",
        help="with --keep: export and score the kept draws again (no new step run)",
    )
    ap.add_argument("--detail", action="store_true", help="per-element results too")
    args = ap.parse_args()
    fams = ("supports", "roof") if args.family == "both" else (args.family,)
    out: dict = {}
    seeds = range(args.seed_start, args.seed_start + args.sweep)
    for fam in fams:
        if args.rescore and args.keep is not None:
            draws = [score_draw(fam, s, args.keep / f"{fam}{s}") for s in seeds]
        else:
            draws = [run_draw(fam, s, args.keep) for s in seeds]
        if not args.detail:
            for r in draws:
                r.pop("elements_detail", None)
        out[f"{fam}_summary"] = summary(draws)
        out[f"{fam}_draws"] = draws
    print(json.dumps(out, indent=1, default=float))


if __name__ == "__main__":
    interruptible(main)
