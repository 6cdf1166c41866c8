"""Result of a segmentation: per-point labels aligned with the input plus an objects table.

DESIGN.md rule 1 (labels, not copies) and rule 2 (nothing is lost): row i of
every array is point i of the input; a point is in exactly one object, the
ground, or the remainder.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from pyheracles.errors import HeraclesError

__all__ = ["Segmentation"]


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
            ids = np.unique(self.instance[self.instance != 0])
            table_ids = np.sort(self.objects["instance"].to_numpy())
            if not np.array_equal(ids, table_ids):
                raise HeraclesError(
                    "labels inconsistent: object ids on points differ from the objects table"
                )
            counts = np.bincount(self.instance, minlength=int(table_ids.max()) + 1)
            if not np.array_equal(
                counts[self.objects["instance"].to_numpy()], self.objects["n_points"].to_numpy()
            ):
                raise HeraclesError("labels inconsistent: n_points in the objects table is wrong")
        elif np.any(self.instance != 0):
            raise HeraclesError("labels inconsistent: points carry object ids but no objects")
        return c
