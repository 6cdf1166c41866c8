"""Overlapping footprints: a point inside two polygons goes to the roof surface it continues.

Cadastral outlines of neighbouring buildings overlap where they were digitised apart
(BGT or OSM polygons shifted by the drawing error, an annex drawn over the main
building).  The returns in such a strip are one building's or the other's, and which
one is told by the surface they lie on: two gabled roofs meeting in a valley slope down
to it from either side, and a point of the strip lies on the extension of the face of
its own roof, not on the other's (complex family draw 29: five points of B06's roof
slope, 6.2-6.7 m high, went to B05, whose eave beside them stood at 6.0-6.4 m but whose
face, extended over the strip, ran 0.5-1 m under them).  Chains of points, which
:func:`pyheracles.complex.cookie.overlaps_by_continuity` follows, reach the nearer
eave first on a sparse survey; the faces decide instead wherever one of them clearly
carries the point.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = ["FaceParams", "face_choice", "face_residuals"]


@dataclass(frozen=True)
class FaceParams:
    """How a contested point is matched with the roof faces of the polygons claiming it.

    Attributes
    ----------
    neighbours
        Points of a polygon's own (those inside it alone) nearest in XY to the contested
        point from which its faces are drawn (every three of them make a candidate face).
    reach
        Farthest of them, in clustering distances (XY).
    tolerance_m
        Largest vertical distance of a point from a face it lies on, metres (as
        :attr:`pyheracles.complex.ComplexParams.eave_tolerance_m`).
    least
        Least number of the neighbours on a face (three make it): a face carried by
        a fourth point is a roof's, not three points across a ridge.
    leverage
        Least height of a face's triangle (XY, over its longest side) as a share of the
        distance from the contested point to its farthest corner: a face from three
        points nearly in a line (an eave) says nothing of the heights off that line.
    margin_m
        Least amount by which the other polygons' faces must miss the point more than
        the chosen one's, metres (twice the tolerance: clearly off them).
    """

    neighbours: int = 6
    reach: float = 2.0
    tolerance_m: float = 0.15
    least: int = 4
    leverage: float = 0.25
    margin_m: float = 0.3

    def __post_init__(self) -> None:
        if self.neighbours < 3 or self.least < 3:
            raise ValueError("neighbours and least must be at least 3")
        for name in ("reach", "tolerance_m", "leverage", "margin_m"):
            if not getattr(self, name) >= 0:
                raise ValueError(f"{name} must be >= 0")


def face_residuals(
    at: NDArray[np.float64],
    near: NDArray[np.float64],
    params: FaceParams,
) -> NDArray[np.float64]:
    """Vertical distance from each point to the nearest face of the points beside it.

    Parameters
    ----------
    at
        (n, 3) points, metres.
    near
        (n, m, 3) points beside each (one polygon's own), NaN rows where fewer are near.
    params
        Tolerance, least support and leverage of a face.

    Returns
    -------
    numpy.ndarray
        (n,) the smallest ``|z - face(x, y)|`` over the faces through three of
        ``near`` that carry at least ``min(params.least, count)`` of them within
        ``params.tolerance_m`` and are not drawn from points nearly in a line (see
        :class:`FaceParams`); ``inf`` where there is none.

    Examples
    --------
    >>> roof = np.array([[[1.0, 0, 5.5], [1.0, 1, 5.5], [2.0, 0, 6.0], [2.0, 1, 6.0]]])
    >>> face_residuals(np.array([[0.0, 0.5, 5.0]]), roof, FaceParams()).round(6)
    array([0.])
    """
    n, m = near.shape[:2]
    out = np.full(n, np.inf)
    if n == 0 or m < 3:
        return out
    tri = np.array(list(itertools.combinations(range(m), 3)))
    rel = near - np.concatenate([at[:, :2], np.zeros((n, 1))], axis=1)[:, None, :]
    corners = rel[:, tri]  # (n, T, 3, 3): the triangles, XY relative to the point
    a_mat = np.concatenate([np.ones(corners.shape[:3] + (1,)), corners[..., :2]], axis=3)
    finite = np.isfinite(corners).all(axis=(2, 3))
    a_mat = np.where(finite[..., None, None], a_mat, np.eye(3))
    det = np.linalg.det(a_mat)  # twice the triangle's XY area
    edges = np.roll(corners[..., :2], -1, axis=2) - corners[..., :2]
    longest = np.hypot(edges[..., 0], edges[..., 1]).max(axis=2)
    farthest = np.hypot(corners[..., 0], corners[..., 1]).max(axis=2)
    ok = finite & (np.abs(det) > 1e-9)
    ok &= np.abs(det) >= params.leverage * farthest * np.maximum(longest, 1e-12)
    z = np.where(finite[..., None], corners[..., 2], 0.0)
    coef = np.zeros(ok.shape + (3,))
    coef[ok] = np.linalg.solve(a_mat[ok], z[ok][..., None])[..., 0]
    # the face's height at the other neighbours, and at the point (its intercept)
    fit = coef[..., :1] + np.einsum("ntj,nmj->ntm", coef[..., 1:], np.nan_to_num(rel[..., :2]))
    on = np.abs(rel[:, None, :, 2] - fit) <= params.tolerance_m  # NaN rows: False
    count = np.isfinite(near[..., 2]).sum(axis=1)
    ok &= on.sum(axis=2) >= np.minimum(params.least, count)[:, None]
    miss = np.where(ok, np.abs(at[:, 2:3] - coef[..., 0]), np.inf)
    return miss.min(axis=1)


def face_choice(
    xyz: NDArray[np.float64],
    pts: NDArray[np.int64],
    poly: NDArray[np.int64],
    seeds: NDArray[np.int64],
    seed_poly: NDArray[np.int64],
    link_m: float,
    params: FaceParams | None = None,
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """The polygon whose roof face each contested point lies on, where one clearly does.

    Parameters
    ----------
    xyz
        (N, 3) points, metres.
    pts, poly
        The claims to decide: point index and polygon position, one row per claim
        (each point claimed by at least two polygons containing it).
    seeds, seed_poly
        The polygons' own points (inside one polygon alone) and their polygon.
    link_m
        The clustering distance, metres (the reach of the faces is
        ``params.reach`` of it).
    params
        See :class:`FaceParams`.

    Returns
    -------
    tuple of numpy.ndarray
        The contested points (unique) and the polygon chosen for each, -1 where no
        face carries the point within ``tolerance_m``, another polygon has no face
        beside it, or another polygon's comes within ``margin_m`` of it.
    """
    from scipy.spatial import cKDTree

    p = params or FaceParams()
    points, row = np.unique(pts, return_inverse=True)
    miss = np.full(len(pts), np.inf)
    for k in np.unique(poly):
        mine = seeds[seed_poly == k]
        rows = np.flatnonzero(poly == k)
        if len(mine) < 3:
            continue
        m = min(p.neighbours, len(mine))
        _, idx = cKDTree(xyz[mine, :2]).query(
            xyz[pts[rows], :2], k=m, distance_upper_bound=p.reach * link_m
        )
        idx = np.asarray(idx).reshape(len(rows), m)
        near = np.concatenate([xyz[mine], np.full((1, 3), np.nan)])[idx]
        miss[rows] = face_residuals(xyz[pts[rows]], near, p)
    # per point: the best face and the next polygon's
    order = np.lexsort((miss, row))
    r, s = row[order], miss[order]
    first = np.ones(len(r), dtype=bool)
    first[1:] = r[1:] != r[:-1]
    best = np.full(len(points), np.inf)
    best[r[first]] = s[first]
    second = np.full(len(points), np.inf)
    nxt = np.flatnonzero(first) + 1
    nxt = nxt[(nxt < len(r))]
    nxt = nxt[r[nxt] == r[nxt - 1]]
    second[r[nxt]] = s[nxt]
    # a face of every other polygon near it, and all of them clearly miss it: a polygon
    # with no face there (a ridge, a crown, a platform among its points) says nothing
    clear = (best <= p.tolerance_m) & np.isfinite(second) & (second > best + p.margin_m)
    heads = np.flatnonzero(first)
    chosen = np.full(len(points), -1, dtype=np.int64)
    chosen[r[heads]] = np.where(clear[r[heads]], poly[order][heads], -1)
    return points, chosen
