"""Plan view of a labelled cloud: every object in its own colour and labelled by its name."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from pyheracles.io.atomic import atomic_path
from pyheracles.report.colours import GROUND, REMAINDER, object_colours
from pyheracles.report.folder import CloudSample

__all__ = ["plan_figure", "plot_plan"]


def plot_plan(sample: CloudSample, labels: Mapping[int, str], path: str | Path, **kw: Any) -> Path:
    """Write :func:`plan_figure` as a PNG, atomically."""
    import matplotlib.pyplot as plt

    fig = plan_figure(sample, labels, **kw)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=100, format="png")
    plt.close(fig)
    return Path(path)


def plan_figure(
    sample: CloudSample,
    labels: Mapping[int, str],
    *,
    footprints: Any = None,
    missing: Sequence[str] = (),
    title: str = "",
    max_legend: int = 40,
    max_points: int = 120_000,
) -> Any:
    """A plan (matplotlib figure): ground light grey, remainder dark grey, objects named.

    Parameters
    ----------
    sample
        The (subsampled) labelled cloud.
    labels
        Instance -> name shown on the map and in the legend.
    footprints
        GeoDataFrame of the objects' polygons (world coordinates), drawn as outlines.
    missing
        Names of features that got no points, listed under the map.
    title
        First line of the title; the CRS and the counts follow.
    max_legend
        Objects listed in the legend at most (every object stays labelled on the map).
    max_points
        Points drawn at most (each object keeps at least 200).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    # a plan needs fewer points than the 3D view: at most max_points, every object kept
    take = _thin(sample.instance, max_points)
    xy = sample.xyz[take, :2].astype(float) + sample.origin[:2]
    inst = sample.instance[take]
    fig, ax = plt.subplots(figsize=(11, 9))
    g = sample.ground[take]
    rest = (inst == 0) & ~g
    ax.scatter(xy[g, 0], xy[g, 1], s=0.2, color=GROUND, lw=0, rasterized=True)
    ax.scatter(xy[rest, 0], xy[rest, 1], s=0.2, color=REMAINDER, lw=0, rasterized=True)
    ids = [int(i) for i in np.unique(inst) if i > 0]
    cols = object_colours(max(ids, default=0))
    handles = [
        Line2D([], [], ls="", marker="s", color=GROUND, label="ground"),
        Line2D([], [], ls="", marker="s", color=REMAINDER, label="remainder"),
    ]
    if ids:
        m = inst > 0
        ax.scatter(xy[m, 0], xy[m, 1], s=0.5, c=cols[inst[m] - 1], lw=0, rasterized=True)
    for i in ids:
        p = xy[inst == i]
        name = labels.get(i, f"object {i}")
        cx, cy = np.median(p[:, 0]), np.median(p[:, 1])
        ax.annotate(
            name,
            (cx, cy),
            fontsize=7,
            ha="center",
            va="center",
            bbox={
                "boxstyle": "round,pad=0.15",
                "fc": "white",
                "ec": cols[i - 1],
                "alpha": 0.8,
                "lw": 1,
            },
        )
        if len(handles) < max_legend + 2:
            handles.append(Line2D([], [], ls="", marker="s", color=cols[i - 1], label=name))
    if footprints is not None and len(footprints):
        footprints.boundary.plot(ax=ax, color="black", lw=0.6)
        handles.append(Line2D([], [], color="black", lw=0.6, label="GIS outline"))
    if len(ids) > max_legend:
        handles.append(Line2D([], [], ls="", label=f"... {len(ids) - max_legend} more (on map)"))
    ax.legend(
        handles=handles,
        loc="center left",
        bbox_to_anchor=(1.01, 0.5),
        fontsize=7,
        markerscale=1.2,
        frameon=False,
    )
    ax.set_aspect("equal")
    ax.ticklabel_format(useOffset=False, style="plain")
    ax.set_xlabel("E (m)")
    ax.set_ylabel("N (m)")
    crs = sample.crs or "no CRS (local coordinates)"
    ax.set_title(f"{title}\n{len(ids)} objects; CRS: {crs}".strip(), fontsize=10)
    if missing:
        text = "features with no points: " + ", ".join(missing[:30])
        if len(missing) > 30:
            text += f" ... ({len(missing)} in all)"
        fig.text(0.01, 0.01, text, fontsize=8, color="crimson")
    fig.tight_layout(rect=(0, 0.03, 1, 1))
    return fig


def _thin(instance: np.ndarray, max_points: int) -> np.ndarray:
    """Indices of at most about ``max_points`` points, each object keeping up to 200."""
    n = len(instance)
    if n <= max_points:
        return np.arange(n)
    step = int(np.ceil(n / max_points))
    keep = np.zeros(n, bool)
    keep[::step] = True
    order = np.argsort(instance, kind="stable")
    ids, starts, counts = np.unique(instance[order], return_index=True, return_counts=True)
    for i, s, c in zip(ids, starts, counts, strict=True):
        if i > 0:
            keep[order[s : s + min(c, 200)]] = True
    return np.flatnonzero(keep)
