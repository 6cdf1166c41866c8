"""Pier candidates that are arcs of a column found beside them (issue 12: one column
found twice, ``ring_split``).

A large ring breaks into arcs in a thin section; a flat arc of it, 0.6 m long and a few
centimetres deep, is a pier island there.  When another section finds the column (the
low one, from another arc), the pier's points lie on that column's surface: they are
the column's, not a second support.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from pyheracles.supports.core import Array
from pyheracles.supports.piers import rect_coords

__all__ = ["ARC_ON_SURFACE_SHARE", "arc_owner", "arc_wall_piers", "surface_offsets"]

#: A pier candidate is an arc of a column when at least this share of its points lie
#: on the column's surface.
ARC_ON_SURFACE_SHARE = 0.8


def surface_offsets(pts: Array, row: dict, centre_z: float) -> Array:
    """Distances of points from a column's surface (metres, > 0 outside).

    ``row``: the column's objects-table row (``x``, ``y``: its axis at height
    ``centre_z``; ``axis_x/y/z``; ``radius_bottom_m`` / ``radius_top_m`` at ``z_min`` /
    ``z_max``, or ``radius_m``).
    """
    axis = np.array([row["axis_x"], row["axis_y"], row["axis_z"]], dtype=np.float64)
    if not np.all(np.isfinite(axis)) or axis[2] <= 0:
        axis = np.array([0.0, 0.0, 1.0])
    axis = axis / np.linalg.norm(axis)
    t = (pts[:, 2] - centre_z) / axis[2]
    centre = np.array([row["x"], row["y"]]) + np.outer(t, axis[:2])
    d = np.hypot(*(pts[:, :2] - centre).T)
    r0, r1 = float(row.get("radius_bottom_m", np.nan)), float(row.get("radius_top_m", np.nan))
    if np.isfinite(r0) and np.isfinite(r1) and row["z_max"] > row["z_min"]:
        f = np.clip((pts[:, 2] - row["z_min"]) / (row["z_max"] - row["z_min"]), 0.0, 1.0)
        r = r0 + (r1 - r0) * f
    else:
        r = float(row["radius_m"])
    return d - r


def arc_owner(pier_pts: Array, columns: list[tuple[dict, Array]], tol: float) -> int | None:
    """Index into ``columns`` of the column whose surface holds a pier candidate's
    points, or None.

    ``columns``: (objects-table row, points) of each column.  The candidate is an arc of
    a column when :data:`ARC_ON_SURFACE_SHARE` of its points lie within ``max(2 tol, 2
    cm)`` of that column's surface and within its height; the column's axis point is
    taken at the mean height of its own points.
    """
    if not len(pier_pts):
        return None
    near = max(2.0 * tol, 0.02)
    for j, (row, pts) in enumerate(columns):
        reach = float(row["radius_m"]) + near
        c = np.array([row["x"], row["y"]])
        lo, hi = pier_pts[:, :2].min(axis=0), pier_pts[:, :2].max(axis=0)
        if np.any(lo > c + reach + 1.0) or np.any(hi < c - reach - 1.0):
            continue  # far off (a leaning column moves less than a metre)
        inside = (pier_pts[:, 2] >= row["z_min"] - near) & (pier_pts[:, 2] <= row["z_max"] + near)
        off = surface_offsets(pier_pts, row, float(np.mean(pts[:, 2])))
        on: NDArray[np.bool_] = inside & (np.abs(off) <= near)
        if np.count_nonzero(on) >= ARC_ON_SURFACE_SHARE * len(pier_pts):
            return j
    return None


#: A pier shape is an arc of an engaged column's ring with a stretch of the wall it
#: stands in when at least ``ARC_WALL_RING_SHARE`` of the section points in its
#: rectangle lie on that ring and ``ARC_WALL_SHARE`` on the ring or the column's wall
#: face (supports draw 38: an island of an engaged column's arc and 1 m of its wall,
#: 28-54 % on the ring and the rest on the face over noise draws, became a pier holding
#: a third of the column, the column itself found in the low section: ``ring_split``).
#: The ring's share only ties the piece to the column: all of it is the column's
#: surface or its wall's.
ARC_WALL_RING_SHARE = 0.1
ARC_WALL_SHARE = 0.9
#: Section points a pier shape needs for the test.
ARC_WALL_MIN_POINTS = 8


def arc_wall_piers(xy: Array, shapes: list[dict], tol: float) -> set[int]:
    """Indices of the pier shapes of one section that are an arc of an engaged column's
    ring with a stretch of the wall it stands in.

    Parameters
    ----------
    xy
        ``(N, 2)`` plan points of the section the pier shapes were found in.
    shapes
        Section shapes (``class``, ``centre``, ``half``, ``angle``; engaged columns also
        ``radius``, ``normal``, ``d``, ``face_gap``: their wall face ``n . x = d``), of
        any section: the pier shapes tested are those given, the engaged ones may come
        from another section (a column's ring and its wall's face hold at every height).
    tol
        Surface tolerance, metres.

    Returns
    -------
    set of int
        A pier shape is in it when its rectangle (grown by ``tol``) holds at least
        ``ARC_WALL_MIN_POINTS`` points of ``xy``, ``ARC_WALL_RING_SHARE`` of them within
        ``max(2 tol, 0.1 r)`` of an engaged column's circle and ``ARC_WALL_SHARE`` of
        them on that circle or within ``max(tol, face_gap)`` of its face.
    """
    engaged = [e for e in shapes if e["class"] == "engaged_column" and "normal" in e]
    out: set[int] = set()
    if not engaged:
        return out
    for k, sh in enumerate(shapes):
        if sh["class"] != "pier":
            continue
        c = np.asarray(sh["centre"], dtype=np.float64)
        half = np.asarray(sh["half"], dtype=np.float64)
        inside = np.all(np.abs(rect_coords(xy, c, sh["angle"])) <= half + tol, axis=1)
        pts = xy[inside]
        if len(pts) < ARC_WALL_MIN_POINTS:
            continue
        for e in engaged:
            ce, r = np.asarray(e["centre"], dtype=np.float64), float(e["radius"])
            if float(np.hypot(*(c - ce))) > r + float(np.hypot(*half)) + tol:
                continue
            ring = np.abs(np.hypot(*(pts - ce).T) - r) <= max(2.0 * tol, 0.1 * r)
            face = np.abs(pts @ np.asarray(e["normal"]) - float(e["d"])) <= max(tol, e["face_gap"])
            if ring.mean() >= ARC_WALL_RING_SHARE and (ring | face).mean() >= ARC_WALL_SHARE:
                out.add(k)
                break
    return out
