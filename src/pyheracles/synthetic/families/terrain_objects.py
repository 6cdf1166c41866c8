"""Objects on the ``terrain`` family's relief: buildings, walls, cars, bridges, water, vegetation.

Every builder adds its triangles to the :class:`~pyheracles.synthetic.scene.Scene` with its
reference (class, instance, part) and returns one ``scene.objects`` entry per object with
its true primitive.  An :class:`Occupancy` grid keeps objects apart (no car inside a
building, no building in the river).

Vegetation is built for airborne LiDAR: a tree crown is a porous shell (a pulse records a
return on its top and on its underside and goes on) with leaf clumps inside and an
optional opaque core (dense foliage no pulse passes), on a trunk; a shrub is a low porous
dome (0.5-2 m: its returns merge with the ground's within the pulse length, as with real
low vegetation).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from pyheracles.synthetic.families.terrain_relief import Relief, heightfield_triangles
from pyheracles.synthetic.scene import FOLIAGE, METAL, PLASTER, STONE, TIMBER, Material, Scene

__all__ = [
    "DENSE_FOLIAGE",
    "Occupancy",
    "add_bridges",
    "add_buildings",
    "add_cars",
    "add_shrubs",
    "add_trees",
    "add_walls",
    "add_water",
    "rect_samples",
    "vegetation_mask",
]

Array = NDArray[np.float64]

#: Foliage so dense that no pulse passes (the core of a crown).
DENSE_FOLIAGE = Material("dense_foliage", 0.45)


def _frame(heading_rad: float) -> Array:
    c, s = np.cos(heading_rad), np.sin(heading_rad)
    return np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])


def rect_samples(
    centre: Array, size: tuple[float, float], heading_rad: float, step_m: float = 1.0
) -> Array:
    """``(K, 2)`` points covering a rotated rectangle (edges included) every ``step_m``."""
    nu = max(2, int(np.ceil(size[0] / step_m)) + 1)
    nv = max(2, int(np.ceil(size[1] / step_m)) + 1)
    u, v = np.meshgrid(
        np.linspace(-size[0] / 2, size[0] / 2, nu), np.linspace(-size[1] / 2, size[1] / 2, nv)
    )
    c, s = np.cos(heading_rad), np.sin(heading_rad)
    return np.column_stack(
        [centre[0] + u.ravel() * c - v.ravel() * s, centre[1] + u.ravel() * s + v.ravel() * c]
    )


@dataclass
class Occupancy:
    """Which grid vertices are taken (by water, buildings, bridges, walls, cars)."""

    relief: Relief
    taken: NDArray[np.bool_]
    lo: float  # usable area: [lo, hi] in x and y
    hi: float

    def ij(self, xy: Array) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
        c = self.relief.cell_m
        j = np.clip(
            np.round((xy[:, 0] - self.relief.x[0]) / c).astype(int), 0, len(self.relief.x) - 1
        )
        i = np.clip(
            np.round((xy[:, 1] - self.relief.y[0]) / c).astype(int), 0, len(self.relief.y) - 1
        )
        return i, j

    def free(self, xy: Array) -> bool:
        """Whether every sample lies inside the usable area on free ground."""
        if (xy < self.lo).any() or (xy > self.hi).any():
            return False
        i, j = self.ij(xy)
        return not self.taken[i, j].any()

    def take(self, xy: Array) -> None:
        """Mark the samples' vertices as taken."""
        i, j = self.ij(xy)
        self.taken[i, j] = True


def _place(
    occ: Occupancy,
    rng: np.random.Generator,
    size: tuple[float, float],
    buffer_m: float,
    max_slope_tan: float,
    tries: int = 60,
) -> tuple[Array, float, Array] | None:
    """A free, not too steep spot for a rectangle: (centre, heading, footprint samples)."""
    for _ in range(tries):
        centre = rng.uniform(occ.lo, occ.hi, 2)
        heading = rng.uniform(0, np.pi)
        big = rect_samples(centre, (size[0] + 2 * buffer_m, size[1] + 2 * buffer_m), heading)
        if not occ.free(big):
            continue
        foot = rect_samples(centre, size, heading)
        lo, hi = occ.relief.footprint_range(foot)
        if hi - lo > max_slope_tan * max(size) + 0.3:
            continue
        occ.take(big)
        return centre, heading, foot
    return None


def add_buildings(
    scene: Scene,
    relief: Relief,
    occ: Occupancy,
    rng: np.random.Generator,
    n: int,
    max_size_m: float,
    first_instance: int,
) -> list[dict[str, Any]]:
    """Rectangular buildings with flat or gabled roofs; the first is ``max_size_m`` long."""
    objects = []
    for k in range(n):
        length = max_size_m if k == 0 else rng.uniform(8.0, max(8.0, max_size_m))
        width = min(40.0, max(6.0, length * rng.uniform(0.35, 1.0)))
        got = _place(
            occ, rng, (length, width), 3.0, np.tan(np.deg2rad(20)), tries=300 if k == 0 else 60
        )  # the largest is worth searching for
        if got is None:
            continue
        centre, heading, foot = got
        base, top = relief.footprint_range(foot)
        height = rng.uniform(3.0, 20.0) if length < 40 else rng.uniform(5.0, 14.0)
        eaves = top + height
        inst = first_instance + len(objects)
        ref = {"instance": inst, "class_name": "building", "material": PLASTER}
        R = _frame(heading)
        zc = (base - 0.5 + eaves) / 2
        gable = rng.random() < 0.5
        faces = ("-x", "+x", "-y", "+y") if gable else ("-x", "+x", "-y", "+y", "+z")
        scene.add_box(
            [*centre, zc],
            [length, width, eaves - base + 0.5],
            frame=R,
            faces=faces,
            part="wall",
            **ref,
        )
        pitch = 0.0
        if gable:
            pitch = float(rng.uniform(15, 45))
            ridge = eaves + width / 2 * np.tan(np.deg2rad(pitch))
            c3 = np.array([*centre, 0.0])
            hl, hw = length / 2, width / 2

            def at(a: float, b: float, z: float, c3=c3, R=R) -> Array:
                return c3 + a * R[0] + b * R[1] + np.array([0.0, 0.0, z])

            for side in (-1, 1):
                scene.add_quad(
                    [
                        at(-hl, side * hw, eaves),
                        at(hl, side * hw, eaves),
                        at(hl, 0, ridge),
                        at(-hl, 0, ridge),
                    ],
                    part="roof",
                    **ref,
                )
            for end in (-1, 1):
                scene.add_triangles(
                    [[at(end * hl, -hw, eaves), at(end * hl, hw, eaves), at(end * hl, 0, ridge)]],
                    part="wall",
                    **ref,
                )
        objects.append(
            {
                "instance": inst,
                "class": "building",
                "box": {
                    "center": [*centre.tolist(), zc],
                    "size": [length, width, eaves - base + 0.5],
                    "heading_deg": float(np.rad2deg(heading)),
                },
                "roof": "gable" if gable else "flat",
                "pitch_deg": pitch,
                "height_m": float(height),
                "terrain_z": [base, top],
            }
        )
    return objects


def add_walls(
    scene: Scene,
    relief: Relief,
    occ: Occupancy,
    rng: np.random.Generator,
    n: int,
    first_instance: int,
) -> list[dict[str, Any]]:
    """Free-standing walls (1-3 m high, 10-60 m long) whose top follows the terrain."""
    objects = []
    for _ in range(n):
        length = rng.uniform(10.0, 60.0)
        thick = rng.uniform(0.3, 0.6)
        height = rng.uniform(1.0, 3.0)
        got = _place(occ, rng, (length, thick), 1.0, np.tan(np.deg2rad(35)))
        if got is None:
            continue
        centre, heading, _ = got
        inst = first_instance + len(objects)
        u = np.array([np.cos(heading), np.sin(heading)])
        v = np.array([-u[1], u[0]])
        m = max(2, int(np.ceil(length / 1.0)) + 1)
        s = np.linspace(-length / 2, length / 2, m)
        axis = centre + s[:, None] * u
        zt = relief.height(axis)
        pts = {}
        for side in (-1, 1):
            xy = axis + side * thick / 2 * v
            pts[side] = (np.column_stack([xy, zt - 0.5]), np.column_stack([xy, zt + height]))
        tris = []
        for side in (-1, 1):
            lo, hi = pts[side]
            tris += [
                np.stack([lo[:-1], lo[1:], hi[1:]], 1),
                np.stack([lo[:-1], hi[1:], hi[:-1]], 1),
            ]
        hl, hr = pts[-1][1], pts[1][1]
        tris += [np.stack([hl[:-1], hl[1:], hr[1:]], 1), np.stack([hl[:-1], hr[1:], hr[:-1]], 1)]
        for e in (0, -1):
            tris.append(
                np.array(
                    [
                        [pts[-1][0][e], pts[1][0][e], pts[1][1][e]],
                        [pts[-1][0][e], pts[1][1][e], pts[-1][1][e]],
                    ]
                )
            )
        scene.add_triangles(
            np.concatenate(tris), instance=inst, class_name="wall", part="wall", material=STONE
        )
        objects.append(
            {
                "instance": inst,
                "class": "wall",
                "segment": [axis[0].tolist(), axis[-1].tolist()],
                "thickness_m": float(thick),
                "height_above_terrain_m": float(height),
            }
        )
    return objects


def add_cars(
    scene: Scene,
    relief: Relief,
    occ: Occupancy,
    rng: np.random.Generator,
    n: int,
    first_instance: int,
) -> list[dict[str, Any]]:
    """Cars (boxes 4.2-4.9 x 1.7-1.9 x 1.4-1.6 m) on gentle ground."""
    objects = []
    for _ in range(n):
        size = (rng.uniform(4.2, 4.9), rng.uniform(1.7, 1.9))
        h = rng.uniform(1.4, 1.6)
        got = _place(occ, rng, size, 0.5, np.tan(np.deg2rad(10)))
        if got is None:
            continue
        centre, heading, foot = got
        base, top = relief.footprint_range(foot)
        inst = first_instance + len(objects)
        zc = (base - 0.2 + top + h) / 2
        scene.add_box(
            [*centre, zc],
            [size[0], size[1], top + h - base + 0.2],
            frame=_frame(heading),
            faces=("-x", "+x", "-y", "+y", "+z"),
            instance=inst,
            class_name="car",
            part="body",
            material=METAL,
        )
        objects.append(
            {
                "instance": inst,
                "class": "car",
                "box": {
                    "center": [*centre.tolist(), zc],
                    "size": [size[0], size[1], top + h - base + 0.2],
                    "heading_deg": float(np.rad2deg(heading)),
                },
            }
        )
    return objects


def add_water(
    scene: Scene, relief: Relief, first_instance: int, material: Material
) -> tuple[NDArray[np.bool_], list[dict[str, Any]]]:
    """The water surface of the river (cells whose four corners are under water).

    Returns the mask of water cells ``(ny - 1, nx - 1)`` (the terrain leaves them out) and
    the water's object entry.
    """
    ny, nx = relief.z.shape
    if relief.river is None:
        return np.zeros((ny - 1, nx - 1), bool), []
    w = relief.river.water_z
    wet = np.isfinite(w)
    cells = wet[:-1, :-1] & wet[1:, :-1] & wet[:-1, 1:] & wet[1:, 1:]
    if not cells.any():
        return cells, []
    tris = heightfield_triangles(relief.x, relief.y, np.nan_to_num(w), cells)
    scene.add_triangles(
        tris, instance=first_instance, class_name="water", part="surface", material=material
    )
    zw = w[wet]
    obj = {
        "instance": first_instance,
        "class": "water",
        "surface": "river",
        "level_z": [float(zw.min()), float(zw.max())],
        "area_m2": float(cells.sum() * relief.cell_m**2),
    }
    return cells, [obj]


def add_bridges(
    scene: Scene,
    relief: Relief,
    occ: Occupancy,
    rng: np.random.Generator,
    n: int,
    first_instance: int,
) -> list[dict[str, Any]]:
    """Bridge decks over the river cut (with parapets, and piers on long spans).

    Placed before anything else takes the ground (the water included).
    """
    river = relief.river
    if river is None or n <= 0:
        return []
    line = river.centreline
    inside = np.flatnonzero((line >= occ.lo + 10).all(1) & (line <= occ.hi - 10).all(1))
    if len(inside) < 10:
        return []
    objects = []
    span = river.width_m + 2 * river.depth_m / np.tan(np.deg2rad(river.bank_deg))
    for _ in range(n * 4):
        if len(objects) >= n:
            break
        k = int(rng.choice(inside[5:-5]))
        t = line[min(k + 3, len(line) - 1)] - line[max(k - 3, 0)]
        t /= np.linalg.norm(t)
        across = np.array([-t[1], t[0]])
        length = span + 2 * rng.uniform(3.0, 8.0)
        width = rng.uniform(4.0, 12.0)
        heading = float(np.arctan2(across[1], across[0]))
        centre = line[k]
        ends = centre + np.outer([-length / 2, length / 2], across)
        ze = relief.height(ends)
        if abs(ze[0] - ze[1]) > 2.0:
            continue
        if not occ.free(rect_samples(centre, (length, width + 2), heading)):
            continue
        occ.take(rect_samples(centre, (length, width + 6), heading))
        inst = first_instance + len(objects)
        thick = rng.uniform(0.6, 1.4)
        top = float(ze.max()) + 0.2
        R = _frame(heading)
        ref = {"instance": inst, "class_name": "bridge", "material": STONE}
        scene.add_box(
            [*centre, top - thick / 2],
            [length, width, thick],
            frame=R,
            faces=("-x", "+x", "-y", "+y", "+z"),
            part="deck",
            **ref,
        )
        for side in (-1, 1):
            pc = centre + side * (width / 2 - 0.15) * R[1, :2]
            scene.add_box([*pc, top + 0.5], [length, 0.3, 1.0], frame=R, part="parapet", **ref)
        n_piers = int(length // 20)
        for q in range(1, n_piers + 1):
            pc = centre + (-length / 2 + q * length / (n_piers + 1)) * across
            zb = float(relief.height(pc[None])[0]) - 1.0
            scene.add_box(
                [*pc, (zb + top - thick) / 2],
                [1.2, width * 0.8, top - thick - zb],
                frame=R,
                faces=("-x", "+x", "-y", "+y"),
                part="pier",
                **ref,
            )
        objects.append(
            {
                "instance": inst,
                "class": "bridge",
                "deck": {
                    "center": [*centre.tolist(), top - thick / 2],
                    "size": [length, width, thick],
                    "heading_deg": float(np.rad2deg(heading)),
                },
                "piers": n_piers,
            }
        )
    return objects


def vegetation_mask(
    relief: Relief, rng: np.random.Generator, cover: float, slope_bias: float
) -> NDArray[np.bool_]:
    """Patches covering ``cover`` of the area, more likely on slopes (per grid vertex)."""
    if cover <= 0:
        return np.zeros(relief.z.shape, bool)
    c = relief.cell_m
    f = ndimage.gaussian_filter(rng.normal(size=relief.z.shape), sigma=max(1.0, 12.0 / c))
    f = (f - f.mean()) / max(f.std(), 1e-12)
    gy, gx = np.gradient(relief.z, c)
    sl = np.hypot(gx, gy)
    f = f + slope_bias * np.clip(sl / np.tan(np.deg2rad(30)), 0, 1.5)
    return f >= np.quantile(f, 1 - cover)


def _ellipsoid_template(segments: int, upper_only: bool = False) -> Array:
    """Unit-sphere triangles ``(T, 3, 3)`` (a dome if ``upper_only``)."""
    n_th = segments // 2
    th = np.linspace(0, np.pi / 2 if upper_only else np.pi, (n_th // 2 if upper_only else n_th) + 1)
    ph = np.linspace(0, 2 * np.pi, segments + 1)
    T, P = np.meshgrid(th, ph, indexing="ij")
    pts = np.stack([np.sin(T) * np.cos(P), np.sin(T) * np.sin(P), np.cos(T)], -1)
    a, b, c, d = pts[:-1, :-1], pts[:-1, 1:], pts[1:, 1:], pts[1:, :-1]
    tris = np.concatenate(
        [np.stack([a, b, c], -2).reshape(-1, 3, 3), np.stack([a, c, d], -2).reshape(-1, 3, 3)]
    )
    area = np.linalg.norm(np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]), axis=1)
    return tris[area > 1e-9]


def _spots(
    mask: NDArray[np.bool_],
    relief: Relief,
    occ: Occupancy,
    spacing_m: float,
    rng: np.random.Generator,
) -> Array:
    """Jittered-grid positions ``(K, 2)`` inside ``mask`` on free ground."""
    lo, hi = occ.lo, occ.hi
    g = np.arange(lo, hi, spacing_m)
    X, Y = np.meshgrid(g, g)
    p = np.column_stack([X.ravel(), Y.ravel()]) + rng.uniform(-0.4, 0.4, (X.size, 2)) * spacing_m
    p = p[((p >= lo) & (p <= hi)).all(1)]
    i, j = occ.ij(p)
    return p[mask[i, j] & ~occ.taken[i, j]]


def add_trees(
    scene: Scene,
    relief: Relief,
    occ: Occupancy,
    rng: np.random.Generator,
    mask: NDArray[np.bool_],
    core_share: float,
    first_instance: int,
    segments: int = 14,
) -> list[dict[str, Any]]:
    """Trees in the ``mask`` patches: porous crowns with leaf clumps and an opaque core.

    ``segments`` tessellates the crown shell (fewer for sparse scans: fewer triangles).
    """
    spacing = rng.uniform(4.0, 9.0)
    xy = _spots(mask, relief, occ, spacing, rng)
    n = len(xy)
    if n == 0:
        return []
    zg = relief.height(xy)
    h = rng.uniform(5.0, 30.0, n)
    r = np.clip(h * rng.uniform(0.15, 0.3, n), 1.5, 0.75 * spacing + 1.0)
    rv = np.clip(r * rng.uniform(0.8, 1.6, n), 1.0, 0.45 * h)
    cz = zg + h - rv
    centres = np.column_stack([xy, cz])
    shell = _ellipsoid_template(segments)
    radii = np.column_stack([r, r, rv])
    jitter = rng.uniform(0.8, 1.1, (n, len(shell), 1, 1))
    crowns = centres[:, None, None, :] + shell[None] * radii[:, None, None, :] * jitter
    keep = rng.random((n, len(shell))) >= rng.uniform(0.05, 0.35, (n, 1))  # gaps in the crown
    inst = first_instance + np.arange(n)
    _add_many(scene, crowns, keep, inst, "vegetation", "crown", FOLIAGE)
    # leaf clumps inside the crown
    m = 10
    u = rng.normal(size=(n, m, 3))
    u /= np.linalg.norm(u, axis=2, keepdims=True)
    pos = centres[:, None] + u * rng.random((n, m, 1)) ** (1 / 3) * radii[:, None] * 0.9
    leaf = rng.normal(size=(n, m, 3, 3)) * 0.35
    _add_many(
        scene,
        pos[:, :, None, :] + leaf,
        np.ones((n, m), bool),
        inst,
        "vegetation",
        "leaves",
        FOLIAGE,
    )
    if core_share > 0:
        core = _ellipsoid_template(6)
        cores = centres[:, None, None, :] + core[None] * (radii * core_share)[:, None, None, :]
        _add_many(
            scene, cores, np.ones((n, len(core)), bool), inst, "vegetation", "core", DENSE_FOLIAGE
        )
    # trunks: square prisms from below the ground to the crown centre
    tw = np.clip(h * 0.02, 0.15, 0.5)
    sq = np.array([[1, 1], [-1, 1], [-1, -1], [1, -1], [1, 1]], float)
    tris = []
    for q in range(4):
        a = np.column_stack([xy + sq[q] * tw[:, None], zg - 0.3])
        b = np.column_stack([xy + sq[q + 1] * tw[:, None], zg - 0.3])
        c = np.column_stack([xy + sq[q + 1] * tw[:, None], cz])
        d = np.column_stack([xy + sq[q] * tw[:, None], cz])
        tris += [np.stack([a, b, c], 1)[:, None], np.stack([a, c, d], 1)[:, None]]
    _add_many(
        scene, np.concatenate(tris, 1), np.ones((n, 8), bool), inst, "vegetation", "trunk", TIMBER
    )
    return [
        {
            "instance": int(inst[k]),
            "class": "vegetation",
            "kind": "tree",
            "crown": {"center": centres[k].tolist(), "radii": radii[k].tolist()},
            "height_m": float(h[k]),
            "ground_z": float(zg[k]),
        }
        for k in range(n)
    ]


def add_shrubs(
    scene: Scene,
    relief: Relief,
    occ: Occupancy,
    rng: np.random.Generator,
    mask: NDArray[np.bool_],
    first_instance: int,
) -> list[dict[str, Any]]:
    """Low shrubs (0.5-2 m high, 0.6-2.5 m radius): porous domes in the ``mask`` patches."""
    spacing = rng.uniform(2.0, 4.5)
    xy = _spots(mask, relief, occ, spacing, rng)
    n = len(xy)
    if n == 0:
        return []
    zg = relief.height(xy)
    h = rng.uniform(0.5, 2.0, n)
    r = np.minimum(rng.uniform(0.6, 2.5, n), 0.6 * spacing + 0.3)
    dome = _ellipsoid_template(10, upper_only=True)
    radii = np.column_stack([r, r, h + 0.3])
    base = np.column_stack([xy, zg - 0.3])
    tris = base[:, None, None, :] + dome[None] * radii[:, None, None, :] * rng.uniform(
        0.85, 1.1, (n, len(dome), 1, 1)
    )
    inst = first_instance + np.arange(n)
    _add_many(scene, tris, np.ones((n, len(dome)), bool), inst, "low_vegetation", "shrub", FOLIAGE)
    return [
        {
            "instance": int(inst[k]),
            "class": "low_vegetation",
            "kind": "shrub",
            "dome": {
                "base": [*xy[k].tolist(), float(zg[k])],
                "radius_m": float(r[k]),
                "height_m": float(h[k]),
            },
        }
        for k in range(n)
    ]


def _add_many(
    scene: Scene,
    tris: Array,
    keep: NDArray[np.bool_],
    instances: NDArray[np.int64],
    class_name: str,
    part: str,
    material: Material,
) -> None:
    """Add ``(n, T, 3, 3)`` triangles of ``n`` objects at once, one instance each."""
    n, t = tris.shape[:2]
    inst = np.broadcast_to(instances[:, None], (n, t))[keep]
    flat = tris[keep]
    # one call per instance would be slow: add by runs of equal instance through the scene's
    # triangle API, grouping triangles of the same instance together
    order = np.argsort(inst, kind="stable")
    inst, flat = inst[order], flat[order]
    cuts = np.flatnonzero(np.diff(inst)) + 1
    for chunk, ids in zip(np.split(flat, cuts), np.split(inst, cuts), strict=True):
        scene.add_triangles(
            chunk, instance=int(ids[0]), class_name=class_name, part=part, material=material
        )
