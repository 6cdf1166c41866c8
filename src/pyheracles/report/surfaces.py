"""Surfaces of the 3D view: walls (``walls.gpkg``, ``openings.gpkg``) and buildings (CityJSON).

Every face is a planar polygon in 3D (possibly with holes: windows in a wall,
courtyards in a roof).  It is triangulated in its own plane by a constrained
Delaunay triangulation (GEOS, through shapely), so holes and concave outlines
are respected, and drawn as translucent triangles with its outline as lines.

Examples
--------
>>> import numpy as np
>>> square = np.array([[0, 0, 0], [2, 0, 0], [2, 0, 1], [0, 0, 1.0]])
>>> tri, edges = face_triangles([square])
>>> tri.shape, edges.shape   # 2 triangles, 4 edges
((6, 3), (8, 3))
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "SurfaceSet",
    "cityjson_surfaces",
    "face_triangles",
    "faces_triangles",
    "polygon_surfaces",
]

Array = NDArray[np.float64]

#: Colours of the CityJSON semantic surfaces in the 3D view.
SEMANTIC_COLOURS = {
    "RoofSurface": "#c0392b",
    "WallSurface": "#d9c7a0",
    "GroundSurface": "#7f8c8d",
}


@dataclass(frozen=True)
class SurfaceSet:
    """Triangles and outline segments of one kind of surface, in local coordinates.

    Attributes
    ----------
    name
        Legend entry (``walls``, ``roofs`` ...).
    colour
        ``#rrggbb``.
    triangles
        ``(3k, 3)`` vertices, three per triangle.
    edges
        ``(2m, 3)`` vertices, two per outline segment.
    """

    name: str
    colour: str
    triangles: Array
    edges: Array


def face_triangles(rings: Sequence[Array]) -> tuple[Array, Array]:
    """Triangulate one planar face: ``rings[0]`` its outline, the others its holes.

    Parameters
    ----------
    rings
        ``(n, 3)`` vertex arrays, world or local coordinates (no closing vertex).

    Returns
    -------
    triangles, edges
        ``(3k, 3)`` triangle vertices and ``(2m, 3)`` outline segment ends; no
        triangles for a degenerate face (no area).
    """
    return faces_triangles([rings])


def faces_triangles(faces: Sequence[Sequence[Array]]) -> tuple[Array, Array]:
    """Triangulate many planar faces at once (see :func:`face_triangles`).

    Each face is projected on its own plane (normal by Newell's method on its
    outline), the 2D polygons are triangulated in one vectorised call of
    GEOS's constrained Delaunay triangulation and lifted back to 3D.
    """
    import shapely

    rings, ring_face = [], []
    for f, face in enumerate(faces):
        for r in face:
            r = np.asarray(r, float)[:, :3]
            if len(r) >= 3:
                rings.append(r)
                ring_face.append(f)
    if not rings:
        return np.empty((0, 3)), np.empty((0, 3))
    ring_face_a = np.asarray(ring_face)
    edges = np.concatenate([np.stack([r, np.roll(r, -1, axis=0)], axis=1) for r in rings])
    edges = edges.reshape(-1, 3)
    nf = len(faces)
    first = np.full(nf, -1)
    for k in range(len(rings) - 1, -1, -1):
        first[ring_face[k]] = k
    has = first >= 0
    # plane of each face: Newell normal and centroid of its outline (vectorised over faces)
    outer = [int(first[f]) for f in np.flatnonzero(has)]
    r = np.concatenate([rings[k] for k in outer])
    sizes = np.array([len(rings[k]) for k in outer])
    starts = np.concatenate([[0], np.cumsum(sizes)[:-1]])
    nxt = np.arange(len(r)) + 1
    nxt[starts + sizes - 1] = starts
    q = r[nxt]
    terms = np.column_stack(
        [
            (r[:, 1] - q[:, 1]) * (r[:, 2] + q[:, 2]),
            (r[:, 2] - q[:, 2]) * (r[:, 0] + q[:, 0]),
            (r[:, 0] - q[:, 0]) * (r[:, 1] + q[:, 1]),
        ]
    )
    normal = np.zeros((nf, 3))
    centre = np.zeros((nf, 3))
    normal[has] = np.add.reduceat(terms, starts, axis=0)
    centre[has] = np.add.reduceat(r, starts, axis=0) / sizes[:, None]
    length = np.linalg.norm(normal, axis=1)
    ok = has & (length > 1e-12)
    if not ok.any():
        return np.empty((0, 3)), edges
    n = normal / np.where(length > 0, length, 1.0)[:, None]
    ref = np.where((np.abs(n[:, 2]) < 0.9)[:, None], [[0.0, 0, 1]], [[1.0, 0, 0]])
    u = np.cross(ref, n)
    u /= np.maximum(np.linalg.norm(u, axis=1), 1e-12)[:, None]
    v = np.cross(n, u)
    keep = [k for k in range(len(rings)) if ok[ring_face[k]]]
    coords = np.concatenate([rings[k] for k in keep])
    vf = np.repeat(ring_face_a[keep], [len(rings[k]) for k in keep])
    d = coords - centre[vf]
    uv = np.column_stack([np.einsum("ij,ij->i", d, u[vf]), np.einsum("ij,ij->i", d, v[vf])])
    lr = shapely.linearrings(
        uv, indices=np.repeat(np.arange(len(keep)), [len(rings[k]) for k in keep])
    )
    faces_ok = np.flatnonzero(ok)
    slot = np.searchsorted(faces_ok, ring_face_a[keep])
    polys = shapely.polygons(lr, indices=slot)
    bad = ~shapely.is_valid(polys)
    if bad.any():
        polys[bad] = shapely.make_valid(polys[bad])
    tris, owner = shapely.get_parts(
        shapely.constrained_delaunay_triangles(polys), return_index=True
    )
    if len(tris) == 0:
        return np.empty((0, 3)), edges
    xy = shapely.get_coordinates(tris).reshape(len(tris), 4, 2)[:, :3]
    f = faces_ok[owner]
    pts = centre[f][:, None] + xy[..., :1] * u[f][:, None] + xy[..., 1:] * v[f][:, None]
    return pts.reshape(-1, 3), edges


def _collect(name: str, colour: str, faces: list[list[Array]]) -> SurfaceSet:
    tri, edges = faces_triangles(faces)
    return SurfaceSet(name, colour, tri, edges)


def polygon_surfaces(gdf: Any, origin: Array, name: str, colour: str) -> SurfaceSet | None:
    """The 3D polygons of a GeoDataFrame (``walls.gpkg`` ...) as a :class:`SurfaceSet`.

    Polygons without z (2D footprints) are skipped: they have no place in 3D.
    """
    import shapely

    if gdf is None or len(gdf) == 0:
        return None
    faces = []
    for geom in shapely.get_parts(np.asarray(gdf.geometry.values)):
        if geom is None or geom.is_empty or geom.geom_type != "Polygon" or not geom.has_z:
            continue
        rings = [np.asarray(geom.exterior.coords)[:-1] - origin]
        rings += [np.asarray(h.coords)[:-1] - origin for h in geom.interiors]
        faces.append(rings)
    return _collect(name, colour, faces) if faces else None


def cityjson_surfaces(doc: Mapping[str, Any], origin: Array) -> list[SurfaceSet]:
    """Roof, wall and ground surfaces of a CityJSON document (the highest LoD per object).

    Reads ``vertices`` with its ``transform``, Solid / MultiSurface /
    CompositeSurface geometries and their ``semantics``; surfaces without
    semantics count as walls.
    """
    verts = np.asarray(doc.get("vertices") or [], float).reshape(-1, 3)
    tr = doc.get("transform") or {}
    if tr:
        verts = verts * np.asarray(tr.get("scale", [1, 1, 1]), float) + np.asarray(
            tr.get("translate", [0, 0, 0]), float
        )
    verts = verts - origin
    faces: dict[str, list[list[Array]]] = {k: [] for k in SEMANTIC_COLOURS}
    for obj in (doc.get("CityObjects") or {}).values():
        geoms = [g for g in obj.get("geometry") or [] if isinstance(g, dict)]
        if not geoms:
            continue
        g = max(geoms, key=lambda x: float(x.get("lod", 0) or 0))
        kind = g.get("type")
        if kind == "Solid":
            shells = g.get("boundaries") or []
            sem_values = ((g.get("semantics") or {}).get("values")) or [None] * len(shells)
        elif kind in ("MultiSurface", "CompositeSurface"):
            shells = [g.get("boundaries") or []]
            sem_values = [((g.get("semantics") or {}).get("values"))]
        else:
            continue
        surfaces = (g.get("semantics") or {}).get("surfaces") or []
        for shell, values in zip(shells, sem_values, strict=False):
            for k, face in enumerate(shell):
                s = values[k] if values is not None and k < len(values) else None
                sem = surfaces[s].get("type") if s is not None and s < len(surfaces) else None
                rings = [verts[np.asarray(r, int)] for r in face if len(r) >= 3]
                faces[sem if sem in faces else "WallSurface"].append(rings)
    names = {"RoofSurface": "roofs", "WallSurface": "walls", "GroundSurface": "ground faces"}
    return [
        _collect(f"{names[k]} (CityJSON)", SEMANTIC_COLOURS[k], v) for k, v in faces.items() if v
    ]
