"""Labelled surface scenes for the scan simulator: triangles with a material and a reference.

A :class:`Scene` is what a scanner looks at: triangles, each carrying the
reference of the object it belongs to (``instance``, ``class_id``, ``part``)
and a :class:`Material` (reflectance; glass lets most of the beam through;
foliage is porous, so one airborne pulse gives several returns).  Scene
families (:mod:`pyheracles.synthetic.families`) build scenes from the shapes
below and record each object's true primitive in :attr:`Scene.objects`.

Curved shapes are tessellated finely enough that the chord error stays far
below scanner noise (a column of radius ``r`` with ``n`` segments deviates by
``r (1 - cos(pi / n))``: 0.3 mm for r = 1.5 m and 160 segments).

Examples
--------
>>> import numpy as np
>>> s = Scene()
>>> s.add_box([0, 0, 0.5], [1, 1, 1], instance=1, class_name="pier", part="shaft")
>>> s.n_triangles
12
>>> s.class_names[s.triangle_class[0]]
'pier'
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import shapely
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "FOLIAGE",
    "GLASS",
    "GROUND",
    "MATERIALS",
    "METAL",
    "PLASTER",
    "STONE",
    "TIMBER",
    "WATER",
    "Material",
    "Scene",
    "frame_from_axis",
]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class Material:
    """How a surface answers a laser beam or a camera.

    Parameters
    ----------
    name
        Name recorded in ``scene.json``.
    reflectance
        Diffuse reflectance at the scanner's wavelength, 0-1; the return's
        intensity and its detection probability grow with it.
    transmittance
        Share of beams that pass through (glass 0.85-0.95): a beam that does
        not pass gives a weak return on the surface, one that passes goes on
        to what lies behind.
    porous
        Foliage: an airborne pulse that hits it records a return and goes on
        (multiple returns); terrestrial scanners record the first hit only.
    matchable
        Whether dense image matching finds points on it (glass: no).
    """

    name: str
    reflectance: float = 0.5
    transmittance: float = 0.0
    porous: bool = False
    matchable: bool = True


STONE = Material("stone", 0.55)
PLASTER = Material("plaster", 0.75)
TIMBER = Material("timber", 0.35)
GROUND = Material("ground", 0.3)
METAL = Material("metal", 0.25)
GLASS = Material("glass", 0.08, transmittance=0.9, matchable=False)
FOLIAGE = Material("foliage", 0.45, porous=True)
WATER = Material("water", 0.005, matchable=False)  # specular: few diffuse echoes
MATERIALS = {m.name: m for m in (STONE, PLASTER, TIMBER, GROUND, METAL, GLASS, FOLIAGE, WATER)}


def frame_from_axis(axis: ArrayLike) -> Array:
    """An orthonormal frame ``(3, 3)`` whose third row is the unit ``axis``.

    The first row is horizontal when the axis is not vertical (so that a
    beam's width is measured across it horizontally).
    """
    w = np.asarray(axis, float)
    w = w / np.linalg.norm(w)
    ref = np.array([0.0, 0.0, 1.0]) if abs(w[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    u = np.cross(ref, w)
    u /= np.linalg.norm(u)
    v = np.cross(w, u)
    return np.vstack([u, v, w])


@dataclass
class Scene:
    """A growing set of labelled triangles (the world a scanner sees).

    Attributes
    ----------
    class_names, part_names
        Codes to names; code 0 is ``"none"`` in both.
    objects
        One dict per object (``instance``, ``class``, true primitive ...),
        written to ``scene.json``.
    """

    class_names: dict[int, str] = field(default_factory=lambda: {0: "none"})
    part_names: dict[int, str] = field(default_factory=lambda: {0: "none"})
    objects: list[dict[str, Any]] = field(default_factory=list)
    _tris: list[Array] = field(default_factory=list, repr=False)
    _labels: list[NDArray[np.int32]] = field(default_factory=list, repr=False)
    _materials: list[Material] = field(default_factory=list, repr=False)

    # --- codes -----------------------------------------------------------
    def class_code(self, name: str) -> int:
        """The code of a class name, registering it on first use."""
        return _code(self.class_names, name)

    def part_code(self, name: str) -> int:
        """The code of a part name, registering it on first use."""
        return _code(self.part_names, name)

    def material_code(self, material: Material) -> int:
        """The index of a material, registering it on first use."""
        if material not in self._materials:
            self._materials.append(material)
        return self._materials.index(material)

    @property
    def materials(self) -> list[Material]:
        """Materials by code."""
        return list(self._materials)

    # --- triangles -------------------------------------------------------
    def add_triangles(
        self,
        triangles: ArrayLike,
        *,
        instance: int = 0,
        class_name: str = "none",
        part: str = "none",
        material: Material = STONE,
    ) -> None:
        """Add ``(T, 3, 3)`` triangles with one reference and one material."""
        tris = np.asarray(triangles, float).reshape(-1, 3, 3)
        if len(tris) == 0:
            return
        if not np.isfinite(tris).all():
            raise ValueError(f"non-finite triangle vertices in part {part!r}")
        lab = np.empty((len(tris), 4), np.int32)
        lab[:] = (
            instance,
            self.class_code(class_name),
            self.part_code(part),
            self.material_code(material),
        )
        self._tris.append(tris)
        self._labels.append(lab)

    def add_mesh(self, vertices: ArrayLike, faces: ArrayLike, **ref: Any) -> None:
        """Add an indexed mesh (``vertices (V, 3)``, ``faces (F, 3)``)."""
        v = np.asarray(vertices, float)
        self.add_triangles(v[np.asarray(faces, int)], **ref)

    def add_quad(self, corners: ArrayLike, **ref: Any) -> None:
        """Add a planar quadrilateral given by its 4 corners in order."""
        c = np.asarray(corners, float)
        self.add_triangles(np.stack([c[[0, 1, 2]], c[[0, 2, 3]]]), **ref)

    def add_box(
        self,
        center: ArrayLike,
        size: ArrayLike,
        *,
        frame: ArrayLike | None = None,
        faces: Sequence[str] = ("-x", "+x", "-y", "+y", "-z", "+z"),
        **ref: Any,
    ) -> None:
        """Add a cuboid: ``size`` along the rows of ``frame`` (identity by default).

        ``faces`` selects the faces to build (a beam resting on a wall has no
        bottom face to see; leaving it out saves triangles).
        """
        R = np.eye(3) if frame is None else np.asarray(frame, float)
        h = np.asarray(size, float) / 2
        c = np.asarray(center, float)
        corner = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
        pts = c + (corner * h) @ R
        quads = {
            "-x": [0, 1, 3, 2],
            "+x": [4, 6, 7, 5],
            "-y": [0, 4, 5, 1],
            "+y": [2, 3, 7, 6],
            "-z": [0, 2, 6, 4],
            "+z": [1, 5, 7, 3],
        }
        for f in faces:
            self.add_quad(pts[quads[f]], **ref)

    def add_cylinder(
        self,
        base: ArrayLike,
        axis: ArrayLike,
        height: float,
        radius: float | Callable[[Array], Array],
        *,
        segments: int = 96,
        rings: int = 1,
        flutes: int = 0,
        flute_depth: float = 0.0,
        caps: tuple[bool, bool] = (False, True),
        **ref: Any,
    ) -> None:
        """Add a column shaft: a (tapered, swelling or fluted) surface of revolution.

        Parameters
        ----------
        base
            Centre of the bottom section, metres.
        axis
            Direction of the axis (need not be vertical: leaning columns).
        height
            Length along the axis, metres.
        radius
            Radius in metres, or a function of the normalised height
            ``t in [0, 1]`` giving it (taper, entasis).
        segments, rings
            Tessellation around and along the axis.
        flutes, flute_depth
            Number of concave flutes (0 = smooth) and their depth, metres.
        caps
            Close the bottom / top with a disc.
        """
        R = frame_from_axis(axis)
        t = np.linspace(0.0, 1.0, rings + 1)
        r = np.broadcast_to(radius(t) if callable(radius) else np.full_like(t, radius), t.shape)
        phi = np.linspace(0.0, 2 * np.pi, segments + 1)[:-1]
        dr = np.zeros_like(phi)
        if flutes > 0 and flute_depth > 0:
            # each flute a circular-ish hollow: depth * sin^2 profile between arrises
            dr = -flute_depth * np.sin(phi * flutes / 2) ** 2
        rr = r[:, None] + dr[None, :]
        local = np.stack(
            [rr * np.cos(phi), rr * np.sin(phi), np.broadcast_to(t[:, None] * height, rr.shape)],
            axis=-1,
        )
        pts = np.asarray(base, float) + local @ R
        j = np.arange(segments)
        j1 = (j + 1) % segments
        tris = []
        for i in range(rings):
            a, b = pts[i, j], pts[i, j1]
            c, d = pts[i + 1, j1], pts[i + 1, j]
            tris += [np.stack([a, b, c], 1), np.stack([a, c, d], 1)]
        self.add_triangles(np.concatenate(tris), **ref)
        for k, want in zip((0, rings), caps, strict=True):
            if want:
                ctr = np.asarray(base, float) + t[k] * height * R[2]
                ring = pts[k]
                self.add_triangles(
                    np.stack([np.broadcast_to(ctr, ring.shape), ring[j], ring[j1]], 1), **ref
                )

    def add_prism(
        self,
        polygon: shapely.Polygon,
        origin: ArrayLike,
        frame: ArrayLike,
        thickness: float,
        *,
        faces: str = "both",
        sides: bool = True,
        **ref: Any,
    ) -> None:
        """Add a slab: a planar polygon (with holes) in the frame's (u, v), thick along w.

        A wall with openings is a prism whose holes are the openings; the
        sides of the holes are the reveals.  ``faces`` is ``"both"``,
        ``"front"`` (w = 0) or ``"back"`` (w = thickness).
        """
        R = np.asarray(frame, float)
        o = np.asarray(origin, float)
        tri2d = _triangulate(polygon)

        def lift(uv: Array, w: float) -> Array:
            return o + uv[..., 0, None] * R[0] + uv[..., 1, None] * R[1] + w * R[2]

        if faces in ("both", "front"):
            self.add_triangles(lift(tri2d, 0.0), **ref)
        if faces in ("both", "back") and thickness > 0:
            self.add_triangles(lift(tri2d, thickness), **ref)
        if sides and thickness > 0:
            for ring in [polygon.exterior, *polygon.interiors]:
                xy = np.asarray(ring.coords)[:, :2]
                a, b = xy[:-1], xy[1:]
                p0, p1 = lift(a, 0.0), lift(b, 0.0)
                q0, q1 = lift(a, thickness), lift(b, thickness)
                self.add_triangles(
                    np.concatenate([np.stack([p0, p1, q1], 1), np.stack([p0, q1, q0], 1)]), **ref
                )

    def add_heightfield(self, x: Array, y: Array, z: Array, **ref: Any) -> None:
        """Add a terrain from a regular grid: ``z[i, j]`` at ``(x[j], y[i])``."""
        X, Y = np.meshgrid(x, y)
        P = np.stack([X, Y, z], -1)
        a, b, c, d = P[:-1, :-1], P[:-1, 1:], P[1:, 1:], P[1:, :-1]
        tris = np.concatenate(
            [np.stack([a, b, c], -2).reshape(-1, 3, 3), np.stack([a, c, d], -2).reshape(-1, 3, 3)]
        )
        self.add_triangles(tris, **ref)

    def add_sphere(
        self, center: ArrayLike, radius: float, *, segments: int = 32, **ref: Any
    ) -> None:
        """Add a UV sphere (registration targets)."""
        th = np.linspace(0, np.pi, segments // 2 + 1)
        ph = np.linspace(0, 2 * np.pi, segments + 1)
        T, P = np.meshgrid(th, ph, indexing="ij")
        pts = np.asarray(center, float) + radius * np.stack(
            [np.sin(T) * np.cos(P), np.sin(T) * np.sin(P), np.cos(T)], -1
        )
        a, b, c, d = pts[:-1, :-1], pts[:-1, 1:], pts[1:, 1:], pts[1:, :-1]
        tris = np.concatenate(
            [np.stack([a, b, c], -2).reshape(-1, 3, 3), np.stack([a, c, d], -2).reshape(-1, 3, 3)]
        )
        area = np.linalg.norm(np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]), axis=1)
        self.add_triangles(tris[area > 1e-12], **ref)

    # --- views -----------------------------------------------------------
    @property
    def n_triangles(self) -> int:
        """Number of triangles."""
        return int(sum(len(t) for t in self._tris))

    @property
    def triangles(self) -> Array:
        """All triangles, ``(T, 3, 3)``."""
        return np.concatenate(self._tris) if self._tris else np.empty((0, 3, 3))

    def _label(self, k: int) -> NDArray[np.int32]:
        if not self._labels:
            return np.empty(0, np.int32)
        return np.concatenate(self._labels)[:, k]

    @property
    def triangle_instance(self) -> NDArray[np.int32]:
        """Instance of each triangle (0 = no object)."""
        return self._label(0)

    @property
    def triangle_class(self) -> NDArray[np.int32]:
        """Class code of each triangle."""
        return self._label(1)

    @property
    def triangle_part(self) -> NDArray[np.int32]:
        """Part code of each triangle."""
        return self._label(2)

    @property
    def triangle_material(self) -> NDArray[np.int32]:
        """Material code of each triangle."""
        return self._label(3)

    def bounds(self) -> tuple[Array, Array]:
        """Lower and upper corner of the scene, metres."""
        t = self.triangles.reshape(-1, 3)
        return t.min(0), t.max(0)

    def to_json(self) -> dict[str, Any]:
        """The scene's description for ``scene.json`` (no triangles)."""
        return {
            "classes": {str(k): v for k, v in self.class_names.items()},
            "parts": {str(k): v for k, v in self.part_names.items()},
            "materials": [m.__dict__ for m in self._materials],
            "objects": self.objects,
            "n_triangles": self.n_triangles,
        }


def _code(table: dict[int, str], name: str) -> int:
    for k, v in table.items():
        if v == name:
            return k
    k = max(table) + 1
    table[k] = name
    return k


def _triangulate(polygon: shapely.Polygon) -> Array:
    """Triangles ``(T, 3, 2)`` covering a polygon with holes (constrained Delaunay)."""
    tris = shapely.constrained_delaunay_triangles(polygon)
    parts = shapely.get_parts(tris)
    coords = [np.asarray(p.exterior.coords)[:3, :2] for p in parts]
    return np.asarray(coords, float).reshape(-1, 3, 2)
