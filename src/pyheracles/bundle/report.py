"""Reports of a bundle adjustment: DBAT-style text report and ``report.json``.

The text report follows the section layout of DBAT's ``bundle_result_file`` so
that our results and DBAT's can be compared line by line (same labels, same
units: camera unit mm, object unit m, angles in degrees).
"""

from __future__ import annotations

import datetime as _dt
import platform
import socket
import uuid
from pathlib import Path

import numpy as np

from pyheracles import __version__
from pyheracles.bundle import quality as qa
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
    xyz_std = result.xyz_std if result.xyz_std is not None else np.full_like(result.xyz, np.nan)
    total_std = np.sqrt(np.sum(xyz_std**2, axis=1))
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
            "std_max_xyz": xyz_std[tie].max(axis=0).tolist() if tie.any() else None,
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
        "uuid": str(uuid.uuid4()),
        "quality": _quality(result, angles),
    }


def _quality(result, angles: np.ndarray) -> dict:
    """DBAT's quality figures (see :mod:`pyheracles.bundle.quality`)."""
    has_cov = result.cov_cam is not None
    return {
        "significance": qa.distortion_significance(result) if has_cov else None,
        "camera_geometry": qa.camera_geometry(result),
        "coverage": qa.coverage(result),
        "calibrated_region": qa.calibrated_region(result),
        "rays": qa.ray_counts(result),
        "residuals": qa.residual_extremes(result),
        "precision": qa.point_precision(result),
        "angles": qa.angle_summary(result, angles),
        "reference": qa.reference_tables(result),
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


def _model_line(model: int) -> str:
    if model > 0:
        return f"Backward (Photogrammetry) model {model}"
    return f"Forward (Computer Vision) model {-model}"


def _pct_range(v: list[float], union: float) -> str:
    a = 100 * np.asarray(v, float)
    if not len(a):
        return "-"
    return (f"{round(a.min()):d}%-{round(a.max()):d}% ({round(a.mean()):d}% average, "
            f"{round(100 * union):d}% union)")  # fmt: skip


def _label(lab: str, pid: int) -> str:
    return f"{lab}, " if lab and lab != str(pid) else ""


def _header_lines(d: dict, result, add) -> None:
    p = result.project
    net = result.network
    add("   Project")
    add(f"      Name             : {d['project']}")
    add(f"      Computation UUID : {d['uuid']}")
    add(f"      Input file name  : {d['source']}")
    ctl = d.get("control_file")
    if ctl:
        add(f"      Ctrl pt file     : {ctl['source']}")
    add("   Problems and suggestions:")
    add("      Project Problems:")
    rank_ok = not d["rank_deficiency"]
    add(f"         Structural rank: {'ok' if rank_ok else 'deficient'}.")
    add(f"         Numerical rank: {'ok' if rank_ok else 'deficient'}.")
    probs = []
    if not d["converged"]:
        probs.append(f"Bundle failed ({d['status']}).")
    if any(c["high_correlations"] for c in d["cameras"]):
        probs.append("One or more of the camera parameter has a high correlation (see below).")
    if d["correlations"]["eo"]:
        probs.append(
            "One or more of the camera station parameters has a high correlation (see below)."
        )
    if d["correlations"]["op_pairs_above"]:
        probs.append("One or more of the object point coordinates has a high correlation.")
    sig = d["quality"]["significance"] or []
    if any(s["failed"] for s in sig):
        probs.append("One or more estimated lens and/or affine distortion coefficients "
                     "failed significance test (see below).")  # fmt: skip
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
    add(f"      pyheracles version:     {__version__}")
    add(f"      Python version:         {platform.python_version()}")
    add(f"      Host system:            {platform.system()} {platform.machine()}")
    add(f"      Host name:              {socket.gethostname()}")
    add(f"      Status:                 {'OK' if d['converged'] else d['status']}")
    add(f"      Sigma0:                 {d['sigma0']:.6g}")
    add(f"      Sigma0 (pixels):        {d['sigma0_px']:.6g}")
    add(f"      Redundancy              {d['redundancy']}")
    add(
        f"      Number of params:       {d['n_parameters']} ({d['n_parameters_io']} IO, "
        f"{d['n_parameters_eo']} EO, {d['n_parameters_op']} OP)"
    )
    n_eo = int(np.isfinite(net.eo_prior_std).sum())
    n_prior = d["n_observations"] - d["n_image_observations"]
    add(
        f"      Number of observations: {d['n_observations']} ({d['n_image_observations']} IP, "
        f"0 IO, {n_eo} EO, {n_prior - n_eo} OP)"
    )
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
    par = result.parameters
    calib = bool(net.io_free.any())
    add("      Processing options:")
    add("         Orientation:             on")
    add("         Global optimization:     on")
    add(f"         Calibration:             {'on' if calib else 'off'}")
    add("         Constraints:             off")
    add(f"         Maximum # of iterations: {par.max_iterations}")
    add(f"         Convergence tolerance:   {par.tolerance:g}")
    add("         Termination criteria:    relative")
    add("         Singular test:           on")
    add("         Chirality veto:          off")
    add(f"         Damping:                 {_DAMPING_NAMES[par.damping]}")
    add(f"         Datum:                   {d['datum']}")
    add(f"         Data snooping:           {d['data_snooping']['description']}")
    add("         Camera unit (cu):        mm")
    add("         Object space unit (ou):  m")
    add(f"         Initial value comment:   {p.meta.get('initial', '')}".rstrip())
    add("      Total error:")
    add("         Number of stages:     1")
    add(f"         Number of iterations: {d['iterations']}")
    add(f"         First error:          {d['residual_norm_history'][0]:.6g}")
    add(f"         Last error:           {d['residual_norm_history'][-1]:.6g}")
    t = d["timings_s"]
    add("      Execution times (s):")
    for label, key in (("Bundle:", "adjust"), ("Post-cov prep:", "cov_prep"),
                       ("Post-cov CIO:", "cov_io"), ("Post-cov CEO:", "cov_eo"),
                       ("Post-cov COP:", "cov_op"), ("Redundancy numbers:", "redundancy"),
                       ("Total:", "total")):  # fmt: skip
        if key in t:
            add(f"         {label:<15}{t[key]:.2f}")


def _camera_lines(d: dict, result, add) -> None:
    p = result.project
    models = sorted({c.model for c in p.cameras})
    add("      Lens distortion models:")
    add(f"         {_model_line(models[0]) if len(models) == 1 else 'Mixed Forward/Backward'}")
    add("      Cameras:")
    ests = {tuple(c["estimated"]) for c in d["cameras"]}
    if len(ests) == 1:
        est = next(iter(ests))
        add(f"         Calibration: {'yes (' + ' '.join(est) + ')' if est else 'no'}")
    else:
        add("         Calibration: yes (mixed parameters)")
    qual = d["quality"]
    for ci, cam in enumerate(d["cameras"]):
        est = cam["estimated"]
        sig = (qual["significance"] or [{}] * (ci + 1))[ci]
        add(f"         Camera{cam['id']} (simple)")
        add("            Lens distortion model:")
        add(f"               {_model_line(cam['model'])}")
        corr: dict[str, list[str]] = {}
        for c in cam["high_correlations"]:
            a, b = c["pair"]
            corr.setdefault(a, []).append(f"{b}:{100 * c['r']:.1f}%")
            corr.setdefault(b, []).append(f"{a}:{100 * c['r']:.1f}%")
        w, h = cam["image_size_px"]
        pw, ph = cam["pixel_size_mm"]
        for name in _CAM_ORDER:
            label, unit = _CAM_LABELS[name]
            add(f"            {label}:")
            add(f"               Value:        {_fmt_val(cam['values'][name])} {unit}".rstrip())
            if name in est:
                add(f"               Deviation:    {cam['std'][name]:.3g} {unit}".rstrip())
            if name in sig.get("significance", {}):
                add(f"               Significance: p={sig['significance'][name]:.2f}")
            if name in sig.get("cumulative", {}):
                add(f"               Cumulative significance:p={sig['cumulative'][name]:.2f}")
            if name in corr:
                add(f"               Correlations over 95%: {', '.join(corr[name])}.")
            if name == "py":
                add("            Format width:")
                add(f"               Value:        {w * pw:.6g} mm")
                add("            Format height:")
                add(f"               Value:        {h * ph:.6g} mm")
        for label, val, unit in (("Image width", w, "px"), ("Image height", h, "px"),
                                 ("X resolution", 1 / pw, "px/mm"),
                                 ("Y resolution", 1 / ph, "px/mm"),
                                 ("Pixel width", pw, "mm"),
                                 ("Pixel height", ph, "mm")):  # fmt: skip
            add(f"            {label}:")
            add(f"               Value:        {val:.6g} {unit}")
        g = qual["camera_geometry"][ci]
        aov = ", ".join(f"{a:.0f}" for a in g["angle_of_view_deg"])
        add(f"         Rated angle of view (h,v,d): ({aov}) deg")
        add(
            f"         Largest distortion: {g['largest_distortion_mm']:.2g} mm "
            f"({g['largest_distortion_px']:.1f} px, "
            f"{g['largest_distortion_pct_half_diagonal']:.1f}% of half-diagonal); "
            f"|dx|+|dy| (DBAT's figure): {g['largest_distortion_l1_mm']:.2g} mm "
            f"({g['largest_distortion_l1_px']:.1f} px)"
        )


def _photo_lines(d: dict, add) -> None:
    add("      Precisions / Standard Deviations:")
    add("         Photograph Standard Deviations:")
    names = {x[0]: x[1] for x in _EO_LABELS}
    for k, im in enumerate(d["images"], 1):
        add(f"            Photo {k}: {im['name']}")
        corr: dict[str, list[str]] = {}
        for c in im["high_correlations"]:
            a, b = c["pair"]
            corr.setdefault(a, []).append(f"{names[b]}:{100 * c['r']:.1f}%")
            corr.setdefault(b, []).append(f"{names[a]}:{100 * c['r']:.1f}%")
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


def _quality_lines(d: dict, result, add) -> None:
    p = result.project
    qual = d["quality"]
    add("   Quality")
    add("      Photographs")
    add(f"         Total number: {p.n_images}")
    add(f"         Numbers used: {p.n_images}")
    add("      Cameras")
    add(f"         Total number: {len(p.cameras)} ({len(p.cameras)} simple, 0 mixed)")
    for cam, cov in zip(d["cameras"], qual["coverage"], strict=True):
        add(f"         Camera{cam['id']}:")
        cal = "yes" if cam["estimated"] else "<not available>"
        add(f"            Calibration:                   {cal}")
        add(f"            Number of photos using camera: {len(cov['images'])}")
        add("            Photo point coverage:")
        add(f"               Rectangular: {_pct_range(cov['rect'], cov['union']['rect'])}")
        add(f"               Convex hull: {_pct_range(cov['hull'], cov['union']['hull'])}")
        add(f"               Radial:      {_pct_range(cov['radial'], cov['union']['radial'])}")
    add("      Photo Coverage")
    add("         Reference points outside calibrated region:")
    for reg in qual["calibrated_region"]:
        if not reg["calibrated"]:
            add(f"            Camera {reg['camera']}: <not available>")
        elif not reg["outside"]:
            add(f"            Camera {reg['camera']}: none")
        else:
            add(f"            Camera {reg['camera']}: {len(reg['outside'])} measurement(s) "
                "outside the convex hull of the tie point measurements")  # fmt: skip
            for o in reg["outside"][:20]:
                add(f"               pt {o['point']} ({o['label']}) on photo {o['image']}")
    add("      Point Measurements")
    add(f"         Number of control pts: {int((p.point_role == 'control').sum())}")
    add(f"         Number of check pts: {int((p.point_role == 'check').sum())}")
    add(f"         Number of object pts: {int((p.point_role == 'tie').sum())}")
    for key in ("CP", "CCP", "OP"):
        r = qual["rays"][key]
        if r is None:
            add(f"         {key} ray count: -")
            continue
        zero = f"{r['n_zero']}x0, " if r["n_zero"] else ""
        add(f"         {key} ray count: {zero}{r['min']}-{r['max']} ({r['mean']:.1f} avg)")
        for k, v in r["histogram"].items():
            add(f"            {v} points with {k} rays.")
    res = qual["residuals"]
    add("      Point Marking Residuals")
    add(f"         Overall point RMS: {res['overall_rms_px']:.3f} pixels")
    add("         Mark point residuals:")
    m = res["max"]
    add(f"            Maximum: {m['px']:.3f} pixels (OP {m['point']} on photo {m['photo']})")
    add("         Object point residuals (RMS over all images of a point):")
    for word, key in (("Minimum", "point_min"), ("Maximum", "point_max")):
        m = res[key]
        add(f"            {word}: {m['px']:.3f} pixels (OP {m['point']} over {m['n_images']} "
            "images)")  # fmt: skip
    add("         Photo residuals (RMS over all points in an image):")
    for word, key in (("Minimum", "photo_min"), ("Maximum", "photo_max")):
        m = res[key]
        add(f"            {word}: {m['px']:.3f} pixels (photo {m['photo']} over "
            f"{m['n_points']} points)")  # fmt: skip
    pr = qual["precision"]
    if pr is not None:
        c = d["correlations"]
        add("      Point Precision")
        # DBAT's label; the value is sqrt(sX^2 + sY^2 + sZ^2), as DBAT computes it.
        add("         Total standard deviation (RMS of X/Y/Z std):")
        add(f"            Minimum: {pr['total_min']:.2g} (OP {pr['total_min_point']})")
        add(f"            Maximum: {pr['total_max']:.2g} (OP {pr['total_max_point']})")
        for ax, v, pid in zip("XYZ", pr["max_xyz"], pr["max_xyz_points"], strict=True):
            add(f"         Maximum {ax} standard deviation: {v:.2g} (OP {pid})")
        add("         Points with high correlations")
        add(f"            Points with correlation above 95%: {c['op_pairs_above']}")
        add(f"            Points with correlation above 99%: {c['op_pairs_above_99']}")
        if c["op_pairs_above"]:
            add("            Points with highest correlations:")
            for pid, r in c["op_top"]:
                add(f"               Points {pid}: {100 * r:.2f}")
    add("      Point Angles")
    for key in ("CP", "CCP", "OP"):
        a = qual["angles"][key]
        add(f"         {key}")
        if a is None:
            for word in ("Minimum", "Maximum", "Average"):
                add(f"            {word}: -")
            continue
        if a["n_zero_rays"]:
            add(f"            Ignoring {a['n_zero_rays']} {key} with 0 rays.")
        for word, k in (("Minimum", "min"), ("Maximum", "max")):
            lab = a[f"{k}_label"]
            extra = f", label {lab}" if key != "OP" and lab and lab != str(a[f"{k}_point"]) else ""
            add(f"            {word}: {a[k]:.1f} degrees ({key} {a[f'{k}_point']}{extra})")
        add(f"            Average: {a['mean']:.1f} degrees")
        if key == "OP":
            add("            Smallest angles (ID, angle [deg], vis in cameras)")
            for s in a["smallest"]:
                imgs = " ".join(f"{i:4d}" for i in s["images"])
                add(f"               {s['point']:6d}: {s['angle']:5.2f} ({imgs})")
    for role, title, word in (("control", "Ctrl measurements", "Ctrl"),
                              ("check", "Check measurements", "Check")):  # fmt: skip
        add(f"      {title}")
        tab = qual["reference"][role]
        if tab is None:
            add("         none")
            continue
        _reference_table(tab, word, add)


def _reference_table(tab: dict, word: str, add) -> None:
    """DBAT's Prior / Posterior / Diff tables and the point delta summary."""
    pre = "         "
    add(pre + "Prior")
    add(pre + f"{'id':>6}, {'x':>8}, {'y':>8}, {'z':>8}, {'stdx':>8}, {'stdy':>8}, "
        f"{'stdz':>8}, label")  # fmt: skip
    for r in tab["rows"]:
        x, s = r["prior"], r["prior_std"]
        add(pre + f"{r['id']:6d}, {x[0]:8.3f}, {x[1]:8.3f}, {x[2]:8.3f}, {s[0]:8.3g}, "
            f"{s[1]:8.3g}, {s[2]:8.3g}, {r['label']}")  # fmt: skip
    add(pre + "Posterior")
    add(pre + f"{'id':>6}, {'x':>8}, {'y':>8}, {'z':>8}, {'stdx':>8}, {'stdy':>8}, "
        f"{'stdz':>8}, {'rays':>4}, label")  # fmt: skip
    for r in tab["rows"]:
        x, s = r["posterior"], r["posterior_std"]
        add(pre + f"{r['id']:6d}, {x[0]:8.3f}, {x[1]:8.3f}, {x[2]:8.3f}, {s[0]:8.3g}, "
            f"{s[1]:8.3g}, {s[2]:8.3g}, {r['rays']:4d}, {r['label']}")  # fmt: skip
    add(pre + "Diff (pos=abs diff, std=rel diff)")
    add(pre + f"{'id':>6}, {'x':>8}, {'y':>8}, {'z':>8}, {'xy':>8}, {'xyz':>8}, {'stdx':>8}, "
        f"{'stdy':>8}, {'stdz':>8}, {'rays':>4}, label")  # fmt: skip
    for r in tab["rows"]:
        x, s = r["delta"], r["std_change_pct"]
        add(pre + f"{r['id']:6d}, {x[0]:8.3f}, {x[1]:8.3f}, {x[2]:8.3f}, {r['delta_xy']:8.3f}, "
            f"{r['delta_xyz']:8.3f}, {s[0]:7.1f}%, {s[1]:7.1f}%, {s[2]:7.1f}%, "
            f"{r['rays']:4d}, {r['label']}")  # fmt: skip
    add(pre + f"{word} point delta")
    m = tab["max"]
    add(pre + f"   Max: {m['delta']:.3f} ou ({_label(m['label'], m['id'])}pt {m['id']})")
    add(pre + "   Max X,Y,Z")
    for ax, m in zip("XYZ", tab["max_xyz"], strict=True):
        add(pre + f"      {ax}: {m['delta']:.3f} ou ({_label(m['label'], m['id'])}pt {m['id']})")
    add(pre + f"   RMS: {tab['rms']:.3f} ou (from {tab['n']} items)")


def _test_lines(d: dict, add) -> None:
    """Our additions: coverage per photo, control point tests against their
    intersection, data snooping."""
    add("      Photo coverage per image (ours; DBAT prints the ranges above)")
    add("         photo  points  rect %  hull %  radial %  RMS px  name")
    for cov in d["quality"]["coverage"]:
        for k, i in enumerate(cov["images"]):
            im = d["images"][i]
            add(
                f"         {i + 1:5d}  {im['n_points']:6d}  {100 * cov['rect'][k]:6.1f}  "
                f"{100 * cov['hull'][k]:6.1f}  {100 * cov['radial'][k]:8.1f}  "
                f"{im['rms_px']:6.3f}  {im['name']}"
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
        if test.get("rule"):
            add(f"         {test['rule']}")
        add("         id        label      role     rays  |delta| (ou)   T         gross")
        for q_ in test["points"]:
            add(
                f"         {q_['id']:<9} {q_['label']:<10} {q_['role']:<8} {q_['rays']:<5} "
                f"{q_['delta_norm']:<14.5g} {_g(q_['T']):<9} {'GROSS' if q_['gross'] else ''}"
            )
    ds = d["data_snooping"]
    sym = "tau" if ds["test"] == "tau" else "w"
    add(f"      Data snooping ({ds['description']}) on image coordinates")
    add(f"         Critical value: {ds['critical']:.2f}; flagged observations: {ds['n_flagged']}")
    for q_ in ds["worst"]:
        add(
            f"            OP {q_['point']} on image {q_['image']}: |{sym}| = "
            f"{q_['statistic']:.2f}, residual ({q_['residual_px'][0]:+.2f}, "
            f"{q_['residual_px'][1]:+.2f}) px"
        )


def report_text(result, data: dict | None = None) -> str:
    """DBAT-style text report: DBAT's sections, labels and number formats, in its order.

    Our additions (control file echo, datum, data snooping, control point tests
    against their intersection) are extra lines; every section of DBAT 0.9.2's
    ``bundle_result_file`` is present.
    """
    d = data or report_dict(result)
    lines = ["Damped Bundle Adjustment Toolbox result file"]
    add = lines.append
    _header_lines(d, result, add)
    _camera_lines(d, result, add)
    _photo_lines(d, add)
    _quality_lines(d, result, add)
    _test_lines(d, add)
    add("End of result file")
    return "\n".join(lines) + "\n"


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
