"""Similarity (Helmert) transformation from point pairs, least squares and robust.

Model (thesis eq. 1.5, Murtiyoso 2020 ch. 3)::

    x_target = t + s * R(omega, phi, kappa) @ x_source + v

with ``R = Rz(kappa) @ Ry(phi) @ Rx(omega)`` (``Rotation.from_euler("xyz", ...)``,
extrinsic, radians), 7 parameters (or 6 with ``s = 1``).  The adjustment is a
Gauss-Markov model on the target coordinates; the precision of the source
coordinates is propagated into the observation weights.  The result carries what
a geodetic report needs: a-posteriori sigma0, redundancy, parameter standard
deviations and correlations, residuals per point in X, Y, Z and 3D, redundancy
numbers and outlier flags.

Robust estimation is iteratively reweighted least squares (IRLS) on per-point
standardised residuals with a robust (median-based) scale: the modified Danish
method and the minimum-sum (L1) estimator used in 3DVEM in the thesis, plus
Huber and Tukey.  After the robust iterations the flagged points are removed and
a final least-squares adjustment gives the reported parameters and precision.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation
from scipy.stats import chi2

from pyheracles.errors import DegenerateGeometryError, EstimationError, InputError

__all__ = [
    "ESTIMATORS",
    "PARAMETER_NAMES",
    "SimilarityParams",
    "SimilarityResult",
    "estimate_similarity",
    "similarity_matrix",
    "skew",
]

ESTIMATORS = ("lsq", "danish", "l1", "huber", "tukey")
PARAMETER_NAMES = ("tx", "ty", "tz", "omega", "phi", "kappa", "scale")
_MEDIAN_CHI2_3 = float(chi2.ppf(0.5, 3))


@dataclass(frozen=True)
class SimilarityParams:
    """Parameters of :func:`estimate_similarity`.

    Attributes
    ----------
    with_scale
        ``True``: 7-parameter similarity (Helmert); ``False``: 6-parameter rigid body.
    estimator
        ``"lsq"`` (least squares + data snooping), ``"danish"`` (modified Danish
        method), ``"l1"`` (minimum sum), ``"huber"`` or ``"tukey"`` (IRLS).
    sigma_m
        Default a-priori standard deviation of one coordinate, metres, used for
        points without sigmas in their file.  Only relative weights matter for
        the estimate; sigma0 is estimated a posteriori.
    alpha
        Significance level of the per-point outlier test (chi-square, 3 degrees of
        freedom, on the standardised residual with a robust scale).
    danish_c, huber_k, tukey_c
        Tuning constants, in units of the standardised residual (RMS over X, Y, Z of
        the residual divided by its standard deviation).
    max_iterations
        Maximum number of robust reweighting iterations.
    tolerance
        Convergence threshold: largest weight change between iterations (largest
        residual change in units of sigma for L1).
    """

    with_scale: bool = True
    estimator: str = "lsq"
    sigma_m: float = 0.01
    alpha: float = 0.001
    danish_c: float = 2.0
    huber_k: float = 1.5
    tukey_c: float = 4.0
    max_iterations: int = 50
    tolerance: float = 1e-3

    def __post_init__(self) -> None:
        if self.estimator not in ESTIMATORS:
            raise InputError(
                f"unknown estimator {self.estimator!r}; choose one of {', '.join(ESTIMATORS)}"
            )
        if not 0 < self.alpha < 0.5:
            raise InputError(f"alpha must be in (0, 0.5), got {self.alpha}")
        if self.sigma_m <= 0:
            raise InputError(f"sigma_m must be positive, got {self.sigma_m}")


@dataclass(frozen=True)
class SimilarityResult:
    """Result of a similarity/rigid transformation adjustment.

    ``T_target_source`` maps homogeneous source coordinates into the target frame.
    ``parameters``/``std`` are in metres (tx, ty, tz), radians (omega, phi, kappa)
    and unitless (scale); ``std`` of scale is 0 for a 6-parameter fit.
    ``residuals`` are ``target - T(source)`` (metres) for every input pair (also
    the rejected ones); ``weights`` are the final robust weights (0 = rejected).
    """

    T_target_source: NDArray[np.float64]
    parameters: dict[str, float]
    std: dict[str, float]
    covariance: NDArray[np.float64]
    correlation: NDArray[np.float64]
    sigma0: float
    redundancy: int
    n_pairs: int
    n_used: int
    residuals: NDArray[np.float64]
    residual_3d: NDArray[np.float64]
    redundancy_numbers: NDArray[np.float64]
    test_statistic: NDArray[np.float64]
    outliers: NDArray[np.bool_]
    weights: NDArray[np.float64]
    estimator: str
    with_scale: bool
    iterations: int
    converged: bool
    ids: tuple[str, ...] = field(default=())

    @property
    def parameter_names(self) -> tuple[str, ...]:
        return PARAMETER_NAMES if self.with_scale else PARAMETER_NAMES[:6]

    def apply(self, xyz: ArrayLike) -> NDArray[np.float64]:
        """Transform ``(N, 3)`` source coordinates into the target frame."""
        p = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
        return p @ self.T_target_source[:3, :3].T + self.T_target_source[:3, 3]

    def point_covariance(self, xyz: ArrayLike) -> NDArray[np.float64]:
        """``(N, 3, 3)`` covariance of transformed points due to the parameter uncertainty.

        First-order propagation ``J C J^T`` of the parameter covariance, with the
        Jacobian of ``T(x)`` taken by central differences over the 6/7 parameters
        (vectorised over the points); the points themselves are taken as exact.
        """
        p = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
        names = self.parameter_names
        x0 = np.array([self.parameters[k] for k in PARAMETER_NAMES])
        J = np.zeros((len(p), 3, len(names)))
        for k in range(len(names)):
            h = 1e-6 * max(1.0, abs(x0[k])) if k < 3 else 1e-7
            xp, xm = x0.copy(), x0.copy()
            xp[k] += h
            xm[k] -= h
            Tp = similarity_matrix(xp[:3], xp[3:6], xp[6])
            Tm = similarity_matrix(xm[:3], xm[3:6], xm[6])
            J[:, :, k] = (p @ (Tp[:3, :3] - Tm[:3, :3]).T + (Tp[:3, 3] - Tm[:3, 3])) / (2 * h)
        C = self.covariance[: len(names), : len(names)]
        return np.einsum("nik,kl,njl->nij", J, C, J)

    def rms(self, *, inliers_only: bool = True) -> dict[str, float]:
        """RMS of the residuals in X, Y, Z and 3D, metres."""
        v = self.residuals[~self.outliers] if inliers_only else self.residuals
        if len(v) == 0:
            return {"x": float("nan"), "y": float("nan"), "z": float("nan"), "3d": float("nan")}
        r = np.sqrt(np.mean(v**2, axis=0))
        return {
            "x": float(r[0]),
            "y": float(r[1]),
            "z": float(r[2]),
            "3d": float(np.sqrt(np.mean(np.sum(v**2, axis=1)))),
        }

    def to_dict(self) -> dict:
        """JSON-ready summary (angles also in degrees)."""
        names = self.parameter_names
        k = len(names)
        return {
            "estimator": self.estimator,
            "model": "similarity (7 parameters)" if self.with_scale else "rigid (6 parameters)",
            "T_target_source": self.T_target_source.tolist(),
            "parameters": {n: self.parameters[n] for n in names},
            "std": {n: self.std[n] for n in names},
            "parameters_deg": {n: float(np.degrees(self.parameters[n])) for n in names[3:6]},
            "std_deg": {n: float(np.degrees(self.std[n])) for n in names[3:6]},
            "correlation": {"names": list(names), "matrix": self.correlation[:k, :k].tolist()},
            "sigma0": self.sigma0,
            "redundancy": self.redundancy,
            "n_pairs": self.n_pairs,
            "n_used": self.n_used,
            "rms_m": self.rms(),
            "iterations": self.iterations,
            "converged": self.converged,
            "points": [
                {
                    "id": self.ids[i] if self.ids else str(i),
                    "vx": float(self.residuals[i, 0]),
                    "vy": float(self.residuals[i, 1]),
                    "vz": float(self.residuals[i, 2]),
                    "v3d": float(self.residual_3d[i]),
                    "weight": float(self.weights[i]),
                    "test_statistic": float(self.test_statistic[i]),
                    "outlier": bool(self.outliers[i]),
                }
                for i in range(self.n_pairs)
            ],
        }


def similarity_matrix(
    translation: ArrayLike, angles_rad: ArrayLike, scale: float = 1.0
) -> NDArray[np.float64]:
    """4x4 matrix ``T_target_source`` from (tx, ty, tz), (omega, phi, kappa) and scale."""
    T = np.eye(4)
    T[:3, :3] = scale * Rotation.from_euler("xyz", np.asarray(angles_rad, float)).as_matrix()
    T[:3, 3] = np.asarray(translation, dtype=float)
    return T


def skew(q: NDArray[np.float64]) -> NDArray[np.float64]:
    """Stack of cross-product matrices ``[q]x`` for ``(N, 3)`` vectors."""
    z = np.zeros(len(q))
    return np.stack(
        [
            np.stack([z, -q[:, 2], q[:, 1]], axis=-1),
            np.stack([q[:, 2], z, -q[:, 0]], axis=-1),
            np.stack([-q[:, 1], q[:, 0], z], axis=-1),
        ],
        axis=1,
    )


def parameter_covariance(
    R: NDArray[np.float64],
    s: float,
    centre_source: NDArray[np.float64],
    cov_local: NDArray[np.float64],
    with_scale: bool,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Euler angles and the 7x7 covariance of (tx, ty, tz, omega, phi, kappa, scale).

    ``cov_local`` is the covariance of the adjustment unknowns (t', d, s) of the
    centred model ``x_t - c_t = t' + s exp([d]x) R (x_s - c_s)``; the translation of
    the full transform is ``t = c_t + t' - s R c_s``.
    """
    u = 7 if with_scale else 6
    angles = Rotation.from_matrix(R).as_euler("xyz")
    # d(angles)/d(rotation increment), central differences on the rotation manifold
    Je = np.zeros((3, 3))
    h = 1e-6
    for k in range(3):
        d = np.zeros(3)
        d[k] = h
        ap = Rotation.from_matrix(Rotation.from_rotvec(d).as_matrix() @ R).as_euler("xyz")
        am = Rotation.from_matrix(Rotation.from_rotvec(-d).as_matrix() @ R).as_euler("xyz")
        Je[:, k] = np.angle(np.exp(1j * (ap - am))) / (2 * h)
    # dt/dt' = I, dt/dd = s [R c_s]x, dt/ds = -R c_s
    Rcs = R @ np.asarray(centre_source, dtype=np.float64)
    G = np.zeros((7, u))
    G[0:3, 0:3] = np.eye(3)
    G[0:3, 3:6] = s * skew(Rcs[None, :])[0]
    G[3:6, 3:6] = Je
    if with_scale:
        G[0:3, 6] = -Rcs
        G[6, 6] = 1.0
    return angles, G @ cov_local @ G.T


def _check_geometry(src: NDArray[np.float64], tgt: NDArray[np.float64]) -> None:
    for name, p in (("source", src), ("target", tgt)):
        c = p - p.mean(axis=0)
        sv = np.linalg.svd(c, compute_uv=False)
        extent = max(float(sv[0]), 1e-300)
        if sv[0] < 1e-9:
            raise DegenerateGeometryError(
                f"the {name} points coincide; a similarity transform needs at least 3 "
                "distinct, non-collinear points",
                hint="measure points spread over the whole object",
            )
        if sv[1] / extent < 1e-6:
            raise DegenerateGeometryError(
                f"the {name} points are collinear (second singular value "
                f"{sv[1] / extent:.1e} of the first); the rotation about their line is "
                "undetermined",
                hint="add points off the line, spread in all directions",
            )


@dataclass
class _Fit:
    R: NDArray[np.float64]
    s: float
    t: NDArray[np.float64]  # in the centred frame
    cov_local: NDArray[np.float64]  # (dt', drotvec, ds) whitened, unscaled (N^-1)
    v: NDArray[np.float64]  # residuals (n, 3)
    red: NDArray[np.float64]  # redundancy numbers (n, 3)
    vtpv: float
    n_obs: int


def _weighted_fit(
    src: NDArray[np.float64],
    tgt: NDArray[np.float64],
    sig: NDArray[np.float64],
    w: NDArray[np.float64],
    with_scale: bool,
) -> tuple[_Fit, NDArray[np.float64]]:
    """Weighted least squares similarity on centred coordinates (Gauss-Newton).

    Hand-written Gauss-Newton because the rotation is updated on the manifold
    (``R <- exp([d]x) R``), which keeps the adjustment free of Euler-angle
    singularities; ``scipy.optimize.least_squares`` has no manifold update.  The
    closed-form start (``Rotation.align_vectors``, Kabsch/Horn) is already close, so
    2-4 iterations suffice.
    """
    sw = np.sqrt(w)  # (n, 3) per-coordinate weights, incl. 1/sigma^2 below
    use = (w > 0).any(axis=1)
    wp = w.sum(axis=1)
    cs = (src * wp[:, None]).sum(0) / wp.sum()
    ct = (tgt * wp[:, None]).sum(0) / wp.sum()
    a = src - cs
    b = tgt - ct
    rot, _ = Rotation.align_vectors(b[use], a[use], weights=wp[use])
    R = rot.as_matrix()
    if with_scale:
        ra = a[use] @ R.T
        s = float(np.sum(wp[use][:, None] * ra * b[use]) / np.sum(wp[use][:, None] * ra * ra))
    else:
        s = 1.0
    t = np.zeros(3)
    u = 7 if with_scale else 6
    n = len(src)
    ww = (sw / sig).reshape(-1)  # whitening factors per observation
    for _ in range(20):
        q = a @ R.T  # rotated source
        pred = t + s * q
        v = b - pred
        J = np.zeros((n, 3, u))
        J[:, :, 0:3] = np.eye(3)
        J[:, :, 3:6] = -s * skew(q)  # d(exp([d]x) q)/dd = -[q]x
        if with_scale:
            J[:, :, 6] = q
        Jw = J.reshape(3 * n, u) * ww[:, None]
        vw = v.reshape(-1) * ww
        dx, *_ = np.linalg.lstsq(Jw, vw, rcond=None)
        t = t + dx[:3]
        R = Rotation.from_rotvec(dx[3:6]).as_matrix() @ R
        if with_scale:
            s = s + float(dx[6])
        if np.max(np.abs(dx[3:])) < 1e-13 and np.max(np.abs(dx[:3])) < 1e-12 * (
            1 + np.abs(b).max()
        ):
            break
    q = a @ R.T
    v = b - (t + s * q)
    J = np.zeros((n, 3, u))
    J[:, :, 0:3] = np.eye(3)
    J[:, :, 3:6] = -s * skew(q)
    if with_scale:
        J[:, :, 6] = q
    Jw = J.reshape(3 * n, u) * ww[:, None]
    N = Jw.T @ Jw
    try:
        Ninv = np.linalg.inv(N)
    except np.linalg.LinAlgError as exc:  # pragma: no cover - geometry checked before
        raise EstimationError("singular normal matrix in the similarity adjustment") from exc
    h = np.einsum("ij,jk,ik->i", Jw, Ninv, Jw).reshape(n, 3)
    red = np.clip(1.0 - h, 0.0, 1.0)
    vw = v.reshape(-1) * ww
    # translation of the full transform: x_t = ct + t + s R (x_s - cs)
    return _Fit(
        R=R,
        s=s,
        t=ct + t - s * (R @ cs),
        cov_local=Ninv,
        v=v,
        red=red,
        vtpv=float(vw @ vw),
        n_obs=int((w > 0).sum()),
    ), cs


def _standardised(
    v: NDArray[np.float64], sig: NDArray[np.float64], red: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Per point: sum over X, Y, Z of v^2 / (sigma^2 r), ~ sigma0^2 chi2(3) without blunder."""
    return np.sum(v**2 / (sig**2 * np.maximum(red, 1e-6)), axis=1)


def _robust_weights(e: NDArray[np.float64], params: SimilarityParams) -> NDArray[np.float64]:
    """Per-point weights from standardised residuals ``e`` (RMS over X, Y, Z, unit sigma)."""
    if params.estimator == "huber":
        k = params.huber_k
        return np.where(e <= k, 1.0, k / np.maximum(e, 1e-12))
    if params.estimator == "tukey":
        c = params.tukey_c
        return np.where(e < c, (1.0 - (e / c) ** 2) ** 2, 0.0)
    if params.estimator == "danish":
        # modified Danish method (Krarup, Juhl & Kubik 1980; Kubik's modification):
        # full weight inside c, then an exponential decay that is continuous at c.
        c = params.danish_c
        return np.where(e <= c, 1.0, np.exp(1.0 - (e / c) ** 2))
    raise AssertionError(params.estimator)  # pragma: no cover


def estimate_similarity(
    source: ArrayLike,
    target: ArrayLike,
    params: SimilarityParams | None = None,
    *,
    source_sigma: ArrayLike | None = None,
    target_sigma: ArrayLike | None = None,
    ids: Sequence[str] | None = None,
) -> SimilarityResult:
    """Estimate the similarity (7p) or rigid (6p) transform mapping source onto target.

    Parameters
    ----------
    source, target
        ``(N, 3)`` coordinates of the same N points in the source and target frames,
        metres.  Large (national grid) coordinates are fine: the adjustment works on
        centred coordinates.
    params
        :class:`SimilarityParams`; default least squares, 7 parameters.
    source_sigma, target_sigma
        Standard deviations of the coordinates, metres: scalar, ``(N,)`` or ``(N, 3)``.
        Default ``params.sigma_m`` for the target and 0 for the source.
    ids
        Point names, reported with the residuals.

    Returns
    -------
    SimilarityResult
        Transform, parameters with standard deviations and correlations, sigma0,
        redundancy, residuals and outlier flags.

    Raises
    ------
    InputError
        Fewer than 3 pairs, shape mismatch, NaN.
    DegenerateGeometryError
        Coincident or collinear points.
    EstimationError
        The robust estimation left fewer than 3 points.

    Examples
    --------
    >>> import numpy as np
    >>> src = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])
    >>> T = similarity_matrix([10, 20, 30], [0, 0, np.pi / 2], 2.0)
    >>> res = estimate_similarity(src, src @ T[:3, :3].T + T[:3, 3])
    >>> round(res.parameters["scale"], 6), round(np.degrees(res.parameters["kappa"]), 6)
    (2.0, 90.0)
    """
    p = params or SimilarityParams()
    src = np.asarray(source, dtype=np.float64)
    tgt = np.asarray(target, dtype=np.float64)
    if src.ndim != 2 or src.shape[1] != 3 or src.shape != tgt.shape:
        raise InputError(
            f"source and target must both be (N, 3) arrays, got {src.shape} and {tgt.shape}"
        )
    n = len(src)
    if n < 3:
        raise InputError(
            f"a similarity transform needs at least 3 point pairs, got {n}",
            hint="measure more common points (tie or control points) in both frames",
        )
    if not (np.isfinite(src).all() and np.isfinite(tgt).all()):
        raise InputError("point coordinates contain NaN or infinite values")
    id_tuple = tuple(str(i) for i in ids) if ids is not None else ()
    if id_tuple and len(id_tuple) != n:
        raise InputError(f"{len(id_tuple)} ids for {n} point pairs")
    _check_geometry(src, tgt)
    ss = np.broadcast_to(
        np.asarray(0.0 if source_sigma is None else source_sigma, float).reshape(
            (-1, 1) if np.ndim(source_sigma) == 1 else np.shape(source_sigma) or (1,)
        ),
        (n, 3),
    )
    ts = np.broadcast_to(
        np.asarray(p.sigma_m if target_sigma is None else target_sigma, float).reshape(
            (-1, 1) if np.ndim(target_sigma) == 1 else np.shape(target_sigma) or (1,)
        ),
        (n, 3),
    )
    if (ss < 0).any() or (ts < 0).any():
        raise InputError("coordinate standard deviations must not be negative")
    u = 7 if p.with_scale else 6
    need = 3

    def sigmas(fit_R: NDArray[np.float64] | None, s: float) -> NDArray[np.float64]:
        if fit_R is None or not ss.any():
            return np.maximum(np.sqrt(ts**2 + ss**2), 1e-12)
        prop = (s**2) * (ss**2) @ (fit_R**2).T  # diag of s^2 R diag(ss^2) R^T
        return np.maximum(np.sqrt(ts**2 + prop), 1e-12)

    sig = sigmas(None, 1.0)
    w = np.ones((n, 3))
    fit, _ = _weighted_fit(src, tgt, sig, w, p.with_scale)
    if ss.any():
        sig = sigmas(fit.R, fit.s)
        fit, _ = _weighted_fit(src, tgt, sig, w, p.with_scale)

    def stats(fit: _Fit, mask: NDArray[np.bool_]) -> tuple[NDArray[np.float64], float]:
        T2 = _standardised(fit.v, sig, fit.red)
        good = T2[mask]
        scale2 = float(np.median(good) / _MEDIAN_CHI2_3) if len(good) else 1.0
        return T2, max(scale2, 1e-300)

    iterations = 0
    converged = True
    point_w = np.ones(n)
    if p.estimator != "lsq":
        converged = False
        for iterations in range(1, p.max_iterations + 1):  # noqa: B007
            if p.estimator == "l1":
                # minimum sum of |v|/sigma per coordinate: IRLS weights 1/|v| (Beaton-Tukey)
                z = np.abs(fit.v) / sig
                floor = max(1e-6, 1e-3 * float(np.median(z)))
                cw = 1.0 / np.maximum(z, floor)
                w = cw / cw.max()
                v_prev = fit.v
            else:
                T2, s2 = stats(fit, point_w > 0)
                e = np.sqrt(T2 / (3.0 * s2))
                new_pw = _robust_weights(e, p)
                change = float(np.max(np.abs(new_pw - point_w)))
                point_w = new_pw
                w = np.repeat(point_w[:, None], 3, axis=1)
            if int(((w > 1e-3).any(axis=1)).sum()) < need:
                raise EstimationError(
                    f"robust estimation ({p.estimator}) rejected all but "
                    f"{int((w > 1e-3).any(axis=1).sum())} points",
                )
            fit, _ = _weighted_fit(src, tgt, sig, np.maximum(w, 1e-12), p.with_scale)
            if p.estimator == "l1":  # converged when the residuals stop moving
                change = float(np.max(np.abs(fit.v - v_prev) / sig))
            if change < p.tolerance:
                converged = True
                break
        if p.estimator == "l1":
            point_w = w.mean(axis=1)
    # outlier test: chi2(3) on the standardised residual.  The scale is sigma0 of a
    # least-squares fit on the points the robust estimator trusts (more efficient than
    # the median scale of ~10 points, which gives too many false alarms).
    crit = float(chi2.ppf(1.0 - p.alpha, 3))
    if p.estimator == "l1":
        T2, s2 = stats(fit, np.ones(n, bool))
        trusted = T2 / s2 <= float(chi2.ppf(1.0 - 1e-6, 3))  # drop only clear blunders
    else:
        trusted = point_w > 0.1  # excludes only clear blunders (e > ~3.3 for Tukey)
    if trusted.sum() < 4:
        trusted = np.ones(n, bool)
    w_t = np.repeat(trusted[:, None], 3, axis=1).astype(float)
    fit_t, _ = _weighted_fit(src, tgt, sig, np.maximum(w_t, 1e-12), p.with_scale)
    red_t = 3 * int(trusted.sum()) - u
    s2_t = float(np.sum((fit_t.v[trusted] / sig[trusted]) ** 2)) / max(red_t, 1)
    test = _standardised(fit_t.v, sig, fit_t.red) / max(s2_t, 1e-300)
    outliers = test > crit
    if p.estimator == "lsq":
        # data snooping: reject only the worst point per round
        outliers = np.zeros(n, bool)
        for _ in range(max(0, n - u // 3 - 1)):
            w_ls = np.repeat((~outliers)[:, None], 3, axis=1).astype(float)
            fit_i, _ = _weighted_fit(src, tgt, sig, np.maximum(w_ls, 1e-12), p.with_scale)
            T2i = _standardised(fit_i.v, sig, fit_i.red)
            ref = T2i[~outliers]
            s2i = max(float(np.median(ref) / _MEDIAN_CHI2_3), 1e-300)
            ti = np.where(outliers, -np.inf, T2i / s2i)
            worst = int(np.argmax(ti))
            if ti[worst] <= crit or (~outliers).sum() <= 4:
                break
            outliers[worst] = True
    n_used = int((~outliers).sum())
    if n_used < 3:
        raise EstimationError(f"only {n_used} points left after outlier rejection")
    # final least-squares adjustment on the accepted points
    w_final = np.repeat((~outliers)[:, None], 3, axis=1).astype(float)
    fit, cs = _weighted_fit(src, tgt, sig, np.maximum(w_final, 1e-12), p.with_scale)
    redundancy = 3 * n_used - u
    vw = fit.v / sig
    vtpv = float(np.sum(vw[~outliers] ** 2))
    sigma0 = float(np.sqrt(vtpv / redundancy)) if redundancy > 0 else float("nan")
    # per-point test statistic of the final adjustment: ~chi2(3) for a good point
    test = _standardised(fit.v, sig, fit.red) / (sigma0**2 if redundancy > 0 else 1.0)
    # covariance of (t', dtheta, s) in the centred frame -> (t, omega, phi, kappa, s)
    c_loc = (sigma0**2 if redundancy > 0 else 1.0) * fit.cov_local
    R = fit.R
    angles, cov = parameter_covariance(R, fit.s, cs, c_loc, p.with_scale)
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(sd, sd)
    corr[~np.isfinite(corr)] = 0.0
    values = [*fit.t.tolist(), *angles.tolist(), fit.s]
    T = np.eye(4)
    T[:3, :3] = fit.s * R
    T[:3, 3] = fit.t
    v_all = tgt - (src @ T[:3, :3].T + T[:3, 3])
    return SimilarityResult(
        T_target_source=T,
        parameters=dict(zip(PARAMETER_NAMES, map(float, values), strict=True)),
        std=dict(zip(PARAMETER_NAMES, map(float, sd), strict=True)),
        covariance=cov,
        correlation=corr,
        sigma0=sigma0,
        redundancy=int(redundancy),
        n_pairs=n,
        n_used=n_used,
        residuals=v_all,
        residual_3d=np.linalg.norm(v_all, axis=1),
        redundancy_numbers=fit.red,
        test_statistic=test,
        outliers=outliers,
        weights=np.where(outliers, 0.0, point_w if p.estimator != "lsq" else 1.0),
        estimator=p.estimator,
        with_scale=p.with_scale,
        iterations=iterations,
        converged=converged,
        ids=id_tuple,
    )
