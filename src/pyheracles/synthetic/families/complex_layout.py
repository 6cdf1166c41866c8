"""Layouts of walled complexes: what stands where, before any triangle is built.

A :class:`Layout` lists the objects of one complex in plan: buildings and
open pavilions (one or several rectangular parts, a plinth or a raised
platform, a roof style), wall runs, gates (split gates whose towers flank an
opening, roofed gates), trees, clutter, and the terrain (:class:`Terrain`:
slope, hills, terrace steps).
:func:`~pyheracles.synthetic.families.complex_draw.draw_layout` draws one
from the family parameters;
:mod:`~pyheracles.synthetic.families.complex_model` turns it into surfaces.

The complex has its own plan frame (``Layout.frame``: the enclosure's axes,
rotated by ``orientation_deg`` about the centre of the survey area); wall
lines are given in it, buildings and gates in their own frames
(:class:`~pyheracles.synthetic.families.complex_build.Placement`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray
from shapely.geometry import LineString, box
from shapely.ops import unary_union

from pyheracles.synthetic.families.complex_build import Placement

__all__ = [
    "Building",
    "Clutter",
    "Gate",
    "Layout",
    "Part",
    "Terrain",
    "Tree",
    "Wall",
    "building_footprint",
    "gate_footprint",
    "gate_rects",
    "part_outline",
    "wall_footprint",
]

Array = NDArray[np.float64]


# ----------------------------------------------------------------------------- specs
@dataclass(frozen=True)
class Terrain:
    """Terrain height in the scene frame: a plane, Gaussian hills and terrace steps.

    Attributes
    ----------
    base_m
        Height of the plane at the origin of ``frame``.
    gradient
        ``(dz/dx, dz/dy)`` of the plane in the scene frame.
    hills
        Rows ``(x, y, amplitude_m, sigma_m)`` in the scene frame.
    steps
        Rows ``(v, height_m, width_m)``: a terrace edge along the line ``v`` =
        const of ``frame``, rising ``height_m`` over ``width_m`` (smoothstep).
    frame
        The complex frame (terrace edges run along its u axis).
    """

    base_m: float = 0.0
    gradient: tuple[float, float] = (0.0, 0.0)
    hills: tuple[tuple[float, float, float, float], ...] = ()
    steps: tuple[tuple[float, float, float], ...] = ()
    frame: Placement = field(default_factory=Placement)

    def __call__(self, x: Array, y: Array) -> Array:
        """Heights at scene ``(x, y)``, metres."""
        x = np.asarray(x, dtype=np.float64)
        y = np.asarray(y, dtype=np.float64)
        ox, oy = self.frame.origin
        z = self.base_m + self.gradient[0] * (x - ox) + self.gradient[1] * (y - oy)
        for hx, hy, amp, sig in self.hills:
            z = z + amp * np.exp(-((x - hx) ** 2 + (y - hy) ** 2) / (2.0 * sig * sig))
        if self.steps:
            a = np.deg2rad(self.frame.angle_deg)
            v = -(x - ox) * np.sin(a) + (y - oy) * np.cos(a)
            for v0, h, w in self.steps:
                t = np.clip((v - v0) / w + 0.5, 0.0, 1.0)
                z = z + h * t * t * (3.0 - 2.0 * t)
        return z


@dataclass(frozen=True)
class Part:
    """One wing of a building, in the building frame.

    Attributes
    ----------
    rect
        ``(x0, y0, x1, y1)`` of the walls (closed buildings) or of the column
        grid (pavilions), metres.
    eave_height_m
        Eave above the floor (the plinth or platform top).
    roof, pitch_deg
        Roof style (see :func:`~pyheracles.synthetic.families.complex_build.add_roof`)
        and slope.
    eaves_m
        Roof overhang beyond ``rect`` on the west, south, east and north sides.
    parapet_m
        Parapet height of a flat roof.
    """

    rect: tuple[float, float, float, float]
    eave_height_m: float
    roof: str = "hipped"
    pitch_deg: float = 30.0
    eaves_m: tuple[float, float, float, float] = (0.8, 0.8, 0.8, 0.8)
    parapet_m: float = 0.0


@dataclass(frozen=True)
class Building:
    """A building or open pavilion: one GIS feature.

    Attributes
    ----------
    kind
        ``closed`` (walls under the roof) or ``pavilion`` (columns on a platform).
    base, base_height_m, base_margin_m
        ``plinth`` or ``platform``; its height above the ground at the centre
        (at least 0.15 m above the highest ground under it) and how far it
        reaches beyond the walls / columns.
    status
        ``extant`` or ``demolished`` (in the GIS, not in the scene).
    """

    fid: str
    name: str
    function: str
    kind: str
    place: Placement
    parts: tuple[Part, ...]
    base: str = "plinth"
    base_height_m: float = 0.3
    base_margin_m: float = 0.2
    status: str = "extant"
    storeys: int = 1


@dataclass(frozen=True)
class Wall:
    """A wall run (one GIS feature): a polyline in the complex frame."""

    fid: str
    name: str
    function: str
    material: str
    line: tuple[tuple[float, float], ...]
    thickness_m: float
    height_m: float
    caps: tuple[bool, bool] = (False, False)


@dataclass(frozen=True)
class Gate:
    """A gate in a wall; its frame has u along the wall, origin at the gate's centre.

    ``split`` gates are two stepped towers flanking an opening of ``opening_m``
    (a MultiPolygon in the GIS); ``roofed`` gates a block under a roof.
    """

    fid: str
    name: str
    gate_type: str
    place: Placement
    width_m: float
    depth_m: float
    height_m: float
    opening_m: float = 0.0


@dataclass(frozen=True)
class Tree:
    """A tree in the scene frame (instance 0)."""

    x: float
    y: float
    crown_radius_m: float
    crown_half_height_m: float
    trunk_height_m: float
    leaf_area_density: float
    penetration: float


@dataclass(frozen=True)
class Clutter:
    """Street furniture, cars, unmapped sheds (instance 0): a kind and a frame."""

    kind: str
    place: Placement


@dataclass(frozen=True)
class Layout:
    """Everything of one complex, before triangulation."""

    bounds: tuple[float, float, float, float]
    frame: Placement
    terrain: Terrain
    buildings: tuple[Building, ...]
    walls: tuple[Wall, ...]
    gates: tuple[Gate, ...]
    trees: tuple[Tree, ...] = ()
    clutter: tuple[Clutter, ...] = ()
    wall_groups: dict[str, str] = field(default_factory=dict)
    building_groups: dict[str, str] = field(default_factory=dict)


# ----------------------------------------------------------------------------- footprints
def gate_rects(g: Gate) -> list[tuple[float, float, float, float]]:
    """The gate's solid parts in its frame: two towers, or one block."""
    w, d = g.width_m / 2, g.depth_m / 2
    if g.gate_type == "split":
        o = g.opening_m / 2
        return [(-w, -d, -o, d), (o, -d, w, d)]
    return [(-w, -d, w, d)]


def gate_footprint(g: Gate) -> Any:
    """True plan outline of a gate (scene frame); a roofed gate's roof overhangs 0.3 m."""
    grow = 0.3 if g.gate_type == "roofed" else 0.0
    rects = [box(x0 - grow, y0 - grow, x1 + grow, y1 + grow) for x0, y0, x1, y1 in gate_rects(g)]
    return g.place.geometry(unary_union(rects))


def part_outline(p: Part, b: Building) -> Any:
    """Plan outline of one part: roof (with eaves) and plinth / platform, building frame."""
    x0, y0, x1, y1 = p.rect
    w, s, e, n = p.eaves_m
    m = b.base_margin_m
    return box(x0 - w, y0 - s, x1 + e, y1 + n).union(box(x0 - m, y0 - m, x1 + m, y1 + m))


def building_footprint(b: Building) -> Any:
    """True plan outline of a building (scene frame): roofs and bases of all parts."""
    return b.place.geometry(unary_union([part_outline(p, b) for p in b.parts]))


def wall_footprint(w: Wall, frame: Placement) -> Any:
    """True plan outline of a wall run (scene frame)."""
    line = LineString(w.line).buffer(w.thickness_m / 2, cap_style="flat", join_style="mitre")
    return frame.geometry(line)
