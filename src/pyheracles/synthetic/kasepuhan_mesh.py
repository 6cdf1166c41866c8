"""Terrain and mesh building blocks of the Kasepuhan complex (see ``complex_scene``).

The ground surface (a slope plus Gaussian hills), the surface kinds of the
scene's internal mesh, and :class:`SceneMesh`, which accumulates labelled
triangles for prisms, roofs of Javanese forms, cones and terrain-following walls.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pyheracles.synthetic.families.complex_build import band as ring_band
from pyheracles.synthetic.families.complex_build import fan as ring_fan
from pyheracles.synthetic.families.complex_build import (
    half_min_side,
    rect_ring,
    ridge_ring,
)
from pyheracles.synthetic.families.complex_build import quads as quad_triangles
from pyheracles.synthetic.families.complex_build import with_z as ring_with_z

# Surface kinds of the internal mesh (turned into part names and materials of the Scene).
GROUND, ROOF, FACADE, WALL, GATE, COLUMN, FLOOR, TREE, CLUTTER = range(1, 10)
BURY_M = 0.3  # foundations reach this far below the lowest ground under a footprint


# ----------------------------------------------------------------------------- terrain
# (x, y, amplitude m, sigma m): the Siti Inggil terrace is a hill, plus undulations.
HILLS = np.array(
    [
        [70.0, 166.0, 1.3, 16.0],
        [28.0, 60.0, 1.2, 22.0],
        [112.0, 118.0, -0.9, 18.0],
        [100.0, 30.0, 0.6, 14.0],
        [20.0, 150.0, 0.5, 10.0],
    ]
)


def ground_height(x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
    """Terrain height above the scene base at local ``(x, y)``, metres.

    A slope rising 2.4 m to the north and 0.7 m to the west plus Gaussian hills.
    """
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    z = 1.0 + 0.012 * y - 0.005 * x
    for hx, hy, amp, sig in HILLS:
        z = z + amp * np.exp(-((x - hx) ** 2 + (y - hy) ** 2) / (2.0 * sig * sig))
    return z


# ----------------------------------------------------------------------------- meshes


class SceneMesh:
    """Accumulates triangles with their owner, surface kind and occlusion group."""

    def __init__(self) -> None:
        self.tris: list[NDArray[np.float64]] = []
        self.owner: list[NDArray[np.int32]] = []
        self.kind: list[NDArray[np.uint8]] = []
        self.group: list[NDArray[np.int32]] = []
        self.n_groups = 0

    def add(self, tris: NDArray[np.float64], owner: int, kind: int) -> None:
        """Add triangles forming one surface (one occlusion group)."""
        self.n_groups += 1
        n = len(tris)
        self.tris.append(np.asarray(tris, dtype=np.float64).reshape(n, 3, 3))
        self.owner.append(np.full(n, owner, np.int32))
        self.kind.append(np.full(n, kind, np.uint8))
        self.group.append(np.full(n, self.n_groups, np.int32))

    def arrays(self) -> tuple[NDArray[Any], ...]:
        return (
            np.concatenate(self.tris),
            np.concatenate(self.owner),
            np.concatenate(self.kind),
            np.concatenate(self.group),
        )

    # -- building blocks ------------------------------------------------------
    def prism(
        self,
        ring: NDArray[np.float64],
        z_bottom: float,
        z_top: float,
        owner: int,
        kind: int,
        *,
        top: bool = True,
        top_kind: int | None = None,
        scale_top: float = 1.0,
    ) -> None:
        """Vertical (or tapered) sides of a ring extruded from ``z_bottom`` to ``z_top``."""
        c = ring.mean(axis=0)
        ring_top = c + (ring - c) * scale_top
        self.add(ring_band(ring_with_z(ring, z_bottom), ring_with_z(ring_top, z_top)), owner, kind)
        if top:
            self.add(ring_fan(ring_with_z(ring_top, z_top)), owner, top_kind or kind)

    def roof(
        self, rect: NDArray[np.float64], z_eave: float, style: str, owner: int, kind: int = ROOF
    ) -> None:
        """Hipped, pyramidal, two-tier (joglo) or stacked (tumpang) roof over a rectangle.

        Pitches follow Javanese roofs: about 30 degrees for the lower tier, 45-50
        degrees for the upper one.
        """
        half = half_min_side(rect)
        if style in ("hipped", "pyramid"):
            inner = ridge_ring(rect, 0.0)
            self.add(
                ring_band(ring_with_z(rect, z_eave), ring_with_z(inner, z_eave + 0.9 * half)),
                owner,
                kind,
            )
        elif style == "joglo":  # shallow lower tier, steep upper hipped roof
            mid = ridge_ring(rect, 0.45)
            z_mid = z_eave + 0.55 * half * 0.6
            self.add(ring_band(ring_with_z(rect, z_eave), ring_with_z(mid, z_mid)), owner, kind)
            inner = ridge_ring(mid, 0.0)
            top_half = half_min_side(mid)
            self.add(
                ring_band(ring_with_z(mid, z_mid), ring_with_z(inner, z_mid + 1.2 * top_half)),
                owner,
                kind,
            )
        elif style == "tumpang":  # two pyramids, the upper one raised on a short drum
            mid = ridge_ring(rect, 0.5)
            z_mid = z_eave + 0.5 * half * 0.8
            self.add(ring_band(ring_with_z(rect, z_eave), ring_with_z(mid, z_mid)), owner, kind)
            upper = ridge_ring(rect, 0.62)
            self.add(
                ring_band(ring_with_z(mid, z_mid), ring_with_z(mid, z_mid + 0.6)), owner, FACADE
            )
            apex = ridge_ring(upper, 0.0)
            z_up = z_mid + 0.6
            self.add(
                ring_band(
                    ring_with_z(upper, z_up), ring_with_z(apex, z_up + 1.0 * half_min_side(upper))
                ),
                owner,
                kind,
            )
        else:  # pragma: no cover - internal layout table
            raise ValueError(f"unknown roof style {style!r}")

    def cone(self, ring: NDArray[np.float64], z_eave: float, height: float, owner: int) -> None:
        """Conical roof over any convex ring (round pavilion)."""
        apex = np.repeat(ring.mean(axis=0, keepdims=True), len(ring), axis=0)
        self.add(
            ring_band(ring_with_z(ring, z_eave), ring_with_z(apex, z_eave + height)), owner, ROOF
        )

    def wall(
        self,
        line: NDArray[np.float64],
        thickness: float,
        height: float,
        owner: int,
        kind: int = WALL,
        *,
        caps: bool = False,
        piece_m: float = 1.5,
    ) -> None:
        """A wall of constant height above the terrain along a polyline.

        Both faces and the top follow the terrain in pieces of ``piece_m``; corners
        are filled by extending inner legs by half the thickness; end caps only
        where the wall ends free (``caps``), not where it abuts a gate.
        """
        line = np.asarray(line, dtype=np.float64)
        n_legs = len(line) - 1
        for k in range(n_legs):  # loop over a few wall legs, not over points
            p, q = line[k].copy(), line[k + 1].copy()
            d = (q - p) / np.linalg.norm(q - p)
            if k > 0:
                p -= d * thickness / 2
            if k < n_legs - 1:
                q += d * thickness / 2
            length = float(np.linalg.norm(q - p))
            n_pieces = max(1, math.ceil(length / piece_m))
            s = np.linspace(0.0, 1.0, n_pieces + 1)[:, None]
            axis = p + s * (q - p)
            nrm = np.array([-d[1], d[0]]) * thickness / 2
            zg = ground_height(axis[:, 0], axis[:, 1])
            zb, zt = zg - BURY_M, zg + height
            left, right = axis + nrm, axis - nrm
            for side in (left, right):
                lo, hi = ring_with_z(side, zb), ring_with_z(side, zt)
                quads = np.stack([lo[:-1], lo[1:], hi[1:], hi[:-1]], axis=1)
                self.add(quad_triangles(quads), owner, kind)
            tl, tr = ring_with_z(left, zt), ring_with_z(right, zt)
            self.add(
                quad_triangles(np.stack([tl[:-1], tl[1:], tr[1:], tr[:-1]], axis=1)), owner, kind
            )
            if caps and (k == 0 or k == n_legs - 1):
                for i in ([0] if k == 0 else []) + ([-1] if k == n_legs - 1 else []):
                    cap = np.array(
                        [
                            [*left[i], zb[i]],
                            [*right[i], zb[i]],
                            [*right[i], zt[i]],
                            [*left[i], zt[i]],
                        ]
                    )
                    self.add(quad_triangles(cap[None]), owner, kind)


def ring_ground(ring: NDArray[np.float64]) -> tuple[float, float]:
    """(lowest ground under a footprint, ground at its centre)."""
    pts = np.vstack([ring, ring.mean(axis=0, keepdims=True)])
    z = ground_height(pts[:, 0], pts[:, 1])
    return float(z.min()), float(z[-1])


def expand_rect(rect: NDArray[np.float64], dx0: float, dy0: float, dx1: float, dy1: float):
    (x0, y0), (x1, y1) = rect[0], rect[2]
    return rect_ring(x0 - dx0, y0 - dy0, x1 + dx1, y1 + dy1)
