"""Fitting geometric primitives to points: plane, line, circle, cylinder, oriented box.

Every fit returns a frozen result object that is truthy, or a :class:`FailedFit`
that is *falsy* and carries the reason (the pattern of scikit-image's
``measure.fit.FailedEstimation``), so callers write ``if not fit: ...`` instead of
checking NaNs.  Robust variants use MSAC (Torr & Zisserman 2000): RANSAC whose
score is the truncated sum of squared residuals, with an explicit seed.

Conventions: all lengths in the units of the input (metres for pyheracles
clouds); ``rms`` is the root mean square of the orthogonal residuals of the
inliers used in the final least-squares step.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

__all__ = [
    "BoxFit",
    "CircleFit",
    "CylinderFit",
    "FailedFit",
    "LineFit",
    "MSACParams",
    "PlaneFit",
    "fit_circle",
    "fit_circle_msac",
    "fit_cylinder",
    "fit_line",
    "fit_oriented_box",
    "fit_plane",
    "fit_plane_msac",
    "min_area_rectangle",
    "perpendicular_basis",
]

Array = NDArray[np.float64]


# ---------------------------------------------------------------------------- results
@dataclass(frozen=True)
class FailedFit:
    """A fit that did not give a usable result; evaluates to ``False``.

    Attributes
    ----------
    reason
        Human-readable cause ("fewer than 3 points", "collinear points" ...).
    """

    reason: str

    def __bool__(self) -> bool:
        return False


@dataclass(frozen=True)
class PlaneFit:
    """Plane ``normal . x = d`` with a unit normal (z component >= 0 when not vertical)."""

    normal: Array
    d: float
    centroid: Array
    rms: float
    inliers: NDArray[np.bool_] | None = None

    def distance(self, points: ArrayLike) -> Array:
        """Signed orthogonal distances of ``points`` (N, 3) to the plane."""
        return np.asarray(points, dtype=np.float64) @ self.normal - self.d


@dataclass(frozen=True)
class LineFit:
    """3D (or 2D) line through ``point`` along the unit vector ``direction``."""

    point: Array
    direction: Array
    rms: float

    def distance(self, points: ArrayLike) -> Array:
        """Orthogonal distances of ``points`` to the line."""
        p = np.asarray(points, dtype=np.float64) - self.point
        along = p @ self.direction
        return np.linalg.norm(p - np.outer(along, self.direction), axis=1)


@dataclass(frozen=True)
class CircleFit:
    """Circle in the plane: centre ``(2,)``, radius, residual RMS."""

    center: Array
    radius: float
    rms: float
    inliers: NDArray[np.bool_] | None = None

    def residuals(self, xy: ArrayLike) -> Array:
        """Signed radial residuals ``|p - c| - r`` of points ``(N, 2)``."""
        p = np.asarray(xy, dtype=np.float64)
        return np.hypot(p[:, 0] - self.center[0], p[:, 1] - self.center[1]) - self.radius


@dataclass(frozen=True)
class CylinderFit:
    """Cylinder: axis through ``point`` (centre of the fitted height) along unit ``axis``.

    ``height`` is the extent of the fitted points along the axis; ``rms`` the RMS of
    the radial residuals.
    """

    point: Array
    axis: Array
    radius: float
    height: float
    rms: float

    def residuals(self, points: ArrayLike) -> Array:
        """Signed radial residuals (distance to axis minus radius)."""
        p = np.asarray(points, dtype=np.float64) - self.point
        along = p @ self.axis
        return np.linalg.norm(p - np.outer(along, self.axis), axis=1) - self.radius


@dataclass(frozen=True)
class BoxFit:
    """Oriented box (cuboid).

    Attributes
    ----------
    centre
        ``(3,)`` centre of the box.
    axes
        ``(3, 3)`` orthonormal axes as *columns*: ``axes[:, k]`` is the k-th box axis,
        ordered by decreasing extent.  A right-handed frame (det = +1).
    extents
        ``(3,)`` full edge lengths along ``axes[:, 0..2]``.
    rms
        RMS distance of the inlier points to the nearest box face.
    inliers
        ``(N,)`` boolean mask of the points kept by the trimming.
    """

    centre: Array
    axes: Array
    extents: Array
    rms: float
    inliers: NDArray[np.bool_] = field(default_factory=lambda: np.zeros(0, dtype=bool))

    def to_local(self, points: ArrayLike) -> Array:
        """Coordinates of ``points`` in the box frame (origin at the centre)."""
        return (np.asarray(points, dtype=np.float64) - self.centre) @ self.axes

    def face_distance(self, points: ArrayLike) -> Array:
        """Unsigned distance of each point to the nearest face plane of the box."""
        return _box_face_distance(self.to_local(points), self.extents / 2.0)[0]


@dataclass(frozen=True)
class MSACParams:
    """Parameters of MSAC robust fitting.

    Attributes
    ----------
    threshold
        Inlier distance threshold, same unit as the points (metres).
    max_trials
        Number of random minimal samples drawn.
    min_inlier_fraction
        A consensus smaller than this fraction of the points is a failure.
    """

    threshold: float = 0.02
    max_trials: int = 500
    min_inlier_fraction: float = 0.05


# ---------------------------------------------------------------------------- helpers
def _as_points(points: ArrayLike, dim: int, minimum: int) -> Array | FailedFit:
    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != dim:
        raise ValueError(f"points must have shape (N, {dim}), got {p.shape}")
    if not np.isfinite(p).all():
        raise ValueError("points contain NaN or infinite coordinates")
    if len(p) < minimum:
        return FailedFit(f"fewer than {minimum} points ({len(p)})")
    return p


def _rng(rng: np.random.Generator | int | None) -> np.random.Generator:
    return rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)


def _pca(p: Array) -> tuple[Array, Array, Array]:
    """Centroid, eigenvalues (descending) and eigenvectors (columns) of the covariance."""
    c = p.mean(axis=0)
    q = p - c
    cov = q.T @ q / max(len(p), 1)
    w, v = np.linalg.eigh(cov)
    order = np.argsort(w)[::-1]
    return c, w[order], v[:, order]


# ---------------------------------------------------------------------------- plane
def fit_plane(points: ArrayLike) -> PlaneFit | FailedFit:
    """Total least-squares plane through ``points`` (N, 3).

    Returns
    -------
    PlaneFit or FailedFit
        Failure when fewer than 3 points or when the points are collinear.

    Examples
    --------
    >>> import numpy as np
    >>> xy = np.random.default_rng(0).uniform(0, 1, (50, 2))
    >>> fit = fit_plane(np.c_[xy, 0.5 + 0 * xy[:, 0]])
    >>> np.round(fit.normal, 6).tolist(), round(fit.d, 6)
    ([0.0, 0.0, 1.0], 0.5)
    """
    p = _as_points(points, 3, 3)
    if isinstance(p, FailedFit):
        return p
    c, w, v = _pca(p)
    if w[1] <= 1e-12 * max(w[0], 1e-300):
        return FailedFit("collinear points")
    n = v[:, 2]
    if n[2] < 0 or (n[2] == 0 and n[1] < 0):
        n = -n
    rms = float(np.sqrt(max(w[2], 0.0)))
    return PlaneFit(normal=n, d=float(n @ c), centroid=c, rms=rms)


def fit_plane_msac(
    points: ArrayLike,
    params: MSACParams | None = None,
    *,
    rng: np.random.Generator | int | None = None,
) -> PlaneFit | FailedFit:
    """Robust plane by MSAC, refined by least squares on the inliers.

    Hypotheses are drawn in one vectorised batch (no Python loop over trials).

    Parameters
    ----------
    points
        ``(N, 3)`` points.
    params
        Threshold (metres), number of trials, minimal consensus.
    rng
        Seed or generator (deterministic for a given seed).
    """
    params = params or MSACParams()
    p = _as_points(points, 3, 3)
    if isinstance(p, FailedFit):
        return p
    gen = _rng(rng)
    # Score on a subsample when the cloud is large: the consensus fraction is what matters.
    score_idx = gen.choice(len(p), size=min(len(p), 5000), replace=False)
    ps = p[score_idx]
    idx = gen.integers(0, len(p), size=(params.max_trials, 3))
    a, b, c = p[idx[:, 0]], p[idx[:, 1]], p[idx[:, 2]]
    n = np.cross(b - a, c - a)
    norm = np.linalg.norm(n, axis=1)
    ok = norm > 1e-12
    if not ok.any():
        return FailedFit("all samples degenerate (collinear points)")
    n = n[ok] / norm[ok, None]
    d = np.einsum("ij,ij->i", n, a[ok])
    t2 = params.threshold**2
    best, best_cost = None, np.inf
    for start in range(0, len(n), 64):  # chunks bound memory to 64 x 5000
        r2 = (ps @ n[start : start + 64].T - d[start : start + 64]) ** 2
        cost = np.minimum(r2, t2).sum(axis=0)
        k = int(np.argmin(cost))
        if cost[k] < best_cost:
            best_cost, best = cost[k], start + k
    inl = np.abs(p @ n[best] - d[best]) <= params.threshold
    if inl.sum() < max(3, params.min_inlier_fraction * len(p)):
        return FailedFit(f"consensus too small ({int(inl.sum())} of {len(p)} points)")
    for _ in range(2):  # refine, re-select inliers
        fit = fit_plane(p[inl])
        if not fit:
            return fit
        inl = np.abs(fit.distance(p)) <= params.threshold
    fit = fit_plane(p[inl])
    if not fit:
        return fit
    return PlaneFit(fit.normal, fit.d, fit.centroid, fit.rms, inliers=inl)


# ---------------------------------------------------------------------------- line
def fit_line(points: ArrayLike) -> LineFit | FailedFit:
    """Total least-squares line through ``points`` (N, 2) or (N, 3)."""
    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] not in (2, 3):
        raise ValueError(f"points must have shape (N, 2) or (N, 3), got {p.shape}")
    if len(p) < 2:
        return FailedFit(f"fewer than 2 points ({len(p)})")
    c = p.mean(axis=0)
    q = p - c
    w, v = np.linalg.eigh(q.T @ q / len(p))
    if w[-1] <= 1e-18:
        return FailedFit("coincident points")
    direction = v[:, -1]
    if direction[np.argmax(np.abs(direction))] < 0:
        direction = -direction
    rms = float(np.sqrt(max(w[:-1].sum(), 0.0)))
    return LineFit(point=c, direction=direction, rms=rms)


# ---------------------------------------------------------------------------- circle
def _circle_algebraic(p: Array) -> tuple[Array, float] | None:
    """Kåsa fit on centred coordinates (linear least squares)."""
    m = p.mean(axis=0)
    q = p - m
    a = np.c_[2 * q, np.ones(len(q))]
    b = (q**2).sum(axis=1)
    sol, *_ = np.linalg.lstsq(a, b, rcond=None)
    r2 = sol[2] + sol[0] ** 2 + sol[1] ** 2
    if not np.isfinite(r2) or r2 <= 0:
        return None
    return sol[:2] + m, float(np.sqrt(r2))


def fit_circle(xy: ArrayLike, *, method: str = "geometric") -> CircleFit | FailedFit:
    """Least-squares circle through 2D points.

    Parameters
    ----------
    xy
        ``(N, 2)`` points.
    method
        ``"algebraic"`` (Kåsa: linear, fast, biased for short arcs) or ``"geometric"``
        (orthogonal distances minimised by Levenberg-Marquardt from the algebraic start).

    Examples
    --------
    >>> import numpy as np
    >>> t = np.linspace(0, 2 * np.pi, 40, endpoint=False)
    >>> fit = fit_circle(np.c_[1 + 2 * np.cos(t), -1 + 2 * np.sin(t)])
    >>> np.round(fit.center, 6).tolist(), round(fit.radius, 6)
    ([1.0, -1.0], 2.0)
    """
    if method not in {"algebraic", "geometric"}:
        raise ValueError(f"method must be one of 'algebraic', 'geometric', got {method!r}")
    p = _as_points(xy, 2, 3)
    if isinstance(p, FailedFit):
        return p
    init = _circle_algebraic(p)
    if init is None:
        return FailedFit("collinear or degenerate points")
    c, r = init
    if method == "geometric":
        m = p.mean(axis=0)
        q = p - m

        def res(x: Array) -> Array:
            return np.hypot(q[:, 0] - x[0], q[:, 1] - x[1]) - x[2]

        def jac(x: Array) -> Array:
            d = np.hypot(q[:, 0] - x[0], q[:, 1] - x[1])
            d = np.where(d > 0, d, 1e-12)
            return np.c_[-(q[:, 0] - x[0]) / d, -(q[:, 1] - x[1]) / d, -np.ones(len(q))]

        sol = least_squares(res, np.r_[c - m, r], jac=jac, method="lm")
        c, r = sol.x[:2] + m, float(abs(sol.x[2]))
    if not np.isfinite(r) or r <= 0 or r > 1e6:
        return FailedFit("degenerate circle (points nearly collinear)")
    resid = np.hypot(p[:, 0] - c[0], p[:, 1] - c[1]) - r
    return CircleFit(center=np.asarray(c, dtype=np.float64), radius=r, rms=_rms(resid))


def _rms(r: Array) -> float:
    return float(np.sqrt(np.mean(np.square(r)))) if len(r) else float("nan")


def fit_circle_msac(
    xy: ArrayLike,
    params: MSACParams | None = None,
    *,
    rng: np.random.Generator | int | None = None,
    radius_range: tuple[float, float] = (0.0, np.inf),
) -> CircleFit | FailedFit:
    """Robust circle by MSAC over 3-point circles, refined geometrically on the inliers.

    ``radius_range`` (same unit as the points) rejects hypotheses of implausible size.
    """
    params = params or MSACParams()
    p = _as_points(xy, 2, 3)
    if isinstance(p, FailedFit):
        return p
    gen = _rng(rng)
    idx = gen.integers(0, len(p), size=(params.max_trials, 3))
    a, b, c = p[idx[:, 0]], p[idx[:, 1]], p[idx[:, 2]]
    # circumcentre of each triple, vectorised
    d = 2 * (a[:, 0] * (b[:, 1] - c[:, 1]) + b[:, 0] * (c[:, 1] - a[:, 1]))
    d += 2 * c[:, 0] * (a[:, 1] - b[:, 1])
    ok = np.abs(d) > 1e-12
    a2, b2, c2 = (a**2).sum(1), (b**2).sum(1), (c**2).sum(1)
    with np.errstate(divide="ignore", invalid="ignore"):
        ux = (a2 * (b[:, 1] - c[:, 1]) + b2 * (c[:, 1] - a[:, 1]) + c2 * (a[:, 1] - b[:, 1])) / d
        uy = (a2 * (c[:, 0] - b[:, 0]) + b2 * (a[:, 0] - c[:, 0]) + c2 * (b[:, 0] - a[:, 0])) / d
    r = np.hypot(a[:, 0] - ux, a[:, 1] - uy)
    ok &= np.isfinite(r) & (r >= radius_range[0]) & (r <= radius_range[1])
    if not ok.any():
        return FailedFit("no valid 3-point circle hypothesis")
    ux, uy, r = ux[ok], uy[ok], r[ok]
    sub = p if len(p) <= 3000 else p[gen.choice(len(p), 3000, replace=False)]
    t2 = params.threshold**2
    best, best_cost = 0, np.inf
    for start in range(0, len(r), 128):
        sl = slice(start, start + 128)
        res = np.hypot(sub[:, :1] - ux[sl], sub[:, 1:] - uy[sl]) - r[sl]
        cost = np.minimum(res**2, t2).sum(axis=0)
        k = int(np.argmin(cost))
        if cost[k] < best_cost:
            best_cost, best = cost[k], start + k
    inl = np.abs(np.hypot(p[:, 0] - ux[best], p[:, 1] - uy[best]) - r[best]) <= params.threshold
    if inl.sum() < max(3, params.min_inlier_fraction * len(p)):
        return FailedFit(f"consensus too small ({int(inl.sum())} of {len(p)} points)")
    fit = fit_circle(p[inl])
    if not fit:
        return fit
    inl = np.abs(fit.residuals(p)) <= params.threshold
    fit = fit_circle(p[inl]) if inl.sum() >= 3 else fit
    if not fit:
        return fit
    return CircleFit(fit.center, fit.radius, fit.rms, inliers=inl)


# ---------------------------------------------------------------------------- cylinder
def perpendicular_basis(axis: Array) -> tuple[Array, Array]:
    """Two unit vectors ``(u, w)`` completing the unit ``axis`` to a right-handed frame
    (``u = axis x helper``, ``w = axis x u``; the helper is x unless the axis lies near it)."""
    helper = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = np.cross(axis, helper)
    u /= np.linalg.norm(u)
    return u, np.cross(axis, u)


def _cross3(a: Array, b: Array) -> Array:
    """Cross product of two 3-vectors (np.cross costs ~30x more on single vectors)."""
    return np.array(
        [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    )


def fit_cylinder(
    points: ArrayLike,
    *,
    axis_hint: ArrayLike | None = None,
    loss: str = "soft_l1",
    f_scale: float = 0.01,
) -> CylinderFit | FailedFit:
    """Least-squares cylinder through surface points (N, 3).

    The axis starts from ``axis_hint`` (e.g. the vertical for columns) or from the
    principal direction of the points; the cross-section circle is fitted in the plane
    orthogonal to it, then axis direction, axis position and radius are refined
    together on the orthogonal distances (Levenberg-Marquardt / trust region with a
    robust ``loss``; ``f_scale`` is the residual scale in metres where the robust loss
    starts to down-weight, e.g. 2 x the noise).

    Returns
    -------
    CylinderFit or FailedFit
        ``point`` is the axis point at mid-height of the fitted points.
    """
    p = _as_points(points, 3, 6)
    if isinstance(p, FailedFit):
        return p
    m = p.mean(axis=0)
    q = p - m
    if axis_hint is None:
        _, _, v = _pca(q)
        axis0 = v[:, 0]
    else:
        axis0 = np.asarray(axis_hint, dtype=np.float64)
        axis0 = axis0 / np.linalg.norm(axis0)
    u, w = perpendicular_basis(axis0)
    circ = fit_circle(np.c_[q @ u, q @ w], method="algebraic")
    if not circ:
        return FailedFit(f"cross-section circle failed: {circ.reason}")
    c0 = circ.center[0] * u + circ.center[1] * w

    # parameters: two small rotations of the axis (about u and w), centre offsets along
    # u and w, radius.  Parametrising around the start frame avoids the pole singularity.
    def frame(x: Array) -> tuple[Array, Array]:
        # Rodrigues' formula; the rotation axis k is orthogonal to axis0, so the k (k.a)
        # term vanishes (written out: scipy's Rotation costs more than the residuals)
        v = x[0] * u + x[1] * w
        theta = float(np.sqrt(v @ v))
        a = (
            axis0
            if theta == 0
            else np.cos(theta) * axis0 + np.sin(theta) / theta * _cross3(v, axis0)
        )
        c = c0 + x[2] * u + x[3] * w
        return a, c

    q2 = np.einsum("ij,ij->i", q, q)

    def parts(x: Array) -> tuple[Array, Array, Array, Array]:
        # distance to the axis from |d|^2 - (d.a)^2 with d = q - c: two mat-vec products
        a, c = frame(x)
        qc = q @ np.c_[c, a]
        along = qc[:, 1] - c @ a
        dist = np.sqrt(np.maximum(q2 - 2 * qc[:, 0] + c @ c - along**2, 0.0))
        return a, c, along, dist

    def res(x: Array) -> Array:
        return parts(x)[3] - x[4]

    def jac(x: Array) -> Array:
        # analytic: d(dist)/d(axis) = -(d.a) (d.da) / dist, d(dist)/dc = -(perp.dc) / dist
        a, c, along, dist = parts(x)
        v = x[0] * u + x[1] * w
        theta = float(np.sqrt(v @ v))
        da = []
        for e in (u, w):  # derivative of Rodrigues' rotation of axis0 by v along e
            if theta < 1e-12:
                da.append(_cross3(e, axis0))
                continue
            dtheta = float(v @ e) / theta
            ds = (theta * np.cos(theta) - np.sin(theta)) / theta**2 * dtheta
            da.append(
                -np.sin(theta) * dtheta * axis0
                + ds * _cross3(v, axis0)
                + np.sin(theta) / theta * _cross3(e, axis0)
            )
        g = q @ np.c_[da[0], da[1], u, w] - np.array([c @ da[0], c @ da[1], c @ u, c @ w])
        inv = 1.0 / np.maximum(dist, 1e-12)
        out = np.empty((len(q), 5))
        out[:, 0] = -along * g[:, 0] * inv
        out[:, 1] = -along * g[:, 1] * inv
        out[:, 2] = -(g[:, 2] - along * (a @ u)) * inv
        out[:, 3] = -(g[:, 3] - along * (a @ w)) * inv
        out[:, 4] = -1.0
        return out

    sol = least_squares(
        res, np.array([0.0, 0.0, 0.0, 0.0, circ.radius]), jac=jac, loss=loss, f_scale=f_scale
    )
    a, c = frame(sol.x)
    radius = float(abs(sol.x[4]))
    if not np.isfinite(radius) or radius <= 0:
        return FailedFit("degenerate cylinder")
    if a[2] < 0:
        a = -a
    along = (q - c) @ a
    lo, hi = float(along.min()), float(along.max())
    point = m + c + a * (lo + hi) / 2
    resid = res(sol.x)
    return CylinderFit(point=point, axis=a, radius=radius, height=hi - lo, rms=_rms(resid))


# ---------------------------------------------------------------------------- box
def min_area_rectangle(xy: ArrayLike) -> tuple[Array, float, Array]:
    """Minimum-area enclosing rectangle of 2D points (rotating calipers on the hull).

    Returns
    -------
    centre : (2,) array
    angle : float
        Direction of the first rectangle axis, radians from +x.
    size : (2,) array
        Full side lengths along the first and second axis (first >= second).
    """
    from scipy.spatial import ConvexHull, QhullError

    p = np.asarray(xy, dtype=np.float64)
    try:
        hull = p[ConvexHull(p).vertices]
    except (QhullError, ValueError):
        hull = p
    edges = np.diff(np.vstack([hull, hull[:1]]), axis=0)
    angles = np.unique(np.mod(np.arctan2(edges[:, 1], edges[:, 0]), np.pi / 2))
    cos, sin = np.cos(angles), np.sin(angles)
    u = hull @ np.vstack([cos, sin])  # (H, A)
    v = hull @ np.vstack([-sin, cos])
    area = (u.max(0) - u.min(0)) * (v.max(0) - v.min(0))
    k = int(np.argmin(area))
    su, sv = u[:, k].max() - u[:, k].min(), v[:, k].max() - v[:, k].min()
    cu, cv = (u[:, k].max() + u[:, k].min()) / 2, (v[:, k].max() + v[:, k].min()) / 2
    ang = float(angles[k])
    centre = np.array([cu * cos[k] - cv * sin[k], cu * sin[k] + cv * cos[k]])
    if sv > su:
        su, sv, ang = sv, su, ang + np.pi / 2
    return centre, ang, np.array([su, sv])


def _box_face_distance(local: Array, half: Array) -> tuple[Array, Array, Array]:
    """Distance of local points to the nearest of the 6 face planes, face axis and side."""
    a = np.abs(local)
    gap = np.abs(a - half)  # (N, 3) distance to the face plane on the point's side
    k = np.argmin(gap, axis=1)
    rows = np.arange(len(local))
    return gap[rows, k], k, np.sign(local[rows, k])


def fit_oriented_box(
    points: ArrayLike,
    *,
    up: ArrayLike | None = None,
    trim_fraction: float = 0.1,
    iterations: int = 3,
) -> BoxFit | FailedFit:
    """Oriented box (cuboid) fitted to points sampled on its faces.

    1. Initial frame from PCA (or, with ``up`` given, ``up`` as one axis and the
       minimum-area rectangle of the points projected on the plane normal to it, which
       is exact for square cross-sections where PCA is undetermined).
    2. Each point is assigned to its nearest face; the rotation, centre and
       half-extents are refined together by least squares on the point-to-face
       distances, dropping the ``trim_fraction`` largest residuals (trimmed least
       squares, robust to clutter), re-assigning faces between ``iterations``.

    Parameters
    ----------
    points
        ``(N, 3)`` points on the box surface (or filling it: extents stay right, rms
        then measures the fill).
    up
        Optional known axis (e.g. ``(0, 0, 1)`` for piers); keeps one box axis on it.
    trim_fraction
        Fraction of largest residuals excluded from each refinement, in [0, 0.5).
    iterations
        Face re-assignment rounds.

    Returns
    -------
    BoxFit or FailedFit
        ``centre`` (3,), ``axes`` (3, 3) with the axes as columns ordered by decreasing
        extent, ``extents`` (3,) full edge lengths, ``rms`` of the kept residuals.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(1)
    >>> p = rng.uniform(-1, 1, (3000, 3)) * [2.0, 1.0, 0.5]
    >>> k = rng.integers(0, 3, 3000)
    >>> p[np.arange(3000), k] = np.sign(p[np.arange(3000), k]) * np.array([2.0, 1.0, 0.5])[k]
    >>> np.round(fit_oriented_box(p).extents, 3).tolist()
    [4.0, 2.0, 1.0]
    """
    if not 0 <= trim_fraction < 0.5:
        raise ValueError(f"trim_fraction must be in [0, 0.5), got {trim_fraction}")
    p = _as_points(points, 3, 8)
    if isinstance(p, FailedFit):
        return p
    # trimmed PCA: drop the points farthest from the median before estimating the frame
    dist = np.linalg.norm(p - np.median(p, axis=0), axis=1)
    core = p[dist <= np.quantile(dist, 1 - trim_fraction)] if trim_fraction > 0 else p
    c, w, v = _pca(core)
    if w[1] <= 1e-12 * max(w[0], 1e-300):
        return FailedFit("collinear points: no box")
    if up is not None:
        ax_up = np.asarray(up, dtype=np.float64)
        ax_up = ax_up / np.linalg.norm(ax_up)
        e1, e2 = perpendicular_basis(ax_up)
        q = core - c
        centre2, ang, _ = min_area_rectangle(np.c_[q @ e1, q @ e2])
        a1 = np.cos(ang) * e1 + np.sin(ang) * e2
        frame = np.column_stack([a1, np.cross(ax_up, a1), ax_up])
        c = c + centre2[0] * e1 + centre2[1] * e2
    else:
        frame = v.copy()
    if np.linalg.det(frame) < 0:
        frame[:, 1] = -frame[:, 1]
    local = (core - c) @ frame
    lo, hi = np.quantile(local, 0.01, axis=0), np.quantile(local, 0.99, axis=0)
    c = c + frame @ ((lo + hi) / 2)
    half = np.maximum((hi - lo) / 2, 1e-9)
    keep = np.ones(len(p), dtype=bool)
    fix_up = up is not None

    for _ in range(max(iterations, 1)):
        local = (p - c) @ frame
        _, face, side = _box_face_distance(local, half)
        resid0, _, _ = _box_face_distance(local, half)
        if trim_fraction > 0:
            keep = resid0 <= np.quantile(resid0, 1 - trim_fraction)
        pk, fk, sk = p[keep], face[keep], side[keep]

        def res(
            x: Array,
            pk: Array = pk,
            fk: NDArray[np.int64] = fk,
            sk: Array = sk,
            frame0: Array = frame,
            c0: Array = c,
        ) -> Array:
            rv = np.r_[0.0, 0.0, x[0]] if fix_up else x[:3]
            rot = Rotation.from_rotvec(frame0 @ rv).as_matrix()
            f = rot @ frame0
            o = 1 if fix_up else 3
            loc = (pk - (c0 + x[o : o + 3])) @ f
            return loc[np.arange(len(loc)), fk] - sk * x[o + 3 + fk]

        n_rot = 1 if fix_up else 3
        x0 = np.r_[np.zeros(n_rot + 3), half]
        sol = least_squares(res, x0, method="lm" if len(pk) > len(x0) else "trf")
        rv = np.r_[0.0, 0.0, sol.x[0]] if fix_up else sol.x[:3]
        frame = Rotation.from_rotvec(frame @ rv).as_matrix() @ frame
        c = c + sol.x[n_rot : n_rot + 3]
        half = np.abs(sol.x[n_rot + 3 :])

    local = (p - c) @ frame
    resid, _, _ = _box_face_distance(local, half)
    keep = resid <= np.quantile(resid, 1 - trim_fraction) if trim_fraction > 0 else resid >= 0
    # A face without points (open pier ends, unscanned tops) leaves its extent free in
    # the least squares; the span of the kept points is then the honest extent.
    _, face, _ = _box_face_distance(local, half)
    sparse_axis = np.bincount(face[keep], minlength=3) < 0.02 * keep.sum()
    lo, hi = np.quantile(local[keep], 0.002, axis=0), np.quantile(local[keep], 0.998, axis=0)
    wider = sparse_axis & ((hi - lo) / 2 > half)
    c = c + frame @ np.where(wider, (lo + hi) / 2, 0.0)
    half = np.where(wider, (hi - lo) / 2, half)
    local = (p - c) @ frame
    resid, _, _ = _box_face_distance(local, half)
    order = np.argsort(half)[::-1]
    axes = frame[:, order]
    if np.linalg.det(axes) < 0:
        axes[:, 2] = -axes[:, 2]
    return BoxFit(centre=c, axes=axes, extents=2 * half[order], rms=_rms(resid[keep]), inliers=keep)


# ---------------------------------------------------------------------------- generic MSAC
def msac(
    data: Array,
    estimate: Callable[[Array], object],
    residuals: Callable[[object, Array], Array],
    min_samples: int,
    params: MSACParams | None = None,
    *,
    rng: np.random.Generator | int | None = None,
) -> tuple[object, NDArray[np.bool_]] | FailedFit:
    """Generic MSAC loop for models without a vectorised hypothesis generator.

    ``estimate(sample)`` returns a model or a falsy failure; ``residuals(model, data)``
    returns absolute residuals.  Returns ``(model refitted on inliers, inlier mask)``.
    """
    params = params or MSACParams()
    gen = _rng(rng)
    if len(data) < min_samples:
        return FailedFit(f"fewer than {min_samples} samples ({len(data)})")
    t2 = params.threshold**2
    best_model, best_cost = None, np.inf
    for _ in range(params.max_trials):
        sample = data[gen.choice(len(data), min_samples, replace=False)]
        model = estimate(sample)
        if not model:
            continue
        cost = np.minimum(residuals(model, data) ** 2, t2).sum()
        if cost < best_cost:
            best_model, best_cost = model, cost
    if best_model is None:
        return FailedFit("no valid hypothesis")
    inl = residuals(best_model, data) <= params.threshold
    if inl.sum() < max(min_samples, params.min_inlier_fraction * len(data)):
        return FailedFit(f"consensus too small ({int(inl.sum())} of {len(data)})")
    model = estimate(data[inl])
    if not model:
        return FailedFit("refit on inliers failed")
    return model, inl
