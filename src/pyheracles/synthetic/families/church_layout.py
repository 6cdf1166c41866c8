"""The building of a ``church`` family draw: nave, aisles, apse, tower, openings, furniture.

Plan frame (metres): the nave runs along +x from its west gable (outer face
at x = 0) to its east wall (x = L), centred on y = 0; the floor is z = 0.
Walls are listed counter-clockwise so that the inside is on their left.
The building goes into a :class:`~pyheracles.synthetic.scene.Scene` with
one instance per wall, window light, door, roof, furniture item; the true
window geometry is recorded in ``scene.objects``
(:func:`~pyheracles.synthetic.families.church_geometry.add_wall`).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import shapely
from numpy.typing import NDArray
from shapely.geometry import Polygon, box

from pyheracles.synthetic.families.church_geometry import Opening, Wall, add_wall, wall_object
from pyheracles.synthetic.families.church_openings import arch, bay_windows, door, window_lights
from pyheracles.synthetic.families.church_site import (
    InstanceCounter,
    Terrain,
    add_furniture,
    make_terrain,
)
from pyheracles.synthetic.scene import GROUND, PLASTER, STONE, Scene

if TYPE_CHECKING:
    from pyheracles.synthetic.families.church import ChurchFamilyParams

__all__ = ["ChurchPlan", "build_church", "heights"]

Array = NDArray[np.float64]


@dataclass
class ChurchPlan:
    """What the acquisitions need to know about the built church.

    Attributes
    ----------
    scene
        The labelled surfaces so far (targets and gravestones are added later).
    footprint
        Outer plan outline of the whole building (tower included).
    floor_free
        Floor areas inside that are free of furniture (tripods, stations).
    aisle_line
        ``(x0, x1)`` of the central aisle of the nave (stations go there).
    walls
        The walls built.
    terrain
        The ground outside.
    heights
        Eaves, ridge, ceiling heights, metres.
    counts
        Windows per shape, leaded lights, doors.
    """

    scene: Scene
    footprint: Polygon
    floor_free: list[Polygon]
    aisle_line: tuple[float, float]
    walls: list[Wall]
    terrain: Terrain
    heights: dict[str, float] = field(default_factory=dict)
    counts: dict[str, int] = field(default_factory=dict)
    inner_polygons: list[Polygon] = field(default_factory=list)


# ----------------------------------------------------------------------------- openings
# ----------------------------------------------------------------------------- walls
def _gable(length: float, eaves: float, ridge: float) -> tuple[tuple[float, float], ...]:
    return ((length, eaves), (length / 2, ridge), (0.0, eaves))


def _flat(length: float, z: float) -> tuple[tuple[float, float], ...]:
    return ((length, z), (0.0, z))


def _bays(u0: float, u1: float, n: int) -> list[tuple[float, float]]:
    e = np.linspace(u0, u1, n + 1)
    return [(float(a), float(b)) for a, b in itertools.pairwise(e)]


def _door_sides(p: ChurchFamilyParams) -> list[str]:
    """Where the doors go, in order of preference (south first, the west gable if free)."""
    order = ["south", *(["west"] if p.tower != "west" else []), "north", "south"]
    return order[: p.n_doors]


def _side_openings(
    p: ChurchFamilyParams,
    rng: np.random.Generator,
    ids: InstanceCounter,
    u_bays: list[tuple[float, float]],
    n_doors: int,
    z_range: tuple[float, float],
    door_top: float,
    thickness: float,
    blocked: tuple[float, float] | None = None,
) -> list[Opening]:
    """Doors and windows of a side wall, one window per bay (bays behind a tower stay blank)."""
    usable = [
        k
        for k, (a, b) in enumerate(u_bays)
        if blocked is None or b < blocked[0] - 0.3 or a > blocked[1] + 0.3
    ]
    if not usable:
        return []
    doors: dict[int, Opening] = {}
    first = usable[int(rng.integers(0, min(2, len(usable))))]
    for j in range(n_doors):  # the first door near the west end, a second one further east
        k = first if j == 0 else usable[-1 - int(rng.integers(0, min(2, len(usable))))]
        if k not in doors:
            doors[k] = door(p, rng, ids, sum(u_bays[k]) / 2, door_top, thickness)
    bays = [u_bays[k] if k in usable else (u_bays[k][0], u_bays[k][0]) for k in range(len(u_bays))]
    return bay_windows(p, rng, ids, bays, z_range, thickness, doors)


def _nave_walls(
    p: ChurchFamilyParams,
    rng: np.random.Generator,
    ids: InstanceCounter,
    z_bottom: float,
    h: dict[str, float],
) -> list[Wall]:
    L, W, t = p.nave_length_m, p.nave_width_m, p.wall_thickness_m
    H, Hr = h["eaves"], h["ridge"]
    walls = []
    bays = _bays(t, L - t, p.n_bays)
    sides = _door_sides(p)
    tower_x = (t + 0.5, t + 0.5 + p.tower_size_m) if p.tower == "south" else None
    for side in ("south", "north"):
        if side == "south":
            p0, p1 = (0.0, -W / 2), (L, -W / 2)
            u_bays = bays
            blocked = tower_x
        else:
            p0, p1 = (L, W / 2), (0.0, W / 2)
            u_bays = [(L - b, L - a) for a, b in bays][::-1]
            blocked = None
        openings: list[Opening] = []
        if p.aisles:
            # arcade below, clerestory above the aisle roof (the doors are in the aisles)
            pier = float(rng.uniform(0.6, 1.1))
            top = h["aisle_ceiling"] - 0.4
            for a, b in u_bays:
                if (b - a) - pier > 1.0:
                    openings.append(arch((a + b) / 2, (b - a) - pier, top, p.window_style))
            clere = (h["aisle_roof_top"] + 0.4, H - 0.4)
            if clere[1] - clere[0] >= 1.0:
                openings += bay_windows(p, rng, ids, u_bays, clere, t, {})
        else:
            openings = _side_openings(
                p, rng, ids, u_bays, sides.count(side), (1.6, H - 0.5), H - 1.0, t, blocked
            )
        walls.append(
            Wall(
                side,
                p0,
                p1,
                t,
                (t, L - t),
                z_bottom,
                _flat(L, H),
                0.0,
                H,
                tuple(openings),
                ids(),
                STONE,
                PLASTER,
            )
        )
    # gables: west (door, windows unless a west tower) and east (windows unless an apse)
    for side, p0, p1 in (("east", (L, -W / 2), (L, W / 2)), ("west", (0.0, W / 2), (0.0, -W / 2))):
        openings = []
        if side == "east" and p.apse:
            r_in = h["apse_inner_radius"]
            width = 2 * r_in - 2 * float(rng.uniform(0.2, 0.5))
            openings.append(arch(W / 2, width, min(h["apse_eaves"], H) - 0.6, p.window_style))
        elif not (side == "west" and p.tower == "west"):
            lo = 1.6
            if side == "west" and "west" in sides:
                west_door = door(p, rng, ids, W / 2, H - 1.0, t)
                openings.append(west_door)
                lo = west_door.top_m + 0.6
            if p.n_gable_windows > 0 and H - 0.5 - lo >= 0.8:
                g_bays = _bays(t, W - t, p.n_gable_windows)
                openings += bay_windows(p, rng, ids, g_bays, (lo, H - 0.5), t, {})
        walls.append(
            Wall(
                side,
                p0,
                p1,
                t,
                (t, W - t),
                z_bottom,
                _gable(W, H, Hr),
                0.0,
                H,
                tuple(openings),
                ids(),
                STONE,
                PLASTER,
            )
        )
    return walls


def _aisle_walls(
    p: ChurchFamilyParams,
    rng: np.random.Generator,
    ids: InstanceCounter,
    z_bottom: float,
    h: dict[str, float],
) -> list[Wall]:
    L, W, t, Wa = p.nave_length_m, p.nave_width_m, p.wall_thickness_m, p.aisle_width_m
    He, Ht = h["aisle_eaves"], h["aisle_roof_top"]
    bays = _bays(t, L - t, p.n_bays)
    sides = _door_sides(p)
    walls = []
    for sign, side in ((-1.0, "south"), (1.0, "north")):
        yo = sign * (W / 2 + Wa)
        yn = sign * W / 2
        if side == "south":
            outer = ((0.0, yo), (L, yo))
            u_bays = bays
            east = ((L, yo), (L, yn), (t, Wa), ((Wa, Ht), (0.0, He)))
            west = ((0.0, yn), (0.0, yo), (0.0, Wa - t), ((Wa, He), (0.0, Ht)))
        else:
            outer = ((L, yo), (0.0, yo))
            u_bays = [(L - b, L - a) for a, b in bays][::-1]
            east = ((L, yn), (L, yo), (0.0, Wa - t), ((Wa, He), (0.0, Ht)))
            west = ((0.0, yo), (0.0, yn), (t, Wa), ((Wa, Ht), (0.0, He)))
        openings = _side_openings(
            p, rng, ids, u_bays, sides.count(side), (1.4, He - 0.4), He - 0.8, t
        )
        walls.append(
            Wall(
                f"{side}_aisle",
                outer[0],
                outer[1],
                t,
                (t, L - t),
                z_bottom,
                _flat(L, He),
                0.0,
                He,
                tuple(openings),
                ids(),
                STONE,
                PLASTER,
            )
        )
        for name, (q0, q1, iu, top) in ((f"{side}_aisle_east", east), (f"{side}_aisle_west", west)):
            walls.append(
                Wall(name, q0, q1, t, iu, z_bottom, top, 0.0, He, (), ids(), STONE, PLASTER)
            )
    return walls


def _apse_walls(
    p: ChurchFamilyParams,
    rng: np.random.Generator,
    ids: InstanceCounter,
    z_bottom: float,
    h: dict[str, float],
) -> tuple[list[Wall], Array, Array]:
    """Facets of a polygonal apse on the east wall; returns walls, outer and inner vertices."""
    L, t, n = p.nave_length_m, p.wall_thickness_m, p.apse_facets
    R = h["apse_radius"]
    c = np.cos(np.pi / (2 * n))
    r_in = (R * c - t) / c
    theta = np.linspace(-np.pi / 2, np.pi / 2, n + 1)
    P = np.column_stack([L + R * np.cos(theta), R * np.sin(theta)])
    Q = np.column_stack([L + r_in * np.cos(theta), r_in * np.sin(theta)])
    He = h["apse_eaves"]
    walls = []
    for k in range(n):
        p0, p1 = P[k], P[k + 1]
        u = (p1 - p0) / np.linalg.norm(p1 - p0)
        iu = (float((Q[k] - p0) @ u), float((Q[k + 1] - p0) @ u))
        length = float(np.linalg.norm(p1 - p0))
        openings: list[Opening] = []
        if length > 1.6 and (n == 3 or k % 2 == 1 or n <= 5):
            openings = window_lights(
                p,
                rng,
                ids,
                length / 2,
                min(iu[1] - iu[0], length) - 0.9 - 2 * p.splay_m,
                (1.6, He - 0.5),
                t,
            )
        walls.append(
            Wall(
                f"apse_{k}",
                (float(p0[0]), float(p0[1])),
                (float(p1[0]), float(p1[1])),
                t,
                iu,
                z_bottom,
                _flat(length, He),
                0.0,
                He,
                tuple(openings),
                ids(),
                STONE,
                PLASTER,
            )
        )
    return walls, P, Q


# ----------------------------------------------------------------------------- roofs, floors
def _add_flat(scene: Scene, poly: Polygon, z: float, **ref: Any) -> None:
    scene.add_prism(poly, [0.0, 0.0, z], np.eye(3), 0.0, faces="front", sides=False, **ref)


def _roofs(
    scene: Scene,
    p: ChurchFamilyParams,
    ids: InstanceCounter,
    h: dict[str, float],
    apse_outer: Array | None,
) -> None:
    L, W = p.nave_length_m, p.nave_width_m
    ov = 0.35
    tan = np.tan(np.deg2rad(p.roof_pitch_deg))
    H, Hr = h["eaves"], h["ridge"]
    ref = {"instance": ids(), "class_name": "roof", "part": "slope", "material": STONE}
    scene.objects.append(
        {
            "instance": ref["instance"],
            "class": "roof",
            "kind": "gable",
            "eaves_m": H,
            "ridge_m": Hr,
            "pitch_deg": p.roof_pitch_deg,
            "overhang_m": ov,
        }
    )
    for s in (-1.0, 1.0):
        y_e = s * (W / 2 + ov)
        z_e = H - ov * tan
        scene.add_quad(
            [[-ov, y_e, z_e], [L + ov, y_e, z_e], [L + ov, 0.0, Hr], [-ov, 0.0, Hr]], **ref
        )
    if p.aisles:
        Wa, He, Ht = p.aisle_width_m, h["aisle_eaves"], h["aisle_roof_top"]
        ta = (Ht - He) / Wa
        ref = {"instance": ids(), "class_name": "roof", "part": "lean_to", "material": STONE}
        scene.objects.append(
            {
                "instance": ref["instance"],
                "class": "roof",
                "kind": "lean_to",
                "eaves_m": He,
                "top_m": Ht,
                "overhang_m": ov,
            }
        )
        for s in (-1.0, 1.0):
            y_e = s * (W / 2 + Wa + ov)
            z_e = He - ov * ta
            scene.add_quad(
                [
                    [-ov, y_e, z_e],
                    [L + ov, y_e, z_e],
                    [L + ov, s * W / 2, Ht],
                    [-ov, s * W / 2, Ht],
                ],
                **ref,
            )
    if apse_outer is not None:
        He = h["apse_eaves"]
        R = h["apse_radius"]
        apex = np.array([L, 0.0, He + R * tan])
        d = apse_outer - np.array([L, 0.0])
        rad = d / np.linalg.norm(d, axis=1, keepdims=True)
        c = np.cos(np.pi / (2 * p.apse_facets))
        eave = apse_outer + rad * ov / c
        e3 = np.column_stack([eave, np.full(len(eave), He - ov * tan)])
        tris = np.stack([e3[:-1], e3[1:], np.broadcast_to(apex, e3[1:].shape)], axis=1)
        inst = ids()
        scene.add_triangles(
            tris, instance=inst, class_name="roof", part="apse_roof", material=STONE
        )
        scene.objects.append(
            {
                "instance": inst,
                "class": "roof",
                "kind": "half_pyramid",
                "eaves_m": He,
                "apex_m": apex.tolist(),
                "overhang_m": ov,
            }
        )


def _tower(
    scene: Scene, p: ChurchFamilyParams, ids: InstanceCounter, z_bottom: float, h: dict[str, float]
) -> Polygon | None:
    if p.tower == "none":
        return None
    S, W, t = p.tower_size_m, p.nave_width_m, p.wall_thickness_m
    if p.tower == "west":
        x0, y0 = -S, -S / 2
    else:
        x0, y0 = t + 0.5, -W / 2 - S
    top = h["tower_top"]
    fp = box(x0, y0, x0 + S, y0 + S)
    c = np.asarray(fp.exterior.coords)[:-1]
    inst = ids()
    for i in range(4):
        a, b = c[i], c[(i + 1) % 4]
        scene.add_quad(
            [[*a, z_bottom], [*b, z_bottom], [*b, top], [*a, top]],
            instance=inst,
            class_name="tower",
            part="face",
            material=STONE,
        )
    apex = [x0 + S / 2, y0 + S / 2, top + S * h["spire_ratio"]]
    ring = np.column_stack([c, np.full(4, top)])
    tris = np.stack([ring, np.roll(ring, -1, axis=0), np.broadcast_to(apex, ring.shape)], axis=1)
    scene.add_triangles(tris, instance=inst, class_name="tower", part="spire", material=STONE)
    scene.objects.append(
        {
            "instance": inst,
            "class": "tower",
            "box": [x0, y0, x0 + S, y0 + S],
            "top_m": top,
            "spire_apex_m": apex,
        }
    )
    return fp


# ----------------------------------------------------------------------------- building
def heights(p: ChurchFamilyParams) -> dict[str, float]:
    """Eaves, ridge, aisle and apse heights implied by the parameters."""
    W = p.nave_width_m
    tan = np.tan(np.deg2rad(p.roof_pitch_deg))
    h = {"eaves": p.nave_height_m}
    if p.aisles:
        he = p.aisle_height_m
        top = he + p.aisle_width_m * np.tan(np.deg2rad(18.0))
        h.update(aisle_eaves=he, aisle_ceiling=he, aisle_roof_top=float(top))
        h["eaves"] = float(max(p.nave_height_m, top + 2.6))
    h["ridge"] = float(h["eaves"] + W / 2 * tan)
    if p.apse:
        R = p.apse_ratio * W / 2
        c = np.cos(np.pi / (2 * p.apse_facets))
        h.update(
            apse_radius=float(R),
            apse_inner_radius=float((R * c - p.wall_thickness_m) / c),
            apse_eaves=float(max(h["eaves"] - 1.0, 4.5)),
        )
    h["tower_top"] = float(h["ridge"] + 2.0 + p.tower_size_m)
    h["spire_ratio"] = 1.2
    return h


def build_church(
    p: ChurchFamilyParams, rng: np.random.Generator
) -> tuple[ChurchPlan, InstanceCounter]:
    """Build the church of resolved parameters ``p`` (every field drawn) into a new scene."""
    scene = Scene()
    ids = InstanceCounter()
    h = heights(p)
    L, W, t = p.nave_length_m, p.nave_width_m, p.wall_thickness_m
    g0 = -float(rng.uniform(0.05, 0.4))  # ground at the walls, below the floor
    z_bottom = g0 - 3.0 * p.ground_relief_m - p.ground_slope * 40.0 - 1.0
    walls = _nave_walls(p, rng, ids, z_bottom, h)
    body = [box(0.0, -W / 2, L, W / 2)]
    inner = [box(t, -W / 2 + t, L - t, W / 2 - t)]
    if p.aisles:
        walls += _aisle_walls(p, rng, ids, z_bottom, h)
        Wa = p.aisle_width_m
        body.append(box(0.0, -W / 2 - Wa, L, W / 2 + Wa))
        inner += [box(t, -W / 2 - Wa + t, L - t, -W / 2), box(t, W / 2, L - t, W / 2 + Wa - t)]
    apse_outer = None
    if p.apse:
        aw, apse_outer, apse_inner = _apse_walls(p, rng, ids, z_bottom, h)
        walls += aw
        body.append(Polygon(apse_outer))
        inner.append(Polygon(apse_inner))
    counts = {"windows": 0, "leaded": 0, "doors": 0, "rect": 0, "round": 0, "pointed": 0}
    for w in walls:  # tens of walls
        scene.objects.append(wall_object(w))
        for obj in add_wall(scene, w):
            scene.objects.append(obj)
            if obj["class"] == "window":
                counts["windows"] += 1
                counts[obj["shape"]] += 1
                counts["leaded"] += int(obj["leaded"])
            else:
                counts["doors"] += 1
    body_poly = shapely.union_all(body)
    # floor over the whole body (hidden under the walls), ceilings over each inner space
    inst = ids()
    _add_flat(
        scene, body_poly, 0.0, instance=inst, class_name="floor", part="floor", material=STONE
    )
    scene.objects.append(
        {"instance": inst, "class": "floor", "plane": {"normal": [0, 0, 1], "d": 0.0}}
    )
    inst = ids()
    ceil_h = [h["eaves"]]
    _add_flat(
        scene,
        inner[0],
        h["eaves"],
        instance=inst,
        class_name="ceiling",
        part="nave",
        material=PLASTER,
    )
    if p.aisles:
        for poly in inner[1:3]:
            _add_flat(
                scene,
                poly,
                h["aisle_ceiling"],
                instance=inst,
                class_name="ceiling",
                part="aisle",
                material=PLASTER,
            )
        ceil_h.append(h["aisle_ceiling"])
    if p.apse:
        _add_flat(
            scene,
            inner[-1],
            h["apse_eaves"],
            instance=inst,
            class_name="ceiling",
            part="apse",
            material=PLASTER,
        )
        ceil_h.append(h["apse_eaves"])
    scene.objects.append({"instance": inst, "class": "ceiling", "heights_m": ceil_h})
    _roofs(scene, p, ids, h, apse_outer)
    tower = _tower(scene, p, ids, z_bottom, h)
    footprint = body_poly if tower is None else shapely.union_all([body_poly, tower])
    free, aisle_line = add_furniture(scene, p, rng, ids, h, inner)
    if p.aisles:
        free += [
            box(t + 0.5, -W / 2 - p.aisle_width_m + t + 0.4, L - t - 0.5, -W / 2 - 0.3),
            box(t + 0.5, W / 2 + 0.3, L - t - 0.5, W / 2 + p.aisle_width_m - t - 0.4),
        ]
    margin = 22.0
    terrain = make_terrain(p, rng, footprint, margin, g0)
    inst = ids()
    scene.add_heightfield(
        terrain.x,
        terrain.y,
        terrain.z,
        instance=inst,
        class_name="ground",
        part="ground",
        material=GROUND,
    )
    scene.objects.append({"instance": inst, "class": "ground", "level_at_walls_m": g0})
    plan = ChurchPlan(scene, footprint, free, aisle_line, walls, terrain, h, counts, inner)
    return plan, ids
