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
    "control_point_test",
    "data_snooping",
    "high_correlations",
    "image_statistics",
    "ray_angles",
    "tau_critical",
    "worst_observations",
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


def tau_critical(redundancy: int, alpha: float = 0.001) -> float:
    """Critical value of Pope's tau distribution (two-sided, level ``alpha``).

    ``tau = sqrt(r) t / sqrt(r - 1 + t^2)`` with ``t`` Student's quantile for
    ``r - 1`` degrees of freedom (Pope 1976); tends to the normal quantile for a
    large redundancy ``r``.
    """
    from scipy.stats import norm, t

    if redundancy <= 1:
        return float("inf")
    if redundancy > 1e6:
        return float(norm.ppf(1 - alpha / 2))
    q = float(t.ppf(1 - alpha / 2, redundancy - 1))
    return float(np.sqrt(redundancy) * q / np.sqrt(redundancy - 1 + q * q))


def data_snooping(result, critical: float | None = None, test: str | None = None) -> dict:
    """Normalised residuals of the image coordinates (Baarda's w-test, Pope's tau test).

    ``w = v / sigma_v`` with ``sigma_v = sigma_prior * sqrt(redundancy number)``
    (the a priori unit variance), and ``tau = w / sigma0`` (the posterior one).
    The w-test assumes the a priori standard deviations are right: with sigma0 =
    1.6 a clean network already has many |w| > 3.29; the tau test does not.

    Parameters
    ----------
    critical
        Critical value of the chosen statistic; default 3.29 (two-sided 0.1 %
        normal quantile, Baarda) for "w", :func:`tau_critical` of the redundancy
        at ``result.parameters.snooping_alpha`` for "tau".
    test
        "w" or "tau"; default ``result.parameters.snooping``.

    Returns
    -------
    dict with ``test``, ``statistic`` (m,2) of the chosen test, ``w`` (m,2),
    ``tau`` (m,2), ``flagged`` (indices of observations whose max |statistic|
    exceeds ``critical``, worst first), ``critical``, ``n_flagged``, ``sigma``
    (the unit standard deviation the test uses) and ``description``.
    """
    params = getattr(result, "parameters", None)
    test = test or getattr(params, "snooping", "w")
    if test not in ("w", "tau"):
        raise ValueError(f"unknown data snooping test '{test}'; choose 'w' or 'tau'")
    m = result.project.n_observations
    r = result.weighted_residuals[: 2 * m].reshape(m, 2)
    red = result.redundancy_numbers
    with np.errstate(invalid="ignore", divide="ignore"):
        w = np.where(red > 1e-10, r / np.sqrt(np.clip(red, 1e-300, None)), 0.0)
    tau = w / result.sigma0 if result.sigma0 > 0 else w
    if test == "w":
        stat, crit_default, sigma = w, 3.29, 1.0
        desc = "Baarda w-test (a priori standard deviations, sigma = 1)"
    else:
        alpha = getattr(params, "snooping_alpha", 0.001)
        stat, crit_default, sigma = tau, tau_critical(result.redundancy, alpha), result.sigma0
        desc = f"Pope tau test (posterior sigma0 = {result.sigma0:.4g}, alpha = {alpha:g})"
    crit = crit_default if critical is None else critical
    worst = np.max(np.abs(stat), axis=1)
    flagged = np.flatnonzero(worst > crit)
    flagged = flagged[np.argsort(-worst[flagged])]
    return {"test": test, "statistic": stat, "w": w, "tau": tau, "flagged": flagged,
            "critical": crit, "n_flagged": len(flagged), "sigma": float(sigma),
            "description": desc}  # fmt: skip


def control_point_test(net, io: np.ndarray, eo: np.ndarray, sigma: float = 1.0,
                       alpha: float = 0.001, ratio: float = 5.0,
                       min_others: int = 2) -> dict:  # fmt: skip
    """Test every control and check point against its intersection from the images.

    Each point's rays are intersected with the given orientations (least squares,
    three Gauss-Newton steps on the image residuals); the discrepancy ``d =
    x_intersected - x_reference`` is tested with ``T = d' (C_int + C_ref)^-1 d``
    against the chi-square (3) quantile ``1 - alpha``, where ``C_int = sigma^2 A^-1``
    (A: the point's normal matrix) and ``C_ref`` the reference's prior covariance
    (0 for fixed points).  A point is *gross* when it fails the test and its
    discrepancy is also over ``ratio`` times the median discrepancy of the *other*
    tested points (the orientations are approximate before the adjustment and
    ``C_int`` ignores their uncertainty after it, so typical points may fail the
    chi-square test: the gross ones stand out from the rest).  Including the point
    itself in the median (as an earlier version did) let a gross point raise the
    median it is compared with (with 2 points it is half of it and can never exceed
    5 times it).  With fewer than ``min_others`` other points there is no rest to
    compare with: T is reported, no point is declared gross (``rule`` says so).

    Parameters
    ----------
    net
        The :class:`~pyheracles.bundle.network.Network` (observations in mm, weights).
    io, eo
        (ncam,10) interior and (n,6) exterior orientation to intersect with.
    sigma
        Standard deviation of unit weight (1 before the adjustment, sigma0 after).

    Returns
    -------
    dict with ``points`` (list of {id, label, role, rays, delta (3,), delta_norm,
    T, median_others, gross}), ``gross`` (ids), ``critical``, ``median_delta`` (all
    points), ``ratio``, ``min_others`` and ``rule`` (the rule in words).
    """
    from scipy.special import gammaincinv  # scipy.stats costs ~1 s to import

    from pyheracles.bundle.camera import image_residuals
    from pyheracles.bundle.initial import centre_rotation, forward_intersection, ideal_rays

    p = net.project
    rays_n = p.rays()
    cand = np.flatnonzero(
        np.isin(p.point_role, ("control", "check"))
        & np.all(np.isfinite(p.xyz), axis=1)
        & (rays_n >= 2)
    )
    crit = float(2.0 * gammaincinv(1.5, 1.0 - alpha))  # chi2(3) quantile
    rule = (
        f"gross = T > chi2(3, {1 - alpha:g}) and |delta| > {ratio:g} x the median "
        f"|delta| of the other tested points"
    )
    if len(cand) - 1 < min_others:
        rule += f"; fewer than {min_others} other points: none can be declared gross"
    out: dict = {"points": [], "gross": [], "critical": crit, "median_delta": None,
                 "sigma": float(sigma), "alpha": alpha, "ratio": ratio,
                 "min_others": min_others, "rule": rule}  # fmt: skip
    if len(cand) == 0:
        return out
    local = np.full(p.n_points, -1)
    local[cand] = np.arange(len(cand))
    sel = local[p.obs_point] >= 0
    k = local[p.obs_point[sel]]
    img = p.obs_image[sel]
    io_o = io[net.obs_cam[sel]]
    centres, rots = centre_rotation(eo)
    rays = ideal_rays(net.uv_mm[sel], io_o, net.model)
    x = forward_intersection(centres[img], rots[img], rays, k, len(cand))
    ok = np.all(np.isfinite(x), axis=1)
    x[~ok] = p.xyz[cand][~ok]
    w = net.sqrt_w[sel]
    a = np.zeros((len(cand), 3, 3))
    for _ in range(3):
        res, (d_xyz, _, _) = image_residuals(io_o, eo[img], x[k], net.uv_mm[sel], net.model,
                                             jacobian=True)  # fmt: skip
        jw = d_xyz * w[:, :, None]
        rw = res * w
        a = np.zeros((len(cand), 3, 3))
        np.add.at(a, k, np.einsum("mri,mrj->mij", jw, jw))
        g = np.zeros((len(cand), 3))
        np.add.at(g, k, np.einsum("mri,mr->mi", jw, rw))
        good = np.abs(np.linalg.det(a)) > 1e-300
        step = np.zeros_like(x)
        step[good] = -np.linalg.solve(a[good], g[good][..., None])[..., 0]
        if not np.all(np.isfinite(step)):
            break
        x = x + step
    d = x - p.xyz[cand]
    sref = np.nan_to_num(p.xyz_std[cand], nan=0.0)
    cov = np.zeros_like(a)
    good = np.abs(np.linalg.det(a)) > 1e-300
    cov[good] = sigma**2 * np.linalg.inv(a[good])
    cov += np.einsum("ni,ij->nij", sref**2, np.eye(3))
    t = np.full(len(cand), np.inf)
    pos = good & (np.abs(np.linalg.det(cov)) > 0)
    t[pos] = np.einsum("ni,ni->n", d[pos], np.linalg.solve(cov[pos], d[pos][..., None])[..., 0])
    dn = np.linalg.norm(d, axis=1)
    med = float(np.median(dn))
    n = len(dn)
    if n - 1 >= min_others:
        # Leave-one-out median: drop the point's own value from the sorted list.
        srt = np.sort(dn)
        pos = np.searchsorted(srt, dn)
        others = np.array([np.median(np.delete(srt, k)) for k in pos])
        outlying = dn > ratio * others
    else:
        others = np.full(n, np.nan)
        outlying = np.zeros(n, bool)
    gross = (t > crit) & outlying & ok
    out["median_delta"] = med
    for j, i in enumerate(cand):
        out["points"].append({
            "id": int(p.point_ids[i]), "label": p.point_labels[i], "role": str(p.point_role[i]),
            "rays": int(rays_n[i]), "delta": d[j].tolist(), "delta_norm": float(dn[j]),
            "T": float(t[j]) if np.isfinite(t[j]) else None,
            "median_others": float(others[j]) if np.isfinite(others[j]) else None,
            "gross": bool(gross[j]),
        })  # fmt: skip
    order = np.argsort(-dn[gross])
    out["gross"] = [int(p.point_ids[cand[gross][o]]) for o in order]
    return out


def worst_observations(net, residual_weighted: np.ndarray, top: int = 20) -> list[dict]:
    """The ``top`` image observations with the largest weighted residual norm."""
    p = net.project
    m = p.n_observations
    r = residual_weighted[: 2 * m].reshape(m, 2)
    norm = np.linalg.norm(r, axis=1)
    order = np.argsort(-norm)[:top]
    px = r / net.sqrt_w / np.array([c.pixel_size_mm[0] for c in p.cameras])[net.obs_cam][:, None]
    return [
        {
            "image": int(p.image_ids[p.obs_image[k]]),
            "point": int(p.point_ids[p.obs_point[k]]),
            "label": p.point_labels[p.obs_point[k]],
            "weighted_residual": float(norm[k]),
            "residual_px": px[k].tolist(),
        }
        for k in order
    ]
