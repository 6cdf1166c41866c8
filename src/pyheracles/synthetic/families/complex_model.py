"""A complex's layout as labelled surfaces, and its GIS layers as a surveyor digitises them.

:func:`build_scene` triangulates a :class:`~pyheracles.synthetic.families.complex_layout.Layout`
into a :class:`~pyheracles.synthetic.scene.Scene`: one instance per GIS
feature (buildings, then walls, then gates, numbered from 1 in layer order),
the terrain as class ``ground``, trees and clutter as instance 0.
:func:`digitise` moves the true outlines as drawing on an orthophoto does
(a shift per feature or per group of touching features, a smooth per-vertex
error, simplification), and :func:`gis_layers` makes the GeoDataFrames
(projected CRS, world coordinates) with their attributes, among them the
64-bit integer ``object_id``.
"""

from __future__ import annotations

from typing import Any

import geopandas as gpd
import numpy as np
import pandas as pd
import shapely
from numpy.typing import NDArray
from shapely import affinity

from pyheracles.synthetic.families.complex_build import (
    Placement,
    add_column_grid,
    add_crown,
    add_prism,
    add_roof,
    add_terrain,
    add_trunk,
    add_wall_line,
    rect_ring,
    ring_ground,
)
from pyheracles.synthetic.families.complex_layout import (
    Building,
    Clutter,
    Gate,
    Layout,
    building_footprint,
    gate_footprint,
    gate_rects,
    wall_footprint,
)
from pyheracles.synthetic.scene import GLASS, METAL, PLASTER, STONE, TIMBER, Scene

__all__ = ["LAYERS", "OBJECT_ID_BASE", "build_scene", "digitise", "gis_layers", "instances"]

#: GIS layers in instance-numbering order.
LAYERS = ("building", "wall", "gate")
#: ``object_id`` of feature k (from 1) is ``OBJECT_ID_BASE + k``: beyond 32 bits, as in
#: national registers (BAG, BGT identifiers), so a reader must keep 64-bit integers.
OBJECT_ID_BASE = 5_000_000_000_000
_BURY_M = 0.3
_ROOF_MATERIALS = (TIMBER, STONE, METAL)


def instances(layout: Layout) -> dict[str, int]:
    """Instance of each feature: buildings, walls, gates in layer order, from 1."""
    fids = ([b.fid for b in layout.buildings] + [w.fid for w in layout.walls]
            + [g.fid for g in layout.gates])  # fmt: skip
    return {fid: i + 1 for i, fid in enumerate(fids)}


def _expand(
    rect: tuple[float, float, float, float], w: float, s: float, e: float, n: float
) -> NDArray[np.float64]:
    x0, y0, x1, y1 = rect
    return rect_ring(x0 - w, y0 - s, x1 + e, y1 + n)


def _add_building(
    scene: Scene, b: Building, inst: int, ground: Any, rng: np.random.Generator
) -> dict[str, Any]:
    """Triangles of one building; returns its true primitive for ``scene.objects``."""
    ref = {"instance": inst, "class_name": "building"}
    place = b.place
    m = b.base_margin_m
    bases = [_expand(p.rect, m, m, m, m) for p in b.parts]
    lows, mids, highs = zip(*(ring_ground(ground, place, r) for r in bases), strict=True)
    z_low, z_mid, z_high = min(lows), float(np.mean(mids)), max(highs)
    floor = max(z_mid + b.base_height_m, z_high + 0.15)
    roof_mat = _ROOF_MATERIALS[int(rng.integers(len(_ROOF_MATERIALS)))]
    tops = []
    for part, base in zip(b.parts, bases, strict=True):
        add_prism(scene, place, base, z_low - _BURY_M, floor, part=b.base, material=STONE, **ref)
        z_eave = floor + part.eave_height_m
        rect = rect_ring(*part.rect)
        roof_rect = _expand(part.rect, *part.eaves_m)
        if b.kind == "pavilion":
            x0, y0, x1, y1 = part.rect
            add_column_grid(scene, place, rect, floor, z_eave,
                            spacing_m=float(rng.uniform(2.0, 3.5)),
                            radius_m=float(rng.uniform(0.1, 0.22)),
                            inner=min(x1 - x0, y1 - y0) > 7, part="column", material=TIMBER,
                            **ref)  # fmt: skip
        else:
            add_prism(
                scene, place, rect, floor, z_eave, top=False, part="facade", material=PLASTER, **ref
            )
        tops.append(add_roof(scene, place, roof_rect, z_eave, part.roof, pitch_deg=part.pitch_deg,
                             wall_rect=rect, parapet_m=part.parapet_m, material=roof_mat,
                             **ref))  # fmt: skip
    return {
        "instance": inst, "class": "building", "fid": b.fid, "kind": b.kind,
        "footprint": shapely.to_wkt(building_footprint(b), rounding_precision=3),
        "floor_z_m": round(floor, 3), "top_z_m": round(max(tops), 3),
        "base": b.base, "base_height_m": round(floor - z_mid, 3),
        "roofs": [p.roof for p in b.parts], "storeys": b.storeys,
    }  # fmt: skip


def _add_gate(scene: Scene, g: Gate, inst: int, ground: Any) -> dict[str, Any]:
    ref = {"instance": inst, "class_name": "gate", "material": STONE}
    tops = []
    for x0, y0, x1, y1 in gate_rects(g):
        rect = rect_ring(x0, y0, x1, y1)
        z_low, z_mid, _ = ring_ground(ground, g.place, rect)
        if g.gate_type == "split":
            # stepped, tapering half-towers (candi bentar)
            n = 4
            c = rect.mean(axis=0)
            edges = np.linspace(0.0, g.height_m, n + 1)
            for k in range(n):
                s = 1.0 - 0.55 * k / n
                zb = z_low - _BURY_M if k == 0 else z_mid + edges[k]
                add_prism(scene, g.place, c + (rect - c) * s, zb, z_mid + edges[k + 1],
                          part="tower", **ref)  # fmt: skip
            tops.append(z_mid + g.height_m)
        else:
            body = 0.6 * g.height_m
            add_prism(scene, g.place, rect, z_low - _BURY_M, z_mid + body, top=False,
                      part="gate_body", **ref)  # fmt: skip
            tops.append(add_roof(scene, g.place, _expand((x0, y0, x1, y1), 0.3, 0.3, 0.3, 0.3),
                                 z_mid + body, "pyramid", pitch_deg=40.0, part="gate_roof",
                                 **ref))  # fmt: skip
    return {"instance": inst, "class": "gate", "fid": g.fid, "gate_type": g.gate_type,
            "footprint": shapely.to_wkt(gate_footprint(g), rounding_precision=3),
            "top_z_m": round(max(tops), 3), "width_m": g.width_m, "depth_m": g.depth_m,
            "opening_m": g.opening_m}  # fmt: skip


def _add_clutter(scene: Scene, c: Clutter, ground: Any) -> None:
    x, y = c.place.origin
    zg = float(ground(np.array([x]), np.array([y]))[0])
    ref = {"instance": 0, "class_name": "clutter", "part": c.kind}
    loc = Placement(c.place.angle_deg, c.place.origin)
    if c.kind == "bench":
        add_prism(
            scene,
            loc,
            rect_ring(-0.9, -0.25, 0.9, 0.25),
            zg - 0.1,
            zg + 0.45,
            material=TIMBER,
            **ref,
        )
    elif c.kind == "lamp":
        add_prism(
            scene,
            loc,
            rect_ring(-0.07, -0.07, 0.07, 0.07),
            zg - 0.1,
            zg + 4.0,
            material=METAL,
            **ref,
        )
        add_prism(
            scene,
            loc,
            rect_ring(-0.25, -0.25, 0.25, 0.25),
            zg + 4.0,
            zg + 4.3,
            material=METAL,
            **ref,
        )
    elif c.kind == "planter":
        add_prism(
            scene, loc, rect_ring(-0.6, -0.6, 0.6, 0.6), zg - 0.1, zg + 0.8, material=STONE, **ref
        )
    elif c.kind == "car":
        add_prism(
            scene, loc, rect_ring(-2.2, -0.9, 2.2, 0.9), zg + 0.25, zg + 0.95, material=METAL, **ref
        )
        add_prism(
            scene,
            loc,
            rect_ring(-1.1, -0.8, 0.9, 0.8),
            zg + 0.95,
            zg + 1.45,
            scale_top=0.85,
            material=GLASS,
            **ref,
        )
    elif c.kind == "shed":  # a small unmapped structure (not in the GIS)
        add_prism(
            scene,
            loc,
            rect_ring(-1.5, -1.2, 1.5, 1.2),
            zg - 0.1,
            zg + 2.2,
            top=False,
            material=TIMBER,
            **ref,
        )
        add_roof(
            scene,
            loc,
            rect_ring(-1.7, -1.4, 1.7, 1.4),
            zg + 2.2,
            "gabled",
            pitch_deg=20.0,
            material=METAL,
            **ref,
        )
    else:  # kiosk / market stall: a canopy on four posts
        for sx in (-1, 1):
            for sy in (-1, 1):
                add_prism(scene, loc, rect_ring(sx * 1.2 - 0.05, sy * 1.0 - 0.05,
                                                sx * 1.2 + 0.05, sy * 1.0 + 0.05),
                          zg, zg + 2.3, material=METAL, **ref)  # fmt: skip
        add_roof(
            scene,
            loc,
            rect_ring(-1.4, -1.2, 1.4, 1.2),
            zg + 2.3,
            "hipped",
            pitch_deg=15.0,
            material=PLASTER,
            **ref,
        )


def build_scene(layout: Layout, rng: np.random.Generator, *, terrain_cell_m: float = 0.5) -> Scene:
    """Triangulate a layout: terrain, buildings, walls, gates, trees and clutter.

    ``scene.objects`` gets one entry per GIS feature (demolished ones included,
    with ``"status": "demolished"`` and no surfaces).
    """
    scene = Scene()
    for name in ("ground", "building", "wall", "gate", "tree", "clutter"):
        scene.class_code(name)
    ground = layout.terrain
    add_terrain(scene, ground, layout.bounds, cell_m=terrain_cell_m)
    inst = instances(layout)
    for b in layout.buildings:
        if b.status == "demolished":
            scene.objects.append(
                {
                    "instance": inst[b.fid],
                    "class": "building",
                    "fid": b.fid,
                    "status": "demolished",
                    "footprint": shapely.to_wkt(building_footprint(b), rounding_precision=3),
                }
            )
            continue
        scene.objects.append({**_add_building(scene, b, inst[b.fid], ground, rng),
                              "status": "extant"})  # fmt: skip
    for w in layout.walls:
        add_wall_line(scene, layout.frame, np.array(w.line), w.thickness_m, w.height_m, ground,
                      caps=w.caps, instance=inst[w.fid], class_name="wall", part="wall",
                      material=PLASTER if "plastered" in w.material else STONE)  # fmt: skip
        scene.objects.append({
            "instance": inst[w.fid], "class": "wall", "fid": w.fid,
            "axis": [list(layout.frame.xy(np.array(pt))) for pt in w.line],
            "thickness_m": w.thickness_m, "height_m": w.height_m,
            "footprint": shapely.to_wkt(wall_footprint(w, layout.frame), rounding_precision=3),
        })  # fmt: skip
    for g in layout.gates:
        scene.objects.append(_add_gate(scene, g, inst[g.fid], ground))
    for t in layout.trees:
        zg = float(ground(np.array([t.x]), np.array([t.y]))[0])
        zc = zg + t.trunk_height_m + t.crown_half_height_m
        add_trunk(
            scene,
            (t.x, t.y, zg),
            t.trunk_height_m + 0.5 * t.crown_half_height_m,
            radius_m=float(np.clip(0.06 * t.crown_radius_m, 0.12, 0.45)),
        )
        add_crown(
            scene,
            (t.x, t.y, zc),
            t.crown_radius_m,
            t.crown_half_height_m,
            rng,
            leaf_area_density=t.leaf_area_density,
            penetration=t.penetration,
        )
    for c in layout.clutter:
        _add_clutter(scene, c, ground)
    return scene


# ----------------------------------------------------------------------------- GIS
def digitise(
    footprints: dict[str, Any], groups: dict[str, str], error_m: float, rng: np.random.Generator
) -> dict[str, Any]:
    """Outlines as drawn on an orthophoto: shifted, jittered, simplified.

    Each group of features (touching features drawn together: a row of
    buildings, the walls with their gates) shares one shift of a length up to
    ``error_m`` in a random direction; a smooth per-vertex error of up to
    ``error_m / 5`` (at most 5 cm) is added, so shared vertices move together and
    touching outlines stay touching; then the outline is simplified by
    ``min(0.1, error_m / 3)``.
    """
    amp = min(0.05, error_m / 5)
    phase = rng.uniform(0, 2 * np.pi, 4)
    shifts = {}
    for g in sorted(set(groups.values())):
        ang = rng.uniform(0, 2 * np.pi)
        shifts[g] = error_m * rng.uniform(0.3, 1.0) * np.array([np.cos(ang), np.sin(ang)])
    tol = min(0.1, error_m / 3)
    out = {}
    for fid, geom in footprints.items():
        d = shifts[groups.get(fid, fid)] if groups.get(fid, fid) in shifts else np.zeros(2)

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
        if tol > 0:
            moved = shapely.simplify(moved, tol, preserve_topology=True)
        out[fid] = moved if moved.is_valid else shapely.make_valid(moved)
    return out


def gis_layers(
    layout: Layout,
    digitised: dict[str, Any],
    offset_xy: tuple[float, float],
    crs: str,
    counts: NDArray[np.int64],
) -> tuple[dict[str, gpd.GeoDataFrame], pd.DataFrame]:
    """The GIS layers (world coordinates, ``crs``) and the reference objects table.

    ``counts[instance]`` is the number of points of each reference object.
    """
    inst = instances(layout)

    def world(fid: str) -> Any:
        return affinity.translate(digitised[fid], *offset_xy)

    def oid(fid: str) -> np.int64:
        return np.int64(OBJECT_ID_BASE + inst[fid])

    rows = {
        "building": [{
            "object_id": oid(b.fid), "fid": b.fid, "name": b.name, "function": b.function,
            "kind": b.kind, "roof": b.parts[0].roof, "storeys": b.storeys,
            "open": b.kind == "pavilion", "status": b.status,
            "height_m": round(b.parts[0].eave_height_m + b.base_height_m, 1),
            "geometry": world(b.fid),
        } for b in layout.buildings],
        "wall": [{
            "object_id": oid(w.fid), "fid": w.fid, "name": w.name, "function": w.function,
            "material": w.material, "height_m": round(w.height_m, 2),
            "thickness_m": round(w.thickness_m, 2), "geometry": world(w.fid),
        } for w in layout.walls],
        "gate": [{
            "object_id": oid(g.fid), "fid": g.fid, "name": g.name,
            "gate_type": "candi bentar" if g.gate_type == "split" else "paduraksa",
            "height_m": round(g.height_m, 1), "geometry": world(g.fid),
        } for g in layout.gates],
    }  # fmt: skip
    layers = {}
    for name, r in rows.items():
        gdf = (
            gpd.GeoDataFrame(r, geometry="geometry", crs=crs)
            if r
            else gpd.GeoDataFrame(
                {"object_id": pd.Series(dtype=np.int64), "fid": pd.Series(dtype=str)},
                geometry=gpd.GeoSeries([], crs=crs),
            )
        )
        gdf["object_id"] = gdf["object_id"].astype(np.int64)
        layers[name] = gdf
    obj = []
    for name in LAYERS:
        for i, row in layers[name].iterrows():
            k = inst[row["fid"]]
            obj.append({"instance": k, "layer": name, "fid": row["fid"],
                        "feature_index": int(i), "name": row["name"],
                        "object_id": int(row["object_id"]),
                        "n_points": int(counts[k]) if k < len(counts) else 0})  # fmt: skip
    objects = pd.DataFrame(obj).astype({"instance": np.int32, "object_id": np.int64})
    return layers, objects
