"""Validity of polyhedral solids, as val3dity checks it (the parts that matter here).

The official validator (val3dity, and its Python binding ``cjvalpy``) has no
wheel for every Python; this module checks what it checks for a LoD1/LoD2
building shell (Ledoux 2018, "On the validation of solids represented with the
international standards for geographic information", error codes in
brackets):

* every ring has at least 3 distinct vertices, indices in range (101, 104);
* every face is planar within ``planarity_m`` (203) and simple in its plane (201);
* the shell is closed: every edge is used by exactly two faces, once in each
  direction (301 not closed, 302 non-manifold edge, 307 wrongly oriented);
* the faces point outwards: the signed volume is positive (307, 308);
* no two faces intersect other than along shared edges and vertices (306),
  tested edge against triangle (Moeller-Trumbore) between faces that do not
  share the vertex.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence

import numpy as np
import shapely
from numpy.typing import ArrayLike, NDArray

__all__ = ["signed_volume", "validate_solid"]


class _Rings:
    """The rings of a shell flattened: vertex, ring and face per corner, vectorised."""

    def __init__(self, faces: list[list[list[int]]]) -> None:
        flat = [(fi, r) for fi, rings in enumerate(faces) for r in rings]
        self.n_faces = len(faces)
        self.vid = np.array([x for _, r in flat for x in r], dtype=np.int64)
        sizes = np.array([len(r) for _, r in flat], dtype=np.int64)
        self.ring = np.repeat(np.arange(len(flat)), sizes)
        self.face = np.repeat(np.array([fi for fi, _ in flat], dtype=np.int64), sizes)
        self.start = np.r_[0, np.cumsum(sizes)[:-1]]
        self.sizes = sizes
        pos = np.arange(len(self.vid)) - self.start[self.ring]
        self.nxt = self.vid[self.start[self.ring] + (pos + 1) % sizes[self.ring]]
        self.is_outer = np.r_[True, self.face[self.start[1:]] != self.face[self.start[1:] - 1]]


def _frames(v: NDArray[np.float64], rg: _Rings) -> tuple[NDArray[np.float64], ...]:
    """Per face: centroid, unit normal (Newell), two in-plane axes, and the normal's norm."""
    p, q = v[rg.vid], v[rg.nxt]
    terms = np.column_stack(
        [
            (p[:, 1] - q[:, 1]) * (p[:, 2] + q[:, 2]),
            (p[:, 2] - q[:, 2]) * (p[:, 0] + q[:, 0]),
            (p[:, 0] - q[:, 0]) * (p[:, 1] + q[:, 1]),
        ]
    )
    n = np.zeros((rg.n_faces, 3))
    np.add.at(n, rg.face, terms)
    cnt = np.bincount(rg.face, minlength=rg.n_faces)[:, None]
    c = np.zeros((rg.n_faces, 3))
    np.add.at(c, rg.face, p)
    c /= np.maximum(cnt, 1)
    norm = np.linalg.norm(n, axis=1)
    n = n / np.where(norm > 0, norm, 1.0)[:, None]
    e = np.where((np.abs(n[:, 0]) < 0.9)[:, None], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    u = np.cross(n, e)
    u /= np.maximum(np.linalg.norm(u, axis=1), 1e-300)[:, None]
    return c, n, u, np.cross(n, u), norm


def signed_volume(vertices: ArrayLike, faces: Sequence[Sequence[Sequence[int]]]) -> float:
    """Signed volume of a closed shell, cubic metres (positive when faces point outwards)."""
    v = np.asarray(vertices, dtype=np.float64)
    if not len(v) or not faces:
        return 0.0
    v = v - v.mean(axis=0)
    rg = _Rings([[list(r) for r in f] for f in faces])
    p0 = v[rg.vid[rg.start[rg.ring]]]
    # tetrahedra (origin, ring's first vertex, corner, next corner)
    return float(np.einsum("ij,ij->", p0, np.cross(v[rg.vid], v[rg.nxt]))) / 6.0


def _triangles(
    uv: NDArray[np.float64], rg: _Rings, fi: int, convex: bool
) -> list[tuple[int, int, int]]:
    """Triangles (vertex ids) of face ``fi``: a fan when convex, else constrained Delaunay."""
    sel = np.flatnonzero(rg.face == fi)
    ids = rg.vid[sel]
    if convex:
        return [(int(ids[0]), int(ids[i]), int(ids[i + 1])) for i in range(1, len(ids) - 1)]
    rings = [sel[rg.ring[sel] == r] for r in np.unique(rg.ring[sel])]
    where = {(round(a, 6), round(b, 6)): int(rg.vid[i]) for i in sel for a, b in [uv[i]]}
    poly = shapely.Polygon(uv[rings[0]], [uv[r] for r in rings[1:]])
    out = []
    for t in shapely.get_parts(shapely.constrained_delaunay_triangles(poly)):
        xy = np.asarray(t.exterior.coords)[:3]
        try:
            out.append(tuple(where[(round(a, 6), round(b, 6))] for a, b in xy.tolist()))
        except KeyError:
            continue
    return out


def _crossings(
    v: NDArray[np.float64],
    edges: NDArray[np.int64],
    tris: NDArray[np.int64],
    eps: float,
) -> list[tuple[int, int]]:
    """(edge, triangle) pairs where an edge pierces a triangle's interior."""
    found: list[tuple[int, int]] = []
    a, b, c = v[tris[:, 0]], v[tris[:, 1]], v[tris[:, 2]]
    e1, e2 = b - a, c - a
    for start in range(0, len(edges), 256):
        ed = edges[start : start + 256]
        p0 = v[ed[:, 0]][:, None, :]
        d = (v[ed[:, 1]] - v[ed[:, 0]])[:, None, :]
        h = np.cross(d, e2[None])
        det = np.einsum("ijk,jk->ij", h, e1)
        ok = np.abs(det) > 1e-12
        inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
        s = p0 - a[None]
        u = inv * np.einsum("ijk,ijk->ij", s, h)
        q = np.cross(s, e1[None])
        w = inv * np.einsum("ijk,ijk->ij", d, q)
        t = inv * np.einsum("jk,ijk->ij", e2, q)
        hit = ok & (u > eps) & (w > eps) & (u + w < 1 - eps) & (t > eps) & (t < 1 - eps)
        share = (ed[:, None, 0:1] == tris[None]).any(-1) | (ed[:, None, 1:2] == tris[None]).any(-1)
        for i, j in zip(*np.nonzero(hit & ~share), strict=True):
            found.append((start + int(i), int(j)))
    return found


def validate_solid(
    vertices: ArrayLike,
    faces: Sequence[Sequence[Sequence[int]]],
    *,
    planarity_m: float = 0.01,
    check_intersections: bool = True,
) -> list[str]:
    """Errors of a solid's outer shell; an empty list when it is valid.

    Parameters
    ----------
    vertices
        ``(M, 3)`` coordinates, metres.
    faces
        Per face its rings (outer first, then holes) of vertex indices,
        counter-clockwise seen from outside.
    planarity_m
        Largest distance of a face's vertex from the face's plane, metres
        (val3dity's default: 1 cm).
    check_intersections
        Test faces against each other (the slowest check).

    Returns
    -------
    list of str
        One message per problem, with the val3dity error code (empty: valid).

    Examples
    --------
    >>> cube = [[[0, 3, 2, 1]], [[4, 5, 6, 7]], [[0, 1, 5, 4]], [[1, 2, 6, 5]],
    ...         [[2, 3, 7, 6]], [[3, 0, 4, 7]]]
    >>> v = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]]
    >>> validate_solid(v, cube)
    []
    >>> validate_solid(v, cube[1:])[0][:3]
    '301'
    """
    v = np.asarray(vertices, dtype=np.float64)
    if v.ndim != 2 or v.shape[1] != 3 or not np.isfinite(v).all():
        return ["vertices are not finite (M, 3) coordinates"]
    if not faces:
        return ["301 the solid has no faces"]
    clean = [[[int(x) for x in r] for r in rings] for rings in faces]
    errors: list[str] = []
    for fi, rings in enumerate(clean):
        for r in rings:
            if any(x < 0 or x >= len(v) for x in r):
                return [f"104 face {fi}: vertex index out of range"]
            if len(r) < 3 or len(set(r)) != len(r):
                errors.append(f"101 face {fi}: a ring has fewer than 3 or repeated vertices")
    if errors:
        return errors
    v = v - v.mean(axis=0)
    rg = _Rings(clean)
    count = Counter(zip(rg.vid.tolist(), rg.nxt.tolist(), strict=True))
    for (x, y), k in count.items():
        if k > 1:
            errors.append(f"302 edge {x}-{y} used {k} times in one direction")
        elif (y, x) not in count:
            errors.append(f"301 edge {x}-{y} has no opposite edge (open shell)")
    c, n, u, w, norm = _frames(v, rg)
    dev = np.zeros(rg.n_faces)
    np.maximum.at(dev, rg.face, np.abs(np.einsum("ij,ij->i", v[rg.vid] - c[rg.face], n[rg.face])))
    for fi in np.flatnonzero((dev > planarity_m) | (norm <= 0)):
        errors.append(f"203 face {fi}: not planar ({dev[fi]:.3f} m > {planarity_m} m)")
    rel = v[rg.vid] - c[rg.face]
    uv = np.column_stack([np.einsum("ij,ij->i", rel, u[rg.face]),
                          np.einsum("ij,ij->i", rel, w[rg.face])])  # fmt: skip
    rings = shapely.linearrings(uv, indices=rg.ring)
    outer = rg.is_outer
    single = np.bincount(rg.face[rg.start], minlength=rg.n_faces) == 1
    polys = np.empty(rg.n_faces, dtype=object)
    polys[single] = shapely.polygons(rings[outer][single])
    for fi in np.flatnonzero(~single):
        rs = np.flatnonzero(rg.face[rg.start] == fi)
        polys[fi] = shapely.Polygon(rings[rs[0]], rings[rs[1:]])
    bad = ~shapely.is_valid(polys) | (shapely.area(polys) <= 0)
    for fi in np.flatnonzero(bad):
        errors.append(f"201 face {fi}: the polygon is not simple in its plane")
    if errors:
        return errors
    vol = float(np.einsum("ij,ij->", v[rg.vid[rg.start[rg.ring]]], np.cross(v[rg.vid], v[rg.nxt])))
    if vol <= 0:
        errors.append(f"307 faces point inwards (signed volume {vol / 6:.3f} m3)")
    if check_intersections:
        first = rg.start[rg.ring]
        nxt = first + (np.arange(len(uv)) - first + 1) % rg.sizes[rg.ring]
        d = uv[nxt] - uv
        turn = d[:, 0] * d[nxt, 1] - d[:, 1] * d[nxt, 0]
        neg = np.zeros(rg.n_faces, bool)
        pos = np.zeros(rg.n_faces, bool)
        np.logical_or.at(neg, rg.face, turn < -1e-9)
        np.logical_or.at(pos, rg.face, turn > 1e-9)
        convex = single & ~(neg & pos)
        tris: list[tuple[int, int, int]] = []
        for fi in range(rg.n_faces):
            tris.extend(_triangles(uv, rg, fi, bool(convex[fi])))
        edges = np.array(sorted({(min(a, b), max(a, b)) for a, b in count}), dtype=np.int64)
        if tris and len(edges):
            scale = float(np.ptp(v, axis=0).max()) or 1.0
            hits = _crossings(v, edges, np.array(tris), 1e-9 * scale + 1e-9)
            if hits:
                errors.append(f"306 faces intersect ({len(hits)} edge-face crossings)")
    return errors
