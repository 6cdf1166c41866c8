"""Sparse bundle adjustment with self-calibration (Gauss-Newton, Armijo, Levenberg-Marquardt).

The normal equations are reduced to the camera parameters with the Schur
complement on the object points (each point is a 3x3 block), solved by a
Cholesky factorisation of the small camera system, and back-substituted.  The
damping schemes are those of DBAT (Börlin & Grussenmeyer 2013): undamped
Gauss-Newton ("gn"), Gauss-Newton with an Armijo line search ("gna", the
default) and Levenberg-Marquardt ("lm").  The termination test is DBAT's
relative one: ``||J p|| <= tol ||r||``.
"""

from __future__ import annotations

import time
import warnings
from contextlib import contextmanager
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg

from pyheracles.bundle.camera import IO_NAMES, image_residuals
from pyheracles.bundle.diagnostics import control_point_test
from pyheracles.bundle.network import Network, prepare_network
from pyheracles.bundle.parameters import EO_NAMES, BundleParameters
from pyheracles.bundle.posterior import (
    posterior_covariance,
    prior_redundancy,
    redundancy_numbers,
)
from pyheracles.bundle.project import BundleWarning, Project
from pyheracles.bundle.schur import PointCameraSystem, SchurLayout
from pyheracles.errors import DegenerateGeometryError, EstimationError

__all__ = ["BundleResult", "bundle_adjust"]


@dataclass
class BundleResult:
    """Outcome of :func:`bundle_adjust`.

    Attributes
    ----------
    converged, iterations, status
        Convergence flag, number of iterations, and a text status.
    sigma0
        Posterior standard deviation of unit weight (sqrt(r'Wr / redundancy)).
    redundancy, n_observations, n_parameters
        Degrees of freedom, observation count (image coordinates + prior
        observations), unknown count.
    io, eo, xyz
        Estimated interior (ncam,10), exterior (n,6) orientation, points (N,3).
    io_std, eo_std, xyz_std
        Posterior standard deviations (0 for fixed parameters).
    cov_io_eo
        Posterior covariance of the camera parameters in the column order of
        ``network.io_col`` / ``network.eo_col`` (free parameters only).
    cov_xyz
        (N,3,3) posterior covariance of each object point.
    residuals_px
        (m,2) image residuals (projected - measured) in pixels.
    history
        Weighted residual norm per iteration, step lengths (gna) or damping (lm).
    timings
        Seconds per stage.
    """

    project: Project
    network: Network
    parameters: BundleParameters
    converged: bool
    iterations: int
    status: str
    sigma0: float
    redundancy: int
    n_observations: int
    n_parameters: int
    io: np.ndarray
    eo: np.ndarray
    xyz: np.ndarray
    io_std: np.ndarray | None = None
    eo_std: np.ndarray | None = None
    xyz_std: np.ndarray | None = None
    cov_cam: np.ndarray | None = None
    cov_xyz: np.ndarray | None = None
    residuals_px: np.ndarray | None = None
    weighted_residuals: np.ndarray | None = None
    history: dict = field(default_factory=dict)
    timings: dict = field(default_factory=dict)
    rank_deficiency: list = field(default_factory=list)
    redundancy_numbers: np.ndarray | None = None
    prior_redundancy_numbers: np.ndarray | None = None
    diagnosis: dict = field(default_factory=dict)

    @property
    def cameras(self):
        return tuple(c.with_io(io) for c, io in zip(self.project.cameras, self.io, strict=True))


# ---------------------------------------------------------------------------
# Residuals and normal equations
# ---------------------------------------------------------------------------


@dataclass
class _State:
    io: np.ndarray
    eo: np.ndarray
    xyz: np.ndarray

    def copy(self) -> _State:
        return _State(self.io.copy(), self.eo.copy(), self.xyz.copy())


def _residuals(net: Network, st: _State, jacobian: bool = False):
    p = net.project
    out = image_residuals(
        st.io[net.obs_cam],
        st.eo,
        st.xyz[p.obs_point],
        net.uv_mm,
        net.model,
        jacobian=jacobian,
        obs_image=p.obs_image,
    )
    res, jac = out if jacobian else (out, None)
    r_img = res * net.sqrt_w
    eo_m = np.isfinite(net.eo_prior_std)
    op_m = np.isfinite(net.op_prior_std)
    r_eo = ((st.eo - net.eo_prior) / net.eo_prior_std)[eo_m]
    r_op = ((st.xyz - net.op_prior) / net.op_prior_std)[op_m]
    r = np.concatenate([r_img.ravel(), r_eo, r_op])
    return r, jac


def _singular_points(project: Project):
    def fail(idx: np.ndarray) -> None:
        raise DegenerateGeometryError(
            f"{len(idx)} object point(s) are undetermined (singular 3x3 normal block: rays "
            f"parallel or from one centre), ids {project.point_ids[idx][:10].tolist()}",
            path=project.source,
            hint="remove these points or add images with a wider base",
        )

    return fail


def _cholesky(s: np.ndarray):
    """Jacobi-scaled Cholesky factor of the reduced matrix; None when not positive definite."""
    d = np.sqrt(np.clip(np.diag(s), 1e-300, None))
    ss = s / d[:, None] / d[None, :]
    try:
        fac = scipy.linalg.cho_factor(ss, lower=True, check_finite=False)
    except np.linalg.LinAlgError:
        return None, d
    if not np.all(np.isfinite(fac[0])) or np.min(np.abs(np.diag(fac[0]))) < 1e-9:
        return None, d
    return fac, d


def _solve(ne: PointCameraSystem, fac, d) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Newton step (dx_op (N,3), dx_cam (nc,)) for N dx = -J^T r."""
    rhs = ne.reduced_rhs()
    dc = scipy.linalg.cho_solve(fac, rhs / d, check_finite=False) / d if rhs.size else rhs
    return ne.back_substitute(dc), dc


def _apply(net: Network, st: _State, dp: np.ndarray, dc: np.ndarray, alpha: float) -> _State:
    new = st.copy()
    new.xyz += alpha * dp * net.op_free
    if dc.size:
        new.io[net.io_free] += alpha * dc[net.io_col[net.io_free]]
        new.eo[net.eo_free] += alpha * dc[net.eo_col[net.eo_free]]
    return new


def _rank_report(net: Network, s: np.ndarray) -> list[dict]:
    """Name the camera parameters in the near-null space of the reduced matrix."""
    d = np.sqrt(np.clip(np.diag(s), 1e-300, None))
    ss = s / d[:, None] / d[None, :]
    vals, vecs = np.linalg.eigh(ss)
    names = _camera_param_names(net)
    out = []
    tol = 1e-10 * max(vals.max(), 1.0)
    for k in np.flatnonzero(vals < tol):
        v = vecs[:, k]
        order = np.argsort(-np.abs(v))
        # DBAT's rule: keep the elements above halfway between the average and the max.
        thr = 0.5 * (np.abs(v[order[0]]) + np.sqrt(1.0 / v.size))
        out.append(
            {
                "eigenvalue": float(vals[k]),
                "parameters": [names[i] for i in order if abs(v[i]) > thr],
            }
        )
    return out


def _rank_message(deficiency: list[dict]) -> str:
    """Short text: the defect and the kinds of parameters involved (counted)."""
    from collections import Counter

    kinds: Counter[str] = Counter()
    for x in deficiency:
        for name in x["parameters"]:
            parts = name.split()
            kinds[f"{parts[0]} {parts[-1]}"] += 1
    images_only = all(k.startswith("image") for k in kinds)
    what = ", ".join(f"{k} ({n})" for k, n in kinds.most_common(12))
    msg = f"rank defect {len(deficiency)}; undetermined combinations involve {what}"
    if images_only:
        msg += " (the datum is undefined: fix a reference image or use control points)"
    return msg


def _camera_param_names(net: Network) -> list[str]:
    names = [""] * net.n_cam_cols
    for ci, j in zip(*np.nonzero(net.io_free), strict=True):
        names[net.io_col[ci, j]] = f"camera {net.project.cameras[ci].id} {IO_NAMES[j]}"
    for ii, j in zip(*np.nonzero(net.eo_free), strict=True):
        names[net.eo_col[ii, j]] = f"image {net.project.image_ids[ii]} {EO_NAMES[j]}"
    return names


# ---------------------------------------------------------------------------
# Driver
# ---------------------------------------------------------------------------


def bundle_adjust(project: Project, params: BundleParameters | None = None) -> BundleResult:
    """Bundle adjustment with self-calibration and posterior statistics.

    Parameters
    ----------
    project
        The network (see the readers in :mod:`pyheracles.bundle.readers`).
    params
        Settings; defaults reproduce DBAT's (GNA damping, 20 iterations, 1e-6).

    Returns
    -------
    BundleResult

    Raises
    ------
    InputError, DegenerateGeometryError
        Inconsistent project, too few control points for the datum, undetermined
        points or parameters (the message names them).
    EstimationError
        No convergence within ``max_iterations``.

    Examples
    --------
    >>> from pyheracles.bundle import read_project, bundle_adjust
    >>> res = bundle_adjust(read_project("romabundledemo.xml"))  # doctest: +SKIP
    >>> round(res.sigma0, 4)  # doctest: +SKIP
    0.5828
    """
    params = params or BundleParameters()
    with _blas_threads(params.blas_threads):
        return _bundle_adjust(project, params)


@contextmanager
def _blas_threads(n: int | None):
    """Limit BLAS threads: OpenBLAS threads busy-wait on a loaded machine and made a
    358x358 Cholesky 200x slower in our tests; the big work here is sparse anyway."""
    if n is None:
        yield
        return
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # optional dependency (comes with scikit-learn)
        yield
        return
    with threadpool_limits(limits=n, user_api="blas"):
        yield


def _bundle_adjust(project: Project, params: BundleParameters) -> BundleResult:
    t0 = time.perf_counter()
    net = prepare_network(project, params)
    p = net.project
    xyz0 = net.xyz_init if net.xyz_init is not None else p.xyz
    st = _State(np.array([c.io_vector() for c in p.cameras]), p.eo.copy(), xyz0.copy())
    diagnosis: dict = {"control_test_before": control_point_test(net, st.io, st.eo, 1.0)}
    _warn_gross(p, diagnosis["control_test_before"], "before")
    timings = {"setup": time.perf_counter() - t0}
    t1 = time.perf_counter()
    r, jac = _residuals(net, st, jacobian=True)
    norms = [float(np.linalg.norm(r))]
    alphas: list[float] = []
    lambdas: list[float] = []
    n_iter = 0
    converged = False
    status = "ok"
    lam = params.lm_lambda0 if params.damping == "lm" else 0.0
    carried = None  # (residual, Jacobian) of an accepted full step

    def failure(exc: Exception, **extra) -> Exception:
        exc.diagnosis = _failure_diagnosis(net, st, r, norms, n_iter, diagnosis, **extra)
        return exc

    layout = SchurLayout.from_network(net)  # image-pair structure, fixed over iterations
    while True:
        ne = PointCameraSystem.build(net, st, r, jac, layout)
        try:
            ne.reduce(raise_singular=_singular_points(p))
        except DegenerateGeometryError as exc:
            raise failure(exc, status=str(exc)) from None
        fac, d = _cholesky(ne.s)
        if fac is None:
            deficiency = _rank_report(net, ne.s)
            raise failure(
                DegenerateGeometryError(
                    f"the normal equations are rank deficient: {_rank_message(deficiency)}",
                    path=p.source,
                    hint="fix some interior parameters (--estimate) or add control points",
                ),
                status="rank deficient",
                rank_deficiency=deficiency,
            )
        dp, dc = _solve(ne, fac, d)
        g = np.concatenate([ne.g_op.ravel(), ne.g_cam])
        step = np.concatenate([(dp * net.op_free).ravel(), dc])
        fp0 = float(g @ step)  # = -||J p||^2 for the Gauss-Newton step
        if np.sqrt(max(-fp0, 0.0)) <= params.tolerance * np.linalg.norm(r):
            converged = True
            break
        if n_iter >= params.max_iterations:
            status = f"no convergence after {n_iter} iterations"
            break
        n_iter += 1
        f0 = 0.5 * float(r @ r)
        if params.damping == "gn":
            st = _apply(net, st, dp, dc, 1.0)
            alphas.append(1.0)
        elif params.damping == "gna":
            alpha = 1.0
            while alpha >= params.alpha_min:
                trial = _apply(net, st, dp, dc, alpha)
                # A full step (usually accepted) brings its Jacobian for the next round.
                rt, jt = _residuals(net, trial, jacobian=alpha == 1.0)
                if 0.5 * float(rt @ rt) < f0 + params.armijo_mu * alpha * fp0:
                    break
                alpha /= 2
            else:
                status = "line search failed"
                break
            st = trial
            alphas.append(alpha)
            if jt is not None:
                carried = (rt, jt)
        else:  # Levenberg-Marquardt (Marquardt scaling of the diagonal)
            while True:
                ne.reduce(lam)
                fac_l, d_l = _cholesky(ne.s)
                if fac_l is not None:
                    dpl, dcl = _solve(ne, fac_l, d_l)
                    trial = _apply(net, st, dpl, dcl, 1.0)
                    rt, _ = _residuals(net, trial)
                    if float(rt @ rt) < 2 * f0:
                        lam = max(lam / 10, 1e-12)
                        break
                lam *= 10
                if lam > 1e12:
                    status = "damping diverged"
                    break
            if status != "ok":
                break
            st = trial
            lambdas.append(lam)
        if carried is not None:
            (r, jac), carried = carried, None
        else:
            r, jac = _residuals(net, st, jacobian=True)
        norms.append(float(np.linalg.norm(r)))
    timings["adjust"] = time.perf_counter() - t1
    if not converged:
        exc = failure(
            EstimationError(
                f"{p.source}: bundle adjustment did not converge ({status}); "
                f"residual norms {np.round(norms, 3).tolist()}"
            ),
            status=status,
        )
        before = diagnosis["control_test_before"]["gross"]
        after = exc.diagnosis["control_test_after"]["gross"]
        if before or after:
            exc.args = (
                f"{exc.args[0]}; gross control/check point(s) before the adjustment "
                f"{before[:10]}, at the last iterate {after[:10]}",
            )
        raise exc
    m_obs = 2 * p.n_observations + net.n_prior
    n_par = net.n_free
    dof = m_obs - n_par
    if dof <= 0:
        raise DegenerateGeometryError(
            f"no redundancy ({m_obs} observations, {n_par} unknowns)", path=p.source
        )
    sigma0 = float(np.sqrt(r @ r / dof))
    res_mm = r[: 2 * p.n_observations].reshape(-1, 2) / net.sqrt_w
    pix = np.array([c.pixel_size_mm for c in p.cameras])[net.obs_cam]
    result = BundleResult(
        project=p,
        network=net,
        parameters=params,
        converged=converged,
        iterations=n_iter,
        status=status,
        sigma0=sigma0,
        redundancy=int(dof),
        n_observations=int(m_obs),
        n_parameters=int(n_par),
        io=st.io,
        eo=st.eo,
        xyz=st.xyz,
        residuals_px=res_mm / pix,
        weighted_residuals=r,
        history={"residual_norm": norms, "alpha": alphas, "lambda": lambdas},
        timings=timings,
        diagnosis=diagnosis,
    )
    diagnosis["control_test_after"] = control_point_test(net, st.io, st.eo, sigma0)
    _warn_gross(p, diagnosis["control_test_after"], "after")
    if params.covariance:
        t2 = time.perf_counter()
        posterior_covariance(result, ne, fac, d)
        t3 = time.perf_counter()
        result.redundancy_numbers = redundancy_numbers(result, ne, jac)
        result.prior_redundancy_numbers = prior_redundancy(result)
        timings["redundancy"] = time.perf_counter() - t3
        timings["covariance"] = time.perf_counter() - t2
    timings["total"] = time.perf_counter() - t0
    return result


def _warn_gross(p: Project, test: dict, when: str) -> None:
    if test["gross"]:
        worst = {q["id"]: q for q in test["points"]}
        parts = [
            f"{pid} ({worst[pid]['label']}, {worst[pid]['role']}: "
            f"{worst[pid]['delta_norm']:.3g} from its intersection)"
            for pid in test["gross"][:5]
        ]
        warnings.warn(
            f"{p.source}: gross control/check point(s) {when} the adjustment: "
            f"{', '.join(parts)}; median discrepancy {test['median_delta']:.3g}. Check their "
            "coordinates and ids (or make them check points)",
            BundleWarning,
            stacklevel=4,
        )


def _failure_diagnosis(net: Network, st: _State, r: np.ndarray, norms: list, n_iter: int,
                       diagnosis: dict, status: str = "",
                       rank_deficiency: list | None = None) -> dict:  # fmt: skip
    """What a failed run can still tell: iterations, residuals, worst observations."""
    from pyheracles.bundle.diagnostics import worst_observations

    m = 2 * net.project.n_observations + net.n_prior
    dof = m - net.n_free
    out = dict(diagnosis)
    out.update(
        {
            "failed": True,
            "status": status,
            "iterations": n_iter,
            "residual_norm_history": [float(x) for x in norms],
            "sigma0_last": float(np.sqrt(r @ r / dof)) if dof > 0 else None,
            "redundancy": int(dof),
            "n_parameters": int(net.n_free),
            "datum": net.datum,
            "worst_observations": worst_observations(net, r),
            "rank_deficiency": rank_deficiency or [],
        }
    )
    try:
        out["control_test_after"] = control_point_test(net, st.io, st.eo, out["sigma0_last"] or 1.0)
    except (np.linalg.LinAlgError, ValueError):  # pragma: no cover - diagnosis only
        out["control_test_after"] = {"points": [], "gross": []}
    return out
