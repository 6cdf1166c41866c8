"""Clutter and debris of a ``supports`` plan: where the items go, touching supports or not.

:func:`place_clutter` puts the drawn kinds of clutter (sign posts, pulpits,
scaffold towers, fences between neighbouring supports, chairs, benches, pews)
next to supports, a drawn share of them touching one (0-2 cm away), plus a
block of chairs clear of the supports; :func:`place_debris` lays fallen drums
in a ruin.  Both only add specs to the plan;
:func:`~pyheracles.synthetic.families.supports_build.build_plan` builds them.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from pyheracles.synthetic.families.supports_parts import footprint_radius

if TYPE_CHECKING:
    from pyheracles.synthetic.families.supports_layouts import Plan

__all__ = ["clear_of_supports", "place_clutter", "place_debris"]


def place_clutter(p: Any, plan: Plan, rng: np.random.Generator) -> None:
    """Clutter items, a share of them touching a support."""
    free = [s for s in plan.supports if s.group not in ("wall", "anta")]
    if not free or not p.clutter:
        return
    x0, y0, x1, y1 = plan.rect
    for k in range(p.clutter_count):
        kind = p.clutter[k % len(p.clutter)]
        s = free[int(rng.integers(len(free)))]
        touch = rng.random() < p.clutter_touch_share
        reach = (
            footprint_radius(s) / np.sqrt(2)
            if s.klass == "column"
            else max(s.pier_width_m, s.pier_depth_m) / 2 + s.pier_projection_m
        )
        if s.klass == "column" and s.column is not None:
            reach = max(s.column.radius_bottom_m, s.column.plinth_half_m)
        ang = rng.uniform(0, 2 * np.pi)
        gap = rng.uniform(0.0, 0.02) if touch else rng.uniform(0.5, 3.0)
        item: dict[str, Any] = {
            "kind": kind,
            "yaw": float(np.degrees(ang)) + 90.0,
            "touch": bool(touch),
        }
        if kind == "scaffold":
            item.update(
                x=s.x,
                y=s.y,
                yaw=0.0,
                reach=reach + 0.05 + (0.0 if touch else 0.5),
                height=s.height_m * rng.uniform(0.6, 1.0),
            )
        elif kind == "fence":
            nb = [o for o in free if o is not s and abs(o.y - s.y) < 1e-6]
            if not nb:
                continue
            o = min(nb, key=lambda q: abs(q.x - s.x))
            a, b = sorted([s.x, o.x])
            if b - a - 2 * reach < 0.5:
                continue
            item.update(
                x=a + reach,
                y=s.y,
                yaw=0.0,
                reach=b - a - 2 * reach,
                height=rng.uniform(0.9, min(3.0, 0.6 * s.height_m)),
            )
        elif kind == "pew":
            L = rng.uniform(2.0, 5.0)
            up = s.y < (y0 + y1) / 2
            item.update(
                x=s.x, y=s.y + (reach + gap) * (1 if up else -1), yaw=90.0 if up else -90.0, reach=L
            )
        elif kind == "bench":
            L = rng.uniform(1.2, 2.5)
            item.update(
                x=s.x + (reach + gap + 0.25) * np.cos(ang),
                y=s.y + (reach + gap + 0.25) * np.sin(ang),
                reach=L,
                yaw=float(np.degrees(ang)) + 90.0,
            )
        else:
            size = {"sign": 0.05, "pulpit": 0.6, "chair": 0.25}[kind]
            d = reach + gap + size
            item.update(
                x=s.x + d * np.cos(ang),
                y=s.y + d * np.sin(ang),
                height=rng.uniform(1.2, min(2.6, 0.5 * s.height_m + 0.6)),
            )
        if x0 - 3 < item["x"] < x1 + 3 and y0 - 3 < item["y"] < y1 + 3:
            plan.clutter.append(item)
    if "chair" in p.clutter:  # a block of chairs in the middle, clear of the supports
        cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
        for i in range(-3, 4):
            for j in range(-1, 2):
                x, y = cx + 0.8 * i, cy + 0.9 * j
                if clear_of_supports(plan, x, y, 0.45):
                    plan.clutter.append(
                        {"kind": "chair", "x": x, "y": y, "yaw": 0.0, "touch": False, "height": 0.0}
                    )


def clear_of_supports(plan: Plan, x: float, y: float, radius: float) -> bool:
    """Whether a disc at ``(x, y)`` stays clear of every support."""
    return all(np.hypot(s.x - x, s.y - y) > footprint_radius(s) + radius for s in plan.supports)


def place_debris(p: Any, plan: Plan, rng: np.random.Generator) -> None:
    """Fallen drums lying between the supports of a ruin."""
    x0, y0, x1, y1 = plan.rect
    r = p.column_radius_m
    for _ in range(int(rng.integers(1, 6))):
        x, y = float(rng.uniform(x0, x1)), float(rng.uniform(y0, y1))
        length = r * rng.uniform(1.0, 3.0)
        if clear_of_supports(plan, x, y, length / 2 + 0.2):
            plan.debris.append(
                {
                    "x": x,
                    "y": y,
                    "r": r * rng.uniform(0.8, 1.0),
                    "length": length,
                    "yaw": float(rng.uniform(0, 180)),
                }
            )
