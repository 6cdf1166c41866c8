"""Writing segmentation results: labelled cloud, objects table, per-object clouds, run.json."""

from __future__ import annotations

import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import geopandas as gpd
import numpy as np
import pandas as pd

from pyheracles.cloud import PointCloud
from pyheracles.io import write_cloud
from pyheracles.io.atomic import atomic_path
from pyheracles.labels import Segmentation
from pyheracles.provenance import write_run_json

__all__ = ["write_objects_table", "write_segmentation"]

ASPRS_GROUND = 2
ASPRS_UNCLASSIFIED = 1


def _safe_name(value: Any) -> str:
    text = re.sub(r"[^A-Za-z0-9._-]+", "_", str(value)).strip("._")
    return text or "object"


def write_objects_table(objects: pd.DataFrame, outdir: Path, crs: Any) -> Path:
    """``objects.gpkg`` when the table has footprints and a CRS, else ``objects.csv``."""
    if isinstance(objects, gpd.GeoDataFrame) and objects.crs is None and crs is not None:
        objects = objects.set_crs(crs)
    if isinstance(objects, gpd.GeoDataFrame) and objects.crs is not None and len(objects):
        path = outdir / "objects.gpkg"
        table = objects.copy()
        for col in table.columns:  # GPKG has no unsigned 64-bit / object-of-mixed types
            if col != table.geometry.name and table[col].dtype == object:
                table[col] = table[col].astype("string")
        with atomic_path(path) as tmp:
            # "fid" is the GeoPackage primary key's default name; GIS layers often
            # carry an attribute of that name, so the key is called ogc_fid.
            table.to_file(
                tmp, driver="GPKG", layer="objects", engine="pyogrio",
                layer_options={"FID": "ogc_fid"},
            )  # fmt: skip
        return path
    path = outdir / "objects.csv"
    table = pd.DataFrame(objects).drop(columns=["geometry"], errors="ignore")
    if isinstance(objects, gpd.GeoDataFrame) and len(objects):
        table["footprint_wkt"] = objects.geometry.to_wkt()
    with atomic_path(path) as tmp:
        table.to_csv(tmp, index=False)
    return path


def write_segmentation(
    cloud: PointCloud,
    seg: Segmentation,
    outdir: str | Path,
    *,
    step: str,
    parameters: Any = None,
    inputs: tuple[str | Path, ...] | list[str | Path] = (),
    timings: Mapping[str, float] | None = None,
    per_object: str | None = None,
    extra: Mapping[str, Any] | None = None,
    cloud_name: str = "segmented.laz",
) -> dict[str, Path]:
    """Write a segmentation result into ``outdir``.

    Files
    -----
    ``segmented.laz``
        Every input point in input order; extra dimensions ``instance`` (int32)
        and ``class_id`` (uint8); ASPRS classification 2 for ground, 1 for the
        rest; the input's own classification kept as ``source_class``.
    ``objects.gpkg`` / ``objects.csv``
        The objects table (GeoPackage when it has footprints and a CRS).
    ``objects/<name>.laz``
        With ``per_object``: one cloud per object, named after that column of
        the objects table (``instance`` if in doubt).
    ``run.json``
        Provenance, parameters, timings and the conservation balance.
    """
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    counts = seg.check_balance()
    extra_dims: dict[str, np.ndarray] = {"instance": seg.instance, "class_id": seg.class_id}
    attrs = dict(cloud.attributes)
    if "classification" in attrs:
        extra_dims["source_class"] = np.asarray(attrs["classification"]).astype(np.uint8)
    classification = np.full(len(cloud), ASPRS_UNCLASSIFIED, dtype=np.uint8)
    if seg.ground is not None:
        classification[seg.ground] = ASPRS_GROUND
    attrs["classification"] = classification
    out_cloud = PointCloud(
        xyz=cloud.xyz, offset=cloud.offset, attributes=attrs, crs=cloud.crs,
        scale=cloud.scale, source=cloud.source,
    )  # fmt: skip
    paths: dict[str, Path] = {"cloud": write_cloud(out_cloud, out / cloud_name, extra_dims)}
    paths["objects"] = write_objects_table(seg.objects, out, cloud.crs)
    if per_object is not None and len(seg.objects):
        if per_object not in seg.objects.columns:
            from pyheracles.errors import InputError

            raise InputError(
                f"cannot name per-object files after {per_object!r}: no such column",
                hint=f"choose one of {', '.join(map(str, seg.objects.columns))}",
            )
        obj_dir = out / "objects"
        order = np.argsort(seg.instance, kind="stable")
        bounds = np.searchsorted(seg.instance[order], seg.objects["instance"].to_numpy())
        used: set[str] = set()
        for (_, row), start in zip(seg.objects.iterrows(), bounds, strict=True):
            idx = order[start : start + int(row["n_points"])]
            name = _safe_name(row[per_object])
            if name in used:
                name = f"{name}_{int(row['instance'])}"
            used.add(name)
            write_cloud(out_cloud.subset(idx), obj_dir / f"{name}.laz",
                        {"instance": seg.instance[idx], "class_id": seg.class_id[idx]})  # fmt: skip
        paths["objects_dir"] = obj_dir
    paths["run"] = write_run_json(
        out, step=step, parameters=parameters, inputs=inputs, timings=timings, counts=counts,
        extra={"classes": {str(k): v for k, v in seg.classes.items()},
               "warnings": list(seg.warnings), **dict(extra or {})},
    )  # fmt: skip
    return paths
