"""Joins: wall ends moved to the intersection of the planes meeting there (``meshSnap``)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from pyheracles.walls.model import Array, WallParams
from pyheracles.walls.planes import intersect_planes

__all__ = ["join_walls", "snap_outline"]


def join_walls(walls: list[dict[str, Any]], p: WallParams) -> None:
    """Move wall ends to the least-squares intersection of the planes meeting there."""
    if p.snap_m <= 0:
        return
    ends = []  # (wall, side, xy)
    for k, w in enumerate(walls):
        for side, u in ((0, w["u_range"][0]), (1, w["u_range"][1])):
            ends.append((k, side, (w["origin"] + u * w["u_axis"])[:2]))
    for k, side, xy in ends:
        w = walls[k]
        partners = []
        for m, v in enumerate(walls):
            if m == k or abs(float(v["normal"][:2] @ w["normal"][:2])) > math.cos(math.radians(30)):
                continue
            corner = intersect_planes([w["normal"], v["normal"]], [w["d"], v["d"]])[:2]
            uv = float((np.r_[corner, 0.0] - v["origin"]) @ v["u_axis"])
            near_v = v["u_range"][0] - p.snap_m <= uv <= v["u_range"][1] + p.snap_m
            if np.hypot(*(corner - xy)) <= p.snap_m + 0.5 * w["thick"] and near_v:
                partners.append(m)
        if not partners:
            continue
        planes = [walls[m] for m in [k, *partners]]
        corner = intersect_planes([q["normal"] for q in planes], [q["d"] for q in planes])
        uc = float((np.r_[corner[:2], 0.0] - w["origin"]) @ w["u_axis"])
        w["ends"][side] = uc
        w["joined"].extend(f"instance {m + 1}" for m in partners)


def snap_outline(outline: Array, old: tuple[float, float], new: list[float], tol: float) -> Array:
    """Vertices within ``tol`` of an old end move to the new end (``meshSnap``)."""
    out = outline.copy()
    for o, n in zip(old, new, strict=True):
        close = np.abs(out[:, 0] - o) <= tol
        out[close, 0] = n
    return out
