"""Plots of a bundle adjustment (matplotlib imported lazily, Agg backend).

* radial distortion curves of each camera (thesis figure 2.4);
* histograms of the exterior orientation standard deviations (figure 2.5);
* per-image statistics: point count, residual RMS, coverage (figure 2.9).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["write_plots"]


def _pyplot():
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    return plt


def radial_distortion_curve(io: np.ndarray, r_max_mm: float, n: int = 200):
    """Radial distortion dr = K1 r^3 + K2 r^5 + K3 r^7 (mm) for r in [0, r_max]."""
    r = np.linspace(0.0, r_max_mm, n)
    dr = r * (io[5] * r**2 + io[6] * r**4 + io[7] * r**6)
    return r, dr


def write_plots(result, outdir: str | Path) -> dict[str, Path]:
    """Write ``radial_distortion.png``, ``eo_std_hist.png`` and ``image_stats.png``."""
    from pyheracles.bundle.diagnostics import image_statistics
    from pyheracles.io.atomic import atomic_path

    plt = _pyplot()
    out = Path(outdir)
    paths: dict[str, Path] = {}
    p = result.project
    # Radial distortion (thesis fig. 2.4).
    fig, ax = plt.subplots(figsize=(6, 4))
    for ci, cam in enumerate(p.cameras):
        half_diag = 0.5 * float(np.hypot(*(np.asarray(cam.image_size_px) * cam.pixel_size_mm)))
        r, dr = radial_distortion_curve(result.io[ci], half_diag)
        ax.plot(r, dr * 1000.0, label=f"camera {cam.id}")
    ax.axhline(0, color="0.6", lw=0.8)
    ax.set_xlabel("radial distance r [mm]")
    ax.set_ylabel("radial distortion dr [µm]")
    ax.set_title("Radial distortion")
    ax.legend()
    fig.tight_layout()
    with atomic_path(out / "radial_distortion.png") as tmp:
        fig.savefig(tmp, dpi=120, format="png")
    plt.close(fig)
    paths["radial_distortion"] = out / "radial_distortion.png"
    # Histograms of EO standard deviations (fig. 2.5).
    free = result.network.eo_free
    fig, axes = plt.subplots(2, 3, figsize=(10, 5.5))
    names = ("X0 [mm]", "Y0 [mm]", "Z0 [mm]", "omega [deg]", "phi [deg]", "kappa [deg]")
    for j, ax in enumerate(axes.ravel()):
        vals = result.eo_std[free[:, j], j]
        vals = vals * 1000.0 if j < 3 else np.degrees(vals)
        if vals.size:
            ax.hist(vals, bins=min(30, max(5, vals.size // 3)), color="tab:blue")
        ax.set_title(f"std {names[j]}")
    fig.suptitle("Exterior orientation standard deviations")
    fig.tight_layout()
    with atomic_path(out / "eo_std_hist.png") as tmp:
        fig.savefig(tmp, dpi=120, format="png")
    plt.close(fig)
    paths["eo_std_hist"] = out / "eo_std_hist.png"
    # Per-image statistics (fig. 2.9).
    stats = image_statistics(result)
    x = np.arange(1, len(stats) + 1)
    fig, axes = plt.subplots(3, 1, figsize=(9, 7), sharex=True)
    axes[0].bar(x, [s["n_points"] for s in stats], color="tab:blue")
    axes[0].set_ylabel("points")
    axes[1].bar(x, [s["rms_px"] for s in stats], color="tab:orange")
    axes[1].set_ylabel("residual RMS [px]")
    axes[2].bar(x, [100 * s["coverage_hull"] for s in stats], color="tab:green")
    axes[2].set_ylabel("coverage (hull) [%]")
    axes[2].set_xlabel("image")
    fig.suptitle("Per-image statistics")
    fig.tight_layout()
    with atomic_path(out / "image_stats.png") as tmp:
        fig.savefig(tmp, dpi=120, format="png")
    plt.close(fig)
    paths["image_stats"] = out / "image_stats.png"
    return paths
