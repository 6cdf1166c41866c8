"""The quality figures of DBAT's result file, computed from a :class:`BundleResult`.

Each function returns plain data (JSON-serialisable) that
:mod:`pyheracles.bundle.report` prints in DBAT's layout:

* significance of the lens and affine distortion parameters (chi-square tests
  of the estimate against zero with its posterior covariance: each radial
  coefficient alone, K1..Ki together, P1 and P2 together, ``as`` and ``sk``
  alone, as DBAT does);
* the rated angle of view and the largest distortion at the image corners;
* photo point coverage per image and for the union of a camera's images
  (rectangular extent, convex hull, radial extent from the principal point);
* reference (control/check) point measurements outside the region calibrated
  by the tie points;
* ray counts, residual extremes per observation / object point / photo with
  their ids, point precision extremes, intersection angles per point class and
  the smallest ones;
* prior, posterior and differences of control and check points.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import ConvexHull, QhullError
from scipy.stats import chi2

from pyheracles.bundle.camera import IO_NAMES

__all__ = [
    "SIGNIFICANCE_LEVEL",
    "angle_summary",
    "calibrated_region",
    "camera_geometry",
    "coverage",
    "distortion_significance",
    "point_precision",
    "ray_counts",
    "reference_tables",
    "residual_extremes",
]

#: Distortion coefficients with a significance p below this are reported (DBAT's 0.95).
SIGNIFICANCE_LEVEL = 0.95
_IO = {n: i for i, n in enumerate(IO_NAMES)}


def _io_cov(result, ci: int, names: list[str]) -> np.ndarray | None:
    net = result.network
    j = [_IO[n] for n in names]
    if result.cov_cam is None or not np.all(net.io_free[ci, j]):
        return None
    cols = net.io_col[ci, j]
    return result.cov_cam[np.ix_(cols, cols)]


def _chi2_p(x: np.ndarray, cov: np.ndarray) -> float:
    """P(chi2_k <= x' C^-1 x): the probability that the estimate is not zero by chance."""
    try:
        v = float(x @ np.linalg.solve(cov, x))
    except np.linalg.LinAlgError:
        return float("nan")
    return float(chi2.cdf(v, len(x)))


def distortion_significance(result) -> list[dict]:
    """Per camera: significance and cumulative significance of the distortion parameters.

    Returns
    -------
    list of dict
        ``significance`` (name -> p) for K1, K2, K3 (each alone), P1 (P1 and P2
        together, printed at P1 as DBAT does), ``as`` and ``sk`` (each alone);
        ``cumulative`` (name -> p) for Ki (K1..Ki together); only estimated
        parameters appear.  ``failed``: names with p < :data:`SIGNIFICANCE_LEVEL`.
    """
    out = []
    for ci in range(len(result.project.cameras)):
        io = result.io[ci]
        sig: dict[str, float] = {}
        cum: dict[str, float] = {}
        for i, name in enumerate(("K1", "K2", "K3")):
            c = _io_cov(result, ci, [name])
            if c is not None:
                sig[name] = _chi2_p(io[[_IO[name]]], c)
            names = ["K1", "K2", "K3"][: i + 1]
            c = _io_cov(result, ci, names)
            if c is not None:
                cum[name] = _chi2_p(io[[_IO[n] for n in names]], c)
        c = _io_cov(result, ci, ["P1", "P2"])
        if c is not None:
            sig["P1"] = _chi2_p(io[[_IO["P1"], _IO["P2"]]], c)
        for name in ("as", "sk"):
            c = _io_cov(result, ci, [name])
            if c is not None:
                sig[name] = _chi2_p(io[[_IO[name]]], c)
        failed = [n for d in (sig, cum) for n, v in d.items() if v < SIGNIFICANCE_LEVEL]
        out.append({"significance": sig, "cumulative": cum, "failed": sorted(set(failed))})
    return out


def camera_geometry(result) -> list[dict]:
    """Per camera: rated angle of view (h, v, d, degrees) and the largest lens distortion.

    The distortion is the length of the Brown correction (radial + decentering)
    at the four image corners, in mm, pixels and percent of the half-diagonal;
    ``largest_distortion_l1_*`` is the bound |dx| + |dy| that DBAT prints.
    """
    out = []
    for ci, cam in enumerate(result.project.cameras):
        io = result.io[ci]
        w_mm, h_mm = (np.asarray(cam.image_size_px, float) * cam.pixel_size_mm).tolist()
        d_mm = float(np.hypot(w_mm, h_mm))
        aov = np.degrees(2 * np.arctan(np.array([w_mm, h_mm, d_mm]) / (2 * io[0])))
        # Corners in the ideal frame: x right, y up, origin at the principal point.
        ax = np.array([0.0, 0.0, w_mm, w_mm]) - io[1]
        ay = io[2] - np.array([0.0, h_mm, h_mm, 0.0])
        r2 = ax * ax + ay * ay
        rad = r2 * (io[5] + r2 * (io[6] + r2 * io[7]))
        p1, p2 = io[8], io[9]
        dx = ax * rad + p1 * (r2 + 2 * ax * ax) + 2 * p2 * ax * ay
        dy = ay * rad + p2 * (r2 + 2 * ay * ay) + 2 * p1 * ax * ay
        mx = float(np.max(np.hypot(dx, dy)))
        l1 = float(np.max(np.abs(dx) + np.abs(dy)))
        out.append(
            {
                "angle_of_view_deg": aov.tolist(),
                # DBAT prints the bound |dx| + |dy|; we give both.
                "largest_distortion_l1_mm": l1,
                "largest_distortion_l1_px": l1 / float(cam.pixel_size_mm[0]),
                "largest_distortion_mm": mx,
                "largest_distortion_px": mx / float(cam.pixel_size_mm[0]),
                "largest_distortion_pct_half_diagonal": 100 * mx / (d_mm / 2),
            }
        )
    return out


def _extent(uv: np.ndarray, size: tuple[int, int], pp_px: np.ndarray) -> tuple[float, ...]:
    """Rectangular, convex hull and radial coverage of points in one image frame."""
    area = float(size[0] * size[1])
    if len(uv) == 0:
        return 0.0, 0.0, 0.0
    rect = float(np.ptp(uv[:, 0]) * np.ptp(uv[:, 1])) / area
    hull = 0.0
    if len(uv) >= 3:
        try:
            hull = float(ConvexHull(uv).volume) / area
        except QhullError:
            hull = 0.0
    corners = np.array([[0, 0], [0, size[1]], [size[0], size[1]], [size[0], 0]], float)
    rmax = np.max(np.linalg.norm(corners - pp_px, axis=1))
    radial = float(np.max(np.linalg.norm(uv - pp_px, axis=1)) / rmax)
    return rect, hull, radial


def coverage(result) -> list[dict]:
    """Photo point coverage per camera: each image's and the union of its images'.

    Returns
    -------
    list of dict (one per camera)
        ``images`` (image indices), ``rect``, ``hull``, ``radial`` (per image,
        fractions of the frame; radial = farthest point from the principal point
        over the farthest corner) and ``union`` {rect, hull, radial}.
    """
    p = result.project
    out = []
    for ci, cam in enumerate(p.cameras):
        pp = result.io[ci, 1:3] / cam.pixel_size_mm
        imgs = np.flatnonzero(p.image_camera == ci)
        per = [_extent(p.obs_uv_px[p.obs_image == i], cam.image_size_px, pp) for i in imgs]
        sel = np.isin(p.obs_image, imgs)
        u = _extent(p.obs_uv_px[sel], cam.image_size_px, pp)
        arr = np.array(per, float).reshape(-1, 3)
        out.append(
            {
                "camera": int(cam.id),
                "images": imgs.tolist(),
                "rect": arr[:, 0].tolist(),
                "hull": arr[:, 1].tolist(),
                "radial": arr[:, 2].tolist(),
                "union": {"rect": u[0], "hull": u[1], "radial": u[2]},
            }
        )
    return out


def calibrated_region(result) -> list[dict]:
    """Reference point measurements outside the region calibrated by the tie points.

    For each camera whose interior orientation is estimated, the calibrated
    region is the convex hull of its tie point measurements (over all its
    images); control and check point measurements outside it rely on an
    extrapolated lens model.

    Returns
    -------
    list of dict
        ``camera``, ``calibrated`` (bool), ``outside``: list of {point, label,
        image} (empty when none).
    """
    p = result.project
    net = result.network
    out = []
    for ci, cam in enumerate(p.cameras):
        row = {"camera": int(cam.id), "calibrated": bool(net.io_free[ci].any()), "outside": []}
        if row["calibrated"]:
            on_cam = p.image_camera[p.obs_image] == ci
            role = p.point_role[p.obs_point]
            tie = on_cam & (role == "tie")
            ref = np.flatnonzero(on_cam & (role != "tie"))
            if tie.sum() >= 3 and len(ref):
                try:
                    eq = ConvexHull(p.obs_uv_px[tie]).equations  # n.x + c <= 0 inside
                    inside = np.all(p.obs_uv_px[ref] @ eq[:, :2].T + eq[:, 2] <= 1e-9, axis=1)
                except QhullError:
                    inside = np.zeros(len(ref), bool)
                for k in ref[~inside]:
                    j = p.obs_point[k]
                    row["outside"].append({"point": int(p.point_ids[j]),
                                           "label": p.point_labels[j],
                                           "image": int(p.obs_image[k]) + 1})  # fmt: skip
        out.append(row)
    return out


def _rays_summary(rays: np.ndarray) -> dict | None:
    if len(rays) == 0:
        return None
    seen = rays[rays > 0]
    hist = np.bincount(rays)
    return {
        "n_zero": int((rays == 0).sum()),
        "min": int(seen.min()) if len(seen) else 0,
        "max": int(seen.max()) if len(seen) else 0,
        "mean": float(seen.mean()) if len(seen) else 0.0,
        "histogram": {int(k): int(v) for k, v in enumerate(hist) if v},
    }


def ray_counts(result) -> dict:
    """Ray counts of control (CP), check (CCP) and object points (OP).

    As DBAT, "OP" counts every point that is not a control point (check points
    included).
    """
    p = result.project
    rays = p.rays()
    role = p.point_role
    return {
        "CP": _rays_summary(rays[role == "control"]),
        "CCP": _rays_summary(rays[role == "check"]),
        "OP": _rays_summary(rays[role != "control"]),
    }


def residual_extremes(result) -> dict:
    """Largest mark point residual and the extreme RMS per object point and per photo.

    Residual lengths in pixels; photos are numbered from 1 in image order.
    """
    p = result.project
    e = np.linalg.norm(result.residuals_px, axis=1)
    k = int(np.argmax(e))
    n_op = np.bincount(p.obs_point, minlength=p.n_points)
    seen = n_op > 0
    rms_op = np.sqrt(np.bincount(p.obs_point, e**2, p.n_points)[seen] / n_op[seen])
    ids_op = np.flatnonzero(seen)
    n_ph = np.bincount(p.obs_image, minlength=p.n_images)
    rms_ph = np.sqrt(np.bincount(p.obs_image, e**2, p.n_images) / np.maximum(n_ph, 1))
    lo, hi = int(np.argmin(rms_op)), int(np.argmax(rms_op))
    return {
        "overall_rms_px": float(np.sqrt(np.mean(e**2))),
        "max": {"px": float(e[k]), "point": int(p.point_ids[p.obs_point[k]]),
                "photo": int(p.obs_image[k]) + 1},
        "point_min": {"px": float(rms_op[lo]), "point": int(p.point_ids[ids_op[lo]]),
                      "n_images": int(n_op[ids_op[lo]])},
        "point_max": {"px": float(rms_op[hi]), "point": int(p.point_ids[ids_op[hi]]),
                      "n_images": int(n_op[ids_op[hi]])},
        "photo_min": {"px": float(rms_ph.min()), "photo": int(np.argmin(rms_ph)) + 1,
                      "n_points": int(n_ph[np.argmin(rms_ph)])},
        "photo_max": {"px": float(rms_ph.max()), "photo": int(np.argmax(rms_ph)) + 1,
                      "n_points": int(n_ph[np.argmax(rms_ph)])},
    }  # fmt: skip


def point_precision(result) -> dict | None:
    """Extremes of the posterior point standard deviations, with the point ids.

    Over the points whose three coordinates are estimated (tie, check and weighted
    control points): total sqrt(sX^2 + sY^2 + sZ^2) minimum and maximum, and the
    largest standard deviation per axis.
    """
    p = result.project
    if result.xyz_std is None:
        return None
    est = np.flatnonzero(result.network.op_free.all(axis=1))
    if not len(est):
        return None
    sd = result.xyz_std[est]
    tot = np.sqrt(np.sum(sd**2, axis=1))
    ids = p.point_ids[est]
    ax = np.argmax(sd, axis=0)
    return {
        "total_min": float(tot.min()), "total_min_point": int(ids[np.argmin(tot)]),
        "total_max": float(tot.max()), "total_max_point": int(ids[np.argmax(tot)]),
        "max_xyz": sd[ax, [0, 1, 2]].tolist(), "max_xyz_points": ids[ax].astype(int).tolist(),
    }  # fmt: skip


def angle_summary(result, angles: np.ndarray, max_listed: int | None = None) -> dict:
    """Intersection angles (degrees) of control (CP), check (CCP) and object points (OP).

    Each class: minimum and maximum with the point id and label, and the mean.
    ``OP`` also lists its smallest angles with the images (numbered from 1) that
    see each point: at least three, and every point below 1.1 x the third
    smallest angle + 0.1 degree (capped at 80 degrees), as DBAT's list; at most
    ``max_listed`` rows (None: all of them, as DBAT).
    """
    p = result.project
    rays = p.rays()
    out: dict = {}
    for key, sel in (("CP", p.point_role == "control"), ("CCP", p.point_role == "check"),
                     ("OP", p.point_role == "tie")):  # fmt: skip
        idx = np.flatnonzero(sel & (rays > 0))
        if not len(idx):
            out[key] = None
            continue
        a = angles[idx]
        lo, hi = idx[int(np.argmin(a))], idx[int(np.argmax(a))]
        out[key] = {
            "n_zero_rays": int((sel & (rays == 0)).sum()),
            "min": float(angles[lo]), "min_point": int(p.point_ids[lo]),
            "min_label": p.point_labels[lo],
            "max": float(angles[hi]), "max_point": int(p.point_ids[hi]),
            "max_label": p.point_labels[hi],
            "mean": float(a.mean()),
        }  # fmt: skip
        if key == "OP":
            order = idx[np.argsort(a, kind="stable")]
            srt = angles[order]
            limit = min(srt[min(2, len(srt) - 1)] * 1.1 + 0.1, 80.0)
            n = min(max(int((srt < limit).sum()), 3), len(srt), max_listed or len(srt))
            listed = []
            for j in order[:n]:
                imgs = np.unique(p.obs_image[p.obs_point == j]) + 1
                listed.append({"point": int(p.point_ids[j]), "angle": float(angles[j]),
                               "images": imgs.astype(int).tolist()})  # fmt: skip
            out[key]["smallest"] = listed
    return out


def reference_tables(result) -> dict:
    """Prior, posterior and difference of the control ("control") and check ("check") points.

    Returns
    -------
    dict
        Per role: None without such points, else ``rows`` (id, label, prior
        xyz and std, posterior xyz and std, rays, delta xyz, |delta xy|, |delta
        xyz|, relative std change in percent), ``max`` (the largest |delta
        xyz| with its id and label), ``max_xyz`` (largest |delta| per axis with
        ids and labels), ``rms`` (RMS of |delta xyz|), ``n``.
    """
    p = result.project
    rays = p.rays()
    eps = np.finfo(float).eps
    post_std = result.xyz_std if result.xyz_std is not None else np.zeros_like(result.xyz)
    out: dict = {}
    for role in ("control", "check"):
        sel = np.flatnonzero((p.point_role == role) & np.all(np.isfinite(p.xyz), axis=1))
        if not len(sel):
            out[role] = None
            continue
        prior_std = np.nan_to_num(p.xyz_std[sel], nan=0.0)
        delta = result.xyz[sel] - p.xyz[sel]
        rel = ((post_std[sel] + eps) / (prior_std + eps) - 1) * 100
        norm = np.linalg.norm(delta, axis=1)
        rows = []
        for k, j in enumerate(sel):
            rows.append({
                "id": int(p.point_ids[j]), "label": p.point_labels[j],
                "prior": p.xyz[j].tolist(), "prior_std": prior_std[k].tolist(),
                "posterior": result.xyz[j].tolist(), "posterior_std": post_std[j].tolist(),
                "rays": int(rays[j]), "delta": delta[k].tolist(),
                "delta_xy": float(np.hypot(delta[k, 0], delta[k, 1])),
                "delta_xyz": float(norm[k]), "std_change_pct": rel[k].tolist(),
            })  # fmt: skip
        m = int(np.argmax(norm))
        axm = np.argmax(np.abs(delta), axis=0)
        out[role] = {
            "rows": rows,
            "n": len(sel),
            "max": {"delta": float(norm[m]), "id": rows[m]["id"], "label": rows[m]["label"]},
            "max_xyz": [{"delta": float(abs(delta[axm[a], a])), "id": rows[axm[a]]["id"],
                         "label": rows[axm[a]]["label"]} for a in range(3)],
            "rms": float(np.sqrt(np.mean(norm**2))),
        }  # fmt: skip
    return out
