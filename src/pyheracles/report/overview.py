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
    from matplotlib.lines import Line2D

    from pyheracles.report.colours import GROUND, REMAINDER, object_colours

    rng = np.random.default_rng(seed)
    n = len(cloud)
    idx = rng.choice(n, size=min(n, max_points), replace=False) if n > max_points else np.arange(n)
    xy = cloud.world_xyz()[idx, :2]
    inst = seg.instance[idx]
    ncols = 2 if scores is not None and len(scores) else 1
    fig, axes = plt.subplots(
        1, ncols, figsize=(10 * ncols, 9), gridspec_kw={"width_ratios": [3, 2][:ncols]}
    )
    ax = axes[0] if ncols == 2 else axes
    ground = seg.ground[idx] if seg.ground is not None else np.zeros(len(idx), bool)
    rest = (inst == 0) & ~ground
    ax.scatter(xy[ground, 0], xy[ground, 1], s=0.2, color=GROUND, lw=0, rasterized=True)
    ax.scatter(xy[rest, 0], xy[rest, 1], s=0.2, color=REMAINDER, lw=0, rasterized=True)
    obj = inst > 0
    # one colour per object, never the ground's or the remainder's grey
    cols = object_colours(int(seg.instance.max(initial=0)))
    if obj.any():
        ax.scatter(xy[obj, 0], xy[obj, 1], s=0.4, c=cols[inst[obj] - 1], lw=0, rasterized=True)
    names = _object_names(seg.objects)
    for i, name in names.items():
        m = inst == i
        if m.any():
            ax.annotate(
                name,
                (np.median(xy[m, 0]), np.median(xy[m, 1])),
                fontsize=6.5,
                ha="center",
                va="center",
                bbox={
                    "boxstyle": "round,pad=0.12",
                    "fc": "white",
                    "alpha": 0.75,
                    "ec": cols[i - 1],
                    "lw": 0.8,
                },
            )
    handles = [
        Line2D([], [], ls="", marker="s", color=GROUND, label="ground"),
        Line2D([], [], ls="", marker="s", color=REMAINDER, label="remainder"),
    ]
    outline = ["black", "crimson", "navy", "darkgreen", "purple"]
    for k, (name, gdf) in enumerate(layers.items()):
        gdf.boundary.plot(ax=ax, color=outline[k % len(outline)], lw=0.8)
        handles.append(
            Line2D([], [], color=outline[k % len(outline)], lw=0.8, label=f"GIS outline: {name}")
        )
    handles.append(
        Line2D(
            [],
            [],
            ls="",
            marker="s",
            color=cols[0] if len(cols) else "C0",
            label="objects: one colour each, named on the map",
        )
    )
    ax.legend(handles=handles, loc="upper right", fontsize=8)
    ax.set_aspect("equal")
    ax.ticklabel_format(useOffset=False, style="plain")
    crs = getattr(cloud.crs, "name", None) or (str(cloud.crs) if cloud.crs else None)
    ax.set_xlabel("E (m)")
    ax.set_ylabel("N (m)")
    counts = seg.counts()
    ax.set_title(
        f"{counts['n_objects']} objects, {counts['objects']:,} object points, "
        f"{counts['ground']:,} ground, {counts['remainder']:,} remainder\n"
        f"CRS: {crs or 'none (local coordinates)'}",
        fontsize=10,
    )
    missing = _features_without_points(seg.objects, layers)
    if missing:
        fig.text(
            0.01,
            0.01,
            "features that got no points: " + ", ".join(missing),
            fontsize=8,
            color="crimson",
        )
    if ncols == 2:
        bars = scores.dropna(subset=["f1"])
        axes[1].barh(bars["object"].astype(str), bars["f1"], color="steelblue")
        axes[1].axvline(0.95, color="crimson", lw=1, ls="--", label="target: F1 = 0.95")
        axes[1].set_xlim(0, 1)
        axes[1].invert_yaxis()
        axes[1].set_xlabel("F1 per object against the generated reference")
        axes[1].tick_params(axis="y", labelsize=7)
        axes[1].legend(loc="lower left", fontsize=8)
    fig.tight_layout(rect=(0, 0.03, 1, 1))
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)
    return Path(path)


#: Attribute columns that name a GIS feature, in order of preference.
#: Attribute columns that name an object, most telling first (a GIS name, a BAG id, a role).
NAME_COLUMNS = ("name", "naam", "fid", "identificatiebagpnd", "gml_id", "role")


def name_column(objects: pd.DataFrame) -> str | None:
    """The first of :data:`NAME_COLUMNS` that the objects table has and fills at least once."""
    return next((c for c in NAME_COLUMNS if c in objects and objects[c].notna().any()), None)


def object_name(row: Mapping[str, Any], column: str | None) -> str:
    """Display name of an objects-table row: its ``column`` value, else ``"<class> <instance>"``."""
    v = row.get(column) if column else None
    if v is not None and str(v) not in ("", "nan"):
        return str(v)
    cls = row.get("class")
    cls = "object" if cls is None or str(cls) in ("", "nan") else str(cls)
    return f"{cls} {int(row['instance'])}"


def _object_names(objects: pd.DataFrame) -> dict[int, str]:
    col = name_column(objects)
    return {int(row["instance"]): object_name(row, col) for row in objects.to_dict("records")}


def _features_without_points(objects: pd.DataFrame, layers: Mapping[str, Any]) -> list[str]:
    """Names of the GIS features (per layer) that became no object."""
    out = []
    for name, gdf in layers.items():
        got = set()
        if "source_fid" in objects and "class" in objects:
            got = set(objects.loc[objects["class"] == name, "source_fid"].dropna().astype(int))
        col = next((c for c in NAME_COLUMNS if c in gdf), None)
        for k in range(len(gdf)):
            if k not in got:
                out.append(f"{name} {gdf[col].iloc[k] if col else k}")
    return out
