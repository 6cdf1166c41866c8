"""Writing segmentation results: labelled cloud, objects table, per-object clouds, run.json."""

from __future__ import annotations

import os
import re
import weakref
from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

import geopandas as gpd
import numpy as np
import pandas as pd

from pyheracles.cloud import PointCloud
from pyheracles.io import write_cloud
from pyheracles.io.atomic import atomic_path
from pyheracles.io.vector import write_gpkg
from pyheracles.labels import (
    ASPRS_GROUND,
    ASPRS_UNCLASSIFIED,
    Segmentation,
    asprs_class,
    asprs_classification,
)
from pyheracles.provenance import write_run_json

__all__ = [
    "ASPRS_GROUND",
    "ASPRS_UNCLASSIFIED",
    "write_objects_table",
    "write_segmentation",
    "written_labels",
]

#: The labelled cloud this process wrote last: its path, the file's size and time, and
#: weak references to the cloud and segmentation it was written from (see
#: :func:`written_labels`).  Weak: a result the caller has dropped is not kept alive.
_LAST_WRITTEN: list[tuple[str, tuple[int, int], weakref.ref, weakref.ref]] = []


def _stamp(path: Path) -> tuple[int, int]:
    st = os.stat(path)
    return st.st_size, st.st_mtime_ns


def written_labels(path: str | Path) -> tuple[PointCloud, Segmentation] | None:
    """The cloud and segmentation this process has just written to ``path``.

    ``None`` unless ``path`` is the labelled cloud :func:`write_segmentation` wrote
    last, the file is unchanged since (size and time) and the caller still holds
    both objects.  The report of a run samples them from memory instead of
    decompressing the file it has just written (2.5 s of CPU for 10 M points).
    """
    if not _LAST_WRITTEN:
        return None
    key, stamp, cloud_ref, seg_ref = _LAST_WRITTEN[0]
    try:
        if key != str(Path(path).resolve()) or stamp != _stamp(Path(path)):
            return None
    except OSError:
        return None
    cloud, seg = cloud_ref(), seg_ref()
    return None if cloud is None or seg is None else (cloud, seg)


def _safe_name(value: Any) -> str:
    text = re.sub(r"[^A-Za-z0-9._-]+", "_", str(value)).strip("._")
    return text or "object"


def _missing(value: Any) -> bool:
    try:
        return bool(pd.isna(value))
    except (TypeError, ValueError):  # arrays, lists: a value
        return False


def _object_file_name(row: pd.Series, column: str) -> str:
    """``<value>`` of ``column``; ``<class>_<instance>`` when the object has no value.

    A whole-number float (an integer attribute that went through a float column)
    is written without its ``.0``.
    """
    value = row[column]
    if _missing(value):
        return f"{_safe_name(row.get('class', 'object'))}_{int(row['instance'])}"
    if isinstance(value, (float, np.floating)) and float(value).is_integer():
        value = int(value)
    return _safe_name(value)


def write_objects_table(objects: pd.DataFrame, outdir: Path, crs: Any) -> Path:
    """``objects.gpkg`` (GeoPackage 1.2) when the table has footprints and a CRS, else
    ``objects.csv``; attribute types are kept (nullable integers stay integer fields)."""
    if isinstance(objects, gpd.GeoDataFrame) and objects.crs is None and crs is not None:
        objects = objects.set_crs(crs)
    if isinstance(objects, gpd.GeoDataFrame) and objects.crs is not None and len(objects):
        return write_gpkg(objects, outdir / "objects.gpkg", "objects")
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
        Every input point in input order with every input dimension (the
        source's point format, upgraded to LAS 1.4 formats 6-10 when it cannot
        hold the class codes); extra dimensions ``instance`` (int32) and
        ``class_id`` (uint8); ASPRS classification 2 for ground, the class's
        code for objects (:data:`pyheracles.labels.ASPRS_CLASSES`: building 6,
        wall 64, gate 65 ...), 1 for the rest; the input's own classification
        kept as ``source_class``.
    ``objects.gpkg`` / ``objects.csv``
        The objects table (GeoPackage 1.2 when it has footprints and a CRS).
    ``objects/<name>.laz``
        With ``per_object``: one cloud per object, named after that column of
        the objects table (``instance`` if in doubt); objects without a value
        are named ``<class>_<instance>``.
    ``run.json``
        Provenance, parameters, timings and the conservation balance.
    """
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    counts = seg.check_balance()
    labels: dict[str, np.ndarray] = {"instance": seg.instance, "class_id": seg.class_id}
    attrs = dict(cloud.attributes)
    if "classification" in attrs:
        labels["source_class"] = np.asarray(attrs["classification"]).astype(np.uint8)
    attrs["classification"] = asprs_classification(seg)
    # replace() keeps the source's LAS header: every input dimension is written back
    out_cloud = replace(cloud, attributes=attrs)
    notes: list[str] = []
    paths: dict[str, Path] = {
        "cloud": write_cloud(out_cloud, out / cloud_name, labels, notes=notes)
    }
    written = paths["cloud"].resolve()
    _LAST_WRITTEN[:] = [(str(written), _stamp(written), weakref.ref(cloud), weakref.ref(seg))]
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
            name = _object_file_name(row, per_object)
            if name in used:
                name = f"{name}_{int(row['instance'])}"
            used.add(name)
            write_cloud(out_cloud.subset(idx), obj_dir / f"{name}.laz",
                        {k: v[idx] for k, v in labels.items()}, notes=notes)  # fmt: skip
        paths["objects_dir"] = obj_dir
    asprs = {str(name): asprs_class(name) for name in seg.classes.values()}
    paths["run"] = write_run_json(
        out, step=step, parameters=parameters, inputs=inputs, timings=timings, counts=counts,
        extra={"classes": {str(k): v for k, v in seg.classes.items()},
               "asprs_classes": {"ground": ASPRS_GROUND, "remainder": ASPRS_UNCLASSIFIED,
                                 **asprs},
               "warnings": list(seg.warnings) + list(dict.fromkeys(notes)),
               **dict(extra or {})},
    )  # fmt: skip
    return paths
