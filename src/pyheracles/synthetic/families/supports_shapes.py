"""Triangle shapes of the ``supports`` family: surfaces of revolution, boxes, placement.

Pure functions returning ``(T, 3, 3)`` triangle arrays in a local frame (z up,
the support axis on the z axis).  A :class:`Piece` collects such triangles
with their part names and is then placed (rotated about its base, moved) into
a :class:`~pyheracles.synthetic.scene.Scene` with one reference, so that a
leaning column leans as a whole (plinth, shaft and capital).

Examples
--------
>>> import numpy as np
>>> t = revolve([0.0, 2.0], [0.5, 0.5], segments=64)
>>> t.shape
(128, 3, 3)
>>> bool(np.allclose(np.hypot(t[..., 0], t[..., 1]), 0.5))
True
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pyheracles.synthetic.scene import STONE, Material, Scene

__all__ = ["Piece", "box", "jagged_top", "revolve", "rotation_tilt", "tube"]

Array = NDArray[np.float64]

#: Quads of a box by face name, as corner indices of ``(sx, sy, sz)`` in {-1, 1}^3.
_QUADS = {
    "-x": [0, 1, 3, 2], "+x": [4, 6, 7, 5], "-y": [0, 4, 5, 1],
    "+y": [2, 3, 7, 6], "-z": [0, 2, 6, 4], "+z": [1, 5, 7, 3],
}  # fmt: skip


def revolve(
    z: ArrayLike,
    r: ArrayLike,
    *,
    phi: tuple[float, float] = (0.0, 2 * np.pi),
    segments: int = 96,
    flutes: int = 0,
    flute_depth: float = 0.0,
) -> Array:
    """Surface of revolution about the z axis through a profile ``(z_i, r_i)``.

    Parameters
    ----------
    z, r
        Profile heights and radii (metres), at least two points; ``r`` may vary
        (taper, entasis, mouldings).
    phi
        Angular window, radians (a half column against a wall: about ``(0, pi)``).
    segments
        Segments of the full circle (the window gets its share, at least 4).
    flutes, flute_depth
        Concave flutes between arrises (``depth * sin^2`` profile, as
        :meth:`Scene.add_cylinder`); the radius ``r`` is the radius at the arrises.
    """
    zz = np.asarray(z, float)
    rr = np.asarray(r, float)
    span = phi[1] - phi[0]
    n = max(4, int(np.ceil(segments * span / (2 * np.pi))))
    full = np.isclose(span, 2 * np.pi)
    ang = np.linspace(phi[0], phi[1], n + 1)
    dr = -flute_depth * np.sin(ang * flutes / 2) ** 2 if flutes > 0 else np.zeros_like(ang)
    rad = np.maximum(rr[:, None] + dr[None, :], 0.0)
    pts = np.stack(
        [rad * np.cos(ang), rad * np.sin(ang), np.broadcast_to(zz[:, None], rad.shape)], -1
    )
    j = np.arange(n)
    j1 = j + 1
    if full:
        pts = pts[:, :-1]
        j1 = (j + 1) % n
    a, b = pts[:-1][:, j], pts[:-1][:, j1]
    c, d = pts[1:][:, j1], pts[1:][:, j]
    tris = np.concatenate([np.stack([a, b, c], -2), np.stack([a, c, d], -2)], axis=1)
    tris = tris.reshape(-1, 3, 3)
    area = np.linalg.norm(np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]), axis=1)
    return tris[area > 1e-12]


def box(
    lo: ArrayLike,
    hi: ArrayLike,
    *,
    faces: Sequence[str] = ("-x", "+x", "-y", "+y", "-z", "+z"),
) -> Array:
    """Axis-aligned cuboid between corners ``lo`` and ``hi`` (local frame)."""
    lo_, hi_ = np.asarray(lo, float), np.asarray(hi, float)
    corner = np.array([[sx, sy, sz] for sx in (0, 1) for sy in (0, 1) for sz in (0, 1)])
    pts = lo_ + corner * (hi_ - lo_)
    out = []
    for f in faces:
        q = pts[_QUADS[f]]
        out += [q[[0, 1, 2]], q[[0, 2, 3]]]
    return np.asarray(out, float).reshape(-1, 3, 3)


def tube(a: ArrayLike, b: ArrayLike, radius: float, segments: int = 10) -> Array:
    """A thin open cylinder from point ``a`` to point ``b`` (scaffold tubes, rails, legs)."""
    from pyheracles.synthetic.scene import frame_from_axis

    pa, pb = np.asarray(a, float), np.asarray(b, float)
    length = float(np.linalg.norm(pb - pa))
    R = frame_from_axis(pb - pa)
    local = revolve([0.0, length], [radius, radius], segments=segments)
    return local @ R + pa


def jagged_top(
    radius: float, z: float, rng: np.random.Generator, *, roughness: float, segments: int = 48
) -> Array:
    """Broken top of a shaft: a rough cap whose rim is the shaft's top circle at ``z``."""
    ang = np.linspace(0.0, 2 * np.pi, segments + 1)[:-1]
    rim = np.c_[radius * np.cos(ang), radius * np.sin(ang), np.full(segments, z)]
    mid_z = z + rng.uniform(-roughness, roughness, segments)
    mid = np.c_[0.55 * rim[:, :2], mid_z]
    centre = np.array([0.0, 0.0, z + rng.uniform(-roughness, roughness)])
    j = np.arange(segments)
    j1 = (j + 1) % segments
    outer = np.concatenate(
        [np.stack([rim[j], rim[j1], mid[j1]], 1), np.stack([rim[j], mid[j1], mid[j]], 1)]
    )
    inner = np.stack([np.broadcast_to(centre, (segments, 3)), mid[j], mid[j1]], 1)
    return np.concatenate([outer, inner])


def rotation_tilt(tilt_deg: float, azimuth_deg: float) -> Array:
    """Rotation turning +z by ``tilt_deg`` towards the horizontal azimuth ``azimuth_deg``."""
    t, a = np.deg2rad(tilt_deg), np.deg2rad(azimuth_deg)
    k = np.array([-np.sin(a), np.cos(a), 0.0])  # rotation axis, horizontal, normal to azimuth
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(t) * K + (1 - np.cos(t)) * K @ K


@dataclass
class Piece:
    """Triangles of one object in its local frame, with a part name and material each."""

    chunks: list[tuple[Array, str, Material]] = field(default_factory=list)

    def add(self, tris: Array, part: str, material: Material = STONE) -> None:
        """Add local triangles of one part."""
        if len(tris):
            self.chunks.append((np.asarray(tris, float).reshape(-1, 3, 3), part, material))

    def place(
        self,
        scene: Scene,
        *,
        origin: ArrayLike,
        yaw_deg: float = 0.0,
        tilt: Array | None = None,
        **ref: Any,
    ) -> None:
        """Add to ``scene``: turned by ``yaw_deg`` about z, tilted (3x3) about the local
        origin, then moved to ``origin``; ``ref`` = ``instance``, ``class_name``."""
        y = np.deg2rad(yaw_deg)
        Rz = np.array([[np.cos(y), -np.sin(y), 0], [np.sin(y), np.cos(y), 0], [0, 0, 1.0]])
        R = (np.eye(3) if tilt is None else np.asarray(tilt, float)) @ Rz
        o = np.asarray(origin, float)
        for tris, part, mat in self.chunks:
            scene.add_triangles(tris @ R.T + o, part=part, material=mat, **ref)
