"""Check point validation: residuals on independent points, RMS, residual map, JSON.

Check points are measured in the registered cloud (or its targets are fitted there)
and compared with their reference coordinates (thesis ch. 3, table 3.3 and figure
3.5).  Residuals are ``reference - measured``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pyheracles.errors import InputError

__all__ = ["CheckPointReport", "check_points", "plot_residual_map"]


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
