"""Walls with glazed openings for the ``church`` family: outlines, reveals, panes, cames.

A wall is a straight slab between an outer and an inner face (plan segments
``p0 -> p1`` on the outer face, the inner face ``thickness_m`` to its left).
Its openings are windows (a glass pane recessed in the reveals, optionally
leaded: small quarries held by metal cames), doors (a timber leaf, or open)
and arches (arcades, chancel arch: no glass).  Every opening outline lies in
the wall's ``(u, z)`` plane: ``u`` metres along the wall from ``p0``, ``z``
the height.

Frames: a point of a wall is ``O + u U + z Z + depth N`` with ``O = (p0, 0)``,
``U`` the unit direction ``p0 -> p1``, ``Z`` up and ``N`` the horizontal
normal pointing *into* the wall from its outer face (depth 0 = outer face,
depth ``thickness_m`` = inner face).

The true window geometry (what registration through the panes should find)
is recorded per light: its outline on the pane mid-plane in 3D, the pane
plane, the glass thickness, the sharp corners (where the outline turns) and
the corners of the outline's bounding rectangle in the wall plane.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import shapely
from numpy.typing import NDArray
from shapely.geometry import LineString, MultiPolygon, Polygon
from shapely.ops import unary_union

from pyheracles.synthetic.scene import GLASS, METAL, STONE, TIMBER, Material, Scene

__all__ = ["SHAPES", "Opening", "Wall", "add_wall", "opening_outline"]

Array = NDArray[np.float64]

#: Window and door head shapes.
SHAPES = ("rect", "round", "pointed")


def opening_outline(
    shape: str, width_m: float, spring_m: float, radius_m: float, n_arc: int = 24
) -> Array:
    """Outline ``(K, 2)`` of an opening in ``(u, v)``: u centred, v from the sill, CCW.

    Parameters
    ----------
    shape
        ``"rect"`` (head at ``spring_m``), ``"round"`` (semicircle of radius
        ``width_m / 2`` springing at ``spring_m``) or ``"pointed"`` (two arcs of
        radius ``radius_m >= width_m / 2`` centred on the springing line).
    width_m, spring_m, radius_m
        Width, springing height above the sill, arc radius (pointed only).
    n_arc
        Segments per arc (pointed: per half arch).

    Notes
    -----
    The vertex count depends on ``shape`` and ``n_arc`` only, so an outline
    offset by ``s`` (``width + 2 s``, ``spring + s``, ``radius + s``, shifted down
    by ``s``) has corresponding vertices: a splayed reveal joins them by quads.
    The first edge is the sill (doors and arches have none).
    """
    h = width_m / 2
    base = [(-h, 0.0), (h, 0.0)]
    if shape == "rect":
        return np.array([*base, (h, spring_m), (-h, spring_m)])
    if shape == "round":
        a = np.linspace(0.0, np.pi, 2 * n_arc + 1)
        arc = np.column_stack([h * np.cos(a), spring_m + h * np.sin(a)])
        return np.vstack([base, arc])
    if shape == "pointed":
        r = max(radius_m, h)
        top = np.sqrt(max(r**2 - (r - h) ** 2, 0.0))
        # right arc: centre (h - r, spring), from angle 0 to the apex
        a_end = np.arctan2(top, r - h)
        a = np.linspace(0.0, a_end, n_arc + 1)
        right = np.column_stack([h - r + r * np.cos(a), spring_m + r * np.sin(a)])
        left = right[-2::-1] * np.array([-1.0, 1.0])
        return np.vstack([base, right, left])
    raise ValueError(f"unknown opening shape {shape!r}; choose one of {', '.join(SHAPES)}")


def sharp_corner_index(shape: str, n_vertices: int) -> list[int]:
    """Indices of the outline vertices where it turns (not tangent-continuous)."""
    if shape == "rect":
        return [0, 1, 2, 3]
    if shape == "round":
        return [0, 1]
    return [0, 1, 2 + (n_vertices - 2) // 2]  # sill corners and the apex


@dataclass(frozen=True)
class Opening:
    """One opening of a wall (a window light, a door or an arch).

    Attributes
    ----------
    kind
        ``"window"``, ``"door"`` or ``"arch"``.
    shape
        One of :data:`SHAPES`.
    u_m, sill_m
        Centre along the wall (outer face, from ``p0``) and height of the sill.
    width_m, spring_m, radius_m
        Outline (see :func:`opening_outline`).
    pane_depth_m
        Depth of the pane mid-plane (windows) or of the leaf (doors) from the
        outer face.
    pane_thickness_m
        Glass thickness (windows) or leaf thickness (doors).
    splay_m
        How much wider the opening is on the inner face (each side, windows).
    leaded, came_pattern, came_spacing_m, came_width_m, came_proud_m
        Leaded glazing: quarries held by metal cames on a ``"grid"`` or
        ``"diamond"`` pattern; the cames stand ``came_proud_m`` out of the glass.
    is_open
        A door without its leaf.
    instance
        Reference of the window light or door (0 for arches).
    """

    kind: str
    shape: str
    u_m: float
    sill_m: float
    width_m: float
    spring_m: float
    radius_m: float = 0.0
    pane_depth_m: float = 0.0
    pane_thickness_m: float = 0.0
    splay_m: float = 0.0
    leaded: bool = False
    came_pattern: str = "grid"
    came_spacing_m: float = 0.15
    came_width_m: float = 0.01
    came_proud_m: float = 0.004
    is_open: bool = False
    instance: int = 0

    def outline(self, offset_m: float = 0.0) -> Array:
        """Outline ``(K, 2)`` in the wall's ``(u, z)``, grown by ``offset_m`` all round."""
        s = offset_m
        ring = opening_outline(
            self.shape, self.width_m + 2 * s, self.spring_m + s, self.radius_m + s
        )
        return ring + np.array([self.u_m, self.sill_m - s])

    @property
    def top_m(self) -> float:
        """Highest point of the outline."""
        return float(self.outline()[:, 1].max())


@dataclass(frozen=True)
class Wall:
    """A straight wall slab (see module docstring for its frame).

    Attributes
    ----------
    name
        Name recorded in ``scene.json``.
    p0, p1
        Plan ends of the outer face; the inside is to the left of ``p0 -> p1``.
    thickness_m
        Wall thickness.
    inner_u
        ``(u_start, u_end)`` of the inner face (shorter at convex corners).
    z_bottom_m
        Bottom of the outer face (below the lowest ground).
    outer_top
        Top edge of the outer face: ``(u, z)`` points from ``u = length`` back to
        ``u = 0`` (eaves line, gable, lean-to).
    inner_bottom_m, inner_top_m
        Floor and ceiling heights of the inner face.
    openings
        Windows, doors and arches.
    instance
        Reference of the wall.
    outer_material, inner_material
        Materials of the two faces (stone outside, plaster inside).
    """

    name: str
    p0: tuple[float, float]
    p1: tuple[float, float]
    thickness_m: float
    inner_u: tuple[float, float]
    z_bottom_m: float
    outer_top: tuple[tuple[float, float], ...]
    inner_bottom_m: float
    inner_top_m: float
    openings: tuple[Opening, ...] = ()
    instance: int = 0
    outer_material: Material = STONE
    inner_material: Material = STONE

    @property
    def length_m(self) -> float:
        """Length of the outer face."""
        return float(np.hypot(self.p1[0] - self.p0[0], self.p1[1] - self.p0[1]))

    def frame(self) -> tuple[Array, Array]:
        """Origin ``O`` and rows ``(U, Z, N)`` of the wall frame."""
        p0, p1 = np.asarray(self.p0, float), np.asarray(self.p1, float)
        u = (p1 - p0) / np.linalg.norm(p1 - p0)
        U = np.array([u[0], u[1], 0.0])
        N = np.array([-u[1], u[0], 0.0])
        return np.array([p0[0], p0[1], 0.0]), np.vstack([U, [0.0, 0.0, 1.0], N])

    def to_3d(self, uz: Array, depth: float | Array) -> Array:
        """Wall-plane points ``(K, 2)`` at ``depth`` (from the outer face) in 3D."""
        O, R = self.frame()
        uz = np.asarray(uz, float).reshape(-1, 2)
        d = np.broadcast_to(np.asarray(depth, float), (len(uz),))
        return O + uz[:, :1] * R[0] + uz[:, 1:] * R[1] + d[:, None] * R[2]


def _ring_quads(a: Array, b: Array, skip_first: bool) -> Array:
    """Triangles joining two corresponding closed rings ``(K, 3)`` (reveal surfaces)."""
    a1, b1 = np.roll(a, -1, axis=0), np.roll(b, -1, axis=0)
    tris = np.concatenate([np.stack([a, a1, b1], 1), np.stack([a, b1, b], 1)])
    if skip_first:
        k = len(a)
        keep = np.ones(2 * k, bool)
        keep[[0, k]] = False
        tris = tris[keep]
    return tris


def _polygons(geom: Any) -> list[Polygon]:
    """The non-empty polygons of a shapely geometry."""
    if geom.is_empty:
        return []
    if isinstance(geom, Polygon):
        return [geom]
    if isinstance(geom, MultiPolygon):
        return [g for g in geom.geoms if not g.is_empty]
    return [g for g in getattr(geom, "geoms", []) if isinstance(g, Polygon) and not g.is_empty]


def _came_segments(op: Opening, pane: Polygon) -> Array:
    """Centre lines ``(S, 2, 2)`` of the cames of a leaded light, clipped to its pane."""
    minx, miny, maxx, maxy = pane.bounds
    s = op.came_spacing_m
    lines = []
    if op.came_pattern == "diamond":
        # lozenges: two families of lines at +-60 deg from the horizontal
        span = (maxx - minx) + (maxy - miny)
        dx = s / np.sin(np.deg2rad(60.0))
        k_max = int(np.ceil(span / dx)) + 1
        t = np.array([-span, span])
        for sign in (1.0, -1.0):
            for k in range(-k_max, k_max + 1):
                x0 = op.u_m + k * dx
                xy = np.column_stack([x0 + sign * t * 0.5, miny + t * np.sin(np.deg2rad(60.0))])
                lines.append(LineString(xy))
    else:
        n_u = max(round((maxx - minx) / s), 1)
        n_v = max(round((maxy - miny) / s), 1)
        for x in np.linspace(minx, maxx, n_u + 1)[1:-1]:
            lines.append(LineString([(x, miny - 1), (x, maxy + 1)]))
        for y in np.linspace(miny, maxy, n_v + 1)[1:-1]:
            lines.append(LineString([(minx - 1, y), (maxx + 1, y)]))
    segs = []
    for piece in shapely.intersection(np.array(lines, dtype=object), pane):  # tens of lines
        for g in getattr(piece, "geoms", [piece]):
            if isinstance(g, LineString) and g.length > 1e-3:
                c = np.asarray(g.coords)
                segs.extend(np.stack([c[:-1], c[1:]], axis=1))
    return np.asarray(segs, float).reshape(-1, 2, 2)


def _came_triangles(wall: Wall, op: Opening, segs: Array) -> Array:
    """Flat strips standing ``came_proud_m`` out of both glass faces along ``segs``."""
    if len(segs) == 0:
        return np.empty((0, 3, 3))
    a, b = segs[:, 0], segs[:, 1]
    d = b - a
    d /= np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-12)
    side = np.column_stack([-d[:, 1], d[:, 0]]) * (op.came_width_m / 2)
    half, proud = op.pane_thickness_m / 2, op.came_proud_m
    tris = []
    for face, out in ((op.pane_depth_m - half, -proud), (op.pane_depth_m + half, proud)):
        q = [a - side, b - side, b + side, a + side]  # strip corners in (u, z)
        top = [wall.to_3d(c, face + out) for c in q]
        base = [wall.to_3d(c, face) for c in q]
        tris += [np.stack([top[0], top[1], top[2]], 1), np.stack([top[0], top[2], top[3]], 1)]
        for i, j in ((0, 1), (2, 3)):  # the two long sides of the strip
            tris += [
                np.stack([base[i], base[j], top[j]], 1),
                np.stack([base[i], top[j], top[i]], 1),
            ]
    return np.concatenate(tris)


def _add_polygon(
    scene: Scene,
    geom: Any,
    wall: Wall,
    depth: float,
    thickness: float,
    *,
    sides: bool,
    **ref: Any,
) -> None:
    O, R = wall.frame()
    origin = O + depth * R[2]
    for poly in _polygons(geom):
        poly = shapely.make_valid(poly)
        for p in _polygons(poly):
            if p.area < 1e-8:
                continue
            faces = "both" if thickness > 0 else "front"
            scene.add_prism(p, origin, R, thickness, faces=faces, sides=sides, **ref)


def _window_object(wall: Wall, op: Opening) -> dict[str, Any]:
    """True geometry of one window light: mid-plane outline, plane, thickness, corners."""
    ring = op.outline()
    mid = wall.to_3d(ring, op.pane_depth_m)
    _, R = wall.frame()
    normal_out = -R[2]
    cz = Polygon(ring).centroid
    centre = wall.to_3d(np.array([[cz.x, cz.y]]), op.pane_depth_m)[0]
    sharp = sharp_corner_index(op.shape, len(ring))
    lo, hi = ring.min(axis=0), ring.max(axis=0)
    box = np.array([[lo[0], lo[1]], [hi[0], lo[1]], [hi[0], hi[1]], [lo[0], hi[1]]])
    return {
        "instance": op.instance,
        "class": "window",
        "wall": wall.name,
        "shape": op.shape,
        "leaded": op.leaded,
        "came_pattern": op.came_pattern if op.leaded else None,
        "came_spacing_m": op.came_spacing_m if op.leaded else None,
        "came_width_m": op.came_width_m if op.leaded else None,
        "width_m": op.width_m,
        "height_m": float(hi[1] - lo[1]),
        "sill_z_m": op.sill_m,
        "thickness_m": op.pane_thickness_m,
        "depth_from_outer_face_m": op.pane_depth_m,
        "outer_reveal_depth_m": op.pane_depth_m - op.pane_thickness_m / 2,
        "inner_reveal_depth_m": wall.thickness_m - op.pane_depth_m - op.pane_thickness_m / 2,
        "splay_m": op.splay_m,
        "plane": {
            "normal": normal_out.tolist(),
            "point": centre.tolist(),
            "d": float(normal_out @ centre),
            "what": "pane mid-plane; normal points outwards",
        },
        "outline_m": mid.tolist(),
        "sharp_corners_m": mid[sharp].tolist(),
        "box_corners_m": wall.to_3d(box, op.pane_depth_m).tolist(),
    }


def add_wall(scene: Scene, wall: Wall) -> list[dict[str, Any]]:
    """Add a wall with its openings to ``scene``; returns the window and door objects.

    Surfaces: outer and inner faces (minus the openings), reveals (straight
    outside, splayed inside), the glass of each window light (a slab of its
    thickness, GLASS) with its cames (METAL), door leaves (TIMBER).
    """
    t = wall.thickness_m
    L = wall.length_m
    ref_wall = {"instance": wall.instance, "class_name": "wall"}
    outer = Polygon([(0.0, wall.z_bottom_m), (L, wall.z_bottom_m), *wall.outer_top])
    u0, u1 = wall.inner_u
    inner = Polygon(
        [
            (u0, wall.inner_bottom_m),
            (u1, wall.inner_bottom_m),
            (u1, wall.inner_top_m),
            (u0, wall.inner_top_m),
        ]
    )
    holes_out = [Polygon(op.outline()) for op in wall.openings]
    holes_in = [
        Polygon(op.outline(op.splay_m if op.kind == "window" else 0.0)) for op in wall.openings
    ]
    if holes_out:
        outer = outer.difference(unary_union(holes_out))
        inner = inner.difference(unary_union(holes_in))
    _add_polygon(
        scene,
        outer,
        wall,
        0.0,
        0.0,
        sides=False,
        part="outer_face",
        material=wall.outer_material,
        **ref_wall,
    )
    _add_polygon(
        scene,
        inner,
        wall,
        t,
        0.0,
        sides=False,
        part="inner_face",
        material=wall.inner_material,
        **ref_wall,
    )
    objects: list[dict[str, Any]] = []
    for op in wall.openings:  # a few to a few tens per wall
        ring = op.outline()
        sill = op.kind != "window"  # doors and arches: the floor is their threshold
        if op.kind == "window":
            dp = op.pane_depth_m
            a = wall.to_3d(ring, 0.0)
            m = wall.to_3d(ring, dp)
            b = wall.to_3d(op.outline(op.splay_m), t)
            scene.add_triangles(
                _ring_quads(a, m, False), part="reveal", material=wall.outer_material, **ref_wall
            )
            scene.add_triangles(
                _ring_quads(m, b, False), part="reveal", material=wall.inner_material, **ref_wall
            )
            pane = Polygon(ring)
            ref_win = {"instance": op.instance, "class_name": "window"}
            if op.leaded:
                tris = _came_triangles(wall, op, _came_segments(op, pane))
                scene.add_triangles(tris, part="came", material=METAL, **ref_win)
            _add_polygon(
                scene,
                pane,
                wall,
                dp - op.pane_thickness_m / 2,
                op.pane_thickness_m,
                sides=False,
                part="pane",
                material=GLASS,
                **ref_win,
            )
            objects.append(_window_object(wall, op))
        else:
            a = wall.to_3d(ring, 0.0)
            b = wall.to_3d(ring, t)
            scene.add_triangles(
                _ring_quads(a, b, sill), part="reveal", material=wall.outer_material, **ref_wall
            )
            if op.kind == "door":
                if not op.is_open:
                    _add_polygon(
                        scene,
                        Polygon(ring),
                        wall,
                        op.pane_depth_m - op.pane_thickness_m / 2,
                        op.pane_thickness_m,
                        sides=False,
                        part="leaf",
                        material=TIMBER,
                        instance=op.instance,
                        class_name="door",
                    )
                _, R = wall.frame()
                lo, hi = ring.min(axis=0), ring.max(axis=0)
                box = np.array([[lo[0], lo[1]], [hi[0], lo[1]], [hi[0], hi[1]], [lo[0], hi[1]]])
                cz = Polygon(ring).centroid
                objects.append(
                    {
                        "instance": op.instance,
                        "class": "door",
                        "wall": wall.name,
                        "shape": op.shape,
                        "open": op.is_open,
                        "width_m": op.width_m,
                        "height_m": op.top_m - op.sill_m,
                        "leaf_thickness_m": op.pane_thickness_m,
                        "depth_from_outer_face_m": op.pane_depth_m,
                        "outline_m": wall.to_3d(ring, op.pane_depth_m).tolist(),
                        "box_corners_m": wall.to_3d(box, op.pane_depth_m).tolist(),
                        "plane": {
                            "normal": (-R[2]).tolist(),
                            "point": wall.to_3d(np.array([[cz.x, cz.y]]), op.pane_depth_m)[
                                0
                            ].tolist(),
                            "what": "door leaf mid-plane; normal points outwards",
                        },
                    }
                )
    return objects


def wall_object(wall: Wall) -> dict[str, Any]:
    """The reference record of a wall: outer face plane, thickness, openings."""
    O, R = wall.frame()
    n_out = -R[2]
    return {
        "instance": wall.instance,
        "class": "wall",
        "name": wall.name,
        "p0": list(wall.p0),
        "p1": list(wall.p1),
        "thickness_m": wall.thickness_m,
        "outer_plane": {"normal": n_out.tolist(), "d": float(n_out @ O)},
        "openings": {
            k: sum(op.kind == k for op in wall.openings) for k in ("window", "door", "arch")
        },
    }
