"""Check point validation: residuals on independent points, RMS, residual map, JSON.

Check points are measured in the registered cloud (or its targets are fitted there)
and compared with their reference coordinates (thesis ch. 3, table 3.3 and figure
3.5).  Residuals are ``reference - measured``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.stats import chi2

from pyheracles.errors import InputError

__all__ = [
    "CheckPointReport",
    "ResidualPropagation",
    "check_points",
    "check_points_frame",
    "plot_residual_map",
    "propagate_residuals",
]


@dataclass(frozen=True, eq=False)
class CheckPointReport:
    """Residuals of check points (metres) and their statistics."""

    ids: tuple[str, ...]
    reference: NDArray[np.float64]
    measured: NDArray[np.float64]
    residuals: NDArray[np.float64]

    @property
    def residual_3d(self) -> NDArray[np.float64]:
        return np.linalg.norm(self.residuals, axis=1)

    @property
    def rms(self) -> dict[str, float]:
        """RMS in X, Y, Z and 3D (metres)."""
        v = self.residuals
        r = np.sqrt(np.mean(v**2, axis=0))
        return {
            "x": float(r[0]),
            "y": float(r[1]),
            "z": float(r[2]),
            "3d": float(np.sqrt(np.mean(np.sum(v**2, axis=1)))),
        }

    def to_dict(self) -> dict[str, Any]:
        v = self.residuals
        return {
            "n_points": len(self.ids),
            "rms_m": self.rms,
            "mean_m": dict(zip("xyz", map(float, v.mean(axis=0)), strict=True)),
            "max_abs_m": dict(zip("xyz", map(float, np.abs(v).max(axis=0)), strict=True)),
            "max_3d_m": float(self.residual_3d.max()),
            "points": [
                {
                    "id": self.ids[i],
                    "reference": self.reference[i].tolist(),
                    "measured": self.measured[i].tolist(),
                    "vx": float(v[i, 0]),
                    "vy": float(v[i, 1]),
                    "vz": float(v[i, 2]),
                    "v3d": float(self.residual_3d[i]),
                }
                for i in range(len(self.ids))
            ],
        }


def check_points_frame(
    xyz: ArrayLike,
    ids: Sequence[str],
    bounds: ArrayLike,
    *,
    margin_m: float = 1.0,
    path: str | Path | None = None,
    cloud: str = "the cloud",
) -> list[str]:
    """Check that reference points are in the frame of the cloud they are measured in.

    Parameters
    ----------
    xyz
        ``(N, 3)`` reference coordinates (world frame of the file they come from).
    ids
        Their ids.
    bounds
        ``(2, 3)`` world min and max corners of the cloud (``PointCloud.bounds()``).
    margin_m
        Points this far outside the cloud's box still count as inside, metres.
    path, cloud
        The points file and the cloud, for the message.

    Returns
    -------
    list of str
        Ids of the points outside the cloud's box (the caller may report them).

    Raises
    ------
    InputError
        No point lies within the cloud's box: the points are in another frame (local
        scanner coordinates for a georeferenced cloud, or the reverse), or belong to
        another cloud.
    """
    p = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    b = np.asarray(bounds, dtype=np.float64).reshape(2, 3)
    outside = ((p < b[0] - margin_m) | (p > b[1] + margin_m)).any(axis=1)
    if len(p) and outside.all():
        centre = b.mean(axis=0)
        gap = float(np.median(np.linalg.norm(p - centre, axis=1)))
        raise InputError(
            f"none of the {len(p)} points lies within {cloud} (extent "
            f"{b[0, 0]:.1f},{b[0, 1]:.1f},{b[0, 2]:.1f} - {b[1, 0]:.1f},{b[1, 1]:.1f},"
            f"{b[1, 2]:.1f}; the points are {gap:.4g} m from its centre): they are in "
            "another frame, or belong to another cloud",
            path=path,
            hint="give the points in the cloud's own frame (a georeferenced cloud takes "
            "surveyed national-grid coordinates, a scan its scanner coordinates)",
        )
    return [str(ids[i]) for i in np.flatnonzero(outside)]


def check_points(
    reference: ArrayLike, measured: ArrayLike, ids: Sequence[str] | None = None
) -> CheckPointReport:
    """Residuals ``reference - measured`` of check points and their RMS.

    Parameters
    ----------
    reference
        ``(N, 3)`` reference coordinates (e.g. total station, national grid), metres.
    measured
        ``(N, 3)`` the same points measured in the registered cloud, metres.
    ids
        Point names.

    Examples
    --------
    >>> rep = check_points([[0, 0, 0], [1, 1, 1]], [[0.01, 0, 0], [1, 1, 1.02]])
    >>> round(rep.rms["3d"], 4)
    0.0158
    """
    ref = np.asarray(reference, dtype=np.float64).reshape(-1, 3)
    mea = np.asarray(measured, dtype=np.float64).reshape(-1, 3)
    if ref.shape != mea.shape:
        raise InputError(f"{len(ref)} reference points but {len(mea)} measured points")
    if len(ref) == 0:
        raise InputError(
            "no check points", hint="give at least one point present in both point lists"
        )
    if not (np.isfinite(ref).all() and np.isfinite(mea).all()):
        raise InputError("check point coordinates contain NaN or infinite values")
    id_t = tuple(str(i) for i in ids) if ids is not None else tuple(str(i) for i in range(len(ref)))
    return CheckPointReport(ids=id_t, reference=ref, measured=mea, residuals=ref - mea)


def plot_residual_map(
    report: CheckPointReport,
    path: str | Path,
    *,
    title: str = "Check point residuals",
    circle_scale: float | None = None,
) -> Path:
    """Plan view of the check points with circles scaled by the 3D residual (PNG).

    As in the thesis's figure 3.5: each check point is drawn at its reference XY
    position with a circle whose radius is proportional to its 3D residual, the
    planimetric residual as an arrow and the colour giving the height residual.
    ``circle_scale`` is map metres per metre of residual (default: the largest
    residual becomes 8 % of the map extent).  Written atomically.
    """
    import matplotlib

    matplotlib.use("Agg", force=False)
    from matplotlib import pyplot as plt
    from matplotlib.patches import Circle

    from pyheracles.io.atomic import atomic_path

    xy = report.reference[:, :2]
    off = np.floor(xy.min(axis=0))
    xy = xy - off
    extent = float(max(np.ptp(xy[:, 0]), np.ptp(xy[:, 1]), 1.0))
    r3 = report.residual_3d
    if circle_scale is None:
        circle_scale = 0.08 * extent / max(float(r3.max()), 1e-9)
    vz = report.residuals[:, 2]
    lim = max(float(np.abs(vz).max()), 1e-6)
    fig, ax = plt.subplots(figsize=(8, 7), dpi=120)
    cmap = plt.get_cmap("coolwarm")
    for i in range(len(xy)):  # one patch per check point (tens of points, not a point loop)
        ax.add_patch(
            Circle(
                xy[i],
                r3[i] * circle_scale,
                facecolor=cmap(0.5 + 0.5 * vz[i] / lim),
                edgecolor="k",
                alpha=0.7,
            )
        )
        ax.annotate(report.ids[i], xy[i], xytext=(4, 4), textcoords="offset points", fontsize=7)
    ax.quiver(
        xy[:, 0],
        xy[:, 1],
        report.residuals[:, 0] * circle_scale,
        report.residuals[:, 1] * circle_scale,
        angles="xy",
        scale_units="xy",
        scale=1.0,
        width=0.003,
    )
    # legend circle: the largest "nice" value (1, 2, 5 x 10^k m) not above the largest residual
    top = max(float(r3.max()), 1e-4)
    nice = np.array([1, 2, 5])[None, :] * 10.0 ** np.arange(-4, 1)[:, None]
    ref_r = float(nice[nice <= top].max())
    legend_xy = (xy[:, 0].min(), xy[:, 1].min() - 0.12 * extent)
    ax.add_patch(Circle(legend_xy, ref_r * circle_scale, fill=False, edgecolor="k"))
    ax.text(
        legend_xy[0] + 1.3 * ref_r * circle_scale,
        legend_xy[1],
        f"{ref_r * 1000:g} mm (3D)",
        va="center",
    )
    sm = plt.cm.ScalarMappable(cmap=cmap, norm=plt.Normalize(-lim * 100, lim * 100))
    fig.colorbar(sm, ax=ax, label="height residual (cm)")
    pad = 0.15 * extent
    ax.set_xlim(xy[:, 0].min() - pad, xy[:, 0].max() + pad)
    ax.set_ylim(xy[:, 1].min() - 2 * pad, xy[:, 1].max() + pad)
    ax.set_aspect("equal")
    ax.set_xlabel(f"X - {off[0]:.0f} (m)")
    ax.set_ylabel(f"Y - {off[1]:.0f} (m)")
    rms = report.rms
    ax.set_title(
        f"{title}\nRMS X {rms['x'] * 100:.1f} cm, Y {rms['y'] * 100:.1f} cm, "
        f"Z {rms['z'] * 100:.1f} cm, 3D {rms['3d'] * 100:.1f} cm (n = {len(xy)})"
    )
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png")
    plt.close(fig)
    return Path(path)


@dataclass(frozen=True, eq=False)
class ResidualPropagation:
    """Check point residuals with their covariance from first-order error propagation.

    Attributes
    ----------
    residuals
        ``(3 n,)`` residuals ``reference - measured`` of the ``n`` check points (X, Y, Z
        per point), metres, computed from the observations as given.
    jacobian
        ``(3 n, m)`` derivatives of the residuals with respect to the ``m`` observations.
    sigma
        ``(m,)`` standard deviations of the observations.
    groups
        ``name -> index array`` of observation columns (e.g. control, tie points).
    """

    residuals: NDArray[np.float64]
    jacobian: NDArray[np.float64]
    sigma: NDArray[np.float64]
    groups: dict[str, NDArray[np.int_]]

    @property
    def n_points(self) -> int:
        return len(self.residuals) // 3

    @property
    def covariance(self) -> NDArray[np.float64]:
        """``(3 n, 3 n)`` covariance ``J diag(sigma^2) J^T`` of the residuals."""
        Js = self.jacobian * self.sigma
        return Js @ Js.T

    @property
    def expected_rms_3d(self) -> float:
        """``sqrt(E[RMS_3D^2]) = sqrt(trace(C) / n)``, metres: the RMS the noise allows."""
        return float(np.sqrt(np.sum((self.jacobian * self.sigma) ** 2) / self.n_points))

    @property
    def rms_3d(self) -> float:
        """3D RMS of :attr:`residuals`, metres."""
        return float(np.sqrt(np.sum(self.residuals**2) / self.n_points))

    def expected_rms_by_group(self) -> dict[str, float]:
        """Share of each observation group in the expected RMS, ``sqrt(trace(C_g) / n)``.

        The groups are independent, so the squares add up to :attr:`expected_rms_3d` squared.
        """
        js = self.jacobian * self.sigma
        return {
            k: float(np.sqrt(np.sum(js[:, i] ** 2) / self.n_points)) for k, i in self.groups.items()
        }

    def chi2_test(self) -> tuple[float, int, float]:
        """Global test of the residuals: ``(v^T C^-1 v, 3 n, upper-tail p-value)``.

        Under the stated noise ``v^T C^-1 v`` follows chi-square with ``3 n`` degrees of
        freedom; it accounts for the correlation of the check points through the shared
        transforms, which the plain RMS ratio does not.
        """
        C = self.covariance
        q = float(self.residuals @ np.linalg.solve(C, self.residuals))
        dof = len(self.residuals)
        return q, dof, float(chi2.sf(q, dof))


def propagate_residuals(
    residual_fn: Callable[[NDArray[np.float64]], NDArray[np.float64]],
    observations: ArrayLike,
    sigma: ArrayLike,
    *,
    groups: dict[str, NDArray[np.int_]] | None = None,
    rel_step: float = 1e-3,
) -> ResidualPropagation:
    """First-order propagation of observation noise into check point residuals.

    Every noise source of a registration chain (targets measured in the clouds, tie
    points, control coordinates, check point references and measurements) is an
    observation with a standard deviation.  ``residual_fn`` runs the whole chain
    (estimation of the transforms, then the residuals of the check points) from a
    flat observation vector.  Its Jacobian ``J`` is taken by forward differences
    (one run per observation, step ``rel_step`` sigma, small enough to keep outlier
    decisions unchanged), and the residuals' covariance is ``C = J diag(sigma^2) J^T``.
    The expected squared 3D RMS of ``n`` check points is then ``trace(C) / n``: the
    RMS that the stated noise allows for *this* estimator, including its weighting and
    all correlations (e.g. the tie error that both clouds' check points share).

    Parameters
    ----------
    residual_fn
        ``(m,) observations -> (3 n,) residuals`` (reference - measured, metres).
    observations, sigma
        ``(m,)`` observation values and their standard deviations (> 0).
    groups
        Optional ``name -> column indices`` for :meth:`ResidualPropagation.expected_rms_by_group`.
    rel_step
        Finite-difference step in units of each observation's sigma.

    Examples
    --------
    >>> import numpy as np
    >>> fn = lambda o: o[:3] - o[3:]  # reference minus measured, no estimation
    >>> pr = propagate_residuals(fn, np.zeros(6), np.full(6, 0.003))
    >>> round(pr.expected_rms_3d * 1000, 3)  # sqrt(3 * (3^2 + 3^2)) mm
    7.348
    """
    x0 = np.asarray(observations, dtype=np.float64).reshape(-1)
    sg = np.asarray(sigma, dtype=np.float64).reshape(-1)
    if sg.shape != x0.shape:
        raise InputError(f"{len(sg)} sigmas for {len(x0)} observations")
    if not (np.isfinite(sg).all() and (sg > 0).all()):
        raise InputError("observation standard deviations must be positive and finite")
    if rel_step <= 0:
        raise InputError(f"rel_step must be positive, got {rel_step}")
    r0 = np.asarray(residual_fn(x0), dtype=np.float64).reshape(-1)
    if len(r0) % 3:
        raise InputError(f"the residual function returned {len(r0)} values, not 3 per point")
    J = np.zeros((len(r0), len(x0)))
    for k in range(len(x0)):  # one run of the chain per observation (hundreds), not per point
        h = rel_step * sg[k]
        x = x0.copy()
        x[k] += h
        J[:, k] = (np.asarray(residual_fn(x), dtype=np.float64).reshape(-1) - r0) / h
    return ResidualPropagation(
        residuals=r0, jacobian=J, sigma=sg, groups=dict(groups or {"all": np.arange(len(x0))})
    )
