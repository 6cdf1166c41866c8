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

from pyheracles.bundle.camera import FORWARD_MODEL, IO_NAMES, MODELS, image_residuals
from pyheracles.bundle.diagnostics import control_point_test
from pyheracles.bundle.initial import (
    centre_rotation,
    forward_intersection,
    ideal_rays,
    relative_block_orientation,
    spatial_resection,
)
from pyheracles.bundle.posterior import (
    posterior_covariance,
    prior_redundancy,
    redundancy_numbers,
)
from pyheracles.bundle.project import BundleWarning, Project
from pyheracles.bundle.schur import PointCameraSystem, SchurLayout
from pyheracles.errors import DegenerateGeometryError, EstimationError, InputError

__all__ = ["BundleParameters", "BundleResult", "bundle_adjust", "prepare_network"]

DAMPINGS = ("gna", "lm", "gn")
DATUMS = ("auto", "control", "depend", "free")
SNOOPING_TESTS = ("w", "tau")
EO_NAMES = ("X0", "Y0", "Z0", "omega", "phi", "kappa")


@dataclass(frozen=True)
class BundleParameters:
    """Settings of :func:`bundle_adjust` (defaults are DBAT's).

    Parameters
    ----------
    damping
        "gna" (Gauss-Newton with Armijo line search, DBAT default), "lm"
        (Levenberg-Marquardt) or "gn" (undamped Gauss-Newton).
    max_iterations
        Maximum number of iterations (DBAT: 20).
    tolerance
        Relative termination tolerance ``||J p|| <= tol ||r||`` (DBAT: 1e-6).
    armijo_mu
        Sufficient-decrease constant of the line search (DBAT: 0.1).
    alpha_min
        Shortest step length of the line search (DBAT: 1e-9).
    lm_lambda0
        Initial Levenberg-Marquardt damping, relative to the normal matrix diagonal.
    estimate_io
        Interior parameters to estimate for every camera (names of
        :data:`~pyheracles.bundle.camera.IO_NAMES`, "pp" = px and py); None keeps the
        project's own choice (a DBAT script's), an empty tuple fixes the cameras.
    datum
        "auto" (control points if the project has at least 3 fixed or weighted
        ones, else dependent relative orientation), "control", "depend", or
        "free" (no datum at all: the adjustment then reports the rank deficiency
        and names the undetermined parameters, as DBAT's no-datum demo).
    min_rays
        Tie points seen by fewer images are dropped with a warning.
    covariance
        Compute the posterior covariance (IO, EO, every object point's 3x3 block).
    blas_threads
        BLAS threads during the adjustment (None = library default).
    snooping
        Data snooping test of the image observations: "w" (Baarda's w-test with
        the a priori standard deviations, critical value 3.29) or "tau" (Pope's
        tau test with the posterior sigma0, critical value from the tau
        distribution for the redundancy, at ``snooping_alpha`` per observation).
    snooping_alpha
        Significance level of the tau test (per observation; Pope 1976).
    """

    damping: str = "gna"
    max_iterations: int = 20
    tolerance: float = 1e-6
    armijo_mu: float = 0.1
    alpha_min: float = 1e-9
    lm_lambda0: float = 1e-3
    estimate_io: tuple[str, ...] | None = None
    datum: str = "auto"
    min_rays: int = 2
    covariance: bool = True
    blas_threads: int | None = 1
    snooping: str = "w"
    snooping_alpha: float = 0.001

    def __post_init__(self) -> None:
        if self.snooping not in SNOOPING_TESTS:
            raise InputError(
                f"unknown data snooping test '{self.snooping}'; choose one of "
                f"{list(SNOOPING_TESTS)}"
            )
        if not (0 < self.snooping_alpha < 1):
            raise InputError("snooping_alpha must be in (0, 1)")
        if self.damping not in DAMPINGS:
            raise InputError(f"unknown damping '{self.damping}'; choose one of {list(DAMPINGS)}")
        if self.datum not in DATUMS:
            raise InputError(f"unknown datum '{self.datum}'; choose one of {list(DATUMS)}")
        if self.max_iterations < 1 or not (0 < self.tolerance < 1):
            raise InputError("max_iterations must be >= 1 and 0 < tolerance < 1")


@dataclass
class Network:
    """Arrays of the adjustment problem (free-parameter layout and observations)."""

    project: Project
    model: int
    uv_mm: np.ndarray  # (m,2) measured, scaled to mm, y flipped
    sqrt_w: np.ndarray  # (m,2) 1 / sigma_mm
    obs_cam: np.ndarray  # (m,) camera index of each observation
    io_free: np.ndarray  # (ncam,10)
    eo_free: np.ndarray  # (n,6)
    op_free: np.ndarray  # (N,3)
    io_col: np.ndarray  # (ncam,10) column in the camera system or -1
    eo_col: np.ndarray  # (n,6)
    n_cam_cols: int
    eo_prior: np.ndarray  # (n,6) prior values, std in eo_prior_std (NaN = none)
    eo_prior_std: np.ndarray
    op_prior: np.ndarray
    op_prior_std: np.ndarray
    datum: str
    fixed_coordinate: tuple[int, int] | None = None  # (image, axis) for "depend"
    xyz_init: np.ndarray | None = None  # (N,3) initial point coordinates (None: project.xyz)

    @property
    def n_free(self) -> int:
        return int(self.io_free.sum() + self.eo_free.sum() + self.op_free.sum())

    @property
    def n_prior(self) -> int:
        return int(np.isfinite(self.eo_prior_std).sum() + np.isfinite(self.op_prior_std).sum())


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
# Problem set-up
# ---------------------------------------------------------------------------


def _choose_datum(project: Project, params: BundleParameters) -> str:
    if params.datum == "free":
        return "free"
    n_ctrl = int(
        np.sum(
            (project.point_role == "control")
            & np.all(np.isfinite(project.xyz), axis=1)
            & np.all(np.isfinite(project.xyz_std), axis=1)
        )
    )
    if params.datum == "control" or (params.datum == "auto" and project.datum == "control"):
        if n_ctrl < 3:
            raise DegenerateGeometryError(
                f"datum by control points needs at least 3 control points, found {n_ctrl}",
                path=project.source,
                hint="add control points (--control) or use --datum depend",
            )
        return "control"
    if params.datum == "depend" or project.datum == "depend":
        return "depend"
    if n_ctrl >= 3:
        return "control"
    warnings.warn(
        f"{project.source}: {n_ctrl} fixed or weighted control point(s) (3 needed for a "
        "datum by control points): the datum is a dependent relative orientation "
        "('depend': first image fixed, scale by one base coordinate), so coordinates are "
        "in an arbitrary frame and scale",
        BundleWarning,
        stacklevel=4,
    )
    return "depend"


def _initial_values(
    project: Project, uv_mm: np.ndarray, obs_cam: np.ndarray
) -> tuple[Project, np.ndarray]:
    """Resect images without EO and intersect points without coordinates.

    Returns the project with the initial exterior orientations and point
    coordinates, except that check points keep their reference coordinates
    (what they are checked against), and the initial coordinates of every point.
    """
    cams = project.cameras
    model = cams[0].model
    io_all = np.array([c.io_vector() for c in cams])
    eo = project.eo.copy()
    xyz = project.xyz.copy()
    known = np.all(np.isfinite(xyz), axis=1) & (project.point_role == "control")
    need = ~np.all(np.isfinite(eo), axis=1)
    if project.needs_resection:
        need[:] = True
    n_known = np.bincount(project.obs_image[known[project.obs_point]], minlength=project.n_images)
    if np.any(need & (n_known < 4)):
        # Scarce control: orient the block relatively (essential matrix of the best
        # pair, resection on the growing block), then move it onto the control.
        scarce = np.flatnonzero(need & (n_known < 4))
        eo, _, info = relative_block_orientation(
            project.obs_image,
            project.obs_point,
            ideal_rays(uv_mm, io_all[obs_cam], model),
            uv_mm,
            io_all[obs_cam],
            model,
            project.n_images,
            project.n_points,
            np.where(known[:, None], xyz, np.nan),
            source=project.source,
        )
        warnings.warn(
            f"{project.source}: image(s) {project.image_ids[scarce][:10].tolist()} lack an "
            "exterior orientation and see fewer than 4 control points: the block was "
            f"initialised by relative orientation of images {project.image_ids[info['pair'][0]]} "
            f"and {project.image_ids[info['pair'][1]]} and resection of the others"
            + (
                f", moved onto {info['n_control_used']} control points"
                if info["frame"] == "control"
                else " (fewer than 3 control points: arbitrary frame and scale)"
            ),
            BundleWarning,
            stacklevel=4,
        )
        need[:] = False
    for i in np.flatnonzero(need):
        sel = (project.obs_image == i) & known[project.obs_point]
        eo[i] = spatial_resection(
            xyz[project.obs_point[sel]], uv_mm[sel], io_all[project.image_camera[i]], model
        )
    # Intersect every free point that has no prior observation (as DBAT does).
    inter = (project.point_role != "control") | ~np.all(np.isfinite(xyz), axis=1)
    if np.any(inter):
        sel = inter[project.obs_point]
        centres, rots = centre_rotation(eo)
        img = project.obs_image[sel]
        rays = ideal_rays(uv_mm[sel], io_all[obs_cam[sel]], model)
        idx = np.cumsum(inter) - 1
        pts = forward_intersection(
            centres[img], rots[img], rays, idx[project.obs_point[sel]], int(inter.sum())
        )
        xyz[inter] = pts
        bad = inter.copy()
        bad[inter] = ~np.all(np.isfinite(pts), axis=1)
        if np.any(bad):
            raise DegenerateGeometryError(
                f"{int(bad.sum())} point(s) cannot be intersected (parallel rays), ids "
                f"{project.point_ids[bad][:10].tolist()}",
                path=project.source,
            )
    check = (project.point_role == "check") & np.all(np.isfinite(project.xyz), axis=1)
    reference = np.where(check[:, None], project.xyz, xyz)
    return project.replace(eo=eo, xyz=reference), xyz


def prepare_network(project: Project, params: BundleParameters | None = None) -> Network:
    """Validate the project, compute initial values and the free-parameter layout."""
    params = params or BundleParameters()
    project = project.validate(params.min_rays)
    if params.estimate_io is not None:
        project = project.with_estimated_io(params.estimate_io)
    cams = project.cameras
    model = cams[0].model
    if model not in MODELS:
        raise InputError(f"unsupported lens distortion model {model}", path=project.source)
    obs_cam = project.image_camera[project.obs_image]
    pix = np.array([c.pixel_size_mm for c in cams])
    # DBAT scales both axes by the x pixel size (square pixels; the aspect is a parameter).
    s = pix[obs_cam, 0]
    uv_mm = np.column_stack([project.obs_uv_px[:, 0] * s, -project.obs_uv_px[:, 1] * s])
    sqrt_w = 1.0 / (project.obs_std_px * pix[obs_cam])
    if not np.all(np.isfinite(sqrt_w)) or np.any(project.obs_std_px <= 0):
        raise InputError("image observation standard deviations must be > 0", path=project.source)
    eo_observed = project.eo.copy()  # prior EO values, before resection replaces them
    project, xyz_init = _initial_values(project, uv_mm, obs_cam)

    io_free = project.estimate_io.copy()
    if model in (1, 2, FORWARD_MODEL):
        dropped = [IO_NAMES[j] for j in (3, 4) if io_free[:, j].any()]
        if dropped:
            warnings.warn(
                f"{project.source}: {' and '.join(dropped)} requested but lens model {model} "
                "has no affinity or skew term: not estimated (choose lens model 3, 4 or 5 to "
                "estimate them)",
                BundleWarning,
                stacklevel=3,
            )
        io_free[:, 3:5] = False
    eo_free = project.estimate_eo.copy()
    role = project.point_role
    op_free = np.ones((project.n_points, 3), bool)
    op_prior = np.full((project.n_points, 3), np.nan)
    op_prior_std = np.full((project.n_points, 3), np.nan)
    ctrl = role == "control"
    std = project.xyz_std
    fixed = ctrl[:, None] & np.isfinite(std) & (std == 0)
    weighted = ctrl[:, None] & np.isfinite(std) & (std > 0)
    datum = _choose_datum(project, params)
    fixed_coord = None
    if datum == "free":
        pass
    elif datum == "control":
        op_free &= ~fixed
        op_prior[weighted] = project.xyz[weighted]
        op_prior_std[weighted] = std[weighted]
    else:
        # Dependent relative orientation: fix the reference image and the largest
        # positive coordinate offset of another image from it (DBAT 'longest').
        ref = project.ref_image
        off = project.eo[:, :3] - project.eo[ref, :3]
        img, axis = np.unravel_index(int(np.argmax(off)), off.shape)
        eo_free[:] = True
        eo_free[ref] = False
        eo_free[img, axis] = False
        fixed_coord = (int(img), int(axis))
    eo_prior = np.where(np.isfinite(project.eo_std) & eo_free, eo_observed, np.nan)
    eo_prior_std = np.where(np.isfinite(project.eo_std) & eo_free, project.eo_std, np.nan)
    eo_prior_std[eo_prior_std <= 0] = np.nan

    io_col = np.full(io_free.shape, -1)
    io_col[io_free] = np.arange(io_free.sum())
    eo_col = np.full(eo_free.shape, -1)
    eo_col[eo_free] = io_free.sum() + np.arange(eo_free.sum())
    return Network(
        project=project,
        model=model,
        uv_mm=uv_mm,
        sqrt_w=sqrt_w,
        obs_cam=obs_cam,
        io_free=io_free,
        eo_free=eo_free,
        op_free=op_free,
        io_col=io_col,
        eo_col=eo_col,
        n_cam_cols=int(io_free.sum() + eo_free.sum()),
        eo_prior=eo_prior,
        eo_prior_std=eo_prior_std,
        op_prior=op_prior,
        op_prior_std=op_prior_std,
        datum=datum,
        fixed_coordinate=fixed_coord,
        xyz_init=xyz_init,
    )


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
