"""Training data for deep learning: labelled clouds in blocks, per scene and per object.

The thesis segments heritage clouds so that the labels can train learning methods
(Murtiyoso 2020, ch. 5 and 7): :func:`export_training` turns any result folder of
``heracles`` (``segmented.laz`` + ``run.json``) into the files learning frameworks
read, with one documented class map:

* ``ply``: binary PLY per block, ``x y z`` float32 in the scene's local frame (its
  offset in a header comment and in ``classes.json``), ``red green blue`` (uint8)
  and ``intensity`` when the cloud has them, ``label`` (uint8, the training class)
  and ``instance`` (int32, 0 = no object);
* ``npz``: the same arrays in one compressed NumPy archive per block
  (``xyz``, ``label``, ``instance``, ``rgb``, ``intensity``, ``offset``, ``bounds``);
* ``s3dis``: the layout of the Stanford S3DIS data set that most segmentation codes
  read: ``Area_1/<block>/<block>.txt`` (``x y z r g b`` per line, mm) and
  ``Annotations/<class>_<k>.txt`` with one file per object, plus one per class for
  the points of no object (ground as ``floor_0``, the rest as ``other_0``).

Blocks are squares of ``block_m`` in plan (world-aligned), so every point lies in
exactly one block; ``blocks.csv`` lists them.  ``objects/`` holds one file per
object (``ply`` and ``npz``), for instance-level training.

Class map (:data:`TRAINING_CLASSES`): the ten classes of the ArCH heritage
benchmark (Matrone et al. 2020, ISPRS Archives XLIII-B2) with their ArCH numbers,
and ``beam`` (10), which ArCH lacks (timber frameworks are step 2b's objects).
Names of pyheracles classes are mapped by :data:`CLASS_NAMES`; a name not in it
goes to ``other`` and is listed in ``classes.json`` under ``unmapped``; a
``--class-map`` JSON file (``{"gate": "wall"}``) extends or overrides it.
"""

from __future__ import annotations

import csv
import io
import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pyheracles.errors import InputError
from pyheracles.io.atomic import atomic_path, atomic_write_json, atomic_write_text
from pyheracles.io.ply import write_vertex_table

__all__ = [
    "CLASS_NAMES",
    "FORMATS",
    "TRAINING_CLASSES",
    "TrainingExport",
    "TrainingParams",
    "export_training",
    "training_labels",
]

#: Training classes: id -> name (ArCH numbering 0-9, ``beam`` added as 10).
TRAINING_CLASSES: Mapping[int, str] = {
    0: "arch", 1: "column", 2: "moldings", 3: "floor", 4: "door_window", 5: "wall",
    6: "stairs", 7: "vault", 8: "roof", 9: "other", 10: "beam",
}  # fmt: skip
_ID = {name: k for k, name in TRAINING_CLASSES.items()}
#: pyheracles class names (case-blind, singular or plural) -> training class name.
CLASS_NAMES: Mapping[str, str] = {
    "column": "column", "pier": "column", "engaged_column": "column", "pilaster": "column",
    "beam": "beam", "member": "beam", "rafter": "beam", "purlin": "beam", "post": "beam",
    "wall": "wall", "fence": "wall", "enclosure": "wall",
    "roof": "roof", "attic": "roof",
    "door": "door_window", "window": "door_window", "opening": "door_window",
    "arch": "arch", "vault": "vault", "stairs": "stairs", "step": "stairs",
    "moulding": "moldings", "molding": "moldings",
    "ground": "floor", "floor": "floor",
}  # fmt: skip
FORMATS = ("ply", "npz", "s3dis")


@dataclass(frozen=True)
class TrainingParams:
    """Parameters of :func:`export_training`.

    Parameters
    ----------
    format
        ``ply``, ``npz`` or ``s3dis`` (see the module notes).
    block_m
        Side of the square plan blocks, metres; 0 writes the scene as one block.
        10 m holds a room or a bay of a church at TLS density in a few million points.
    per_object
        Also write ``objects/<class>_<instance>.<ext>`` per object (ply and npz).
    class_map
        Extra or overriding names -> training class names.
    """

    format: str = "ply"
    block_m: float = 10.0
    per_object: bool = True
    class_map: Mapping[str, str] = field(default_factory=dict)


@dataclass
class TrainingExport:
    """What :func:`export_training` wrote."""

    folder: Path
    n_points: int
    n_blocks: int
    n_objects: int
    class_counts: dict[str, int]
    unmapped: list[str]


def _key(name: str) -> str:
    return str(name).strip().lower().replace(" ", "_").replace("-", "_")


def training_labels(
    class_id: NDArray[np.integer],
    classes: Mapping[int, str],
    ground: NDArray[np.bool_] | None,
    class_map: Mapping[str, str] | None = None,
) -> tuple[NDArray[np.uint8], list[str]]:
    """Training class per point, and the pyheracles class names that went to ``other``.

    Parameters
    ----------
    class_id
        Per-point pyheracles class code (0 = no object).
    classes
        Class code -> name, as in ``run.json``'s ``classes``.
    ground
        Ground mask or None; ground points become ``floor`` unless the map says else.
    class_map
        Names -> training class names, over :data:`CLASS_NAMES`.

    Examples
    --------
    >>> lab, un = training_labels(np.array([0, 1, 2, 3]), {1: "pier", 2: "Beams", 3: "kiosk"}, None)
    >>> lab.tolist(), un
    ([9, 1, 10, 9], ['kiosk'])
    """
    names = {**CLASS_NAMES, **{_key(k): _key(v) for k, v in (class_map or {}).items()}}
    for k, v in names.items():
        if v not in _ID:
            raise InputError(
                f"class map: {k!r} -> {v!r} is not a training class",
                hint=f"use one of {', '.join(TRAINING_CLASSES.values())}",
            )
    lut = np.full(256, _ID["other"], dtype=np.uint8)
    unmapped = []
    for code, name in classes.items():
        key = _key(name)
        target = names.get(key) or (names.get(key[:-1]) if key.endswith("s") else None)
        if target is None:
            unmapped.append(str(name))
        else:
            lut[int(code)] = _ID[target]
    labels = lut[np.asarray(class_id, dtype=np.int64)]
    if ground is not None:
        labels[np.asarray(ground, bool)] = _ID[names.get("ground", "floor")]
    return labels, sorted(unmapped)


def _read_folder(folder: Path) -> tuple[Any, dict[int, str]]:
    from pyheracles.io import read_cloud

    if not folder.is_dir():
        raise InputError("not a result folder", path=folder, hint="give an output folder")
    cloud_path, run_path = folder / "segmented.laz", folder / "run.json"
    if not cloud_path.exists() or not run_path.exists():
        raise InputError(
            "no segmented.laz and run.json",
            path=folder,
            hint="give the output folder of a heracles step (complex, supports, beams, walls)",
        )
    try:
        run = json.loads(run_path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise InputError(f"unreadable run.json: {exc}", path=run_path) from exc
    classes = {int(k): str(v) for k, v in (run.get("classes") or {}).items()}
    cloud = read_cloud(cloud_path)
    if "instance" not in cloud.attributes or "class_id" not in cloud.attributes:
        raise InputError(
            "segmented.laz has no instance / class_id dimensions",
            path=cloud_path,
            hint="give the output folder of a heracles step",
        )
    return cloud, classes


def _colour(cloud: Any) -> NDArray[np.uint8] | None:
    a = cloud.attributes
    if not all(c in a for c in ("red", "green", "blue")):
        return None
    rgb = np.column_stack([np.asarray(a[c], np.float64) for c in ("red", "green", "blue")])
    if rgb.max(initial=0) > 255:  # LAS stores 16-bit colour
        rgb = rgb / 257.0
    return np.clip(np.round(rgb), 0, 255).astype(np.uint8)


def _write_ply(path: Path, arrays: dict[str, NDArray[Any]], offset: NDArray[np.float64]) -> None:
    """Binary little-endian PLY of float32 local coordinates and per-point fields."""
    xyz = arrays["xyz"]
    fields = [("x", xyz[:, 0]), ("y", xyz[:, 1]), ("z", xyz[:, 2])]
    if "rgb" in arrays:
        fields += [(c, arrays["rgb"][:, i]) for i, c in enumerate(("red", "green", "blue"))]
    fields += [(k, arrays[k]) for k in ("intensity", "label", "instance") if k in arrays]
    comments = ("pyheracles training export; world = xyz + offset",
                "offset {:.6f} {:.6f} {:.6f}".format(*offset))  # fmt: skip
    write_vertex_table(path, fields, comments)


def _write_npz(path: Path, arrays: dict[str, NDArray[Any]], offset: NDArray[np.float64]) -> None:
    with atomic_path(path) as tmp, open(tmp, "wb") as fh:
        np.savez_compressed(fh, offset=offset, **arrays)


def _txt(path: Path, xyz: NDArray[np.float32], rgb: NDArray[np.uint8]) -> None:
    """``x y z r g b`` lines (mm), as S3DIS."""
    buf = io.StringIO()
    np.savetxt(buf, np.column_stack([xyz.astype(np.float64), rgb]),
               fmt=["%.3f", "%.3f", "%.3f", "%d", "%d", "%d"])  # fmt: skip
    atomic_write_text(path, buf.getvalue())


def _block_index(xy: NDArray[np.float64], origin: NDArray[np.float64], block_m: float):
    if block_m <= 0:
        return np.zeros(len(xy), np.int64), np.zeros(len(xy), np.int64)
    ij = np.floor((xy + origin) / block_m).astype(np.int64)
    return ij[:, 0], ij[:, 1]


def export_training(
    result_dir: str | Path, out: str | Path, params: TrainingParams | None = None
) -> TrainingExport:
    """Write the labelled cloud of a result folder as training data (see the module notes).

    Parameters
    ----------
    result_dir
        Output folder of a ``heracles`` step (``segmented.laz`` + ``run.json``).
    out
        Folder to write; created.
    params
        Format, block size, per-object files and class map.

    Raises
    ------
    InputError
        Not a result folder, an unknown format, a bad block size or class map.
    """
    p = params or TrainingParams()
    if p.format not in FORMATS:
        raise InputError(f"unknown training format {p.format!r}", hint=f"use {', '.join(FORMATS)}")
    if not np.isfinite(p.block_m) or p.block_m < 0:
        raise InputError(f"block size must be >= 0 m, got {p.block_m!r}")
    folder, out = Path(result_dir), Path(out)
    cloud, classes = _read_folder(folder)
    n = len(cloud)
    cls = cloud.attributes.get("classification")
    ground = None if cls is None else np.asarray(cls) == 2
    inst = np.asarray(cloud.attributes["instance"]).astype(np.int32)
    if ground is not None:
        ground &= inst == 0
    labels, unmapped = training_labels(
        np.asarray(cloud.attributes["class_id"]), classes, ground, p.class_map
    )
    xyz = cloud.xyz.astype(np.float32)
    rgb = _colour(cloud)
    intensity = cloud.attributes.get("intensity")
    per_point: dict[str, NDArray[Any]] = {"xyz": xyz, "label": labels, "instance": inst}
    if rgb is not None:
        per_point["rgb"] = rgb
    if intensity is not None:
        per_point["intensity"] = np.asarray(intensity).astype(np.uint16)

    bi, bj = _block_index(cloud.xyz[:, :2], cloud.offset[:2], p.block_m)
    key = (bi - bi.min(initial=0)) * (int(bj.max(initial=0) - bj.min(initial=0)) + 1) + (
        bj - bj.min(initial=0)
    )
    order = np.argsort(key, kind="stable")  # input order kept inside each block
    starts = np.flatnonzero(np.r_[True, np.diff(key[order]) != 0]) if n else np.zeros(0, int)
    ends = np.r_[starts[1:], n]
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    from pyheracles import progress

    for s, e in progress.track(zip(starts, ends, strict=True), "training blocks", len(starts)):
        idx = order[s:e]
        i, j = int(bi[idx[0]]), int(bj[idx[0]])
        name = f"block_{i}_{j}" if p.block_m > 0 else "scene"
        arrays = {k: v[idx] for k, v in per_point.items()}
        lo = cloud.xyz[idx].min(axis=0) + cloud.offset
        hi = cloud.xyz[idx].max(axis=0) + cloud.offset
        if p.format == "ply":
            rel = f"scene/{name}.ply"
            (out / "scene").mkdir(exist_ok=True)
            _write_ply(out / rel, arrays, cloud.offset)
        elif p.format == "npz":
            rel = f"scene/{name}.npz"
            (out / "scene").mkdir(exist_ok=True)
            _write_npz(out / rel, {**arrays, "bounds": np.vstack([lo, hi])}, cloud.offset)
        else:
            rel = f"Area_1/{name}"
            _write_s3dis_block(out / rel, name, arrays, rgb is not None)
        rows.append([name, i, j, *np.round(lo, 3), *np.round(hi, 3), len(idx), rel])

    n_objects = 0
    if p.per_object and p.format != "s3dis":
        n_objects = _write_objects(out / "objects", per_point, cloud.offset, p.format)
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["block", "i", "j", "xmin", "ymin", "zmin", "xmax", "ymax", "zmax", "n_points",
                "path"])  # fmt: skip
    w.writerows(rows)
    atomic_write_text(out / "blocks.csv", buf.getvalue())
    counts = np.bincount(labels, minlength=len(TRAINING_CLASSES))
    class_counts = {TRAINING_CLASSES[k]: int(counts[k]) for k in TRAINING_CLASSES}
    atomic_write_json(out / "classes.json", {
        "classes": [{"id": k, "name": v, "arch": k if k < 10 else None,
                     "n_points": class_counts[v]} for k, v in TRAINING_CLASSES.items()],
        "reference": "ArCH benchmark classes (Matrone et al. 2020); beam (10) added",
        "source_classes": {str(k): v for k, v in classes.items()},
        "mapping": {**CLASS_NAMES, **{_key(k): _key(v) for k, v in p.class_map.items()}},
        "unmapped": unmapped,
        "ground": "floor",
        "format": p.format,
        "block_m": p.block_m,
        "offset": [float(v) for v in cloud.offset],
        "crs": None if cloud.crs is None else cloud.crs.to_wkt(),
        "source": str(folder),
        "n_points": n,
        "n_blocks": len(rows),
    })  # fmt: skip
    return TrainingExport(out, n, len(rows), n_objects, class_counts, unmapped)


def _write_s3dis_block(
    room: Path, name: str, arrays: dict[str, NDArray[Any]], has_rgb: bool
) -> None:
    """One S3DIS room: all points, and one annotation file per object and per leftover class."""
    ann = room / "Annotations"
    ann.mkdir(parents=True, exist_ok=True)
    xyz, lab, inst = arrays["xyz"], arrays["label"], arrays["instance"]
    rgb = arrays["rgb"] if has_rgb else np.zeros((len(xyz), 3), np.uint8)
    _txt(room / f"{name}.txt", xyz, rgb)
    counter: dict[str, int] = {}
    for o in np.unique(inst[inst > 0]):
        m = inst == o
        cname = TRAINING_CLASSES[int(np.bincount(lab[m]).argmax())]
        k = counter.get(cname, 0) + 1
        counter[cname] = k
        _txt(ann / f"{cname}_{k}.txt", xyz[m], rgb[m])
    for c in np.unique(lab[inst == 0]):
        m = (inst == 0) & (lab == c)
        _txt(ann / f"{TRAINING_CLASSES[int(c)]}_0.txt", xyz[m], rgb[m])


def _write_objects(
    folder: Path,
    per_point: dict[str, NDArray[Any]],
    offset: NDArray[np.float64],
    fmt: str,
) -> int:
    """One file per object, named ``<training class>_<instance>``; the number written."""
    inst = per_point["instance"]
    ids = np.unique(inst[inst > 0])
    if len(ids) == 0:
        return 0
    folder.mkdir(parents=True, exist_ok=True)
    order = np.argsort(inst, kind="stable")
    bounds = np.searchsorted(inst[order], np.r_[ids, ids[-1] + 1])
    for k, o in enumerate(ids):
        idx = order[bounds[k] : bounds[k + 1]]
        arrays = {key: v[idx] for key, v in per_point.items()}
        cname = TRAINING_CLASSES[int(np.bincount(arrays["label"]).argmax())]
        path = folder / f"{cname}_{int(o)}.{fmt}"
        (_write_ply if fmt == "ply" else _write_npz)(path, arrays, offset)
    return len(ids)
