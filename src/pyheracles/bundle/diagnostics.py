"""Posterior diagnostics of a bundle adjustment.

High correlations (thesis Table 2.4), control and check point residuals,
per-image statistics (thesis figure 2.9), ray intersection angles, and data
snooping of the image observations (Baarda 1968; Pope's tau with the
estimated sigma0).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import ConvexHull, QhullError

from pyheracles.bundle.camera import IO_NAMES

__all__ = [
    "control_point_residuals",
    "data_snooping",
    "high_correlations",
    "image_statistics",
    "ray_angles",
]

EO_NAMES = ("X0", "Y0", "Z0", "omega", "phi", "kappa")


def _corr(cov: np.ndarray) -> np.ndarray:
    sd = np.sqrt(np.clip(np.einsum("...ii->...i", cov), 0, None))
    with np.errstate(invalid="ignore", divide="ignore"):
        r = cov / (sd[..., :, None] * sd[..., None, :])
    return np.nan_to_num(r)


def high_correlations(result, threshold: float = 0.95, top: int = 5) -> dict:
    """Parameter pairs with |correlation| > ``threshold`` (DBAT's 95 %).

    Correlations are taken within each camera's interior orientation, within each
    image's exterior orientation and within each object point (as DBAT lists them).

    Returns
    -------
    dict
        ``io``: list of {camera_index, pair, r}; ``eo``: list of {image_index, pair,
        r}; ``op``: {n_pairs_above, n_pairs_above_99 (coordinate pairs, the numbers
        DBAT prints as "points with correlation above"), n_above, n_above_99
        (points), share (of estimated points, thesis Table 2.4), top (id, r),
        max_abs_r (N,)}.
    """
    net = result.network
    cov = result.cov_cam
    out: dict = {"threshold": threshold, "io": [], "eo": []}
    for ci in range(net.io_free.shape[0]):
        cols = net.io_col[ci][net.io_free[ci]]
        names = [IO_NAMES[j] for j in np.flatnonzero(net.io_free[ci])]
        r = _corr(cov[np.ix_(cols, cols)])
        for a in range(len(cols)):
            for b in range(a):
                if abs(r[a, b]) > threshold:
                    out["io"].append(
                        {"camera_index": ci, "pair": (names[b], names[a]), "r": float(r[a, b])}
                    )
    eo_free = net.eo_free
    n = eo_free.shape[0]
    full = np.zeros((n, 6, 6))
    idx = np.where(eo_free, net.eo_col, 0)
    full = cov[idx[:, :, None], idx[:, None, :]] * (eo_free[:, :, None] & eo_free[:, None, :])
    r = _corr(full)
    il, jl = np.tril_indices(6, -1)
    hits = np.abs(r[:, il, jl]) > threshold
    for i, k in zip(*np.nonzero(hits), strict=True):
        out["eo"].append(
            {
                "image_index": int(i),
                "pair": (EO_NAMES[jl[k]], EO_NAMES[il[k]]),
                "r": float(r[i, il[k], jl[k]]),
            }
        )
    rp = _corr(result.cov_xyz)
    il3, jl3 = np.tril_indices(3, -1)
    vals = rp[:, il3, jl3]
    best = np.argmax(np.abs(vals), axis=1)
    rmax = vals[np.arange(len(vals)), best]
    tie = net.op_free.any(axis=1)
    above = (np.abs(rmax) > threshold) & tie
    order = np.argsort(-np.abs(rmax))[:top]
    ids = result.project.point_ids
    pair_hits = np.abs(vals) * tie[:, None]
    out["op"] = {
        "n_pairs_above": int((pair_hits > threshold).sum()),
        "n_pairs_above_99": int((pair_hits > 0.99).sum()),
        "n_above": int(above.sum()),
        "n_above_99": int(((np.abs(rmax) > 0.99) & tie).sum()),
        "share": float(above.sum() / max(tie.sum(), 1)),
        "top": [(int(ids[i]), float(rmax[i])) for i in order],
        "max_abs_r": rmax,
    }
    return out


def control_point_residuals(result) -> dict:
    """Residuals (estimated - reference) of control and check points, object units.

    Returns
    -------
    dict with ``control`` and ``check``: lists of {id, label, residual (3,), std
    (3,)}, plus ``rms`` (3,) and ``rms_3d`` per group.
    """
    p = result.project
    out = {}
    for role in ("control", "check"):
        sel = np.flatnonzero((p.point_role == role) & np.all(np.isfinite(p.xyz), axis=1))
        rows = []
        res = result.xyz[sel] - p.xyz[sel]
        for k, i in enumerate(sel):
            rows.append(
                {
                    "id": int(p.point_ids[i]),
                    "label": p.point_labels[i],
                    "residual": res[k].tolist(),
                    "std": result.xyz_std[i].tolist() if result.xyz_std is not None else None,
                }
            )
        rms = np.sqrt(np.mean(res**2, axis=0)) if len(sel) else np.full(3, np.nan)
        out[role] = {
            "points": rows,
            "rms": rms.tolist(),
            "rms_3d": float(np.sqrt(np.sum(rms**2))) if len(sel) else float("nan"),
        }
    return out


def ray_angles(result) -> np.ndarray:
    """Largest intersection angle (degrees, 0-90) between the rays of each object point."""
    p = result.project
    centres = result.eo[p.obs_image, :3]
    d = result.xyz[p.obs_point] - centres
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    order = np.argsort(p.obs_point, kind="stable")
    pts = p.obs_point[order]
    dd = d[order]
    best = np.zeros(p.n_points)
    maxrays = int(np.bincount(pts).max()) if len(pts) else 0
    for off in range(1, maxrays):
        same = pts[off:] == pts[:-off]
        if not np.any(same):
            break
        # DBAT convention: the acute angle between the two lines, in [0, 90].
        cosang = np.clip(np.abs(np.einsum("ij,ij->i", dd[off:][same], dd[:-off][same])), 0, 1)
        ang = np.degrees(np.arccos(cosang))
        np.maximum.at(best, pts[off:][same], ang)
    return best


def _coverage(uv: np.ndarray, size: tuple[int, int]) -> tuple[float, float]:
    area = float(size[0] * size[1])
    if len(uv) < 3:
        return 0.0, 0.0
    rect = float(np.ptp(uv[:, 0]) * np.ptp(uv[:, 1])) / area
    try:
        hull = ConvexHull(uv).volume / area
    except QhullError:
        hull = 0.0
    return rect, float(hull)


def image_statistics(result) -> list[dict]:
    """Per image: observation count, residual RMS (pixels), coverage of the frame, and the
    mean of the largest ray intersection angle of the points it sees (degrees)."""
    p = result.project
    ang = ray_angles(result)[p.obs_point]
    res = result.residuals_px
    sq = np.sum(res**2, axis=1)
    n = np.bincount(p.obs_image, minlength=p.n_images)
    rms = np.sqrt(np.bincount(p.obs_image, weights=sq, minlength=p.n_images) / np.maximum(n, 1))
    mean_ang = np.bincount(p.obs_image, weights=ang, minlength=p.n_images) / np.maximum(n, 1)
    order = np.argsort(p.obs_image, kind="stable")
    splits = np.cumsum(n)[:-1]
    out = []
    for i, idx in enumerate(np.split(order, splits)):
        cam = p.cameras[p.image_camera[i]]
        rect, hull = _coverage(p.obs_uv_px[idx], cam.image_size_px)
        out.append(
            {
                "image": int(p.image_ids[i]),
                "name": p.image_names[i],
                "n_points": int(n[i]),
                "rms_px": float(rms[i]),
                "coverage_rect": rect,
                "coverage_hull": hull,
                "mean_ray_angle_deg": float(mean_ang[i]),
            }
        )
    return out


def data_snooping(result, critical: float = 3.29) -> dict:
    """Normalised residuals of the image coordinates (Baarda's w-test, Pope's tau).

    ``w = v / (sigma_v)`` with ``sigma_v = sigma_prior * sqrt(redundancy number)``
    (a priori unit variance), and ``tau = w / sigma0`` (estimated variance).

    Parameters
    ----------
    critical
        Critical value for |w| (3.29 = two-sided 0.1 % normal quantile, Baarda).

    Returns
    -------
    dict with ``w`` (m,2), ``tau`` (m,2), ``flagged`` (indices of observations
    with max |w| > critical), and the counts.
    """
    m = result.project.n_observations
    r = result.weighted_residuals[: 2 * m].reshape(m, 2)
    red = result.redundancy_numbers
    with np.errstate(invalid="ignore", divide="ignore"):
        w = np.where(red > 1e-10, r / np.sqrt(np.clip(red, 1e-300, None)), 0.0)
    tau = w / result.sigma0 if result.sigma0 > 0 else w
    worst = np.max(np.abs(w), axis=1)
    flagged = np.flatnonzero(worst > critical)
    flagged = flagged[np.argsort(-worst[flagged])]
    return {"w": w, "tau": tau, "flagged": flagged, "critical": critical, "n_flagged": len(flagged)}
