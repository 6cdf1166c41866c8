"""Closed building solids from a footprint partitioned by roof planes (LoD1.2, LoD2.2).

The approach of roofer (3DBAG) and 3dfier, written from their papers: the
footprint is cut by the lines where neighbouring roof planes meet (ridges,
hips, valleys) and by the step lines between roof parts at different heights
(a plane arrangement), every cell of the arrangement gets the roof plane most
of its points lie on, cells of the same plane are merged, and the result is
extruded: each roof face is its cell lifted onto its plane, walls stand
vertically on every cell edge from the lower to the higher side (the terrain
on the footprint's boundary), and the footprint at the ground level closes the
solid.

Watertightness comes from construction, not repair: every 2D vertex is shared
by the cells around it (the arrangement is noded on a 1 mm grid), every height
used at a 2D vertex is one *level* of that vertex (heights closer than
``weld_m`` are one level), and every wall's vertical side carries every level
it passes, so each edge of the solid is used by exactly two faces in opposite
directions.  An edge whose two roof planes cross along it is split at the
crossing first, so that no wall is twisted.  Faces are oriented outwards
(counter-clockwise seen from outside).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import shapely
from numpy.typing import NDArray
from shapely.geometry import Polygon
from shapely.geometry.polygon import orient

__all__ = ["Solid", "extrude_partition", "flat_solid", "partition_footprint"]

GRID_M = 0.001
"""The arrangement's grid, metres (CityJSON vertices are quantised to 1 mm too)."""


@dataclass(frozen=True)
class Solid:
    """A closed polyhedral solid in the local frame.

    Attributes
    ----------
    vertices
        ``(M, 3)`` float64 coordinates, metres (local frame).
    faces
        One entry per face: a list of rings (the outer ring first, then holes),
        each a list of vertex indices, counter-clockwise seen from outside.
    semantics
        One of ``RoofSurface``, ``WallSurface``, ``GroundSurface`` per face.
    roof_plane
        Per face the roof plane index it lies on (-1 for walls and ground).
    """

    vertices: NDArray[np.float64]
    faces: list[list[list[int]]]
    semantics: list[str]
    roof_plane: list[int] = field(default_factory=list)

    @property
    def n_faces(self) -> int:
        return len(self.faces)


def _plane_z(plane: NDArray[np.float64], xy: NDArray[np.float64]) -> NDArray[np.float64]:
    """Height of the plane ``z = a x + b y + c`` at ``xy``."""
    return plane[0] * xy[..., 0] + plane[1] * xy[..., 1] + plane[2]


def partition_footprint(
    footprint: Polygon,
    lines: Sequence[shapely.LineString],
) -> list[Polygon]:
    """Cells of the footprint cut by ``lines`` (noded on the 1 mm grid).

    Lines are clipped to the footprint; dangling pieces are dropped by the
    polygonisation.  Returns oriented polygons (outer ring counter-clockwise).
    """
    fp = shapely.set_precision(footprint, GRID_M)
    if fp.is_empty or fp.area <= 0:
        return []
    work = [fp.boundary]
    for line in lines:
        clipped = shapely.intersection(line, fp)
        if not clipped.is_empty:
            work.append(clipped)
    noded = shapely.union_all(work, grid_size=GRID_M)
    cells = shapely.get_parts(shapely.polygonize(shapely.get_parts(noded)))
    inside = [c for c in cells if c.area > GRID_M**2 and fp.contains(c.representative_point())]
    return [orient(c, 1.0) for c in inside]


class _Vertices2D:
    """2D vertices on the mm grid, one id per position."""

    def __init__(self) -> None:
        self.ids: dict[tuple[int, int], int] = {}
        self.xy: list[tuple[float, float]] = []

    def key(self, x: float, y: float) -> tuple[int, int]:
        return (round(x / GRID_M), round(y / GRID_M))

    def get(self, x: float, y: float) -> int:
        k = self.key(x, y)
        i = self.ids.get(k)
        if i is None:
            i = len(self.xy)
            self.ids[k] = i
            self.xy.append((k[0] * GRID_M, k[1] * GRID_M))
        return i

    def ring(self, coords: NDArray[np.float64]) -> list[int]:
        out = [self.get(float(x), float(y)) for x, y in coords[:-1, :2]]
        return [v for i, v in enumerate(out) if v != out[i - 1]] if len(out) > 1 else out


def _chain(edges: dict[int, list[int]]) -> list[list[int]] | None:
    """Rings from directed edges ``u -> [v]``; None when a vertex has two ways out."""
    if any(len(v) != 1 for v in edges.values()):
        return None
    nxt = {u: v[0] for u, v in edges.items()}
    rings = []
    seen: set[int] = set()
    for start in sorted(nxt):
        if start in seen:
            continue
        ring = [start]
        seen.add(start)
        u = nxt[start]
        while u != start:
            if u in seen or u not in nxt:
                return None
            ring.append(u)
            seen.add(u)
            u = nxt[u]
        rings.append(ring)
    return rings


def _signed_area(xy: NDArray[np.float64], ring: list[int]) -> float:
    p = xy[ring]
    return 0.5 * float(np.sum(p[:, 0] * np.roll(p[:, 1], -1) - np.roll(p[:, 0], -1) * p[:, 1]))


def _faces_from_rings(xy: NDArray[np.float64], rings: list[list[int]]) -> list[list[list[int]]]:
    """Group rings into faces: counter-clockwise rings are outer, clockwise ones holes."""
    outers = [r for r in rings if _signed_area(xy, r) > 0]
    holes = [r for r in rings if _signed_area(xy, r) <= 0]
    faces: list[list[list[int]]] = [[r] for r in outers]
    polys = [Polygon(xy[r]) for r in outers]
    for h in holes:
        probe = Polygon(xy[h]).representative_point()
        best = None
        for i, poly in enumerate(polys):
            if poly.contains(probe):
                if best is None or poly.area < polys[best].area:
                    best = i
        if best is None:
            return []
        faces[best].append(h)
    return faces


def _merge_cells(
    xy: NDArray[np.float64], cells: list[list[list[int]]], labels: list[int]
) -> tuple[list[list[list[int]]], list[int]]:
    """Merge the cells of each label into faces (kept apart where the merge pinches)."""
    owner: dict[tuple[int, int], int] = {}
    for ci, rings in enumerate(cells):
        for r in rings:
            for i, u in enumerate(r):
                owner[(u, r[(i + 1) % len(r)])] = ci
    faces: list[list[list[int]]] = []
    face_labels: list[int] = []
    for lab in sorted(set(labels)):
        members = [ci for ci, lb in enumerate(labels) if lb == lab]
        edges: dict[int, list[int]] = {}
        for ci in members:
            for r in cells[ci]:
                for i, u in enumerate(r):
                    v = r[(i + 1) % len(r)]
                    twin = owner.get((v, u))
                    if twin is not None and labels[twin] == lab:
                        continue
                    edges.setdefault(u, []).append(v)
        rings = _chain(edges)
        merged = _faces_from_rings(xy, rings) if rings else []
        if not merged:
            merged = [cells[ci] for ci in members]
        faces.extend(merged)
        face_labels.extend([lab] * len(merged))
    return faces, face_labels


def _split_crossings(
    verts: _Vertices2D,
    faces: list[list[list[int]]],
    labels: list[int],
    planes: NDArray[np.float64],
    weld_m: float,
) -> None:
    """Split every edge along which the two roof planes on its sides cross (in place)."""
    for _ in range(4):  # a split can expose no new crossing; bounded for safety
        where: dict[tuple[int, int], tuple[int, int]] = {}
        for fi, rings in enumerate(faces):
            for ri, r in enumerate(rings):
                for i, u in enumerate(r):
                    where[(u, r[(i + 1) % len(r)])] = (fi, ri)
        todo = []
        for (u, v), (fa, _) in where.items():
            tw = where.get((v, u))
            if tw is None or u > v or labels[tw[0]] == labels[fa]:
                continue
            pu, pv = np.asarray(verts.xy[u]), np.asarray(verts.xy[v])
            pa, pb = planes[labels[fa]], planes[labels[tw[0]]]
            du = float(_plane_z(pa, pu) - _plane_z(pb, pu))
            dv = float(_plane_z(pa, pv) - _plane_z(pb, pv))
            if du * dv < 0 and abs(du) > weld_m and abs(dv) > weld_m:
                t = du / (du - dv)
                p = pu + t * (pv - pu)
                w = verts.get(float(p[0]), float(p[1]))
                if w not in (u, v):
                    todo.append((u, v, w))
        if not todo:
            return
        for u, v, w in todo:
            for a, b in ((u, v), (v, u)):
                fi, ri = where[(a, b)]
                r = faces[fi][ri]
                for i, x in enumerate(r):
                    if x == a and r[(i + 1) % len(r)] == b:
                        r.insert(i + 1, w)
                        break


def extrude_partition(
    cells: Sequence[Polygon],
    cell_plane: Sequence[int],
    planes: NDArray[np.float64],
    ground_z: float,
    *,
    weld_m: float = 0.002,
    merge: bool = True,
) -> Solid:
    """The closed solid of a partitioned footprint.

    Parameters
    ----------
    cells
        The cells of the footprint (:func:`partition_footprint`), noded together.
    cell_plane
        Per cell the index of its roof plane in ``planes``.
    planes
        ``(P, 3)`` roof planes as ``z = a x + b y + c`` (local frame, metres).
    ground_z
        Height of the ground face, metres.
    weld_m
        Heights at one 2D vertex closer than this are one vertex, metres.
    merge
        Merge the cells of one plane into one face.
    """
    planes = np.asarray(planes, dtype=np.float64).reshape(-1, 3)
    verts = _Vertices2D()
    cell_rings: list[list[list[int]]] = []
    for c in cells:
        rings = [verts.ring(np.asarray(c.exterior.coords))]
        rings += [verts.ring(np.asarray(h.coords)) for h in c.interiors]
        cell_rings.append([r for r in rings if len(r) >= 3])
    labels = [int(x) for x in cell_plane]
    xy = np.asarray(verts.xy, dtype=np.float64)
    if merge:
        faces2d, labels = _merge_cells(xy, cell_rings, labels)
    else:
        faces2d = [[list(r) for r in rings] for rings in cell_rings]
    faces2d = [[list(r) for r in f] for f in faces2d]
    _split_crossings(verts, faces2d, labels, planes, weld_m)
    xy = np.asarray(verts.xy, dtype=np.float64)

    # half-edges and the labels around every 2D vertex
    owner: dict[tuple[int, int], int] = {}
    around: dict[int, set[int]] = {}
    for fi, rings in enumerate(faces2d):
        for r in rings:
            for i, u in enumerate(r):
                owner[(u, r[(i + 1) % len(r)])] = fi
                around.setdefault(u, set()).add(labels[fi])
    boundary = [(u, v) for (u, v) in owner if (v, u) not in owner]
    on_boundary = {u for u, _ in boundary}

    # levels: welded heights (in grid units) per 2D vertex
    g = round(ground_z / GRID_M)
    weld = max(1, round(weld_m / GRID_M))
    level_of: dict[tuple[int, int], int] = {}  # (vertex, label or -1) -> level
    levels: dict[int, list[int]] = {}
    for u, labs in around.items():
        raw = [(-1, g)] if u in on_boundary else []
        raw += [(lab, round(float(_plane_z(planes[lab], xy[u])) / GRID_M)) for lab in labs]
        raw.sort(key=lambda t: t[1])
        reps: list[int] = []
        for lab, z in raw:
            if not reps or z - reps[-1] > weld:
                reps.append(z)
            level_of[(u, lab)] = reps[-1]
        levels[u] = reps

    index: dict[tuple[int, int], int] = {}
    out_xyz: list[tuple[float, float, float]] = []

    def vid(u: int, z: int) -> int:
        k = (u, z)
        i = index.get(k)
        if i is None:
            i = len(out_xyz)
            index[k] = i
            out_xyz.append((xy[u, 0], xy[u, 1], z * GRID_M))
        return i

    faces: list[list[list[int]]] = []
    semantics: list[str] = []
    roof_plane: list[int] = []
    for fi, rings in enumerate(faces2d):
        lab = labels[fi]
        faces.append([[vid(u, level_of[(u, lab)]) for u in r] for r in rings])
        semantics.append("RoofSurface")
        roof_plane.append(lab)

    def wall(u: int, v: int, bu: int, bv: int, tu: int, tv: int) -> None:
        ring = [(u, bu), (v, bv)]
        ring += [(v, z) for z in levels[v] if bv < z < tv]
        ring += [(v, tv), (u, tu)]
        ring += [(u, z) for z in reversed(levels[u]) if bu < z < tu]
        ids = [vid(a, z) for a, z in ring]
        ids = [x for i, x in enumerate(ids) if x != ids[i - 1]]
        if len(set(ids)) >= 3:
            faces.append([ids])
            semantics.append("WallSurface")
            roof_plane.append(-1)

    for (u, v), fi in owner.items():
        lab = labels[fi]
        tu, tv = level_of[(u, lab)], level_of[(v, lab)]
        twin = owner.get((v, u))
        if twin is None:
            wall(u, v, level_of[(u, -1)], level_of[(v, -1)], tu, tv)
            continue
        other = labels[twin]
        bu, bv = level_of[(u, other)], level_of[(v, other)]
        if tu >= bu and tv >= bv and (tu > bu or tv > bv):
            wall(u, v, bu, bv, tu, tv)

    rings = _chain({v: [u] for u, v in boundary} if boundary else {}) or []
    # seen from below (x mirrored) the reversed boundary is counter-clockwise
    for face in _faces_from_rings(xy * np.array([-1.0, 1.0]), rings):
        faces.append([[vid(u, level_of[(u, -1)]) for u in r] for r in face])
        semantics.append("GroundSurface")
        roof_plane.append(-1)
    return Solid(np.asarray(out_xyz, dtype=np.float64).reshape(-1, 3), faces, semantics, roof_plane)


def flat_solid(footprint: Polygon, ground_z: float, roof_z: float) -> Solid:
    """The footprint extruded from ``ground_z`` to ``roof_z`` (a LoD1.2 block), metres."""
    cells = partition_footprint(footprint, [])
    return extrude_partition(
        cells, [0] * len(cells), np.array([[0.0, 0.0, roof_z]]), ground_z, merge=False
    )
