"""Structural supports of the ``supports`` family and their true primitives.

A :class:`SupportSpec` describes one support: a ``column`` (smooth, tapering,
with entasis or fluted; square plinth, torus base, echinus and abacus; broken
or leaning), a rectangular ``pier`` (free, or an anta / respond against a
wall, so that only 1 to 4 of its faces can be seen) or an ``engaged_column``
(axis on or in front of a wall face).  :func:`add_support` builds it into a
:class:`~pyheracles.synthetic.scene.Scene` as one instance and returns the
reference row written to ``scene.objects``.

Reference row (all lengths in metres, angles in degrees, heights absolute z
unless said otherwise): ``instance``, ``class``, ``group`` (which set of the
layout it belongs to: ``main``, ``aisle``, ``twin``, ``anta`` ...),
``axis_base`` (centre of the support at its bottom), ``axis_direction`` (unit),
``z_bottom``, ``z_top`` (centre of the top), ``height_m`` (along the axis),
``tilt_deg``, ``lean_m`` (horizontal offset of the top from the base),
``lean_azimuth_deg``, ``parts`` (``{name: [from, to]}`` heights along the axis
above the bottom: ``plinth``, ``base``, ``shaft``, ``capital``), and per class:
columns ``radius_bottom_m``, ``radius_top_m`` (shaft, at the arrises; a
broken shaft's top is at the break, ``radius_top_full_m`` that of the whole
shaft), ``radius_mean_m`` (mean surface radius of the shaft, flutes
averaged), ``entasis_m`` (swelling: ``r(t) = r0 + (r1 - r0) t + e sin(pi t)``
over the whole shaft ``shaft_full_m``), ``flutes``, ``flute_depth_m``,
``plinth_half_width_m``, ``abacus_half_width_m``, ``twin_of`` (the other
twin's instance), ``broken``; piers ``box_width_m`` (along the local x
after ``box_yaw_deg``), ``box_depth_m``, ``box_yaw_deg``, ``faces_exposed``;
engaged columns also ``wall_normal`` (into the room) and ``wall_offset_m``
(axis in front of the wall face).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pyheracles.synthetic.families.supports_shapes import (
    Piece,
    box,
    jagged_top,
    revolve,
    rotation_tilt,
)
from pyheracles.synthetic.scene import Scene

__all__ = [
    "SUPPORT_CLASSES",
    "ColumnShape",
    "SupportSpec",
    "add_support",
    "footprint_radius",
    "radius_at",
]

Array = NDArray[np.float64]

#: Reference classes of supports.
SUPPORT_CLASSES = ("column", "pier", "engaged_column")


@dataclass(frozen=True)
class ColumnShape:
    """Profile of a column, metres (0 = the part is absent)."""

    radius_bottom_m: float
    radius_top_m: float
    entasis_m: float = 0.0
    flutes: int = 0
    flute_depth_m: float = 0.0
    plinth_half_m: float = 0.0
    plinth_height_m: float = 0.0
    base_height_m: float = 0.0
    capital_height_m: float = 0.0
    abacus_half_m: float = 0.0
    abacus_height_m: float = 0.0
    square_aspect: float = 1.0  # half depth / half width of plinth and abacus

    def radius(self, t: Array) -> Array:
        """Shaft radius at the arrises at fraction ``t`` of the full shaft."""
        t = np.asarray(t, float)
        r0, r1 = self.radius_bottom_m, self.radius_top_m
        return r0 + (r1 - r0) * t + self.entasis_m * np.sin(np.pi * t)


@dataclass
class SupportSpec:
    """One support to build.  Positions in metres; ``yaw_deg`` turns the square parts
    (and the local frame of a pier or an engaged column: its local +y is the wall
    normal pointing into the room).

    ``cuts`` clips the square parts (plinth, abacus, pier boxes) at a local x or y
    and leaves that face out: twin columns share a plinth split between them, antae
    and engaged columns stop at the wall face (``{"+x": 0.3, "-y": -0.1}``).
    """

    klass: str
    x: float
    y: float
    z0: float
    height_m: float
    column: ColumnShape | None = None
    pier_width_m: float = 0.0
    pier_depth_m: float = 0.0
    pier_projection_m: float = 0.0
    pier_plinth_height_m: float = 0.0
    pier_capital_height_m: float = 0.0
    yaw_deg: float = 0.0
    tilt_deg: float = 0.0
    lean_azimuth_deg: float = 0.0
    broken_at_m: float | None = None
    cuts: dict[str, float] = field(default_factory=dict)
    wall_offset_m: float = 0.0
    group: str = "main"
    twin_of: int | None = None

    @property
    def is_round(self) -> bool:
        return self.klass in ("column", "engaged_column")


def footprint_radius(spec: SupportSpec) -> float:
    """Largest horizontal reach of a support from its axis at the floor, metres."""
    if spec.is_round and spec.column is not None:
        c = spec.column
        return float(
            max(
                c.radius_bottom_m * 1.25, np.sqrt(2) * c.plinth_half_m, np.sqrt(2) * c.abacus_half_m
            )
        )
    half = np.hypot(
        spec.pier_width_m / 2 + spec.pier_projection_m,
        spec.pier_depth_m / 2 + spec.pier_projection_m,
    )
    return float(half)


def _shape(spec: SupportSpec) -> ColumnShape:
    if spec.column is None:
        raise ValueError(f"a {spec.klass} needs a ColumnShape")
    return spec.column


def _square(half_x: float, half_y: float, z0: float, z1: float, cuts: dict[str, float]) -> Array:
    """A box of the square parts, clipped by ``cuts`` (clipped faces left out)."""
    lo = np.array([-half_x, -half_y, z0])
    hi = np.array([half_x, half_y, z1])
    faces = ["-x", "+x", "-y", "+y", "-z", "+z"]
    for face, at in cuts.items():
        k = "xy".index(face[1])
        if face[0] == "+":
            if at <= hi[k]:
                hi[k] = at
                faces.remove(face)
        elif at >= lo[k]:
            lo[k] = at
            faces.remove(face)
    if np.any(hi[:2] <= lo[:2]):
        return np.empty((0, 3, 3))
    faces.remove("-z")  # stands on the floor: never seen
    return box(lo, hi, faces=faces)


def _phi_window(spec: SupportSpec, r: float) -> tuple[float, float]:
    """Angles of an engaged column's surface in front of the wall (local +y = room)."""
    if spec.klass != "engaged_column":
        return (0.0, 2 * np.pi)
    s = float(np.clip(spec.wall_offset_m / max(r, 1e-9), 0.0, 1.0))
    a = np.arcsin(s) + np.deg2rad(3.0)  # a little into the wall: no crack at the junction
    return (-a, np.pi + a)


def _column_piece(spec: SupportSpec, rng: np.random.Generator) -> tuple[Piece, dict]:
    c = _shape(spec)
    piece = Piece()
    parts: dict[str, list[float]] = {}
    phi = _phi_window(spec, c.radius_bottom_m)
    segments = int(np.clip(2 * np.pi * c.radius_bottom_m / 0.02, 64, 192))
    if c.flutes:
        segments = max(segments, 8 * c.flutes)
    H = spec.height_m
    z = 0.0
    if c.plinth_half_m > 0 and c.plinth_height_m > 0:
        piece.add(
            _square(
                c.plinth_half_m,
                c.plinth_half_m * c.square_aspect,
                0.0,
                c.plinth_height_m,
                spec.cuts,
            ),
            "plinth",
        )
        parts["plinth"] = [0.0, c.plinth_height_m]
        z = c.plinth_height_m
    r0 = c.radius_bottom_m
    if c.base_height_m > 0:
        hb = c.base_height_m
        prof_z = [z, z + 0.45 * hb, z + 0.8 * hb, z + hb, z + hb]
        prof_r = [1.2 * r0, 1.24 * r0, 1.14 * r0, 1.06 * r0, r0]
        piece.add(revolve(prof_z, prof_r, phi=phi, segments=segments), "base")
        parts["base"] = [z, z + hb]
        z += hb
    capital = c.capital_height_m + c.abacus_height_m
    z_full = H - capital  # where the complete shaft would end
    broken = spec.broken_at_m is not None and spec.broken_at_m < z_full
    z_end = float(spec.broken_at_m) if broken else z_full
    t_end = (z_end - z) / max(z_full - z, 1e-9)
    rings = 1 if c.entasis_m == 0 else 16
    t = np.linspace(0.0, t_end, rings + 1)
    piece.add(
        revolve(
            z + t * (z_full - z),
            c.radius(t),
            phi=phi,
            segments=segments,
            flutes=c.flutes,
            flute_depth=c.flute_depth_m,
        ),
        "shaft",
    )
    parts["shaft"] = [z, z_end]
    r_end = float(c.radius(t_end))
    if broken:
        top = jagged_top(
            r_end - c.flute_depth_m / 2,
            z_end,
            rng,
            roughness=0.15 * r_end,
            segments=min(segments, 96),
        )
        if spec.klass == "engaged_column":
            top = top[np.all(top[..., 1] >= -spec.wall_offset_m - 1e-6, axis=1)]
        piece.add(top, "shaft")
    elif capital > 0:
        r_cap = min(1.3 * r_end, max(c.abacus_half_m, r_end * 1.3))
        if c.capital_height_m > 0:
            ze = z_end + c.capital_height_m
            piece.add(revolve([z_end, ze], [r_end, r_cap], phi=phi, segments=segments), "capital")
            if c.abacus_height_m == 0:
                piece.add(revolve([ze, ze], [r_cap, 0.0], phi=phi, segments=segments), "capital")
        if c.abacus_height_m > 0:
            a = c.abacus_half_m
            if a > 0:
                piece.add(
                    _square(a, a * c.square_aspect, H - c.abacus_height_m, H, spec.cuts), "capital"
                )
        parts["capital"] = [z_end, H]
    else:
        piece.add(revolve([z_end, z_end], [r_end, 0.0], phi=phi, segments=segments), "shaft")
    return piece, {"parts": parts, "z_end_local": z_end if broken else H, "broken": broken}


def _pier_piece(spec: SupportSpec) -> tuple[Piece, dict]:
    piece = Piece()
    w, d, c = spec.pier_width_m / 2, spec.pier_depth_m / 2, spec.pier_projection_m
    H = spec.height_m
    parts: dict[str, list[float]] = {}
    z = 0.0
    if spec.pier_plinth_height_m > 0:
        cuts = {k: v + np.sign(v) * c if v != 0 else v for k, v in spec.cuts.items()}
        piece.add(_square(w + c, d + c, 0.0, spec.pier_plinth_height_m, cuts), "plinth")
        parts["plinth"] = [0.0, spec.pier_plinth_height_m]
        z = spec.pier_plinth_height_m
    top = H - spec.pier_capital_height_m
    top_end = top if spec.broken_at_m is None else min(top, spec.broken_at_m)
    piece.add(_square(w, d, z, top_end, spec.cuts), "shaft")
    parts["shaft"] = [z, top_end]
    if spec.pier_capital_height_m > 0 and spec.broken_at_m is None:
        cuts = {k: v + np.sign(v) * c if v != 0 else v for k, v in spec.cuts.items()}
        cap = _square(w + c, d + c, top, H, cuts)
        # the impost's underside around the shaft is seen; the part over the shaft is not
        piece.add(cap, "capital")
        piece.add(box([-w - c, -d - c, top], [w + c, d + c, top], faces=("-z",)), "capital")
        parts["capital"] = [top, H]
    exposed = 4 - sum(1 for k in spec.cuts if abs(spec.cuts[k]) <= max(w, d))
    return piece, {
        "parts": parts,
        "z_end_local": top_end if spec.broken_at_m else H,
        "broken": spec.broken_at_m is not None,
        "faces_exposed": exposed,
    }


def add_support(
    scene: Scene, spec: SupportSpec, instance: int, rng: np.random.Generator
) -> dict[str, Any]:
    """Build one support into ``scene`` as ``instance``; return its reference row."""
    if spec.is_round:
        piece, info = _column_piece(spec, rng)
    else:
        piece, info = _pier_piece(spec)
    tilt = rotation_tilt(spec.tilt_deg, spec.lean_azimuth_deg) if spec.tilt_deg else None
    origin = np.array([spec.x, spec.y, spec.z0])
    piece.place(
        scene,
        origin=origin,
        yaw_deg=spec.yaw_deg,
        tilt=tilt,
        instance=instance,
        class_name=spec.klass,
    )
    axis = (tilt if tilt is not None else np.eye(3)) @ np.array([0.0, 0.0, 1.0])
    length = float(info["z_end_local"])
    top = origin + length * axis
    row: dict[str, Any] = {
        "instance": instance,
        "class": spec.klass,
        "group": spec.group,
        "axis_base": origin.tolist(),
        "axis_direction": axis.tolist(),
        "z_bottom": float(spec.z0),
        "z_top": float(top[2]),
        "height_m": length,
        "tilt_deg": float(spec.tilt_deg),
        "lean_m": float(np.hypot(*(top - origin)[:2])),
        "lean_azimuth_deg": float(spec.lean_azimuth_deg) if spec.tilt_deg else 0.0,
        "parts": info["parts"],
        "broken": bool(info["broken"]),
    }
    if spec.is_round:
        c = _shape(spec)
        z_a, z_b = info["parts"]["shaft"]
        full = spec.height_m - c.capital_height_m - c.abacus_height_m - z_a
        t = np.linspace(0, (z_b - z_a) / max(full, 1e-9), 201)
        row.update(
            radius_bottom_m=c.radius_bottom_m,
            radius_top_m=float(c.radius(t[-1])) if info["broken"] else c.radius_top_m,
            radius_top_full_m=c.radius_top_m,
            radius_mean_m=float(np.mean(c.radius(t)) - c.flute_depth_m / 2),
            entasis_m=c.entasis_m,
            flutes=c.flutes,
            flute_depth_m=c.flute_depth_m,
            plinth_half_width_m=c.plinth_half_m,
            abacus_half_width_m=c.abacus_half_m,
            shaft_full_m=[z_a, z_a + full],
            twin_of=spec.twin_of,
        )
    else:
        row.update(
            box_width_m=spec.pier_width_m,
            box_depth_m=spec.pier_depth_m,
            box_yaw_deg=float(spec.yaw_deg),
            faces_exposed=info["faces_exposed"],
        )
    if spec.klass == "engaged_column" or (spec.klass == "pier" and spec.cuts):
        y = np.deg2rad(spec.yaw_deg)
        row.update(wall_normal=[-np.sin(y), np.cos(y), 0.0], wall_offset_m=spec.wall_offset_m)
    return row


def radius_at(row: dict[str, Any], z: float) -> float:
    """True mean surface radius (flutes averaged) of a column's shaft at height ``z``.

    The height is taken along the axis and clamped to the shaft.
    """
    c = ColumnShape(row["radius_bottom_m"], row["radius_top_full_m"], row["entasis_m"])
    z_a, z_full = row["shaft_full_m"]
    z_b = row["parts"]["shaft"][1]
    cos_t = max(float(row["axis_direction"][2]), 1e-6)
    h = np.clip((z - row["z_bottom"]) / cos_t, z_a, z_b)
    t = (h - z_a) / max(z_full - z_a, 1e-9)
    return float(c.radius(t) - row["flute_depth_m"] / 2)
