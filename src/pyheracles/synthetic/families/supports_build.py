"""Build a ``supports`` plan into a scene: triangles, reference rows, footprints of solids."""

from __future__ import annotations

from typing import Any

import numpy as np
import shapely

from pyheracles.synthetic.families.supports_fabric import (
    add_attic,
    add_ceiling,
    add_clutter_item,
    add_drum,
    add_floor,
    add_ground,
    add_wall,
)
from pyheracles.synthetic.families.supports_layouts import Plan
from pyheracles.synthetic.families.supports_parts import add_support, footprint_radius
from pyheracles.synthetic.scene import Scene

__all__ = ["build_plan"]


def build_plan(
    plan: Plan, rng: np.random.Generator
) -> tuple[Scene, list[dict[str, Any]], list[shapely.Geometry]]:
    """Build a plan: the scene, the reference rows of its objects, footprints of solids."""
    scene = Scene()
    for name in (
        "column",
        "pier",
        "engaged_column",
        "attic",
        "wall",
        "floor",
        "ground",
        "ceiling",
        "clutter",
        "debris",
    ):
        scene.class_code(name)
    rows: list[dict[str, Any]] = []
    solids: list[shapely.Geometry] = []
    z_floor = plan.platform_m
    for s in plan.supports:
        s.z0 += z_floor
    for k, s in enumerate(plan.supports, start=1):
        rows.append(add_support(scene, s, k, rng))
        solids.append(shapely.Point(s.x, s.y).buffer(footprint_radius(s) + 0.05))
    for i, s in enumerate(plan.supports):  # twin partners: the next spec of the pair
        if s.group == "twin" and s.cuts.get("+x") is not None:
            rows[i]["twin_of"] = i + 2
            rows[i + 1]["twin_of"] = i + 1
    for w in plan.walls:
        w.z0 += z_floor
        solids.append(add_wall(scene, w))
    x0, y0, x1, y1 = plan.rect
    z_top = plan.z_top + z_floor
    if plan.attic is not None:
        z_eave = add_attic(scene, plan.rect, z_top, **plan.attic)
        rows.append(
            {
                "instance": 0,
                "class": "attic",
                "z_base": z_top,
                "z_eaves": z_eave,
                "rect": list(plan.rect),
                **plan.attic,
            }
        )
    elif plan.ceiling != "none":
        add_ceiling(
            scene,
            plan.ceiling,
            plan.rect,
            z_top,
            rng,
            lines_x=plan.lines_x,
            lines_y=plan.lines_y,
            rise=plan.vault_rise_m,
        )
    # floor, platform, ground
    m = plan.margin_m
    bx = [x0, y0, x1, y1]
    for s in plan.supports:
        bx = [min(bx[0], s.x), min(bx[1], s.y), max(bx[2], s.x), max(bx[3], s.y)]
    for w in plan.walls:
        b = w.footprint().bounds
        bx = [min(bx[0], b[0]), min(bx[1], b[1]), max(bx[2], b[2]), max(bx[3], b[3])]
    if plan.attic is not None:
        o = plan.attic["overhang_m"]
        bx = [min(bx[0], x0 - o), min(bx[1], y0 - o), max(bx[2], x1 + o), max(bx[3], y1 + o)]
    floor_rect = tuple(bx)
    if plan.platform_rect is not None:  # a stylobate under the supports and the walls
        pr = shapely.box(*plan.platform_rect)
        walls = [w.footprint() for w in plan.walls]
        floor_rect = shapely.union_all([pr, *walls]).buffer(0.3, join_style="mitre").bounds
    if plan.platform_m > 0:
        add_floor(scene, shapely.box(*floor_rect), z_floor, thickness=plan.platform_m)
        add_ground(scene, (bx[0] - m, bx[1] - m, bx[2] + m, bx[3] + m), 0.0)
    else:
        add_floor(scene, shapely.box(*floor_rect), 0.0)
        add_ground(scene, (bx[0] - m, bx[1] - m, bx[2] + m, bx[3] + m), -0.02)
    for c in plan.clutter:
        fp = add_clutter_item(
            scene,
            c["kind"],
            c["x"],
            c["y"],
            z_floor,
            c["yaw"],
            rng,
            height_m=c.get("height", 0.0),
            reach_m=c.get("reach", 0.3),
        )
        solids.append(fp)
    for d in plan.debris:
        solids.append(add_drum(scene, d["x"], d["y"], z_floor, d["r"], d["length"], d["yaw"]))
    for b in plan.blocks:
        lo, hi = np.asarray(b["lo"], float), np.asarray(b["hi"], float)
        scene.add_box(
            (lo + hi) / 2,
            hi - lo,
            faces=("-x", "+x", "-y", "+y", "+z"),
            class_name=b["class"],
            part=b["part"],
        )
        solids.append(shapely.box(lo[0], lo[1], hi[0], hi[1]))
    return scene, rows, solids
