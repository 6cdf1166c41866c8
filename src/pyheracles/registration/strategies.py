"""Integration strategies of several clouds (thesis ch. 3): independent, free network, block.

- **Independent georeferencing**: each cloud is transformed to the national grid with
  its own control points.
- **Free network**: cloud B is registered onto cloud A by tie points, then one block
  similarity maps A (with B attached) onto all control points of both clouds.
- **Block adjustment**: the transforms of all clouds and the world coordinates of all
  tie points are estimated at once from every tie and control observation.

Point measurements in the clouds are :class:`PointList` objects in the cloud frame;
a point is a control point when its id is in the control list, a tie point when it is
measured in two clouds or more.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation
from scipy.stats import chi2

from pyheracles.errors import EstimationError, InputError
from pyheracles.registration.points import PointList, pair_points
from pyheracles.registration.similarity import (
    PARAMETER_NAMES,
    SimilarityParams,
    SimilarityResult,
    estimate_similarity,
    parameter_covariance,
    skew,
)

__all__ = [
    "BlockParams",
    "BlockResult",
    "CloudMeasurements",
    "FreeNetworkResult",
    "block_adjustment",
    "free_network",
    "georeference_independent",
]


@dataclass(frozen=True, eq=False)
class CloudMeasurements:
    """Points measured in one cloud (its own frame) and its transform model.

    Attributes
    ----------
    name
        Cloud name (file stem), used in reports.
    points
        Measured points (targets, corners) with ids, cloud frame, metres or model units.
    with_scale
        ``True`` for photogrammetric clouds (7 parameters), ``False`` for TLS (6).
    """

    name: str
    points: PointList
    with_scale: bool = True


def _sim(points_a: PointList, points_b: PointList, params: SimilarityParams, what: str):
    pairs = pair_points(points_a, points_b, unmatched="ignore")
    try:
        return estimate_similarity(
            pairs.a,
            pairs.b,
            params,
            source_sigma=pairs.sigma_a,
            target_sigma=pairs.sigma_b,
            ids=pairs.ids,
        )
    except InputError as exc:
        raise InputError(f"{what}: {exc}") from exc


def georeference_independent(
    clouds: Sequence[CloudMeasurements],
    control: PointList,
    params: SimilarityParams | None = None,
) -> dict[str, SimilarityResult]:
    """Transform each cloud to the control frame with its own control points.

    Returns
    -------
    dict
        ``cloud name -> SimilarityResult`` (``T_target_source`` = ``T_world_cloud``).
    """
    p = params or SimilarityParams()
    out = {}
    for c in clouds:
        cp = SimilarityParams(**{**p.__dict__, "with_scale": c.with_scale})
        out[c.name] = _sim(c.points, control, cp, f"georeferencing of {c.name}")
    return out


@dataclass(frozen=True, eq=False)
class FreeNetworkResult:
    """Result of :func:`free_network`: ``T_world_*`` of both clouds and the two adjustments."""

    T_world_base: NDArray[np.float64]
    T_world_other: NDArray[np.float64]
    tie: SimilarityResult  # other -> base
    georef: SimilarityResult  # base (+ other's control, moved into base) -> world
    # (the moved points are weighted with the tie transform's propagated covariance,
    # their mutual correlation left out: see the notes of free_network)

    def to_dict(self) -> dict[str, Any]:
        return {
            "T_world_base": self.T_world_base.tolist(),
            "T_world_other": self.T_world_other.tolist(),
            "tie_registration": self.tie.to_dict(),
            "block_georeferencing": self.georef.to_dict(),
        }


def free_network(
    base: CloudMeasurements,
    other: CloudMeasurements,
    ties_base: PointList,
    ties_other: PointList,
    control: PointList,
    *,
    tie_params: SimilarityParams | None = None,
    georef_params: SimilarityParams | None = None,
) -> FreeNetworkResult:
    """Free-network integration: tie ``other`` onto ``base``, then georeference the block.

    Parameters
    ----------
    base, other
        Measurements (targets) in the two clouds; ``base.with_scale`` selects the
        model of the final georeferencing, ``other.with_scale`` (or the base's, when
        the base is photogrammetric) the model of the tie registration.
    ties_base, ties_other
        Tie points (same ids) in the two clouds.
    control
        Control points (world); all control points measured in either cloud are used.

    Notes
    -----
    Weights of the block step: a point of ``other`` moved into the base frame gets the
    per-coordinate variance ``(s sigma)^2 + diag(J C_tie J^T)`` (its measurement, scaled,
    plus the tie transform's parameter covariance propagated to that point).  The
    correlation the shared tie error induces between the moved points is left out on
    purpose: with the full covariance (generalised least squares) the block transform
    becomes the best estimate of the *base* cloud's pose and ``other`` then inherits
    the whole tie error, whereas the diagonal weights let the other cloud's control
    points absorb part of it.  On the generated church (Monte Carlo, 300 paired runs,
    seed 0 geometry) the expected 3D check point RMS is 6.7 mm with the diagonal weights
    and 6.8 mm with the full covariance (difference of the mean squares
    2.3 +/- 0.1 mm^2).  The rigorous joint solution is :func:`block_adjustment` (5.8 mm
    there).
    """
    tp = tie_params or SimilarityParams()
    gp = georef_params or SimilarityParams()
    tie_scale = base.with_scale or other.with_scale
    tie = _sim(
        ties_other,
        ties_base,
        SimilarityParams(**{**tp.__dict__, "with_scale": tie_scale}),
        f"tie registration of {other.name} onto {base.name}",
    )
    # control measured in `other`, moved into the base frame, joins the base's measurements
    # their sigma combines the measurement (scaled) and the tie transform's uncertainty
    meas_sig = (
        other.points.sigma
        if other.points.sigma is not None
        else np.full((len(other.points), 3), gp.sigma_m)
    )
    prop = np.diagonal(tie.point_covariance(other.points.xyz), axis1=1, axis2=2)
    moved = PointList(
        ids=other.points.ids,
        xyz=tie.apply(other.points.xyz),
        sigma=np.sqrt((meas_sig * tie.parameters["scale"]) ** 2 + prop),
    )
    common = set(base.points.ids)
    extra = [i for i in moved.ids if i not in common]
    merged = base.points
    if extra:
        m2 = moved.select(extra)
        sig = None
        if base.points.sigma is not None or m2.sigma is not None:
            sa = base.points.sigma if base.points.sigma is not None else np.zeros((len(merged), 3))
            sb = m2.sigma if m2.sigma is not None else np.zeros((len(m2), 3))
            sig = np.vstack([sa, sb])
        merged = PointList(
            ids=base.points.ids + m2.ids,
            xyz=np.vstack([base.points.xyz, m2.xyz]),
            sigma=sig,
        )
    georef = _sim(
        merged,
        control,
        SimilarityParams(**{**gp.__dict__, "with_scale": base.with_scale}),
        f"block georeferencing of {base.name} + {other.name}",
    )
    T_wb = georef.T_target_source
    return FreeNetworkResult(
        T_world_base=T_wb, T_world_other=T_wb @ tie.T_target_source, tie=tie, georef=georef
    )


# ----------------------------------------------------------------------------- block
@dataclass(frozen=True)
class BlockParams:
    """Parameters of :func:`block_adjustment`.

    Attributes
    ----------
    sigma_cloud_m
        Default standard deviation of a point measured in a cloud (cloud units).
    sigma_control_m
        Default standard deviation of a control coordinate, metres.
    alpha
        Significance level of the per-observation outlier test (chi-square, 3 dof).
    max_iterations
        Gauss-Newton iterations.
    """

    sigma_cloud_m: float = 0.01
    sigma_control_m: float = 0.005
    alpha: float = 0.001
    max_iterations: int = 20


@dataclass(frozen=True, eq=False)
class BlockResult:
    """Result of :func:`block_adjustment`."""

    transforms: dict[str, NDArray[np.float64]]  # cloud -> T_world_cloud
    parameters: dict[str, dict[str, float]]
    std: dict[str, dict[str, float]]
    points_world: PointList  # adjusted coordinates of all points, with std devs
    sigma0: float
    redundancy: int
    observations: pd.DataFrame  # one row per observation: kind, cloud, id, residuals, test
    iterations: int
    converged: bool
    extra: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {
            "T_world_cloud": {k: v.tolist() for k, v in self.transforms.items()},
            "parameters": self.parameters,
            "std": self.std,
            "sigma0": self.sigma0,
            "redundancy": self.redundancy,
            "iterations": self.iterations,
            "converged": self.converged,
            "observations": self.observations.to_dict(orient="records"),
        }


def block_adjustment(
    clouds: Sequence[CloudMeasurements],
    control: PointList,
    params: BlockParams | None = None,
) -> BlockResult:
    """Estimate the transforms of all clouds at once from tie and control points.

    Model: for every point j measured in cloud c,
    ``X_j = t_c + s_c R_c x_cj + v`` (3 equations, weight from the cloud sigma scaled
    to world units), and for every control point ``X_j^obs = X_j + v`` (weight from
    the control sigma).  Unknowns: 6/7 parameters per cloud and the world
    coordinates of every point measured at least twice (in two clouds, or in one
    cloud and the control list).  Gauss-Newton with the rotation updated on the
    manifold, starting from a chain of pairwise similarity fits.  The normal matrix
    is small (7 per cloud + 3 per point), so it is solved densely.

    Raises
    ------
    InputError
        A cloud cannot be connected to the control frame (fewer than 3 control or
        tie points linking it), fewer than 3 control points in all.
    """
    bp = params or BlockParams()
    if not clouds:
        raise InputError("block adjustment needs at least one cloud")
    names = [c.name for c in clouds]
    if len(set(names)) != len(names):
        raise InputError(f"cloud names must be unique, got {names}")
    ctrl_idx = {k: i for i, k in enumerate(control.ids)}
    # which points enter: measured >= 2 times in total
    count: dict[str, int] = {}
    for c in clouds:
        for i in c.points.ids:
            count[i] = count.get(i, 0) + 1
    for i in control.ids:
        if i in count:
            count[i] += 1
    pts = sorted(k for k, v in count.items() if v >= 2)
    pidx = {k: i for i, k in enumerate(pts)}
    n_ctrl_used = sum(1 for k in pts if k in ctrl_idx)
    if n_ctrl_used < 3:
        raise InputError(
            f"only {n_ctrl_used} control point(s) are measured in the clouds; at least 3 "
            "are needed to fix the datum",
            hint="check that control ids match the ids measured in the clouds",
        )
    # initial values: chain similarity fits from the control frame outward
    world_known: dict[str, NDArray[np.float64]] = {k: control.xyz[ctrl_idx[k]] for k in ctrl_idx}
    T_init: dict[str, NDArray[np.float64]] = {}
    pending = list(clouds)
    while pending:
        progress = False
        for c in list(pending):
            common = [i for i in c.points.ids if i in world_known]
            if len(common) < 3:
                continue
            src = c.points.select(common).xyz
            dst = np.array([world_known[i] for i in common])
            res = estimate_similarity(
                src, dst, SimilarityParams(with_scale=c.with_scale, estimator="huber")
            )
            T_init[c.name] = res.T_target_source
            moved = res.apply(c.points.xyz)
            for k, x in zip(c.points.ids, moved, strict=True):
                world_known.setdefault(k, x)
            pending.remove(c)
            progress = True
        if not progress:
            raise InputError(
                "cannot connect cloud(s) "
                + ", ".join(c.name for c in pending)
                + " to the control frame: fewer than 3 control or tie points in common",
                hint="measure more tie points shared with an already connected cloud",
            )
    # centring: world centre and per-cloud centroid
    cw = np.mean([world_known[k] for k in pts], axis=0)
    X = np.array([world_known[k] for k in pts]) - cw
    state = []
    for c in clouds:
        T = T_init[c.name]
        s = float(np.cbrt(np.linalg.det(T[:3, :3])))
        R = T[:3, :3] / s
        cc = c.points.xyz.mean(axis=0)
        t_loc = T[:3, :3] @ cc + T[:3, 3] - cw  # X - cw = t' + s R (x - cc)
        state.append({"R": R, "s": s, "t": t_loc, "cc": cc})
    # parameter layout
    offs = []
    k = 0
    for c in clouds:
        offs.append(k)
        k += 7 if c.with_scale else 6
    p0 = k
    n_unk = p0 + 3 * len(pts)
    # observation lists
    obs_c, obs_j, obs_x, obs_s = [], [], [], []
    for ci, c in enumerate(clouds):
        sig = c.points.sigma
        for r, i in enumerate(c.points.ids):
            if i in pidx:
                obs_c.append(ci)
                obs_j.append(pidx[i])
                obs_x.append(c.points.xyz[r] - state[ci]["cc"])
                obs_s.append(sig[r] if sig is not None else np.full(3, bp.sigma_cloud_m))
    obs_c = np.array(obs_c)
    obs_j = np.array(obs_j)
    obs_x = np.array(obs_x)
    obs_s = np.array(obs_s)
    ctrl_j = np.array([pidx[k] for k in pts if k in ctrl_idx])
    ctrl_x = np.array([control.xyz[ctrl_idx[k]] for k in pts if k in ctrl_idx]) - cw
    ctrl_s = np.array(
        [
            control.sigma[ctrl_idx[k]]
            if control.sigma is not None
            else np.full(3, bp.sigma_control_m)
            for k in pts
            if k in ctrl_idx
        ]
    )
    m_c, m_k = len(obs_c), len(ctrl_j)
    n_obs = 3 * (m_c + m_k)
    redundancy = n_obs - n_unk
    if redundancy < 0:
        raise InputError(
            f"block adjustment is underdetermined ({n_obs} observations, {n_unk} unknowns)"
        )

    def build() -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        J = np.zeros((n_obs, n_unk))
        v = np.zeros(n_obs)
        wts = np.zeros(n_obs)
        rows = np.arange(m_c)
        for ci, c in enumerate(clouds):
            sel = rows[obs_c == ci]
            st = state[ci]
            q = obs_x[sel] @ st["R"].T
            pred = st["t"] + st["s"] * q
            o = offs[ci]
            for a in range(3):
                rr = 3 * sel + a
                v[rr] = X[obs_j[sel], a] - pred[:, a]  # "observation" minus model
                J[rr, o + a] = 1.0
                J[rr, o + 3 : o + 6] = -st["s"] * skew(q)[:, a, :]
                if c.with_scale:
                    J[rr, o + 6] = q[:, a]
                J[rr, p0 + 3 * obs_j[sel] + a] = -1.0
                wts[rr] = 1.0 / (st["s"] * obs_s[sel, a])
        for a in range(3):
            rr = 3 * m_c + 3 * np.arange(m_k) + a
            v[rr] = ctrl_x[:, a] - X[ctrl_j, a]
            J[rr, p0 + 3 * ctrl_j + a] = 1.0
            wts[rr] = 1.0 / ctrl_s[:, a]
        return J, v, wts

    converged = False
    it = 0
    for it in range(1, bp.max_iterations + 1):  # noqa: B007
        J, v, wts = build()
        Jw = J * wts[:, None]
        dx, *_ = np.linalg.lstsq(Jw, v * wts, rcond=None)
        for ci, c in enumerate(clouds):
            o = offs[ci]
            state[ci]["t"] = state[ci]["t"] + dx[o : o + 3]
            state[ci]["R"] = Rotation.from_rotvec(dx[o + 3 : o + 6]).as_matrix() @ state[ci]["R"]
            if c.with_scale:
                state[ci]["s"] += float(dx[o + 6])
        X = X + dx[p0:].reshape(-1, 3)
        if np.max(np.abs(dx)) < 1e-10:
            converged = True
            break
    J, v, wts = build()
    Jw = J * wts[:, None]
    vw = v * wts
    N = Jw.T @ Jw
    try:
        Ninv = np.linalg.inv(N)
    except np.linalg.LinAlgError as exc:
        raise EstimationError("singular block adjustment (datum defect)") from exc
    sigma0 = float(np.sqrt(vw @ vw / redundancy)) if redundancy > 0 else float("nan")
    cov = (sigma0**2 if redundancy > 0 else 1.0) * Ninv
    # residuals (model - observation, world units) with redundancy numbers
    h = np.einsum("ij,jk,ik->i", Jw, Ninv, Jw)
    red = np.clip(1 - h, 1e-9, 1)
    T2 = np.sum((vw**2 / red).reshape(-1, 3), axis=1) / max(sigma0**2, 1e-300)
    crit = float(chi2.ppf(1 - bp.alpha, 3))
    res3 = -v.reshape(-1, 3)
    rows = []
    for r in range(m_c):
        rows.append(
            {
                "kind": "control" if pts[obs_j[r]] in ctrl_idx else "tie",
                "cloud": names[obs_c[r]],
                "id": pts[obs_j[r]],
            }
        )
    rows += [{"kind": "control_coordinates", "cloud": "", "id": pts[j]} for j in ctrl_j]
    obs = pd.DataFrame(rows)
    obs["vx"], obs["vy"], obs["vz"] = res3[:, 0], res3[:, 1], res3[:, 2]
    obs["v3d"] = np.linalg.norm(res3, axis=1)
    obs["test_statistic"] = T2
    obs["outlier"] = T2 > crit
    transforms, parameters, stds = {}, {}, {}
    for ci, c in enumerate(clouds):
        st = state[ci]
        o = offs[ci]
        u = 7 if c.with_scale else 6
        T = np.eye(4)
        T[:3, :3] = st["s"] * st["R"]
        T[:3, 3] = cw + st["t"] - st["s"] * st["R"] @ st["cc"]
        transforms[c.name] = T
        angles, cov7 = parameter_covariance(
            st["R"], st["s"], st["cc"], cov[o : o + u, o : o + u], c.with_scale
        )
        vals = [*T[:3, 3], *angles, st["s"]]
        parameters[c.name] = dict(zip(PARAMETER_NAMES, map(float, vals), strict=True))
        stds[c.name] = dict(
            zip(PARAMETER_NAMES, map(float, np.sqrt(np.clip(np.diag(cov7), 0, None))), strict=True)
        )
    sd_pts = np.sqrt(np.clip(np.diag(cov)[p0:], 0, None)).reshape(-1, 3)
    return BlockResult(
        transforms=transforms,
        parameters=parameters,
        std=stds,
        points_world=PointList(ids=tuple(pts), xyz=X + cw, sigma=sd_pts, source="block"),
        sigma0=sigma0,
        redundancy=int(redundancy),
        observations=obs,
        iterations=it,
        converged=converged,
    )
