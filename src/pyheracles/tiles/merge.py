"""The merge of a tiled run: global object ids, the merged objects table, the tile index."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from pyheracles.tiles.catalog import TileCatalog
from pyheracles.tiles.worker import load_record

__all__ = [
    "class_ids",
    "feature_ids",
    "load_records",
    "merged_objects",
    "tile_counts",
    "tile_index",
]


def feature_ids(layers: Mapping[str, Any]) -> dict[str, Any]:
    """Layer name -> the global object id of each of its features (1, 2, ... over the layers
    in order): an object's id is its feature's, so ids do not depend on which tiles ran
    (a resumed run, a failed tile) and never collide."""
    out, base = {}, 1
    for name, gdf in layers.items():
        out[name] = base + np.arange(len(gdf), dtype=np.int64)
        base += len(gdf)
    return out


def class_ids(layer_order: Any, layer_names: Any) -> dict[str, int]:
    """Class name -> class id: ``layer_order`` first, then the other layers in order."""
    names = list(layer_order or ())
    names += [c for c in layer_names if c not in names]
    return {c: k for k, c in enumerate(names, start=1)}


def load_records(catalog: TileCatalog, work: Path, failed: Mapping[str, str]) -> dict[str, Any]:
    """Tile name -> its phase-1 record, for the tiles not in ``failed``."""
    return {t.name: load_record(work / f"{t.name}.pkl") for t in catalog.tiles
            if t.name not in failed}  # fmt: skip


def merged_objects(
    records: Mapping[str, dict[str, Any]],
    classes: Mapping[str, int],
    totals: Mapping[int, int],
    crs: Any,
) -> Any:
    """All owned objects in one GeoDataFrame, by id: ``n_points`` over all tiles
    (``totals``: instance -> points), the owning ``tile``."""  # fmt: skip
    import geopandas as gpd
    import pandas as pd

    tables = []
    for name, rec in records.items():
        rows = rec["objects"]
        if rows is None or not len(rows):
            continue
        rows = rows.copy()
        rows["class_id"] = [classes[c] for c in rows["class"]]
        rows["tile"] = name
        tables.append(rows)
    if not tables:
        return gpd.GeoDataFrame({"instance": np.zeros(0, np.int32)},
                                geometry=gpd.GeoSeries([], crs=crs))  # fmt: skip
    objects = gpd.GeoDataFrame(pd.concat(tables, ignore_index=True), crs=crs)
    objects = objects.sort_values("instance", kind="stable").reset_index(drop=True)
    objects["n_points"] = np.array([totals.get(int(i), 0) for i in objects["instance"]],
                                   dtype=np.int64)  # fmt: skip
    return objects


def tile_index(catalog: TileCatalog, status: Mapping[str, str], output: str, crs: Any) -> Any:
    """The tile index: one row per tile (the unreadable ones too) with its status and
    its output file (``tiles/<tile>/<output>``, empty for a failed tile)."""
    import geopandas as gpd
    import shapely

    tiles = catalog.tiles
    bad = catalog.unreadable
    return gpd.GeoDataFrame(
        {
            "name": [t.name for t in tiles] + [Path(u).stem for u, _ in bad],
            "location": [str(t.path) for t in tiles] + [u for u, _ in bad],
            "n_points": [t.n_points for t in tiles] + [0] * len(bad),
            "status": [status.get(t.name, "failed") for t in tiles]
            + [f"failed: {r}" for _, r in bad],
            "output": [
                str(Path("tiles") / t.name / output)
                if not status.get(t.name, "failed").startswith("failed") else ""
                for t in tiles
            ] + [""] * len(bad),
        },
        geometry=[shapely.box(*t.bounds) for t in tiles] + [None] * len(bad),
        crs=crs,
    )  # fmt: skip


def tile_counts(folder: Path) -> dict[int, int]:
    """Instance -> points of a finished tile folder, from its ``objects.gpkg``."""
    import pyogrio

    gpkg = folder / "objects.gpkg"
    if not gpkg.is_file():
        return {}
    table = pyogrio.read_dataframe(gpkg, read_geometry=False, columns=["instance", "n_points"])
    return dict(zip(table["instance"].astype(int), table["n_points"].astype(int), strict=True))
