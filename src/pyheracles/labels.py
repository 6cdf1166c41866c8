"""Result of a segmentation: per-point labels aligned with the input plus an objects table.

DESIGN.md rule 1 (labels, not copies) and rule 2 (nothing is lost): row i of
every array is point i of the input; a point is in exactly one object, the
ground, or the remainder.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from pyheracles.errors import HeraclesError

__all__ = [
    "ASPRS_CLASSES",
    "ASPRS_GROUND",
    "ASPRS_UNCLASSIFIED",
    "Segmentation",
    "asprs_class",
    "asprs_classification",
    "merge_rows",
]

ASPRS_UNCLASSIFIED = 1
"""ASPRS class of points in no object (the remainder)."""
ASPRS_GROUND = 2
"""ASPRS class of ground points."""

#: ASPRS LAS 1.4 class code written for each class name (README "Output files").
#: Standard codes where the ASPRS table has one (6 building, 9 water, 11 road
#: surface, 17 bridge deck); codes 64-255 are "user definable" in LAS 1.4 R15 and
#: hold the heritage classes the standard lacks (walls and fences, gates, and the
#: structural elements of step 2).  Names are matched case-blind, singular or plural.
ASPRS_CLASSES: Mapping[str, int] = {
    "building": 6, "house": 6, "pand": 6, "pavilion": 6, "body": 6, "attic": 6, "roof": 6,
    "water": 9, "road": 11, "bridge": 17,
    "wall": 64, "fence": 64, "enclosure": 64, "scheiding": 64,
    "gate": 65, "gateway": 65,
    "column": 66, "pier": 67, "engaged_column": 68, "beam": 69,
}  # fmt: skip


def asprs_class(name: str) -> int:
    """ASPRS class code of a class name (:data:`ASPRS_CLASSES`; 1 = unclassified if unknown).

    >>> asprs_class("building"), asprs_class("Walls"), asprs_class("gate"), asprs_class("kiosk")
    (6, 64, 65, 1)
    """
    key = str(name).strip().lower().replace(" ", "_").replace("-", "_")
    if key in ASPRS_CLASSES:
        return ASPRS_CLASSES[key]
    if key.endswith("s") and key[:-1] in ASPRS_CLASSES:
        return ASPRS_CLASSES[key[:-1]]
    return ASPRS_UNCLASSIFIED


@dataclass(frozen=True, eq=False)
class Segmentation:
    """Per-point labels and the table of objects they refer to.

    Parameters
    ----------
    instance
        ``(N,)`` int32 object id per point, 0 = not in an object.
    class_id
        ``(N,)`` uint8 class code per point, 0 = none.
    classes
        Class code -> class name (``{1: "building", 2: "wall"}``).
    objects
        One row per object with at least ``instance``, ``class``, ``n_points``;
        may be a GeoDataFrame with footprints.
    ground
        ``(N,)`` bool, True for ground points (never in an object), or ``None``
        when the step does not extract ground.
    """

    instance: NDArray[np.int32]
    class_id: NDArray[np.uint8]
    classes: Mapping[int, str]
    objects: pd.DataFrame
    ground: NDArray[np.bool_] | None = None
    warnings: tuple[str, ...] = field(default_factory=tuple)

    def __post_init__(self) -> None:
        object.__setattr__(self, "instance", np.asarray(self.instance, dtype=np.int32))
        object.__setattr__(self, "class_id", np.asarray(self.class_id, dtype=np.uint8))
        if self.ground is not None:
            object.__setattr__(self, "ground", np.asarray(self.ground, dtype=bool))

    def __len__(self) -> int:
        return len(self.instance)

    def remainder_mask(self) -> NDArray[np.bool_]:
        """Points neither in an object nor ground."""
        rest = self.instance == 0
        if self.ground is not None:
            rest &= ~self.ground
        return rest

    def counts(self) -> dict[str, int]:
        """Point counts: ``objects``, ``ground``, ``remainder``, ``total``, ``n_objects``."""
        in_obj = int(np.count_nonzero(self.instance))
        ground = 0 if self.ground is None else int(np.count_nonzero(self.ground))
        return {
            "total": len(self),
            "objects": in_obj,
            "ground": ground,
            "remainder": int(np.count_nonzero(self.remainder_mask())),
            "n_objects": len(self.objects),
        }

    def check_balance(self) -> dict[str, int]:
        """Raise unless objects + ground + remainder = total and labels agree with the table.

        Returns the counts so callers can log them.
        """
        c = self.counts()
        if self.ground is not None and np.any(self.ground & (self.instance != 0)):
            raise HeraclesError("conservation broken: some ground points are also in objects")
        if c["objects"] + c["ground"] + c["remainder"] != c["total"]:
            raise HeraclesError(f"conservation broken: {c}")
        if np.any((self.instance != 0) != (self.class_id != 0)):
            raise HeraclesError(
                "labels inconsistent: instance and class_id disagree on some points"
            )
        if len(self.objects):
            ids, counts = ids_and_counts(self.instance)
            table_ids = np.sort(self.objects["instance"].to_numpy())
            if not np.array_equal(ids, table_ids):
                raise HeraclesError(
                    "labels inconsistent: object ids on points differ from the objects table"
                )
            if counts is None:  # negative ids (on points and in the table): bincount says so
                counts = np.bincount(self.instance, minlength=int(table_ids.max()) + 1)
            if not np.array_equal(
                counts[self.objects["instance"].to_numpy()], self.objects["n_points"].to_numpy()
            ):
                raise HeraclesError("labels inconsistent: n_points in the objects table is wrong")
        elif np.any(self.instance != 0):
            raise HeraclesError("labels inconsistent: points carry object ids but no objects")
        return c


def ids_and_counts(
    instance: NDArray[np.integer],
) -> tuple[NDArray[np.integer], NDArray[np.intp] | None]:
    """Object ids on points (sorted, without 0) and the number of points of each id
    (indexed by id; None when an id is negative).

    One ``bincount`` of the labels gives both: the ``unique`` of every labelled point
    it replaces sorted them (every point of a building cloud is labelled: 10 M ints
    sorted when writing the supports of the issue's 10 M point cloud).
    """
    if len(instance) and instance.min() < 0:
        return np.unique(instance[instance != 0]), None
    counts = np.bincount(instance)
    return np.flatnonzero(counts[1:]) + 1, counts


def asprs_classification(seg: Segmentation) -> NDArray[np.uint8]:
    """Per-point ASPRS class: 2 ground, the object's class code (:func:`asprs_class`), 1 else."""
    codes = np.full(256, ASPRS_UNCLASSIFIED, dtype=np.uint8)
    for code, name in seg.classes.items():
        codes[int(code)] = asprs_class(name)
    codes[0] = ASPRS_UNCLASSIFIED
    out = codes[seg.class_id]
    if seg.ground is not None:
        out[seg.ground] = ASPRS_GROUND
    return out


def merge_rows(
    rows: Sequence[Mapping[str, Any]], sources: Iterable[pd.DataFrame], rename: Any = None
) -> pd.DataFrame:
    """A table from row dicts, each column with the dtype it has in the source tables.

    Rows built from several layers hold each layer's attributes; where a layer
    lacks a column the row has no value, and ``pd.DataFrame(rows)`` turns such
    an integer column into float (``503100000000035.0``, and digits lost above
    2^53) and a boolean one into object.  Here a column that is integer
    (boolean) in every source holding it keeps that type exactly, as pandas'
    nullable ``Int64``-style (``boolean``) dtype when values are missing, which
    GeoPackage writes as an integer (boolean) field.  ``rename(name)`` maps a
    source column name to its name in the rows (``None``: the same name).
    """
    rows = list(rows)
    frame = pd.DataFrame(rows)
    kinds: dict[str, set[Any]] = {}
    for table in sources:
        geometry = getattr(table, "_geometry_column_name", None)
        for col in table.columns:
            if col != geometry:
                target = rename(col) if rename is not None else col
                kinds.setdefault(str(target), set()).add(table[col].dtype)
    for col, dtypes in kinds.items():
        if col not in frame.columns or len(dtypes) != 1:
            continue
        dtype = next(iter(dtypes))
        if not (pd.api.types.is_bool_dtype(dtype) or pd.api.types.is_integer_dtype(dtype)):
            continue
        values = [row.get(col) for row in rows]
        present = [v for v in values if not _is_missing(v)]
        if len(present) == len(values):
            frame[col] = np.asarray(values).astype(dtype)
            continue
        if pd.api.types.is_bool_dtype(dtype):
            nullable = "boolean"
        else:  # int32 -> Int32, uint16 -> UInt16
            name = np.dtype(dtype).name if isinstance(dtype, np.dtype) else str(dtype)
            nullable = name.capitalize().replace("Uint", "UInt")
        frame[col] = pd.array([None if _is_missing(v) else v for v in values], dtype=nullable)
    return frame


def _is_missing(value: Any) -> bool:
    return value is None or value is pd.NA or (isinstance(value, float) and np.isnan(value))
