"""Reports of a bundle adjustment: DBAT-style text report and ``report.json``.

The text report follows the section layout of DBAT's ``bundle_result_file`` so
that our results and DBAT's can be compared line by line (same labels, same
units: camera unit mm, object unit m, angles in degrees).
"""

from __future__ import annotations

import datetime as _dt
from pathlib import Path

import numpy as np

from pyheracles.bundle.camera import IO_NAMES
from pyheracles.bundle.diagnostics import (
    control_point_residuals,
    data_snooping,
    high_correlations,
    image_statistics,
    ray_angles,
)

__all__ = ["failure_text", "report_dict", "report_text", "write_failure_report", "write_reports"]

_CAM_LABELS = {
    "cc": ("Camera Constant", "mm"),
    "px": ("px - principal point x", "mm"),
    "py": ("py - principal point y", "mm"),
    "K1": ("K1 - radial distortion 1", "mm^(-3)"),
    "K2": ("K2 - radial distortion 2", "mm^(-5)"),
    "K3": ("K3 - radial distortion 3", "mm^(-7)"),
    "P1": ("P1 - decentering distortion 1", "mm^(-3)"),
    "P2": ("P2 - decentering distortion 2", "mm^(-3)"),
    "as": ("as - off-unit aspect parameter", ""),
    "sk": ("sk - skew", ""),
}
_CAM_ORDER = ("cc", "px", "py", "K1", "K2", "K3", "P1", "P2", "as", "sk")
_EO_LABELS = (("omega", "Omega", 3), ("phi", "Phi", 4), ("kappa", "Kappa", 5),
              ("X0", "Xc", 0), ("Y0", "Yc", 1), ("Z0", "Zc", 2))  # fmt: skip
_DAMPING_NAMES = {"gna": "gna", "lm": "lm", "gn": "none"}


def report_dict(result, *, threshold: float = 0.95, top: int = 20) -> dict:
    """Everything the reports show, as plain JSON-serialisable data.

    Keys: ``sigma0``, ``redundancy``, ``iterations``, ``n_observations``,
    ``n_parameters``, ``cameras`` (values and standard deviations), ``images``
    (EO, standard deviations, statistics), ``control_points``, ``check_points``,
    ``correlations``, ``points`` (summary), ``data_snooping``.
    """
    p = result.project
    net = result.network
    hc = high_correlations(result, threshold)
    cps = control_point_residuals(result)
    stats = image_statistics(result)
    angles = ray_angles(result)
    snoop = data_snooping(result)
    rays = p.rays()
    cams = []
    for ci, cam in enumerate(p.cameras):
        cams.append(
            {
                "id": cam.id,
                "name": cam.name,
                "model": cam.model,
                "image_size_px": list(cam.image_size_px),
                "pixel_size_mm": (cam.pixel_size_mm * [1.0 + result.io[ci, 3], 1.0]).tolist(),
                "estimated": [IO_NAMES[j] for j in np.flatnonzero(net.io_free[ci])],
                "values": dict(zip(IO_NAMES, result.io[ci].tolist(), strict=True)),
                "std": dict(zip(IO_NAMES, result.io_std[ci].tolist(), strict=True)),
                "high_correlations": [
                    {"pair": list(c["pair"]), "r": c["r"]}
                    for c in hc["io"]
                    if c["camera_index"] == ci
                ],
            }
        )
    images = []
    for i in range(p.n_images):
        eo = result.eo[i]
        sd = result.eo_std[i]
        images.append({
            "id": int(p.image_ids[i]),
            "name": p.image_names[i],
            "camera": int(p.cameras[p.image_camera[i]].id),
            "X0": eo[0], "Y0": eo[1], "Z0": eo[2],
            "omega_deg": float(np.degrees(eo[3])), "phi_deg": float(np.degrees(eo[4])),
            "kappa_deg": float(np.degrees(eo[5])),
            "std": {"X0": sd[0], "Y0": sd[1], "Z0": sd[2], "omega_deg": float(np.degrees(sd[3])),
                    "phi_deg": float(np.degrees(sd[4])), "kappa_deg": float(np.degrees(sd[5]))},
            "estimated": [n for n, f in zip(("X0", "Y0", "Z0", "omega", "phi", "kappa"),
                                            net.eo_free[i], strict=True) if f],
            "high_correlations": [
                {"pair": list(c["pair"]), "r": c["r"]} for c in hc["eo"] if c["image_index"] == i
            ],
            **{k: stats[i][k] for k in ("n_points", "rms_px", "coverage_rect", "coverage_hull",
                                        "mean_ray_angle_deg")},
        })  # fmt: skip
    tie = net.op_free.any(axis=1) & (p.point_role == "tie")
    # DBAT's "total standard deviation": sqrt(sX^2 + sY^2 + sZ^2).
    total_std = np.sqrt(np.sum(result.xyz_std**2, axis=1))
    flagged = snoop["flagged"][:top]
    return {
        "project": p.name,
        "source": p.source,
        "created": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
        "status": result.status,
        "converged": result.converged,
        "sigma0": result.sigma0,
        "sigma0_px": result.sigma0 * float(np.median(p.obs_std_px)),
        "redundancy": result.redundancy,
        "iterations": result.iterations,
        "n_observations": result.n_observations,
        "n_image_observations": 2 * p.n_observations,
        "n_parameters": result.n_parameters,
        "n_parameters_io": int(net.io_free.sum()),
        "n_parameters_eo": int(net.eo_free.sum()),
        "n_parameters_op": int(net.op_free.sum()),
        "damping": result.parameters.damping,
        "datum": net.datum,
        "residual_norm_history": result.history["residual_norm"],
        "timings_s": result.timings,
        "cameras": cams,
        "images": images,
        "control_points": cps["control"],
        "check_points": cps["check"],
        "correlations": {
            "threshold": threshold,
            "io": [dict(c, pair=list(c["pair"])) for c in hc["io"]],
            "eo": [dict(c, pair=list(c["pair"])) for c in hc["eo"]],
            "op_pairs_above": hc["op"]["n_pairs_above"],
            "op_pairs_above_99": hc["op"]["n_pairs_above_99"],
            "op_points_above": hc["op"]["n_above"],
            "op_share_points_above": hc["op"]["share"],
            "op_top": hc["op"]["top"],
        },
        "points": {
            "n_points": int(p.n_points),
            "n_tie": int(tie.sum()),
            "rays_min": int(rays.min()),
            "rays_max": int(rays.max()),
            "rays_mean": float(rays.mean()),
            "rays_histogram": {int(k): int(v) for k, v in enumerate(np.bincount(rays)) if v},
            "angle_min_deg": float(angles[tie].min()) if tie.any() else None,
            "angle_max_deg": float(angles[tie].max()) if tie.any() else None,
            "angle_mean_deg": float(angles[tie].mean()) if tie.any() else None,
            "std_total_min": float(total_std[tie].min()) if tie.any() else None,
            "std_total_max": float(total_std[tie].max()) if tie.any() else None,
            "std_max_xyz": result.xyz_std[tie].max(axis=0).tolist() if tie.any() else None,
            # RMS of the residual vector lengths (DBAT's "overall point RMS").
            "residual_rms_px": float(np.sqrt(np.mean(np.sum(result.residuals_px**2, axis=1)))),
            "residual_max_px": float(np.max(np.linalg.norm(result.residuals_px, axis=1))),
        },
        "data_snooping": {
            "test": snoop["test"],
            "description": snoop["description"],
            "sigma": snoop["sigma"],
            "critical": snoop["critical"],
            "critical_w": snoop["critical"],
            "n_flagged": snoop["n_flagged"],
            "worst": [
                {
                    "image": int(p.image_ids[p.obs_image[k]]),
                    "point": int(p.point_ids[p.obs_point[k]]),
                    "statistic": float(np.max(np.abs(snoop["statistic"][k]))),
                    "w": float(np.max(np.abs(snoop["w"][k]))),
                    "tau": float(np.max(np.abs(snoop["tau"][k]))),
                    "residual_px": result.residuals_px[k].tolist(),
                }
                for k in flagged
            ],
        },
        "control_file": p.meta.get("control"),
        "control_point_tests": {
            k: _json_test(result.diagnosis.get(f"control_test_{k}")) for k in ("before", "after")
        },
        "gross_control_points": {
            k: list(result.diagnosis.get(f"control_test_{k}", {}).get("gross", []))
            for k in ("before", "after")
        },
        "rank_deficiency": result.rank_deficiency,
        "object_points": _object_points(result, rays),
    }


def _g(v) -> str:
    return "n/a" if v is None else f"{v:.3g}"


def _json_test(test: dict | None) -> dict | None:
    if test is None:
        return None
    return {k: v for k, v in test.items()}


def _object_points(result, rays: np.ndarray) -> dict:
    """Every object point, columnar: id, label, role, X Y Z, sX sY sZ, rays."""
    p = result.project
    std = result.xyz_std if result.xyz_std is not None else np.full_like(result.xyz, np.nan)
    return {
        "columns": ["id", "label", "role", "X", "Y", "Z", "sX", "sY", "sZ", "rays"],
        "id": p.point_ids.astype(int).tolist(),
        "label": list(p.point_labels),
        "role": [str(r) for r in p.point_role],
        "xyz": np.round(result.xyz, 9).tolist(),
        "std": np.round(std, 12).tolist(),
        "rays": rays.astype(int).tolist(),
    }


def _fmt_val(v: float) -> str:
    return f"{v:g}" if abs(v) < 1e-3 and v != 0 else f"{v:.6g}"


def report_text(result, data: dict | None = None) -> str:
    """DBAT-style text report (section names and labels of DBAT's result file)."""
    d = data or report_dict(result)
    p = result.project
    net = result.network
    L: list[str] = []
    add = L.append
    add("Damped Bundle Adjustment Toolbox result file (pyheracles re-implementation)")
    add("   Project")
    add(f"      Name             : {d['project']}")
    add(f"      Input file name  : {d['source']}")
    add("   Problems and suggestions:")
    add("      Project Problems:")
    add("         Structural rank: ok.")
    add("         Numerical rank: ok.")
    probs = []
    if any(c["high_correlations"] for c in d["cameras"]):
        probs.append("One or more of the camera parameter has a high correlation (see below).")
    if d["correlations"]["eo"]:
        probs.append(
            "One or more of the camera station parameters has a high correlation (see below)."
        )
    if d["correlations"]["op_pairs_above"]:
        probs.append("One or more of the object point coordinates has a high correlation.")
    if d["data_snooping"]["n_flagged"]:
        sym = "tau" if d["data_snooping"]["test"] == "tau" else "w"
        probs.append(
            f"{d['data_snooping']['n_flagged']} image observation(s) fail the data "
            f"snooping test (|{sym}| > {d['data_snooping']['critical']:.2f}, "
            f"{d['data_snooping']['description']})."
        )
    for when in ("before", "after"):
        gross = d["gross_control_points"][when]
        if gross:
            probs.append(
                f"Gross control/check point(s) {when} the adjustment (most discrepant "
                f"first): {', '.join(str(g) for g in gross[:10])}."
            )
    add(f"      Problems related to the processing: ({len(probs)})")
    for s in probs:
        add(f"         {s}")
    add("   Information from last bundle")
    add(f"      Last Bundle Run:        {d['created']}")
    add(f"      Status:                 {'OK' if d['converged'] else d['status']}")
    add(f"      Sigma0:                 {d['sigma0']:.6g}")
    add(f"      Sigma0 (pixels):        {d['sigma0_px']:.6g}")
    add(f"      Redundancy              {d['redundancy']}")
    add(
        f"      Number of params:       {d['n_parameters']} ({d['n_parameters_io']} IO, "
        f"{d['n_parameters_eo']} EO, {d['n_parameters_op']} OP)"
    )
    n_prior = d["n_observations"] - d["n_image_observations"]
    add(
        f"      Number of observations: {d['n_observations']} ({d['n_image_observations']} IP, "
        f"0 IO, {int(np.isfinite(net.eo_prior_std).sum())} EO, "
        f"{n_prior - int(np.isfinite(net.eo_prior_std).sum())} OP)"
    )
    ctl = d.get("control_file")
    if ctl:
        add("      Control file:")
        add(f"         File:    {ctl['source']}")
        add(
            f"         Layout:  {', '.join(ctl['layout'] or [])} "
            f"({'from its header' if ctl['header'] else 'positional grammar'}); "
            f"{ctl['n_control']} control, {ctl['n_check']} check points used"
        )
        for line in ctl["echo"]:
            add(f"         {line}")
    add("      Processing options:")
    add(f"         Maximum # of iterations: {result.parameters.max_iterations}")
    add(f"         Convergence tolerance:   {result.parameters.tolerance:g}")
    add("         Termination criteria:    relative")
    add(f"         Damping:                 {_DAMPING_NAMES[result.parameters.damping]}")
    add(f"         Datum:                   {d['datum']}")
    add("         Camera unit (cu):        mm")
    add("         Object space unit (ou):  m")
    add("      Total error:")
    add(f"         Number of iterations: {d['iterations']}")
    add(f"         First error:          {d['residual_norm_history'][0]:.6g}")
    add(f"         Last error:           {d['residual_norm_history'][-1]:.6g}")
    add("      Execution times (s):")
    for k, v in d["timings_s"].items():
        add(f"         {k + ':':<15}{v:.2f}")
    add("      Lens distortion models:")
    add(f"         Backward (Photogrammetry) model {p.cameras[0].model}")
    add("      Cameras:")
    for cam in d["cameras"]:
        est = cam["estimated"]
        add(f"         Calibration: {'yes (' + ' '.join(est) + ')' if est else 'no'}")
        add(f"         Camera{cam['id']} (simple)")
        corr = {}
        for c in cam["high_correlations"]:
            a, b = c["pair"]
            corr.setdefault(a, []).append(f"{b}:{100 * c['r']:.1f}%")
            corr.setdefault(b, []).append(f"{a}:{100 * c['r']:.1f}%")
        for name in _CAM_ORDER:
            label, unit = _CAM_LABELS[name]
            add(f"            {label}:")
            add(f"               Value:        {_fmt_val(cam['values'][name])} {unit}".rstrip())
            if name in est:
                add(f"               Deviation:    {cam['std'][name]:.3g} {unit}".rstrip())
            if name in corr:
                add(f"               Correlations over 95%: {', '.join(corr[name])}.")
            if name == "py":
                w, h = cam["image_size_px"]
                pw, ph = cam["pixel_size_mm"]
                add("            Format width:")
                add(f"               Value:        {w * pw:.6g} mm")
                add("            Format height:")
                add(f"               Value:        {h * ph:.6g} mm")
        w, h = cam["image_size_px"]
        add("            Image width:")
        add(f"               Value:        {w} px")
        add("            Image height:")
        add(f"               Value:        {h} px")
        add("            Pixel width:")
        add(f"               Value:        {cam['pixel_size_mm'][0]:.6g} mm")
        add("            Pixel height:")
        add(f"               Value:        {cam['pixel_size_mm'][1]:.6g} mm")
    add("      Precisions / Standard Deviations:")
    add("         Photograph Standard Deviations:")
    for k, im in enumerate(d["images"], 1):
        add(f"            Photo {k}: {im['name']}")
        corr = {}
        for c in im["high_correlations"]:
            a, b = c["pair"]
            corr.setdefault(a, []).append(
                f"{dict((x[0], x[1]) for x in _EO_LABELS)[b]}:{100 * c['r']:.1f}%"
            )
            corr.setdefault(b, []).append(
                f"{dict((x[0], x[1]) for x in _EO_LABELS)[a]}:{100 * c['r']:.1f}%"
            )
        for key, label, j in _EO_LABELS:
            ang = j >= 3
            val = im[f"{key}_deg"] if ang else im[key]
            sd = im["std"][f"{key}_deg" if ang else key]
            unit = "deg" if ang else "ou"
            add(f"               {label}:")
            add(f"                  Value:     {val:.6f} {unit}")
            if key in im["estimated"]:
                add(f"                  Deviation: {sd:.3g} {unit}")
            if key in corr:
                add(f"                  Correlations over 95%: {', '.join(corr[key])}.")
    add("   Quality")
    add("      Photographs")
    add(f"         Total number: {p.n_images}")
    add("      Point Measurements")
    add(f"         Number of control pts: {int((p.point_role == 'control').sum())}")
    add(f"         Number of check pts: {int((p.point_role == 'check').sum())}")
    pts = d["points"]
    add(f"         Number of object pts: {pts['n_tie']}")
    add(f"         OP ray count: {pts['rays_min']}-{pts['rays_max']} ({pts['rays_mean']:.1f} avg)")
    for k, v in pts["rays_histogram"].items():
        add(f"            {v} points with {k} rays.")
    add("      Point Marking Residuals")
    add(f"         Overall point RMS: {pts['residual_rms_px']:.3f} pixels")
    add(f"         Maximum: {pts['residual_max_px']:.3f} pixels")
    rms = [im["rms_px"] for im in d["images"]]
    i0, i1 = int(np.argmin(rms)), int(np.argmax(rms))
    add("         Photo residuals (RMS over all points in an image):")
    add(
        f"            Minimum: {rms[i0]:.3f} pixels (photo {i0 + 1} over "
        f"{d['images'][i0]['n_points']} points)"
    )
    add(
        f"            Maximum: {rms[i1]:.3f} pixels (photo {i1 + 1} over "
        f"{d['images'][i1]['n_points']} points)"
    )
    if pts["std_total_min"] is not None:
        add("      Point Precision")
        add("         Total standard deviation (sqrt of sum of X/Y/Z variances):")
        add(f"            Minimum: {pts['std_total_min']:.2g}")
        add(f"            Maximum: {pts['std_total_max']:.2g}")
        for ax, v in zip("XYZ", pts["std_max_xyz"], strict=True):
            add(f"         Maximum {ax} standard deviation: {v:.2g}")
        c = d["correlations"]
        add("         Points with high correlations")
        add(f"            Points with correlation above 95%: {c['op_pairs_above']}")
        add(f"            Points with correlation above 99%: {c['op_pairs_above_99']}")
        add(
            f"            Share of points with a correlation above 95%: "
            f"{100 * c['op_share_points_above']:.1f}%"
        )
        if c["op_pairs_above"]:
            add("            Points with highest correlations:")
            for pid, r in c["op_top"]:
                add(f"               Points {pid}: {100 * r:.2f}")
        add("      Point Angles")
        add("         OP")
        add(f"            Minimum: {pts['angle_min_deg']:.1f} degrees")
        add(f"            Maximum: {pts['angle_max_deg']:.1f} degrees")
        add(f"            Average: {pts['angle_mean_deg']:.1f} degrees")
    for role, title in (("control_points", "Ctrl measurements"),
                        ("check_points", "Check measurements")):  # fmt: skip
        add(f"      {title}")
        grp = d[role]
        if not grp["points"]:
            add("         none")
            continue
        add("         id        label       dX          dY          dZ")
        for q in grp["points"]:
            r = q["residual"]
            add(f"         {q['id']:<9} {q['label']:<10} {r[0]:+.5f} {r[1]:+.5f} {r[2]:+.5f}")
        add(
            f"         RMS                  {grp['rms'][0]:.5f}  {grp['rms'][1]:.5f}  "
            f"{grp['rms'][2]:.5f}  (3D {grp['rms_3d']:.5f})"
        )
    for when in ("before", "after"):
        test = d["control_point_tests"][when]
        if not test or not test["points"]:
            continue
        add(f"      Control/check points against their intersection ({when} the adjustment)")
        add(
            f"         chi2(3) critical value {test['critical']:.2f} at alpha {test['alpha']:g}, "
            f"sigma {test['sigma']:.4g}; median |delta| {test['median_delta']:.4g} ou"
        )
        add("         id        label      role     rays  |delta| (ou)   T         gross")
        for q in test["points"]:
            add(
                f"         {q['id']:<9} {q['label']:<10} {q['role']:<8} {q['rays']:<5} "
                f"{q['delta_norm']:<14.5g} {_g(q['T']):<9} {'GROSS' if q['gross'] else ''}"
            )
    ds = d["data_snooping"]
    sym = "tau" if ds["test"] == "tau" else "w"
    add(f"      Data snooping ({ds['description']}) on image coordinates")
    add(f"         Critical value: {ds['critical']:.2f}; flagged observations: {ds['n_flagged']}")
    for q in ds["worst"]:
        add(
            f"            OP {q['point']} on image {q['image']}: |{sym}| = {q['statistic']:.2f}, "
            f"residual ({q['residual_px'][0]:+.2f}, {q['residual_px'][1]:+.2f}) px"
        )
    add("End of result file")
    return "\n".join(L) + "\n"


def failure_text(diagnosis: dict, project_name: str, message: str) -> str:
    """Text report of a failed adjustment: what went wrong and where to look."""
    L = ["Damped Bundle Adjustment Toolbox result file (pyheracles re-implementation)",
         "   Project", f"      Name             : {project_name}",
         "   Bundle adjustment FAILED", f"      Error: {message}",
         f"      Status: {diagnosis.get('status', '')}",
         f"      Iterations: {diagnosis.get('iterations')}",
         f"      Datum: {diagnosis.get('datum')}",
         f"      Redundancy: {diagnosis.get('redundancy')}",
         f"      Sigma0 at the last iterate: {diagnosis.get('sigma0_last')}",
         "      Residual norm per iteration: "
         + ", ".join(f"{x:.6g}" for x in diagnosis.get("residual_norm_history", []))]  # fmt: skip
    for x in diagnosis.get("rank_deficiency", []):
        L.append(
            f"      Rank defect (eigenvalue {x['eigenvalue']:.3g}): {', '.join(x['parameters'])}"
        )
    for when in ("before", "after"):
        test = diagnosis.get(f"control_test_{when}") or {}
        if test.get("gross"):
            L.append(f"      Gross control/check points {when}: {test['gross']}")
        for q in test.get("points", []):
            L.append(
                f"         {when:<6} {q['id']:<9} {q['label']:<10} |delta| {q['delta_norm']:.5g} "
                f"T {_g(q['T'])}{' GROSS' if q['gross'] else ''}"
            )
    L.append("      Worst observations (weighted residual):")
    for q in diagnosis.get("worst_observations", []):
        L.append(
            f"         OP {q['point']} ({q['label']}) on image {q['image']}: "
            f"{q['weighted_residual']:.4g} ({q['residual_px'][0]:+.2f}, "
            f"{q['residual_px'][1]:+.2f}) px"
        )
    L.append("End of result file")
    return "\n".join(L) + "\n"


def write_failure_report(diagnosis: dict, outdir: str | Path, project, message: str) -> dict:
    """Write ``report.txt`` and ``report.json`` of a failed run (its diagnosis)."""
    from pyheracles.io.atomic import atomic_write_json, atomic_write_text

    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    data = {"project": project.name, "source": project.source, "converged": False,
            "failed": True, "error": message, "control_file": project.meta.get("control"),
            "diagnosis": diagnosis}  # fmt: skip
    return {
        "report_txt": atomic_write_text(
            out / "report.txt", failure_text(diagnosis, project.name, message)
        ),
        "report_json": atomic_write_json(out / "report.json", data),
    }


def write_reports(result, outdir: str | Path, *, plots: bool = True) -> dict[str, Path]:
    """Write ``report.txt``, ``report.json`` (and plots) into ``outdir`` atomically."""
    from pyheracles.io.atomic import atomic_write_json, atomic_write_text

    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    data = report_dict(result)
    paths = {
        "report_txt": atomic_write_text(out / "report.txt", report_text(result, data)),
        "report_json": atomic_write_json(out / "report.json", data),
    }
    if plots:
        from pyheracles.bundle.plots import write_plots

        paths.update(write_plots(result, out))
    return paths
