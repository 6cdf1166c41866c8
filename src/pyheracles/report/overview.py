"""Overview picture of a step-1 result: top view of objects, ground and polygons, plus F1 bars."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pyheracles.cloud import PointCloud
from pyheracles.io.atomic import atomic_path
from pyheracles.labels import Segmentation

__all__ = ["plot_complex_overview"]


def plot_complex_overview(
    cloud: PointCloud,
    seg: Segmentation,
    layers: Mapping[str, Any],
    path: str | Path,
    *,
    scores: pd.DataFrame | None = None,
    max_points: int = 400_000,
    seed: int = 0,
) -> Path:
    """Write a PNG: objects coloured by instance over grey ground, GIS outlines on top.

    Parameters
    ----------
    cloud, seg
        The cloud and its segmentation.
    layers
        Layer name -> GeoDataFrame (world coordinates), drawn as outlines.
    path
        Output PNG (written atomically).
    scores
        Optional per-object evaluation table with ``object`` and ``f1``
        columns; adds a bar chart of F1.
    max_points
        Points drawn at most (a random, seeded subset).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rng = np.random.default_rng(seed)
    n = len(cloud)
    idx = rng.choice(n, size=min(n, max_points), replace=False) if n > max_points else np.arange(n)
    xy = cloud.world_xyz()[idx, :2]
    inst = seg.instance[idx]
    ncols = 2 if scores is not None and len(scores) else 1
    fig, axes = plt.subplots(
        1, ncols, figsize=(9 * ncols, 9), gridspec_kw={"width_ratios": [3, 2][:ncols]}
    )
    ax = axes[0] if ncols == 2 else axes
    ground = seg.ground[idx] if seg.ground is not None else np.zeros(len(idx), bool)
    rest = (inst == 0) & ~ground
    ax.scatter(xy[ground, 0], xy[ground, 1], s=0.2, c="0.85", lw=0, label="ground")
    ax.scatter(xy[rest, 0], xy[rest, 1], s=0.2, c="0.45", lw=0, label="remainder")
    obj = inst > 0
    cmap = plt.get_cmap("tab20")
    ax.scatter(xy[obj, 0], xy[obj, 1], s=0.4, c=cmap((inst[obj] * 7) % 20), lw=0)
    colours = ["black", "crimson", "navy", "darkgreen", "purple"]
    for k, (name, gdf) in enumerate(layers.items()):
        gdf.boundary.plot(ax=ax, color=colours[k % len(colours)], lw=0.8, label=f"GIS: {name}")
    ax.set_aspect("equal")
    ax.ticklabel_format(useOffset=False, style="plain")
    ax.set_xlabel("E (m)")
    ax.set_ylabel("N (m)")
    counts = seg.counts()
    ax.set_title(
        f"{counts['n_objects']} objects, {counts['objects']:,} object points, "
        f"{counts['ground']:,} ground, {counts['remainder']:,} remainder"
    )
    ax.legend(loc="upper right", markerscale=20, fontsize=8)
    if ncols == 2:
        bars = scores.dropna(subset=["f1"])
        axes[1].barh(bars["object"].astype(str), bars["f1"], color="steelblue")
        axes[1].axvline(0.95, color="crimson", lw=1, ls="--")
        axes[1].set_xlim(0, 1)
        axes[1].invert_yaxis()
        axes[1].set_xlabel("F1 per object")
        axes[1].tick_params(axis="y", labelsize=7)
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)
    return Path(path)
