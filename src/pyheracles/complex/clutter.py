"""Clutter beside a building: low things standing on the terrain outside its outline.

The buffer ring around a polygon absorbs digitising errors and catches the facade
and the eaves outside the footprint.  It also holds what stands on the terrain beside
the building: parked cars and bicycles, bins, benches, hedges, and the few terrain
points or low outliers the ground filter left out.  Their smooth points lie within the
clustering distance of the facade's foot and join the building's cluster (AHN3 tile 1:
of the 360 points an object took more than 0.25 m beyond its outline and less than 2 m
above the terrain, 35 are building in the reference; complex family draws 0-29: 267 such
points taken, the 95 right ones platforms and the faces of walls digitised off their
axis, the others terrain, low outliers, steps' risers, cars and benches).

Such a group of points is told from the building's own parts beyond the outline by
four things.  It reaches beyond half the buffer: within that it may be the object's own
face where the polygon was digitised off it.  It is low: its top stands under a
person's head over the terrain, where a canopy or an annex roof one walks under stands
higher.  It stands well under the object beside it, which is taller than clutter: an
eave stands at the roof's height, and beside a garden wall a bin cannot be told from
the wall's face.  It is no platform: the platforms, plinths and steps of a building are
the ground points step 1 released in its footprint (see
:func:`pyheracles.complex.levels.raised_ground`).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from pyheracles.segment.euclidean import euclidean_clusters

__all__ = [
    "CLUTTER_BELOW_M",
    "TERRAIN_NEIGHBOURS",
    "clutter_points",
    "terrain_under",
    "under_terrain",
]

#: Least depth of a clutter group's top under the object's surface beside it, metres: a
#: low wall's or a shed's face digitised off its axis reaches its top, an eave its roof.
CLUTTER_BELOW_M = 1.0
#: Ground points nearest in XY whose median height is the terrain under a point.
TERRAIN_NEIGHBOURS = 8
#: Object points inside the polygon nearest in XY whose highest is its surface beside
#: a group's point (as :data:`pyheracles.complex.clusters.TOP_NEIGHBOURS`).
SURFACE_NEIGHBOURS = 4


def terrain_under(
    ground_xyz: NDArray[np.float64], xy: NDArray[np.float64], tree: object | None = None
) -> NDArray[np.float64]:
    """Height of the terrain under each of ``xy``: the median of the nearest ground points.

    Parameters
    ----------
    ground_xyz
        (G, 3) ground points, metres.
    xy
        (N, 2) positions, metres.
    tree
        A ``scipy.spatial.cKDTree`` of ``ground_xyz[:, :2]`` (built when ``None``).

    Returns
    -------
    numpy.ndarray
        (N,) heights, metres; NaN everywhere when there is no ground.
    """
    if len(ground_xyz) == 0:
        return np.full(len(xy), np.nan)
    from scipy.spatial import cKDTree

    t = tree if tree is not None else cKDTree(ground_xyz[:, :2])
    k = min(TERRAIN_NEIGHBOURS, len(ground_xyz))
    _, idx = t.query(xy, k=k)  # type: ignore[attr-defined]
    idx = np.asarray(idx).reshape(len(xy), k)
    return np.median(ground_xyz[idx, 2], axis=1)


def clutter_points(
    xyz: NDArray[np.float64],
    ring: NDArray[np.bool_],
    far: NDArray[np.bool_],
    inside: NDArray[np.bool_],
    terrain: Callable[[NDArray[np.float64]], NDArray[np.float64]],
    platform: NDArray[np.bool_],
    link_m: float,
    low_m: float,
) -> NDArray[np.bool_]:
    """Mask over an object's points of the low clutter standing beside it.

    The object's points in ``ring`` (outside its polygon beyond the digitising
    tolerance) are grouped by single linkage at ``link_m``.  Heights are taken over the
    terrain under each point (``terrain``), so that a slope does not raise the object
    beside a group.  A group is clutter when

    * it reaches ``far`` from the polygon (beyond half the buffer): a group within that
      may be the object's own face where its polygon was digitised off it (complex
      held-out draw 41: the faces of walls 0.25-0.31 m out), as
      :func:`pyheracles.complex.clusters.select_clusters` keeps the clusters lying
      mostly there however small;
    * its top stands less than ``low_m`` over the terrain;
    * the object's surface beside it (for each of its points, the highest of the
      :data:`SURFACE_NEIGHBOURS` points ``inside`` the polygon nearest in XY) stands
      at least ``low_m`` over the terrain and at least :data:`CLUTTER_BELOW_M` over the
      group's top: beside an object no taller than clutter (a garden wall) a low group
      cannot be told from the object's own face (complex draw 26: the faces of walls
      1.9 m high on a slope, digitised off their axis);
    * none of its points is a ``platform`` point (ground released as a building's
      platform, plinth or steps).

    Parameters
    ----------
    xyz
        (N, 3) the object's points, metres.
    ring, far, inside, platform
        (N,) masks: beyond the tolerance outside the polygon, beyond half the buffer,
        inside the polygon, released ground.
    terrain
        Height of the terrain under (M, 2) positions, metres (NaN: unknown, never
        clutter), e.g. :func:`terrain_under` over the ground points.
    link_m
        Largest gap inside a group, metres (the clustering distance).
    low_m
        Height over the terrain under which a group's top is low, metres.

    Returns
    -------
    numpy.ndarray
        Boolean mask over ``xyz``.
    """
    out = np.zeros(len(xyz), dtype=bool)
    at = np.flatnonzero(ring)
    if not far[at].any() or not inside.any():
        return out
    from scipy.spatial import cKDTree

    labels = euclidean_clusters(xyz[at], link_m, 1)
    n = int(labels.max()) + 1
    cand = np.zeros(n, dtype=bool)
    cand[labels[far[at]]] = True  # the group reaches beyond half the buffer
    cand[labels[platform[at]]] = False
    if not cand.any():
        return out
    use = cand[labels]
    pts = at[use]
    height = xyz[pts, 2] - terrain(xyz[pts, :2])
    over = np.full(n, -np.inf)  # the group's highest point over the terrain under it
    np.maximum.at(over, labels[use], np.where(np.isfinite(height), height, np.inf))
    cand &= over < low_m
    if not cand.any():
        return out
    use = cand[labels]
    pts = at[use]
    inner = xyz[inside]
    k = min(SURFACE_NEIGHBOURS, len(inner))
    _, idx = cKDTree(inner[:, :2]).query(xyz[pts, :2], k=k)
    idx = np.asarray(idx).reshape(-1, k)
    top = idx[np.arange(len(idx)), np.argmax(inner[idx, 2], axis=1)]  # highest beside
    top, back = np.unique(top, return_inverse=True)
    beside = (inner[top, 2] - terrain(inner[top, :2]))[back.ravel()]
    surface = np.full(n, -np.inf)  # the object beside the group over the terrain there
    np.maximum.at(surface, labels[use], np.where(np.isfinite(beside), beside, -np.inf))
    low = cand & (surface >= low_m) & (over < surface - CLUTTER_BELOW_M)
    out[at] = low[labels]
    return out


def under_terrain(
    xyz: NDArray[np.float64],
    ground_z: NDArray[np.float64],
    terrain: Callable[[NDArray[np.float64]], NDArray[np.float64]],
    depth_m: float,
) -> NDArray[np.bool_]:
    """Mask over an object's points of those standing more than ``depth_m`` under the
    terrain under them: low outliers (multipath returns), never a feature's.

    The ground filter leaves them out of the ground, and a building's cluster takes them
    where they lie within the clustering distance of its facade's foot or its plinth
    (complex family draws 0-29: 347 object points more than 0.5 m under the terrain, none
    of them the feature's; AHN3 tile 1 has none).  Only the points under the highest of
    ``ground_z`` (the ground points near the object) less ``depth_m`` are looked at.

    Parameters
    ----------
    xyz
        (N, 3) the object's points, metres.
    ground_z
        Heights of the ground points near the object, metres.
    terrain
        Height of the terrain under (M, 2) positions, metres (NaN: unknown).
    depth_m
        Depth under the terrain beyond which a point is a low outlier, metres.

    Returns
    -------
    numpy.ndarray
        Boolean mask over ``xyz``.
    """
    out = np.zeros(len(xyz), dtype=bool)
    if len(ground_z) == 0:
        return out
    at = np.flatnonzero(xyz[:, 2] < float(np.max(ground_z)) - depth_m)
    if len(at):
        out[at] = xyz[at, 2] < terrain(xyz[at, :2]) - depth_m  # NaN: False
    return out
