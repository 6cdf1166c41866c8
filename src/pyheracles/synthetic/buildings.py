"""Building scenes with reference labels for the attic/body split and the supports.

Four scenes after the hard cases of the thesis (Murtiyoso 2020, ch. 6.2):

``pavilion``
    An open pavilion: rectangular peripheral piers, four inner columns of which
    two stand on a dais, a deep entablature with a flat soffit and a hip roof
    (the attic).
``temple``
    A colonnaded temple ruin on a stylobate: a peristyle of columns, some broken
    at different heights, low cella walls ending in two antae (rectangular
    piers), two columns in antis, fallen drums.
``hall``
    A hall with free-standing columns and engaged half-columns on the long walls
    under a groin-like vaulted (non-planar) ceiling.
``choir``
    A choir with twin columns conjoined at plinth and capital, single columns, an
    iron fence that touches the columns up to mid-height, chairs (some leaning
    on columns) and a sign post.

Surfaces are sampled uniformly at ``1 / spacing_m^2`` points per m^2 and
perturbed by isotropic Gaussian noise ``noise_m``, like a registered
multi-station TLS cloud (no occlusion shadows except where solids touch).

Every point carries its reference: ``instance`` (support id 1..K, 0 = not a
support), ``attic`` (True for the attic), ``part`` (what the point was sampled
from).  The ``supports`` table gives each support's class and true dimensions.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from numpy.typing import NDArray

__all__ = ["SCENES", "BuildingScene", "building_scene"]

SCENES = ("pavilion", "temple", "hall", "choir")

Array = NDArray[np.float64]


@dataclass(frozen=True)
class BuildingScene:
    """A generated building cloud with its reference labels.

    Attributes
    ----------
    name
        Scene kind (one of :data:`SCENES`).
    xyz
        ``(N, 3)`` coordinates, metres, z up, floor / ground at about 0.
    instance
        ``(N,)`` int32 reference support id (1..K), 0 for everything else.
    attic
        ``(N,)`` bool reference attic mask (all False when the scene has no attic).
    part
        ``(N,)`` str label of the surface each point was sampled from
        (``floor``, ``wall``, ``vault``, ``fence``, ``chair`` ...).
    supports
        One row per support: ``instance``, ``class`` (``column``, ``pier``,
        ``engaged_column``), ``x``, ``y`` (axis), ``radius_m`` (columns; NaN for
        piers), ``width_m``, ``depth_m`` (piers), ``z_bottom``, ``z_top``.
    attic_base_m
        Height where the attic starts, or NaN.
    """

    name: str
    xyz: Array
    instance: NDArray[np.int32]
    attic: NDArray[np.bool_]
    part: NDArray[np.str_]
    supports: pd.DataFrame
    attic_base_m: float = float("nan")
    params: dict[str, float] = field(default_factory=dict)


class _Sampler:
    """Accumulates sampled surface patches with their labels (private helper)."""

    def __init__(self, rng: np.random.Generator, density: float) -> None:
        self.rng = rng
        self.density = density
        self.pts: list[Array] = []
        self.inst: list[NDArray[np.int32]] = []
        self.attic: list[NDArray[np.bool_]] = []
        self.part: list[NDArray[np.str_]] = []

    def _n(self, area: float) -> int:
        return int(self.rng.poisson(max(area, 0.0) * self.density))

    def add(self, p: Array, part: str, instance: int | NDArray[np.int32] = 0, attic=False) -> None:
        p = np.asarray(p, dtype=np.float64).reshape(-1, 3)
        self.pts.append(p)
        self.inst.append(np.broadcast_to(np.asarray(instance, dtype=np.int32), len(p)).copy())
        self.attic.append(np.full(len(p), attic, dtype=bool))
        self.part.append(np.full(len(p), part, dtype="<U12"))

    # -- primitive surfaces ------------------------------------------------------------
    def cylinder(self, cx, cy, r, z0, z1, t0=0.0, t1=2 * np.pi) -> Array:
        n = self._n(r * (t1 - t0) * (z1 - z0))
        t = self.rng.uniform(t0, t1, n)
        return np.c_[cx + r * np.cos(t), cy + r * np.sin(t), self.rng.uniform(z0, z1, n)]

    def frustum(self, cx, cy, r0, r1, z0, z1, t0=0.0, t1=2 * np.pi) -> Array:
        slant = np.hypot(r1 - r0, z1 - z0)
        n = self._n((t1 - t0) * (r0 + r1) / 2 * slant)
        xi = self.rng.uniform(0, 1, n)
        if abs(r1 - r0) < 1e-9:
            u = xi
        else:  # area density grows with the radius: inverse CDF of pdf ~ r(u)
            u = (np.sqrt(r0**2 + (r1**2 - r0**2) * xi) - r0) / (r1 - r0)
        r = r0 + (r1 - r0) * u
        t = self.rng.uniform(t0, t1, n)
        return np.c_[cx + r * np.cos(t), cy + r * np.sin(t), z0 + (z1 - z0) * u]

    def annulus(self, cx, cy, r_in, r_out, z, t0=0.0, t1=2 * np.pi) -> Array:
        n = self._n((t1 - t0) / 2 * (r_out**2 - r_in**2))
        r = np.sqrt(self.rng.uniform(r_in**2, r_out**2, n))
        t = self.rng.uniform(t0, t1, n)
        return np.c_[cx + r * np.cos(t), cy + r * np.sin(t), np.full(n, z)]

    def hrect(self, x0, x1, y0, y1, z) -> Array:
        n = self._n((x1 - x0) * (y1 - y0))
        return np.c_[self.rng.uniform(x0, x1, n), self.rng.uniform(y0, y1, n), np.full(n, z)]

    def vrect(self, a, b, z0, z1) -> Array:
        """Vertical rectangle from XY point ``a`` to ``b`` between heights z0 and z1."""
        a, b = np.asarray(a, float), np.asarray(b, float)
        n = self._n(np.linalg.norm(b - a) * (z1 - z0))
        s = self.rng.uniform(0, 1, n)
        xy = a + np.outer(s, b - a)
        return np.c_[xy, self.rng.uniform(z0, z1, n)]

    def box(self, x0, x1, y0, y1, z0, z1, *, top=True, bottom=False, sides=True) -> Array:
        parts = []
        if sides:
            corners = [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]
            for i in range(4):
                parts.append(self.vrect(corners[i], corners[(i + 1) % 4], z0, z1))
        if top:
            parts.append(self.hrect(x0, x1, y0, y1, z1))
        if bottom:
            parts.append(self.hrect(x0, x1, y0, y1, z0))
        return np.vstack(parts) if parts else np.zeros((0, 3))

    def heightfield(self, x0, x1, y0, y1, fn: Callable[[Array, Array], Array]) -> Array:
        """Surface z = fn(x, y), sampled by area (rejection on the slope factor)."""
        # slope factor sqrt(1 + |grad z|^2) estimated on a probe grid
        gx, gy = np.meshgrid(np.linspace(x0, x1, 60), np.linspace(y0, y1, 60))
        h = 1e-3
        dzx = (fn(gx + h, gy) - fn(gx - h, gy)) / (2 * h)
        dzy = (fn(gx, gy + h) - fn(gx, gy - h)) / (2 * h)
        fmax = float(np.sqrt(1 + dzx**2 + dzy**2).max()) * 1.05
        n = self._n((x1 - x0) * (y1 - y0) * fmax)
        x, y = self.rng.uniform(x0, x1, n), self.rng.uniform(y0, y1, n)
        fx = (fn(x + h, y) - fn(x - h, y)) / (2 * h)
        fy = (fn(x, y + h) - fn(x, y - h)) / (2 * h)
        keep = self.rng.uniform(0, fmax, n) <= np.sqrt(1 + fx**2 + fy**2)
        return np.c_[x[keep], y[keep], fn(x[keep], y[keep])]

    def finish(self, noise_m: float) -> tuple[Array, NDArray[np.int32], NDArray[np.bool_], NDArray]:
        xyz = np.vstack(self.pts)
        xyz = xyz + self.rng.normal(0.0, noise_m, xyz.shape)
        return xyz, np.concatenate(self.inst), np.concatenate(self.attic), np.concatenate(self.part)


def _outside(p: Array, footprints: list[tuple[str, tuple[float, ...]]]) -> NDArray[np.bool_]:
    """Mask of points outside every footprint (``("disc", (cx, cy, r))`` or
    ``("rect", (x0, x1, y0, y1))``): floors and ceilings are not seen under solids."""
    keep = np.ones(len(p), dtype=bool)
    for kind, g in footprints:
        if kind == "disc":
            keep &= np.hypot(p[:, 0] - g[0], p[:, 1] - g[1]) > g[2]
        else:
            keep &= ~((p[:, 0] > g[0]) & (p[:, 0] < g[1]) & (p[:, 1] > g[2]) & (p[:, 1] < g[3]))
    return keep


class _Builder:
    """Scene assembly: supports with their reference rows (private helper)."""

    def __init__(self, s: _Sampler) -> None:
        self.s = s
        self.rows: list[dict] = []
        self.footprints: list[tuple[str, tuple[float, ...]]] = []

    def _new(self, cls: str, **kw: float) -> int:
        inst = len(self.rows) + 1
        self.rows.append({"instance": inst, "class": cls, **kw})
        return inst

    def column(self, cx, cy, r, z0, z1, *, capital=True, base=True, top_visible=False) -> int:
        """Column with a square plinth, a torus-like base ring, shaft, echinus and abacus."""
        s = self.s
        inst = self._new(
            "column", x=cx, y=cy, radius_m=r, width_m=2 * r, depth_m=2 * r, z_bottom=z0, z_top=z1
        )
        zs0, zs1 = z0, z1
        a = 1.3 * r
        if base:
            s.add(s.box(cx - a, cx + a, cy - a, cy + a, z0, z0 + 0.15, top=False), "column", inst)
            s.add(s.annulus(cx, cy, 1.2 * r, a, z0 + 0.15), "column", inst)
            top_ring = s.hrect(cx - a, cx + a, cy - a, cy + a, z0 + 0.15)
            s.add(top_ring[np.hypot(top_ring[:, 0] - cx, top_ring[:, 1] - cy) > a], "column", inst)
            s.add(s.cylinder(cx, cy, 1.2 * r, z0 + 0.15, z0 + 0.25), "column", inst)
            s.add(s.annulus(cx, cy, r, 1.2 * r, z0 + 0.25), "column", inst)
            zs0 = z0 + 0.25
        if capital:
            s.add(
                s.box(cx - a, cx + a, cy - a, cy + a, z1 - 0.15, z1, top=top_visible),
                "column",
                inst,
            )
            under = s.hrect(cx - a, cx + a, cy - a, cy + a, z1 - 0.15)
            s.add(under[np.hypot(under[:, 0] - cx, under[:, 1] - cy) > 1.25 * r], "column", inst)
            s.add(s.frustum(cx, cy, r, 1.25 * r, z1 - 0.35, z1 - 0.15), "column", inst)
            zs1 = z1 - 0.35
            self.footprints.append(("rect", (cx - a, cx + a, cy - a, cy + a)))
        else:
            if top_visible:
                s.add(s.annulus(cx, cy, 0.0, r, z1), "column", inst)
            self.footprints.append(("disc", (cx, cy, a if base else r)))
        s.add(s.cylinder(cx, cy, r, zs0, zs1), "column", inst)
        return inst

    def pier(self, cx, cy, w, d, z0, z1, *, capital=True, top_visible=False) -> int:
        s = self.s
        inst = self._new(
            "pier", x=cx, y=cy, radius_m=np.nan, width_m=w, depth_m=d, z_bottom=z0, z_top=z1
        )
        zt = z1 - 0.15 if capital else z1
        s.add(
            s.box(cx - w / 2, cx + w / 2, cy - d / 2, cy + d / 2, z0, zt, top=False), "pier", inst
        )
        if capital:
            c = 0.1
            box = s.box(
                cx - w / 2 - c,
                cx + w / 2 + c,
                cy - d / 2 - c,
                cy + d / 2 + c,
                zt,
                z1,
                top=top_visible,
                bottom=True,
            )
            inner = (np.abs(box[:, 0] - cx) < w / 2) & (np.abs(box[:, 1] - cy) < d / 2)
            s.add(box[~(inner & (np.abs(box[:, 2] - zt) < 1e-9))], "pier", inst)
        elif top_visible:
            s.add(s.hrect(cx - w / 2, cx + w / 2, cy - d / 2, cy + d / 2, z1), "pier", inst)
        c = 0.1 if capital else 0.0
        self.footprints.append(
            ("rect", (cx - w / 2 - c, cx + w / 2 + c, cy - d / 2 - c, cy + d / 2 + c))
        )
        return inst

    def engaged(self, cx, cy, r, z0, z1, facing: float) -> int:
        """Half-column on a wall face; ``facing`` is the direction (radians) into the room."""
        s = self.s
        inst = self._new(
            "engaged_column",
            x=cx,
            y=cy,
            radius_m=r,
            width_m=2 * r,
            depth_m=r,
            z_bottom=z0,
            z_top=z1,
        )
        t0, t1 = facing - np.pi / 2, facing + np.pi / 2
        s.add(s.cylinder(cx, cy, r, z0, z1 - 0.2, t0, t1), "engaged", inst)
        s.add(s.frustum(cx, cy, r, 1.3 * r, z1 - 0.2, z1, t0, t1), "engaged", inst)
        self.footprints.append(("disc", (cx, cy, r)))
        return inst

    def table(self) -> pd.DataFrame:
        return pd.DataFrame(self.rows)


def _floor(s: _Sampler, b: _Builder, x0, x1, y0, y1, z=0.0, part="floor") -> None:
    p = s.hrect(x0, x1, y0, y1, z)
    s.add(p[_outside(p, b.footprints)], part)


def _pavilion(s: _Sampler) -> tuple[_Builder, float]:
    b = _Builder(s)
    top = 4.0
    for x in (0.3, 4.1, 7.9, 11.7):
        for y in (0.3, 7.7):
            b.pier(x, y, 0.6, 0.6, 0.0, top)
    for x in (0.3, 11.7):
        b.pier(x, 4.0, 0.6, 0.6, 0.0, top)
    s.add(s.box(4.0, 8.0, 2.5, 5.5, 0.0, 0.4, top=False), "dais")
    for x, z0 in ((2.2, 0.0), (5.0, 0.4), (7.0, 0.4), (9.8, 0.0)):
        b.column(x, 4.0, 0.22, z0, top)
    _floor(s, b, -1.0, 13.0, -1.0, 9.0)
    dais_top = s.hrect(4.0, 8.0, 2.5, 5.5, 0.4)
    s.add(dais_top[_outside(dais_top, b.footprints)], "dais")
    # attic: entablature overhanging the piers by 0.6 m, soffit, hip roof
    x0, x1, y0, y1 = -0.6, 12.6, -0.6, 8.6
    s.add(s.box(x0, x1, y0, y1, top, top + 0.8, top=False), "entablature", attic=True)
    soffit = s.hrect(x0, x1, y0, y1, top)
    s.add(soffit[_outside(soffit, b.footprints)], "soffit", attic=True)

    def roof(x: Array, y: Array) -> Array:
        d = np.minimum(np.minimum(x - x0, x1 - x), np.minimum(y - y0, y1 - y))
        return top + 0.8 + 0.6 * np.clip(d, 0, None)

    s.add(s.heightfield(x0, x1, y0, y1, roof), "roof", attic=True)
    return b, top


def _temple(s: _Sampler) -> tuple[_Builder, float]:
    b = _Builder(s)
    st = 0.6  # stylobate height
    heights = [6.0, 6.0, 4.2, 6.0, 3.2, 6.0, 6.0, 5.1]
    k = 0
    for i in range(8):
        for j in range(4):
            if 0 < j < 3 and 0 < i < 7:
                continue
            h = heights[k % len(heights)]
            k += 1
            broken = h < 6.0
            b.column(
                1.5 + 3 * i, 1.5 + 3 * j, 0.4, st, st + h, capital=not broken, top_visible=True
            )
    # cella: low walls ending in two antae, two columns in antis
    b.pier(5.5, 3.9, 1.0, 0.8, st, st + 5.4, top_visible=True)
    b.pier(5.5, 8.1, 1.0, 0.8, st, st + 5.4, top_visible=True)
    for y in (5.3, 6.7):
        b.column(5.5, y, 0.3, st, st + 5.4, top_visible=True)
    wall_h = 1.0
    s.add(s.box(6.0, 19.0, 3.5, 4.3, st, st + wall_h), "wall")
    s.add(s.box(6.0, 19.0, 7.7, 8.5, st, st + wall_h), "wall")
    s.add(s.box(18.2, 19.0, 4.3, 7.7, st, st + wall_h), "wall")
    b.footprints.append(("rect", (6.0, 19.0, 3.5, 4.3)))
    b.footprints.append(("rect", (6.0, 19.0, 7.7, 8.5)))
    b.footprints.append(("rect", (18.2, 19.0, 4.3, 7.7)))
    # fallen drums lying on the stylobate
    for cx, cy in ((10.0, 10.4), (14.0, 1.9)):
        n = s._n(2 * np.pi * 0.4 * 1.0)
        t, u = s.rng.uniform(0, 2 * np.pi, n), s.rng.uniform(-0.5, 0.5, n)
        s.add(np.c_[cx + u, cy + 0.4 * np.cos(t), st + 0.4 + 0.4 * np.sin(t)], "drum")
    s.add(s.box(0.0, 24.0, 0.0, 12.0, 0.0, st, top=False), "stylobate")
    top = s.hrect(0.0, 24.0, 0.0, 12.0, st)
    s.add(top[_outside(top, b.footprints)], "stylobate")
    ground = s.hrect(-1.5, 25.5, -1.5, 13.5, 0.0)
    s.add(ground[_outside(ground, [("rect", (0.0, 24.0, 0.0, 12.0))])], "ground")
    return b, float("nan")


def _hall(s: _Sampler) -> tuple[_Builder, float]:
    b = _Builder(s)
    spring, rise, wall_h, t = 5.0, 1.5, 8.0, 0.6
    xs = (4.0, 8.0, 12.0, 16.0)
    ys = (10 / 3, 20 / 3)
    for x in xs:
        for y in ys:
            b.column(x, y, 0.3, 0.0, spring)
    for x in xs:
        b.engaged(x, 0.0, 0.25, 0.0, spring, np.pi / 2)
        b.engaged(x, 10.0, 0.25, 0.0, spring, -np.pi / 2)
    _floor(s, b, 0.0, 20.0, 0.0, 10.0)
    # walls: inner and outer faces, wall heads; inner faces hidden behind engaged columns
    for a, c in (((0, 0), (20, 0)), ((20, 0), (20, 10)), ((20, 10), (0, 10)), ((0, 10), (0, 0))):
        p = s.vrect(a, c, 0.0, wall_h)
        s.add(p[_outside(p, b.footprints) | (p[:, 2] > spring)], "wall")
    s.add(s.box(-t, 20 + t, -t, 10 + t, 0.0, wall_h, top=False), "wall")
    for y0, y1 in ((-t, 0.0), (10.0, 10 + t)):
        s.add(s.hrect(-t, 20 + t, y0, y1, wall_h), "wall")
    for x0, x1 in ((-t, 0.0), (20.0, 20 + t)):
        s.add(s.hrect(x0, x1, 0.0, 10.0, wall_h), "wall")
    bx = np.array([0.0, *xs, 20.0])
    by = np.array([0.0, *ys, 10.0])

    def vault(x: Array, y: Array) -> Array:
        i = np.clip(np.searchsorted(bx, x) - 1, 0, len(bx) - 2)
        j = np.clip(np.searchsorted(by, y) - 1, 0, len(by) - 2)
        u = (x - bx[i]) / (bx[i + 1] - bx[i])
        v = (y - by[j]) / (by[j + 1] - by[j])
        return spring + rise * (1 - (1 - np.sin(np.pi * u)) * (1 - np.sin(np.pi * v)))

    p = s.heightfield(0.0, 20.0, 0.0, 10.0, vault)
    s.add(p[_outside(p, b.footprints)], "vault")
    return b, float("nan")


def _choir(s: _Sampler) -> tuple[_Builder, float]:
    b = _Builder(s)
    ceil, r2 = 6.0, 0.17
    rail_y = 3.0
    # twin columns: two shafts on a shared plinth under a shared capital block
    for x in (4.0, 8.0, 12.0):
        ids = []
        for dx in (-0.24, 0.24):
            ids.append(
                b._new(
                    "column",
                    x=x + dx,
                    y=rail_y,
                    radius_m=r2,
                    width_m=2 * r2,
                    depth_m=2 * r2,
                    z_bottom=0.0,
                    z_top=ceil,
                )
            )
            s.add(s.cylinder(x + dx, rail_y, r2, 0.3, ceil - 0.3), "column", ids[-1])
        for z0, z1, top, bottom in ((0.0, 0.3, True, False), (ceil - 0.3, ceil, False, True)):
            blk = s.box(
                x - 0.5, x + 0.5, rail_y - 0.25, rail_y + 0.25, z0, z1, top=top, bottom=bottom
            )
            if top:  # plinth top, minus the shafts' footprints
                blk = blk[
                    _outside(
                        blk, [("disc", (x - 0.24, rail_y, r2)), ("disc", (x + 0.24, rail_y, r2))]
                    )
                    | (blk[:, 2] < z1 - 1e-9)
                ]
            if bottom:
                blk = blk[
                    _outside(
                        blk, [("disc", (x - 0.24, rail_y, r2)), ("disc", (x + 0.24, rail_y, r2))]
                    )
                    | (blk[:, 2] > z0 + 1e-9)
                ]
            s.add(blk, "column", np.where(blk[:, 0] < x, ids[0], ids[1]).astype(np.int32))
        b.footprints.append(("rect", (x - 0.5, x + 0.5, rail_y - 0.25, rail_y + 0.25)))
    for x in (4.0, 8.0, 12.0):
        b.column(x, 7.0, 0.25, 0.0, ceil)
    # iron fence on the twin row up to mid-height, touching the columns
    fence_top = 3.0
    for z in (0.1, 1.2, fence_top):
        n = s._n(2 * np.pi * 0.015 * 13.0)
        t, u = s.rng.uniform(0, 2 * np.pi, n), s.rng.uniform(0.5, 13.5, n)
        p = np.c_[u, rail_y + 0.015 * np.cos(t), z + 0.015 * np.sin(t)]
        s.add(p[_outside(p, b.footprints)], "fence")
    for x in np.arange(0.6, 13.5, 0.15):
        p = s.cylinder(x, rail_y, 0.008, 0.1, fence_top)
        s.add(p[_outside(p, b.footprints)], "fence")
    # chairs (a few lean on the single columns), a sign post next to a column
    chairs = [(x, y) for x in np.arange(1.5, 13.0, 0.8) for y in (5.0, 5.8)]
    chairs += [(8.0, 7.0 + 0.25 + 0.03 + 0.23), (4.0, 7.0 - 0.25 - 0.03 - 0.23)]
    for cx, cy in chairs:
        for lx in (-0.2, 0.2):
            for ly in (-0.2, 0.2):
                s.add(s.cylinder(cx + lx, cy + ly, 0.015, 0.0, 0.45), "chair")
        s.add(s.box(cx - 0.23, cx + 0.23, cy - 0.23, cy + 0.23, 0.43, 0.46, bottom=True), "chair")
        s.add(s.box(cx - 0.23, cx + 0.23, cy + 0.2, cy + 0.23, 0.46, 0.95), "chair")
    s.add(s.cylinder(12.45, 7.3, 0.03, 0.0, 1.8), "sign")
    s.add(s.box(12.3, 12.6, 7.25, 7.27, 1.4, 1.8), "sign")
    _floor(s, b, 0.0, 14.0, 0.0, 10.0)
    c = s.hrect(0.0, 14.0, 0.0, 10.0, ceil)
    s.add(c[_outside(c, b.footprints)], "ceiling")
    for a, e in (((0, 0), (14, 0)), ((14, 0), (14, 10)), ((14, 10), (0, 10))):
        s.add(s.vrect(a, e, 0.0, 7.0), "wall")
    for a, e in (
        ((0, -0.5), (14.5, -0.5)),
        ((14.5, -0.5), (14.5, 10.5)),
        ((14.5, 10.5), (0, 10.5)),
    ):
        s.add(s.vrect(a, e, 0.0, 7.0), "wall")
    return b, float("nan")


_BUILDERS: dict[str, Callable[[_Sampler], tuple[_Builder, float]]] = {
    "pavilion": _pavilion,
    "temple": _temple,
    "hall": _hall,
    "choir": _choir,
}


def building_scene(
    kind: str,
    *,
    spacing_m: float = 0.05,
    noise_m: float = 0.005,
    rng: np.random.Generator | int | None = 0,
) -> BuildingScene:
    """Generate one building scene with reference labels.

    Parameters
    ----------
    kind
        One of ``"pavilion"``, ``"temple"``, ``"hall"``, ``"choir"``.
    spacing_m
        Mean point spacing on surfaces, metres (density ``1 / spacing^2`` per m^2).
        0.02 m gives about 3.5 M points for the hall.
    noise_m
        Standard deviation of the isotropic Gaussian noise, metres.
    rng
        Seed or generator.

    Examples
    --------
    >>> scene = building_scene("pavilion", spacing_m=0.15, rng=1)
    >>> sorted(scene.supports["class"].unique().tolist())
    ['column', 'pier']
    """
    if kind not in _BUILDERS:
        raise ValueError(f"kind must be one of {', '.join(SCENES)}; got {kind!r}")
    if not spacing_m > 0 or noise_m < 0:
        raise ValueError("spacing_m must be > 0 and noise_m >= 0")
    gen = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
    sampler = _Sampler(gen, 1.0 / spacing_m**2)
    builder, attic_base = _BUILDERS[kind](sampler)
    xyz, inst, attic, part = sampler.finish(noise_m)
    return BuildingScene(
        name=kind,
        xyz=xyz,
        instance=inst,
        attic=attic,
        part=part,
        supports=builder.table(),
        attic_base_m=attic_base,
        params={"spacing_m": spacing_m, "noise_m": noise_m},
    )
