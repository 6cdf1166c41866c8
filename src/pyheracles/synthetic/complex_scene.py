"""A walled heritage complex with ground truth: cloud, GIS layers and reference labels.

The scene imitates the Kasepuhan palace of Cirebon (Indonesia), the heritage
complex of Murtiyoso (2020), chapter 5: an enclosure of low brick walls with
split gates (*candi bentar*) and roofed gates (*paduraksa*), an elevated
terrace (*Siti Inggil*) with open pavilions (*mande*, *pendopo*: columns under
hipped or pyramidal roofs), closed buildings, a main building around an inner
courtyard, a row of rooms sharing party walls, trees whose crowns overhang
roofs and walls, and street furniture, all on uneven ground (a slope plus
smooth hills, about 4 m of relief).

The layout is built as labelled surfaces
(:class:`~pyheracles.synthetic.scene.Scene`) and scanned through the one scan
simulator by an airborne LiDAR survey (:data:`KASEPUHAN_SURVEY`): roofs and
open ground at full density, facades and wall faces as the scan angle
shows them, nothing under closed roofs, several returns per pulse in the tree
crowns (porous foliage, with ground below them), no returns from the pond.
This makes the demo the ``layout="kasepuhan"`` member of the ``complex``
scene family (:mod:`pyheracles.synthetic.families.complex`).  The GIS layers
``building``, ``wall`` and ``gate`` are "roughly digitised": every outline is
shifted by 0.1-0.3 m, its vertices jittered by a few centimetres and
simplified, as if drawn on an orthophoto.

Known layout facts that the tests rely on:

* ``building`` holds a MultiPolygon (twin pavilions ``B08``), a polygon with
  a hole (main building around a courtyard ``B11``), a row of four buildings
  whose polygons touch (``B13``-``B16``), a demolished building with no point
  in the cloud (``B20``, now a pond: no returns inside and 1 m around it) and
  a building cut by the survey edge (``B19``, partly outside the cloud).
* ``gate`` holds MultiPolygons too (the two halves of each split gate).
* Internal walls abut the perimeter wall and the gates (touching polygons).

Scaling: the layout is fixed (about 140 m x 200 m); ``n_points`` only sets the
density (the strips are flown for it and the tile thinned to the exact
count), so ``n_points=10_000_000`` is the same complex at about 360 points
per m^2 (a dense drone survey).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import geopandas as gpd
import numpy as np
import pandas as pd
import pyproj
import shapely
from numpy.typing import NDArray
from shapely import affinity
from shapely.geometry import LineString, Polygon, box
from shapely.ops import unary_union

from pyheracles.cloud import PointCloud
from pyheracles.errors import InputError
from pyheracles.synthetic.families.complex_build import add_crown, add_terrain, plan_strips
from pyheracles.synthetic.families.simulation import Simulation
from pyheracles.synthetic.kasepuhan_layout import BUILDINGS, GATES, TREES_FIXED, WALLS, Gate
from pyheracles.synthetic.kasepuhan_mesh import (
    BURY_M,
    CLUTTER,
    COLUMN,
    FACADE,
    FLOOR,
    GATE,
    ROOF,
    TREE,
    WALL,
    SceneMesh,
    expand_rect,
    ground_height,
    rect_ring,
    ring_band,
    ring_ground,
    ring_with_z,
)
from pyheracles.synthetic.scanner import ScanResult, scan
from pyheracles.synthetic.scene import METAL, PLASTER, STONE, TIMBER, Scene

__all__ = [
    "KASEPUHAN_SURVEY",
    "ComplexScene",
    "ComplexSceneParams",
    "kasepuhan_scene",
    "kasepuhan_simulation",
    "write_scene",
]

#: Layers of the GIS, in instance-numbering order.
LAYERS = ("building", "wall", "gate")


_EXTENT_M = (140.0, 200.0)  # survey extent (local x, y), metres
#: The airborne survey of the demo (its density set by ``n_points``): two strips flown
#: 8 deg north of east with 50 % side overlap and a +-30 deg scan, about 315 m above the
#: ground, so every point is seen from two sides; walls running east-west show both faces,
#: walls running north-south mostly their tops.  (8 deg, not 0: the scan lines of a
#: flight exactly parallel to a wall meet it at the same angles on every line.)
KASEPUHAN_SURVEY: dict[str, Any] = {
    "n_strips": 2, "overlap": 0.5, "heading_deg": 8.0, "half_fov_deg": 30.0,
}  # fmt: skip
_SURVEY = KASEPUHAN_SURVEY


@dataclass(frozen=True)
class ComplexSceneParams:
    """Parameters of :func:`kasepuhan_scene`.

    Attributes
    ----------
    n_points
        Exact number of points in the cloud.  The layout is fixed, so this sets
        the density (400 000 points give about 14 points per m^2).
    noise_m
        Standard deviation of the range noise (along the laser beam), metres.
    seed
        Seed of the random generator (trees, clutter, digitising errors, scan).
    facade_weight, column_weight
        No longer used (still validated, so that old calls run): the airborne
        scan decides how densely facades and columns are seen (scan angle,
        occlusion under the eaves).
    crown_penetration
        Share of the pulses through a tree crown that reach what lies below
        (sets the share of opaque twigs among the leaves).
    digitising_offset_m
        Range of the shift of each digitised outline, metres (orthophoto
        misregistration plus drawing error).
    digitising_jitter_m
        Amplitude of the per-vertex drawing error, metres.
    simplify_m
        Tolerance of the simplification of the digitised outlines, metres.
    origin_en
        UTM 49S (EPSG:32749) easting and northing of the complex centre.
    base_height_m
        Ellipsoidal height of the lowest terrain, metres.
    """

    n_points: int = 400_000
    noise_m: float = 0.02
    seed: int = 0
    facade_weight: float = 0.35
    column_weight: float = 0.6
    crown_penetration: float = 0.3
    digitising_offset_m: tuple[float, float] = (0.1, 0.3)
    digitising_jitter_m: float = 0.04
    simplify_m: float = 0.1
    origin_en: tuple[float, float] = (215_000.0, 9_253_000.0)
    base_height_m: float = 6.0


@dataclass(frozen=True, eq=False)
class ComplexScene:
    """A generated complex: the cloud, its GIS layers and the reference labels.

    Attributes
    ----------
    cloud
        The point cloud in EPSG:32749.
    layers
        ``{"building", "wall", "gate"}`` -> GeoDataFrame (EPSG:32749) with the
        columns ``fid``, ``name``, ``function``, ``period`` and layer-specific ones.
    reference_instance
        ``(N,)`` int32 reference object of each point (0 = none: ground, trees,
        street furniture).
    reference_objects
        One row per GIS feature: ``instance`` (>= 1), ``layer``, ``fid``,
        ``feature_index`` (row in its layer), ``name``, ``n_points``.
    ground
        ``(N,)`` bool, True for points on the terrain.
    extent
        The surveyed area (EPSG:32749): no point lies outside it, and the
        building ``B19`` crosses its eastern edge.
    """

    cloud: PointCloud
    layers: dict[str, gpd.GeoDataFrame]
    reference_instance: NDArray[np.int32]
    reference_objects: pd.DataFrame
    ground: NDArray[np.bool_]
    extent: Polygon = field(default_factory=Polygon)


# ----------------------------------------------------------------------------- scene
def _build_buildings(mesh: SceneMesh, owner_of: dict[str, int], rng: np.random.Generator):
    """Meshes of all buildings; returns the true (roof outline) footprint of each."""
    footprints: dict[str, Any] = {}
    for b in BUILDINGS:  # a few dozen buildings, not points
        owner = owner_of[b.fid]
        roofs = []
        for part in b.parts:
            rect = rect_ring(*part.rect)
            w, s, e, n = part.eaves_m
            roof_rect = expand_rect(rect, w, s, e, n)
            roofs.append(box(*roof_rect[0], *roof_rect[2]))
            if b.kind == "demolished":
                continue
            z_low, z_mid = ring_ground(roof_rect)
            if b.kind in ("pendopo", "round"):
                # raised platform (umpak), floor, columns, roof
                floor = z_mid + 0.45
                plat = expand_rect(rect, 0.3, 0.3, 0.3, 0.3)
                mesh.prism(plat, z_low - BURY_M, floor, owner, FACADE, top_kind=FLOOR)
                z_eave = floor + part.eave_height_m
                (x0, y0), (x1, y1) = rect[0], rect[2]
                nx = max(2, round((x1 - x0) / 2.5) + 1)
                ny = max(2, round((y1 - y0) / 2.5) + 1)
                gx, gy = np.meshgrid(np.linspace(x0, x1, nx), np.linspace(y0, y1, ny))
                edge = (gx == x0) | (gx == x1) | (gy == y0) | (gy == y1)
                gx, gy = gx[edge], gy[edge]
                octagon = 0.14 * np.column_stack(
                    [np.cos(np.arange(8) * np.pi / 4), np.sin(np.arange(8) * np.pi / 4)]
                )
                rings = [octagon + np.array([cx, cy]) for cx, cy in zip(gx, gy, strict=True)]
                cols = [ring_band(ring_with_z(r, floor), ring_with_z(r, z_eave)) for r in rings]
                mesh.add(np.concatenate(cols), owner, COLUMN)
                if b.kind == "round":
                    ang = np.arange(12) * np.pi / 6
                    c = rect.mean(axis=0)
                    ring = c + 4.8 * np.column_stack([np.cos(ang), np.sin(ang)])
                    mesh.cone(ring, z_eave, 3.0, owner)
                    roofs[-1] = Polygon(ring)
                else:
                    mesh.roof(roof_rect, z_eave, part.roof, owner)
            else:
                floor = z_mid + 0.3
                mesh.prism(
                    rect, z_low - BURY_M, floor + part.eave_height_m, owner, FACADE, top=False
                )
                mesh.roof(roof_rect, floor + part.eave_height_m, part.roof, owner)
        geom = unary_union(roofs)
        footprints[b.fid] = geom
    return footprints


def _gate_parts(g: Gate) -> list[NDArray[np.float64]]:
    cx, cy = g.centre
    if g.gate_type == "candi bentar":
        half_w = 0.8
        offs = g.opening_m / 2 + half_w
        centres = [(-offs, 0.0), (offs, 0.0)]
        size = (half_w, g.depth_m / 2)
    else:
        centres = [(0.0, 0.0)]
        size = (g.width_m / 2, g.depth_m / 2)
    rects = []
    for ox, oy in centres:
        if g.along_x:
            rects.append(
                rect_ring(
                    cx + ox - size[0], cy + oy - size[1], cx + ox + size[0], cy + oy + size[1]
                )
            )
        else:
            rects.append(
                rect_ring(cx - size[1], cy + ox - size[0], cx + size[1], cy + ox + size[0])
            )
    return rects


def _build_gates(mesh: SceneMesh, owner_of: dict[str, int]) -> dict[str, Any]:
    footprints: dict[str, Any] = {}
    for g in GATES:
        owner = owner_of[g.fid]
        rects = _gate_parts(g)
        for rect in rects:
            z_low, z_mid = ring_ground(rect)
            if g.gate_type == "candi bentar":
                # stepped, tapering half-towers
                levels = [
                    (0.0, 1.3, 1.0),
                    (1.3, 2.7, 0.86),
                    (2.7, 3.9, 0.72),
                    (3.9, 5.0, 0.56),
                    (5.0, 5.9, 0.38),
                ]
                c = rect.mean(axis=0)
                for z0, z1, s in levels:
                    ring = c + (rect - c) * s
                    zb = z_low - BURY_M if z0 == 0.0 else z_mid + z0
                    mesh.prism(ring, zb, z_mid + z1, owner, GATE)
            else:
                mesh.prism(rect, z_low - BURY_M, z_mid + 3.2, owner, GATE, top=False)
                roof_rect = expand_rect(rect, 0.3, 0.3, 0.3, 0.3)
                mesh.roof(roof_rect, z_mid + 3.2, "pyramid", owner, GATE)
        footprints[g.fid] = unary_union([box(*r[0], *r[2]) for r in rects])
    return footprints


def _build_walls(mesh: SceneMesh, owner_of: dict[str, int]) -> dict[str, Any]:
    footprints: dict[str, Any] = {}
    for w in WALLS:
        line = np.array(w.line)
        mesh.wall(line, w.thickness_m, w.height_m, owner_of[w.fid], caps=w.free_ends)
        footprints[w.fid] = LineString(line).buffer(
            w.thickness_m / 2, cap_style="flat", join_style="mitre"
        )
    return footprints


def _place_trees(rng: np.random.Generator, obstacles: Any) -> NDArray[np.float64]:
    """Fixed trees plus random ones in open ground: rows (x, y, z_centre, r, r_z)."""
    cand = np.column_stack(
        [
            rng.uniform(3.0, _EXTENT_M[0] - 3.0, 80),
            rng.uniform(3.0, _EXTENT_M[1] - 3.0, 80),
            rng.uniform(2.5, 4.5, 80),
            rng.uniform(2.5, 4.0, 80),
        ]
    )
    free = ~shapely.intersects_xy(obstacles.buffer(2.0), cand[:, 0], cand[:, 1])
    extra = cand[free][:18]
    trees = np.vstack([TREES_FIXED, extra])
    zg = ground_height(trees[:, 0], trees[:, 1])
    rz = 0.7 * trees[:, 2]
    return np.column_stack([trees[:, 0], trees[:, 1], zg + trees[:, 3] + rz, trees[:, 2], rz])


def _build_trunks(mesh: SceneMesh, crowns: NDArray[np.float64]) -> None:
    ang = np.arange(8) * np.pi / 4
    unit = np.column_stack([np.cos(ang), np.sin(ang)])
    parts = []
    for cx, cy, cz, _r, rz in crowns:
        zg = float(ground_height(np.array([cx]), np.array([cy]))[0])
        ring = unit * 0.25 + (cx, cy)
        parts.append(ring_band(ring_with_z(ring, zg - BURY_M), ring_with_z(ring, cz - 0.5 * rz)))
    mesh.add(np.concatenate(parts), 0, TREE)


def _build_clutter(mesh: SceneMesh, rng: np.random.Generator, obstacles: Any) -> None:
    """Benches, lamp posts, planters and a few parked cars in open ground."""
    n = 120
    xy = np.column_stack(
        [rng.uniform(2.0, _EXTENT_M[0] - 2.0, n), rng.uniform(2.0, _EXTENT_M[1] - 2.0, n)]
    )
    near = shapely.intersects_xy(obstacles.buffer(4.0), xy[:, 0], xy[:, 1])
    clear = ~shapely.intersects_xy(obstacles.buffer(1.2), xy[:, 0], xy[:, 1])
    # prefer spots close to (but not on) buildings and walls: where clutter confuses a clip
    keep = np.flatnonzero(near & clear)[:40]
    kinds = rng.integers(0, 4, len(keep))
    for (x, y), k in zip(xy[keep], kinds, strict=True):
        zg = float(ground_height(np.array([x]), np.array([y]))[0])
        if k == 0:  # bench
            ring, h = rect_ring(x - 0.8, y - 0.25, x + 0.8, y + 0.25), 0.45
        elif k == 1:  # lamp post
            ring, h = rect_ring(x - 0.08, y - 0.08, x + 0.08, y + 0.08), 3.5
        elif k == 2:  # planter
            ring, h = rect_ring(x - 0.5, y - 0.5, x + 0.5, y + 0.5), 0.8
        else:  # parked car
            ring, h = rect_ring(x - 2.2, y - 0.9, x + 2.2, y + 0.9), 1.0
        mesh.prism(ring, zg - 0.1, zg + h, 0, CLUTTER)
        if k == 3:
            cab = rect_ring(x - 1.0, y - 0.8, x + 0.9, y + 0.8)
            mesh.prism(cab, zg + h, zg + h + 0.5, 0, CLUTTER, scale_top=0.85)


def _digitise(
    footprints: dict[str, Any], params: ComplexSceneParams, rng: np.random.Generator
) -> dict[str, Any]:
    """Simulate digitising on an orthophoto: shift, per-vertex jitter, simplification.

    Features drawn together (the row of rooms, the walls with their gates)
    share one shift, and the jitter is a smooth function of position, so
    shared vertices move identically and touching outlines stay touching.
    """
    lo, hi = params.digitising_offset_m
    phase = rng.uniform(0, 2 * np.pi, 4)
    amp = params.digitising_jitter_m

    def shift() -> NDArray[np.float64]:
        ang = rng.uniform(0, 2 * np.pi)
        return rng.uniform(lo, hi) * np.array([np.cos(ang), np.sin(ang)])

    groups = {fid: fid for fid in footprints}
    for fid in ("B13", "B14", "B15", "B16"):
        groups[fid] = "row"
    for fid in [w.fid for w in WALLS] + [g.fid for g in GATES]:
        groups[fid] = "enclosure"
    shifts = {g: shift() for g in sorted(set(groups.values()))}
    out = {}
    for fid, geom in footprints.items():
        d = shifts[groups[fid]]

        def move(c: NDArray[np.float64], d: NDArray[np.float64] = d) -> NDArray[np.float64]:
            jx = (
                amp
                * np.sin(0.37 * c[:, 0] + 0.23 * c[:, 1] + phase[0])
                * np.cos(0.11 * c[:, 1] + phase[1])
            )
            jy = (
                amp
                * np.sin(0.29 * c[:, 1] - 0.31 * c[:, 0] + phase[2])
                * np.cos(0.13 * c[:, 0] + phase[3])
            )
            return c + d + np.column_stack([jx, jy])

        moved = shapely.transform(geom, move)
        out[fid] = shapely.simplify(moved, params.simplify_m, preserve_topology=True)
    return out


def _validate(params: ComplexSceneParams) -> None:
    seed = params.seed
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise InputError(
            f"seed must be a whole number >= 0, got {params.seed!r}", hint="e.g. --seed 0"
        )
    if params.n_points < 1000:
        raise InputError(f"n_points must be at least 1000, got {params.n_points}")
    if not (params.noise_m >= 0 and np.isfinite(params.noise_m)):
        raise InputError(f"noise_m must be finite and >= 0, got {params.noise_m}")
    for name in ("facade_weight", "column_weight", "crown_penetration"):
        v = getattr(params, name)
        if not 0 <= v <= 1:
            raise InputError(f"{name} must be in [0, 1], got {v}")


#: Part name, material and class (for owner 0) of each surface kind.
_KIND_REF = {
    ROOF: ("roof", TIMBER),
    FACADE: ("facade", PLASTER),
    WALL: ("wall", STONE),
    GATE: ("gate", STONE),
    COLUMN: ("column", TIMBER),
    FLOOR: ("platform", STONE),
    TREE: ("trunk", TIMBER),
    CLUTTER: ("clutter", METAL),
}


def _to_scene(
    mesh: SceneMesh,
    layer_of: dict[int, str],
    crowns: NDArray[np.float64],
    pond: Any,
    params: ComplexSceneParams,
    rng: np.random.Generator,
) -> Scene:
    """The mesh as a labelled :class:`Scene`: terrain (a hole for the pond), objects, trees."""
    scene = Scene()
    for name in ("ground", *LAYERS, "tree", "clutter"):
        scene.class_code(name)
    add_terrain(scene, ground_height, (0.0, 0.0, *_EXTENT_M), cell_m=1.0, holes=pond)
    tris, owner, kind, _group = mesh.arrays()
    for o in np.unique(owner):  # a few dozen owners, each with a handful of kinds
        for k in np.unique(kind[owner == o]):
            sel = (owner == o) & (kind == k)
            part, material = _KIND_REF[int(k)]
            if o > 0:
                cls = layer_of[int(o)]
            else:
                cls = "tree" if k == TREE else "clutter"
            scene.add_triangles(
                tris[sel], instance=int(o), class_name=cls, part=part, material=material
            )
    for cx, cy, cz, r, rz in crowns:
        add_crown(scene, (cx, cy, cz), r, rz, rng, penetration=params.crown_penetration)
    return scene


def _survey(
    scene: Scene, params: ComplexSceneParams, rng: np.random.Generator
) -> tuple[ScanResult, dict[str, Any]]:
    """Airborne strips over the extent; exactly ``params.n_points`` points of the tile.

    The strips are flown for slightly more first returns than points wanted
    (the multiple returns in the crowns add more) and the tile is thinned at
    random to the exact count (the points keep their acquisition order).
    """
    bounds = (0.0, 0.0, *_EXTENT_M)
    x1, y1 = _EXTENT_M

    def fly(density: float) -> tuple[ScanResult, dict[str, Any]]:
        sv, plan = plan_strips(bounds, noise_m=params.noise_m, density_per_m2=density,
                               **_SURVEY)  # fmt: skip
        res = scan(scene, sv, rng=rng)
        x, y = res.xyz[:, 0], res.xyz[:, 1]
        return res.subset((x >= 0) & (x < x1) & (y >= 0) & (y < y1)), plan

    density = 1.02 * params.n_points / (x1 * y1)
    for _attempt in range(4):  # flies again, denser, in the unlikely case it fell short
        res, plan = fly(density)
        if len(res) >= params.n_points:
            break
        density *= 1.05 * params.n_points / max(len(res), 1)
    else:  # pragma: no cover - the first flight gives a few per cent more points
        raise RuntimeError("could not fly enough points")
    keep = np.zeros(len(res), bool)
    keep[rng.choice(len(res), params.n_points, replace=False)] = True
    plan = {**plan, "flown_density_per_m2": density, "points_flown": len(res)}
    return res.subset(keep), plan


def _kasepuhan_world(params: ComplexSceneParams) -> tuple[NDArray[np.float64], pyproj.CRS]:
    offset = np.array(
        [
            params.origin_en[0] - _EXTENT_M[0] / 2,
            params.origin_en[1] - _EXTENT_M[1] / 2,
            params.base_height_m,
        ]
    )
    return offset, pyproj.CRS("EPSG:32749")


def kasepuhan_simulation(params: ComplexSceneParams | None = None) -> Simulation:
    """The demo complex as a member of the ``complex`` scene family.

    Builds the fixed layout as labelled surfaces and scans them with the
    airborne simulator (:data:`KASEPUHAN_SURVEY`); see :func:`kasepuhan_scene`
    for what the layout holds.  ``draw(seed, layout="kasepuhan")`` of
    :mod:`pyheracles.synthetic.families.complex` returns this.

    Returns
    -------
    Simulation
        Family ``complex``, the seed of ``params``, one cloud ``"cloud"`` of
        exactly ``params.n_points`` points (local frame; EPSG:32749 with
        ``sim.offset``) and ``extras`` as the family's (``layers``,
        ``reference_objects``, ``extent``, ``write_extras``).
    """
    from pyheracles.synthetic.families.complex import write_layers

    params = params or ComplexSceneParams()
    _validate(params)
    rng = np.random.default_rng(params.seed)

    # instance numbering: building, wall, gate features in layer order
    layer_fids = {
        "building": [b.fid for b in BUILDINGS],
        "wall": [w.fid for w in WALLS],
        "gate": [g.fid for g in GATES],
    }
    fids = [fid for name in LAYERS for fid in layer_fids[name]]
    owner_of = {fid: i + 1 for i, fid in enumerate(fids)}
    layer_of = {owner_of[fid]: name for name in LAYERS for fid in layer_fids[name]}

    mesh = SceneMesh()
    fp = _build_buildings(mesh, owner_of, rng)
    fp.update(_build_walls(mesh, owner_of))
    fp.update(_build_gates(mesh, owner_of))
    # trees and clutter keep off the pond where the demolished B20 stood (water: no returns)
    obstacles = unary_union([*fp.values(), fp["B20"].buffer(4.5)])
    crowns = _place_trees(rng, obstacles)
    _build_trunks(mesh, crowns)
    _build_clutter(mesh, rng, obstacles)
    digitised = _digitise(fp, params, rng)
    pond = digitised["B20"].buffer(1.0)
    scene = _to_scene(mesh, layer_of, crowns, pond, params, rng)
    res, plan = _survey(scene, params, rng)

    offset, crs = _kasepuhan_world(params)
    layers, objects = _layers(digitised, offset[:2], crs, owner_of, res.instance)
    for name, inst in owner_of.items():
        scene.objects.append(
            {
                "instance": inst,
                "class": layer_of[inst],
                "fid": name,
                "footprint": shapely.to_wkt(fp[name], rounding_precision=3),
            }
        )
    extent = affinity.translate(box(0, 0, *_EXTENT_M), offset[0], offset[1])
    extras = {
        "layers": layers,
        "reference_objects": objects,
        "extent": extent,
        "survey": plan,
        "write_extras": lambda outdir: write_layers(layers, objects, outdir),
    }
    survey = {f"survey_{k}": v for k, v in plan.items()}
    sim_params = {"layout": "kasepuhan", **asdict(params), **survey}
    return Simulation(
        "complex", params.seed, scene, {"cloud": res}, {"cloud": np.eye(4)}, sim_params,
        extras, "EPSG:32749", (float(offset[0]), float(offset[1]), float(offset[2])),
    )  # fmt: skip


def kasepuhan_scene(params: ComplexSceneParams | None = None) -> ComplexScene:
    """Generate the walled complex: cloud, GIS layers and reference labels.

    The layout is built as labelled surfaces and scanned by the airborne
    simulator (:func:`kasepuhan_simulation`, the ``complex`` family's
    ``layout="kasepuhan"`` member; :data:`KASEPUHAN_SURVEY`): walls running
    east-west show both faces, walls running north-south mostly their tops;
    tree crowns give several returns per pulse; the pond gives none.

    Parameters
    ----------
    params
        Density, noise, seed and survey/digitising settings.

    Returns
    -------
    ComplexScene
        Cloud in EPSG:32749 with exactly ``params.n_points`` points (in
        acquisition order: strip by strip, pulse by pulse; attributes
        ``intensity``, ``return_number``, ``number_of_returns``,
        ``point_source_id``, ``gps_time``), the three GIS layers, per-point
        reference object ids (0 = none) and ground mask.

    Examples
    --------
    >>> scene = kasepuhan_scene(ComplexSceneParams(n_points=20_000, seed=1))
    >>> len(scene.cloud), sorted(scene.layers)
    (20000, ['building', 'gate', 'wall'])
    """
    sim = kasepuhan_simulation(params)
    res = sim.clouds["cloud"]
    attributes = {
        "intensity": res.intensity,
        "return_number": res.return_number,
        "number_of_returns": res.number_of_returns,
        "point_source_id": res.point_source_id,
        "gps_time": res.gps_time,
    }
    cloud = PointCloud(
        xyz=res.xyz, offset=np.asarray(sim.offset), crs=pyproj.CRS(sim.crs),
        attributes=attributes, scale=np.full(3, 0.001), source="synthetic:kasepuhan",
    )  # fmt: skip
    ground = res.class_id == sim.scene.class_code("ground")
    layers, objects = sim.extras["layers"], sim.extras["reference_objects"]
    return ComplexScene(cloud, layers, res.instance.astype(np.int32), objects, ground,
                        sim.extras["extent"])  # fmt: skip


def _layers(
    digitised: dict[str, Any],
    offset_xy: NDArray[np.float64],
    crs: pyproj.CRS,
    owner_of: dict[str, int],
    ref_inst: NDArray[np.int32],
) -> tuple[dict[str, gpd.GeoDataFrame], pd.DataFrame]:
    """GeoDataFrames of the digitised features (world coordinates) and the objects table."""

    def world(fid: str) -> Any:
        g = affinity.translate(digitised[fid], offset_xy[0], offset_xy[1])
        return shapely.make_valid(g) if not g.is_valid else g

    rows = {
        "building": [
            {
                "fid": b.fid,
                "name": b.name,
                "function": b.function,
                "period": b.period,
                "roof": "cone" if b.kind == "round" else b.parts[0].roof,
                "open": b.kind in ("pendopo", "round"),
                "status": "demolished" if b.kind == "demolished" else "extant",
                "geometry": world(b.fid),
            }
            for b in BUILDINGS
        ],
        "wall": [
            {
                "fid": w.fid,
                "name": w.name,
                "function": w.function,
                "period": w.period,
                "material": w.material,
                "height_m": w.height_m,
                "thickness_m": w.thickness_m,
                "geometry": world(w.fid),
            }
            for w in WALLS
        ],
        "gate": [
            {
                "fid": g.fid,
                "name": g.name,
                "function": g.function,
                "period": g.period,
                "gate_type": g.gate_type,
                "geometry": world(g.fid),
            }
            for g in GATES
        ],
    }
    layers = {name: gpd.GeoDataFrame(r, geometry="geometry", crs=crs) for name, r in rows.items()}
    counts = np.bincount(ref_inst, minlength=len(owner_of) + 1)
    obj = []
    for name in LAYERS:
        for i, row in layers[name].iterrows():
            inst = owner_of[row["fid"]]
            obj.append(
                {
                    "instance": inst,
                    "layer": name,
                    "fid": row["fid"],
                    "feature_index": int(i),
                    "name": row["name"],
                    "n_points": int(counts[inst]),
                }
            )
    objects = pd.DataFrame(obj).astype({"instance": np.int32})
    return layers, objects


def write_scene(scene: ComplexScene, outdir: str | Path) -> dict[str, Path]:
    """Write a scene: ``cloud.laz``, one GeoPackage per layer, ``reference_objects.csv``.

    ``cloud.laz`` (LAS 1.4, EPSG:32749) carries the extra dimension
    ``reference_instance`` (int32) and ASPRS classification 2 on the reference
    ground (1 elsewhere).  Every file is written atomically.

    Returns
    -------
    dict
        ``{"cloud": ..., "building": ..., "wall": ..., "gate": ..., "objects": ...}``.
    """
    from pyheracles.io import atomic_path, write_cloud

    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    paths: dict[str, Path] = {}
    classification = np.where(scene.ground, 2, 1).astype(np.uint8)
    cloud = scene.cloud.with_attributes(classification=classification)
    paths["cloud"] = write_cloud(
        cloud, out / "cloud.laz", extra_dims={"reference_instance": scene.reference_instance}
    )
    for name, gdf in scene.layers.items():
        from pyheracles.io.vector import write_gpkg

        # GeoPackage 1.2 (read by GDAL 3.6 without a warning); key "ogc_fid", our ids in "fid"
        paths[name] = write_gpkg(gdf, out / f"{name}.gpkg", layer=name)
    target = out / "reference_objects.csv"
    with atomic_path(target) as tmp:
        scene.reference_objects.to_csv(tmp, index=False)
    paths["objects"] = target
    return paths
