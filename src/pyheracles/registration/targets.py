"""Target measurement in a cloud: sphere centres and plane-corner points.

Both work near an approximate position given by the operator (or a point list),
like picking a target in a scanner software, and refine it from the points.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import least_squares
from scipy.spatial import cKDTree

from pyheracles.cloud import PointCloud
from pyheracles.errors import DegenerateGeometryError, EstimationError, InputError
from pyheracles.geometry.fitting import MSACParams, fit_plane, fit_plane_msac
from pyheracles.registration.points import PointList

__all__ = [
    "CornerTarget",
    "SphereTarget",
    "fit_sphere",
    "measure_plane_corner",
    "measure_sphere",
    "measure_spheres",
]


@dataclass(frozen=True)
class SphereTarget:
    """A fitted sphere: centre (metres, cloud frame), radius, RMS of the fit, points used."""

    centre: NDArray[np.float64]
    radius: float
    rms: float
    n_points: int
    centre_std: NDArray[np.float64]


@dataclass(frozen=True)
class CornerTarget:
    """Intersection point of three planes near an approximate position."""

    point: NDArray[np.float64]
    normals: NDArray[np.float64]  # (3, 3), one plane normal per row
    rms: NDArray[np.float64]  # (3,) plane fit RMS
    n_points: NDArray[np.int_]  # (3,) inliers per plane
    condition: float  # |det(normals)|, 1 = orthogonal planes


def fit_sphere(
    xyz: ArrayLike, radius: float | None = None, *, f_scale: float = 0.003
) -> SphereTarget:
    """Sphere fit: algebraic start, geometric refinement with a robust (soft L1) loss.

    Parameters
    ----------
    xyz
        ``(N, 3)`` points on (part of) the sphere, metres.
    radius
        Known radius of the target, metres; ``None`` estimates it.
    f_scale
        Residual scale of the soft-L1 loss, metres (about the scanner noise).
    """
    p = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    need = 3 if radius is not None else 4
    if len(p) < need + 2:
        raise DegenerateGeometryError(
            f"{len(p)} points are too few to fit a sphere",
            hint="increase the search radius or check the approximate position",
        )
    m = p.mean(axis=0)
    q = p - m
    # algebraic: |q|^2 = 2 c.q + k  (linear least squares)
    A = np.column_stack([2 * q, np.ones(len(q))])
    sol, *_ = np.linalg.lstsq(A, np.sum(q**2, axis=1), rcond=None)
    c0 = sol[:3]
    r0 = float(np.sqrt(max(sol[3] + c0 @ c0, 1e-12))) if radius is None else float(radius)

    if radius is None:

        def res(x: NDArray[np.float64]) -> NDArray[np.float64]:
            return np.linalg.norm(q - x[:3], axis=1) - x[3]

        x0 = np.r_[c0, r0]
    else:

        def res(x: NDArray[np.float64]) -> NDArray[np.float64]:
            return np.linalg.norm(q - x[:3], axis=1) - radius

        x0 = c0
    out = least_squares(res, x0, loss="soft_l1", f_scale=f_scale)
    r = res(out.x)
    rad = float(out.x[3]) if radius is None else float(radius)
    dof = max(len(p) - len(out.x), 1)
    s2 = float(np.sum(r**2) / dof)
    try:
        cov = s2 * np.linalg.inv(out.jac.T @ out.jac)
        sd = np.sqrt(np.clip(np.diag(cov)[:3], 0, None))
    except np.linalg.LinAlgError:
        sd = np.full(3, np.nan)
    return SphereTarget(
        centre=out.x[:3] + m,
        radius=rad,
        rms=float(np.sqrt(np.mean(r**2))),
        n_points=len(p),
        centre_std=sd,
    )


def measure_sphere(
    xyz: NDArray[np.float64],
    approx: ArrayLike,
    radius: float,
    *,
    tree: cKDTree | None = None,
    search_m: float | None = None,
    max_residual_m: float = 0.01,
) -> SphereTarget:
    """Centre of a sphere target of known radius near ``approx``.

    Points within ``search_m`` (default 2.5 x radius) of ``approx`` are fitted; points
    farther than ``max_residual_m`` from the first sphere (tripod, wall, ground) are
    dropped and the sphere refitted.

    Raises
    ------
    DegenerateGeometryError
        Too few points near the approximate position or no sphere found there.
    """
    a = np.asarray(approx, dtype=np.float64).reshape(3)
    tr = tree if tree is not None else cKDTree(xyz)
    search = search_m or 2.5 * radius
    idx = np.asarray(tr.query_ball_point(a, search), dtype=int)
    if len(idx) < 10:
        raise DegenerateGeometryError(
            f"only {len(idx)} points within {search:.3f} m of the approximate target position "
            f"{np.round(a, 3).tolist()}",
            hint="check the approximate coordinates (same frame as the cloud) or the radius",
        )
    pts = xyz[idx]
    fit = fit_sphere(pts, radius)
    for _ in range(3):
        d = np.abs(np.linalg.norm(pts - fit.centre, axis=1) - radius)
        keep = d < max_residual_m
        if keep.sum() < 10:
            raise DegenerateGeometryError(
                f"no sphere of radius {radius} m near {np.round(a, 3).tolist()}"
            )
        fit = fit_sphere(pts[keep], radius)
    if np.linalg.norm(fit.centre - a) > search:
        raise EstimationError(
            f"the sphere fitted near {np.round(a, 3).tolist()} lies "
            f"{np.linalg.norm(fit.centre - a):.3f} m away: no target there"
        )
    return fit


def _plane_corner_from_points(
    pts: NDArray[np.float64], threshold: float, rng: np.random.Generator
) -> tuple[list, NDArray[np.float64]]:
    """Up to three planes by sequential MSAC (largest first)."""
    planes = []
    remaining = np.ones(len(pts), bool)
    for _ in range(5):
        if remaining.sum() < 10 or len(planes) == 3:
            break
        sub = np.flatnonzero(remaining)
        fit = fit_plane_msac(
            pts[sub],
            MSACParams(threshold=threshold, max_trials=300, min_inlier_fraction=0.05),
            rng=rng,
        )
        if not fit:
            break
        inl = sub[fit.inliers]
        remaining[inl] = False
        if all(abs(float(fit.normal @ q.normal)) < 0.9 for q, _ in planes):
            planes.append((fit, inl))
    return planes, remaining


def measure_plane_corner(
    xyz: NDArray[np.float64],
    approx: ArrayLike,
    *,
    tree: cKDTree | None = None,
    search_m: float = 0.25,
    threshold_m: float = 0.01,
    rng: np.random.Generator | int | None = 0,
) -> CornerTarget:
    """Corner point where three planes meet, near ``approx`` (e.g. a window or wall corner).

    Three planes are extracted by sequential MSAC from the points within ``search_m``
    and intersected (3x3 linear system).

    Raises
    ------
    DegenerateGeometryError
        Fewer than three distinct planes, or nearly parallel planes.
    """
    a = np.asarray(approx, dtype=np.float64).reshape(3)
    if search_m <= 0 or threshold_m <= 0:
        raise InputError("search_m and threshold_m must be positive")
    gen = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
    tr = tree if tree is not None else cKDTree(xyz)
    idx = np.asarray(tr.query_ball_point(a, search_m), dtype=int)
    if len(idx) < 30:
        raise DegenerateGeometryError(
            f"only {len(idx)} points within {search_m} m of {np.round(a, 3).tolist()}",
            hint="check the approximate position (in Python: increase search_m)",
        )
    pts = xyz[idx]
    planes, _ = _plane_corner_from_points(pts, threshold_m, gen)
    if len(planes) < 3:
        raise DegenerateGeometryError(
            f"found {len(planes)} distinct planes near {np.round(a, 3).tolist()}, 3 are needed "
            "for a corner"
        )
    fits = [fit_plane(pts[inl]) for _, inl in planes]
    N = np.array([f.normal for f in fits])
    d = np.array([f.d for f in fits])
    cond = abs(float(np.linalg.det(N)))
    if cond < 0.2:
        raise DegenerateGeometryError(
            f"the three planes near {np.round(a, 3).tolist()} are nearly parallel "
            f"(|det| = {cond:.2f})"
        )
    return CornerTarget(
        point=np.linalg.solve(N, d),
        normals=N,
        rms=np.array([f.rms for f in fits]),
        n_points=np.array([len(inl) for _, inl in planes]),
        condition=cond,
    )


def measure_spheres(
    cloud: PointCloud,
    approx: PointList,
    radius: float,
    *,
    max_residual_m: float | None = None,
    tree: cKDTree | None = None,
) -> PointList:
    """Measure many sphere targets in a cloud; returns their centres (cloud world frame).

    ``approx`` holds approximate positions in the same (world) frame as the cloud.
    The sigma of each centre is its formal standard deviation from the fit, floored
    at 0.5 mm.
    """
    cloud.validate(what="cloud with sphere targets")
    tr = tree if tree is not None else cKDTree(cloud.xyz)
    max_res = max_residual_m if max_residual_m is not None else 0.25 * radius
    centres = np.zeros((len(approx), 3))
    sig = np.zeros((len(approx), 3))
    for i in range(len(approx)):  # one fit per target (tens), not per point
        try:
            fit = measure_sphere(
                cloud.xyz,
                approx.xyz[i] - cloud.offset,
                radius,
                tree=tr,
                max_residual_m=max_res,
            )
        except (DegenerateGeometryError, EstimationError) as exc:
            raise type(exc)(f"target {approx.ids[i]!r}: {exc}") from exc
        centres[i] = fit.centre + cloud.offset
        sig[i] = np.maximum(fit.centre_std, 5e-4 * radius / 0.0725)
    return PointList(ids=approx.ids, xyz=centres, sigma=sig, source=cloud.source)
