"""Platform tops: the ground points of a released platform that its noise left under the cut.

Step 1 takes a building's platform, plinth and steps off the ground where they stand
above the terrain around its polygon by more than a threshold
(:func:`pyheracles.groundfilters.footprints.raised_in_footprints`: 0.2 m, or three
robust standard deviations of the terrain model's error).  A platform's top is flat, but
its points scatter by the survey's noise (about 5 cm), and on a slope its uphill side
stands lower over the terrain than its middle: the points of a low platform that fall
under the cut stayed ground, a quarter to a half of some platforms (complex family draw
24: 145 of 559 platform points, 129 of them inside the polygons, 0.1 m under the
released points of the same platform on average).

Inside a polygon, where the map says the object stands, such a point is told from the
terrain by its height: it continues the released top beside it, nearer to that top's
level than to the terrain under it (the ground beyond every buffered polygon).  Outside
the polygon, in the digitising tolerance, the strict threshold stays: beside a wall on a
slope, the terrain uphill reaches the height of the wall's top (complex draws 10, 37).
The terrain is a plane through the ground beside a point, not its median: beside a
polygon on a slope that ground lies on one side (complex draw 43, a 20 % slope).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import shapely
from numpy.typing import NDArray

__all__ = [
    "PLATFORM_NEIGHBOURS",
    "PLATFORM_SAMPLE",
    "TERRAIN_CELL_M",
    "TERRAIN_NEIGHBOURS",
    "platform_tops",
    "terrain_plane",
]

#: Released points around a ground point (within the linking distance, XY) needed for
#: their median to be the level of the platform top beside it.  One: on a sparse survey
#: (0.1-0.3 points/m^2) a platform's margin beside its building holds a few points, of
#: which one or two pass the cut, and with two required its edge stayed ground (complex
#: draw 9, B19: 6 platform points, one left as ground 3.7 m from the one released point
#: beside it; draws 0-29: 20 draws gain, none loses an object over F1 0.9).
PLATFORM_NEIGHBOURS = 1
#: Released points at most (the nearest within the linking distance) whose median is the
#: level of the top beside a point.
PLATFORM_SAMPLE = 8
#: Ground points nearest in XY through which the terrain plane under a point is fitted
#: (as many as :data:`pyheracles.complex.clutter.TERRAIN_NEIGHBOURS`).
TERRAIN_NEIGHBOURS = 8
#: Cell of the coarse grid that picks the terrain points near the tested ones, metres.
TERRAIN_CELL_M = 6.0


def platform_tops(
    xyz: NDArray[np.float64],
    ground: NDArray[np.bool_],
    released: NDArray[np.bool_],
    polygons: NDArray[Any],
    buffer_m: float,
    link_m: float,
) -> NDArray[np.bool_]:
    """Ground points inside the polygons that continue a released platform top beside them.

    A ground point inside one of the ``polygons`` with at least
    :data:`PLATFORM_NEIGHBOURS` released points within ``link_m`` of it (XY) is a
    platform's when it stands nearer to the level of the top beside it than to the
    terrain under it: over the terrain by more than half the level's height, which must
    be positive.  The level is the median height of the :data:`PLATFORM_SAMPLE`
    nearest of those released points; the terrain under a point is the plane through
    the :data:`TERRAIN_NEIGHBOURS` ground points nearest it (XY) beyond every polygon
    buffered by ``buffer_m`` (see :func:`terrain_plane`).  The released points are the
    upper tail of the top's noise (the cut took them), so their spread says nothing of
    the band the others lie in; the terrain does.

    Parameters
    ----------
    xyz
        (N, 3) points, metres, the polygons' frame.
    ground
        (N,) the ground mask, the released points already taken off.
    released
        (N,) ground points released as platforms, plinths, steps.
    polygons
        Polygons (shapely) of every layer, the ``xyz`` frame.
    buffer_m
        The release's tolerance about the polygons, metres: the terrain is the ground
        beyond it.
    link_m
        Reach of a released point, metres (step 1's clustering distance).

    Returns
    -------
    numpy.ndarray
        (N,) bool, the ground points to release too (a subset of ``ground``).
    """
    from scipy.spatial import cKDTree

    n = len(xyz)
    out = np.zeros(n, dtype=bool)
    rel = np.flatnonzero(released)
    if len(rel) < PLATFORM_NEIGHBOURS or not ground.any() or len(polygons) == 0:
        return out
    gidx = np.flatnonzero(ground)
    rel_tree = cKDTree(xyz[rel, :2])
    d, _ = rel_tree.query(xyz[gidx, :2], k=PLATFORM_NEIGHBOURS, distance_upper_bound=link_m)
    cand = gidx[np.isfinite(np.asarray(d).reshape(len(gidx), -1)[:, -1])]
    if len(cand) == 0:
        return out
    cand = cand[_within(shapely.STRtree(np.asarray(polygons, dtype=object)), xyz[cand, :2])]
    if len(cand) == 0:
        return out
    # the terrain: ground outside every buffered polygon, in the coarse cells round the
    # candidates
    cell = np.floor(xyz[:, :2] / TERRAIN_CELL_M).astype(np.int64)
    shifts = [(dx, dy) for dx in (-1, 0, 1) for dy in (-1, 0, 1)]
    around_cells = np.unique(np.concatenate([cell[cand] + np.array(s) for s in shifts]), axis=0)
    sup = gidx[_cell_in(cell[gidx], around_cells)]
    near = shapely.STRtree(shapely.buffer(np.asarray(polygons, dtype=object), buffer_m))
    sup = sup[~_within(near, xyz[sup, :2])]
    if len(sup) == 0:
        return out
    k = min(TERRAIN_NEIGHBOURS, len(sup))
    _, idx = cKDTree(xyz[sup, :2]).query(xyz[cand, :2], k=k)
    terrain = terrain_plane(xyz[sup[np.asarray(idx).reshape(len(cand), k)]], xyz[cand, :2])
    # the level of the top beside a point: the median of the released points around it
    # (not their spread: the cut took the upper tail of the top's noise)
    k = PLATFORM_SAMPLE
    _, idx = rel_tree.query(xyz[cand, :2], k=k, distance_upper_bound=link_m)
    zr = np.append(xyz[rel, 2], np.nan)[np.asarray(idx).reshape(len(cand), k)]
    level = np.nanmedian(zr, axis=1)
    height = level - terrain
    out[cand[(height > 0) & (xyz[cand, 2] - terrain > 0.5 * height)]] = True
    return out


def _within(tree: Any, xy: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Mask of the positions ``xy`` inside any polygon of ``tree`` (a shapely STRtree)."""
    hit = np.zeros(len(xy), dtype=bool)
    if len(xy):
        pairs = tree.query(shapely.points(xy[:, 0], xy[:, 1]), predicate="intersects")
        hit[pairs[0]] = True
    return hit


def _cell_in(cells: NDArray[np.int64], chosen: NDArray[np.int64]) -> NDArray[np.bool_]:
    """Mask of the rows of ``cells`` (integer cell pairs) among the rows of ``chosen``."""
    lo = np.minimum(cells.min(axis=0), chosen.min(axis=0))
    span = int(max(cells[:, 1].max(), chosen[:, 1].max()) - lo[1]) + 1
    code = lambda c: (c[:, 0] - lo[0]) * span + (c[:, 1] - lo[1])  # noqa: E731
    return np.isin(code(cells), code(chosen))


def terrain_plane(near: NDArray[np.float64], xy: NDArray[np.float64]) -> NDArray[np.float64]:
    """Height at each of ``xy`` of the plane fitted to its ground points ``near``.

    ``near`` is (M, K, 3): the K ground points nearest each of the M positions ``xy``
    (M, 2).  Beside a polygon these lie on its outer side, downhill or uphill on a
    slope, where their median is off by the slope times their distance; the plane's
    height is clipped to their range (no extrapolation beyond the heights seen), and
    their median stands where the plane is ill-posed (points on a line).
    """
    d = near[:, :, :2] - xy[:, None, :]
    a = np.concatenate([np.ones(d.shape[:2] + (1,)), d], axis=2)  # (M, K, 3)
    ata = np.einsum("mki,mkj->mij", a, a)
    atz = np.einsum("mki,mk->mi", a, near[:, :, 2])
    med = np.median(near[:, :, 2], axis=1)
    if near.shape[1] < 3:
        return med
    det = np.linalg.det(ata)
    scale = np.einsum("mii->m", ata) ** 3
    ok = np.abs(det) > 1e-6 * np.maximum(scale, 1e-12)
    out = med.copy()
    if ok.any():
        sol = np.linalg.solve(ata[ok], atz[ok][:, :, None])[:, 0, 0]
        out[ok] = np.clip(sol, near[ok, :, 2].min(axis=1), near[ok, :, 2].max(axis=1))
    return out
