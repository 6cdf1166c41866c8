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


def _sphere_hypotheses(
    pts: NDArray[np.float64], radius: float, trials: int, rng: np.random.Generator
) -> NDArray[np.float64]:
    """Centres of spheres through 4 nearby points whose radius is within 20 % of ``radius``.

    Samples are local (a seed and three of its neighbours within 1.5 radii), so a
    sphere that holds a tenth of the points near a wall is still sampled often; a
    global 4-point draw would need tens of thousands of trials.
    """
    tree = cKDTree(pts)
    seeds = rng.integers(0, len(pts), trials)
    k = min(24, len(pts))
    dist, nb = tree.query(pts[seeds], k=k, distance_upper_bound=1.5 * radius)
    valid = np.isfinite(dist)
    valid[:, 0] = False  # the seed itself
    enough = valid.sum(axis=1) >= 3
    if not enough.any():
        return np.zeros((0, 3))
    seeds, nb, valid = seeds[enough], nb[enough], valid[enough]
    # three distinct valid neighbours per seed: random keys, invalid ones last
    keys = np.where(valid, rng.random(valid.shape), 2.0)
    pick = np.take_along_axis(nb, np.argsort(keys, axis=1)[:, :3], axis=1)
    quad = pts[np.column_stack([seeds, pick])]  # (T, 4, 3)
    m = quad.mean(axis=1, keepdims=True)
    q = quad - m
    A = np.concatenate([2 * q, np.ones((len(q), 4, 1))], axis=2)
    b = np.sum(q**2, axis=2)
    ok = np.abs(np.linalg.det(A)) > 1e-18
    sol = np.linalg.solve(A[ok], b[ok][..., None])[..., 0]
    c = sol[:, :3]
    r = np.sqrt(np.clip(sol[:, 3] + np.sum(c**2, axis=1), 0, None))
    good = np.abs(r - radius) < 0.2 * radius
    return c[good] + m[ok][good, 0]


def _cap_spread(pts: NDArray[np.float64], centre: NDArray[np.float64]) -> float:
    """Smallest variance of the unit directions from the centre to the points.

    About 0.08 for a scanned hemisphere, 0.01 for a 50 deg cap, and near 0 for the
    ring where a plane (a wall) cuts a hypothetical sphere.
    """
    d = pts - centre
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return float(np.linalg.eigvalsh(np.cov(d.T))[0])


def measure_sphere(
    xyz: NDArray[np.float64],
    approx: ArrayLike,
    radius: float,
    *,
    tree: cKDTree | None = None,
    search_m: float | None = None,
    max_residual_m: float = 0.01,
    min_cap_spread: float = 0.005,
    rng: np.random.Generator | int | None = 0,
) -> SphereTarget:
    """Centre of a sphere target of known radius near ``approx``.

    The points within ``search_m`` (default 2.5 x radius) of ``approx`` hold the
    sphere and whatever it stands on or next to: a wall, the floor, a tripod.  The
    sphere is found by RANSAC on local 4-point samples with the known radius (the
    hypothesis with most points within a tight gate wins), then refined by a robust
    least-squares fit on its own points, re-gated three times at three robust
    standard deviations (at least 1.5 mm, at most twice the RANSAC gate and
    ``max_residual_m``).  A fit on all
    the points of the ball (the former method) was pulled 6-8 cm towards a wall
    whose points near the sphere passed the residual gate.

    Parameters
    ----------
    max_residual_m
        Widest gate between a point and the sphere, metres.
    min_cap_spread
        The sphere's points must cover a cap of at least about 40 deg half-angle
        (smallest variance of their unit directions from the centre, see
        :func:`_cap_spread`); a plane cut by a hypothetical sphere gives a ring and
        no target.

    Raises
    ------
    DegenerateGeometryError
        Too few points near the approximate position or no sphere found there.
    """
    a = np.asarray(approx, dtype=np.float64).reshape(3)
    gen = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
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
    none_here = DegenerateGeometryError(
        f"no sphere of radius {radius} m near {np.round(a, 3).tolist()}",
        hint="check the approximate position and the target radius",
    )
    gate = min(max_residual_m, max(0.05 * radius, 0.0015))
    centres = _sphere_hypotheses(pts, radius, 600, gen)
    if len(centres) == 0:
        raise none_here
    # MSAC score of each hypothesis, in chunks to bound memory
    best, best_cost = None, np.inf
    for lo in range(0, len(centres), 64):
        c = centres[lo : lo + 64]
        r = np.abs(np.linalg.norm(pts[None] - c[:, None], axis=2) - radius)
        cost = np.minimum(r, gate) ** 2
        total = cost.sum(axis=1)
        j = int(np.argmin(total))
        if total[j] < best_cost:
            best, best_cost = c[j], float(total[j])
    keep = np.abs(np.linalg.norm(pts - best, axis=1) - radius) < gate
    if keep.sum() < 10:
        raise none_here
    fit = fit_sphere(pts[keep], radius)
    for _ in range(3):
        res = np.linalg.norm(pts[keep] - fit.centre, axis=1) - radius
        noise = 1.4826 * float(np.median(np.abs(res - np.median(res))))
        # never wider than twice the RANSAC gate: a widening gate lets a wall back in
        g = min(max_residual_m, 2 * gate, max(3 * noise, 0.0015))
        keep = np.abs(np.linalg.norm(pts - fit.centre, axis=1) - radius) < g
        if keep.sum() < 10:
            raise none_here
        fit = fit_sphere(pts[keep], radius)
    if _cap_spread(pts[keep], fit.centre) < min_cap_spread:
        raise DegenerateGeometryError(
            f"the points near {np.round(a, 3).tolist()} fit a sphere of radius {radius} m only "
            "on a ring (a plane cut by it): no target there",
            hint="check the approximate position and the target radius",
        )
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
