"""Openings of the ``church`` family's walls: window lights, doors and arches, bay by bay.

A window is one to three lights (mullions between them) of one head shape,
sized from the drawn typical size with a relative spread, placed in its bay
between a lowest sill and a highest head; a bay with a door has its window
above the door or none.  Each light and door gets its own instance.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from pyheracles.synthetic.families.church_geometry import Opening
from pyheracles.synthetic.families.church_site import InstanceCounter

if TYPE_CHECKING:
    from pyheracles.synthetic.families.church import ChurchFamilyParams

__all__ = ["arch", "bay_windows", "door", "window_lights"]


def window_lights(
    p: ChurchFamilyParams,
    rng: np.random.Generator,
    ids: InstanceCounter,
    u_centre: float,
    max_width: float,
    z_range: tuple[float, float],
    thickness: float,
) -> list[Opening]:
    """The lights of one window centred at ``u_centre`` (empty when it does not fit)."""
    spread = p.size_spread
    w = p.window_width_m * rng.uniform(1 - spread, 1 + spread)
    w = min(w, max_width)
    h = p.window_height_m * rng.uniform(1 - spread, 1 + spread)
    lo, hi = z_range
    h = min(h, hi - lo)
    if w < 0.35 or h < 0.8:
        return []
    shape = p.window_style
    if rng.random() < p.style_mix:
        shape = str(rng.choice([s for s in ("rect", "round", "pointed") if s != p.window_style]))
    n_lights = 1
    if w > 1.0 and rng.random() < p.mullion_share:
        n_lights = int(rng.integers(2, 4))
    mullion = float(rng.uniform(0.12, 0.25))
    wl = (w - (n_lights - 1) * mullion) / n_lights
    if wl < 0.3:
        n_lights, wl = 1, w
    ratio = float(rng.uniform(0.6, 1.0))
    radius = ratio * wl
    rise = {"rect": 0.0, "round": wl / 2, "pointed": np.sqrt(radius**2 - (radius - wl / 2) ** 2)}
    spring = h - rise[shape]
    if spring < 0.3:
        shape, spring = "rect", h
    sill = float(lo + rng.uniform(0.0, max(hi - lo - h, 0.0)))
    th = p.pane_thickness_m
    dp = float(np.clip(p.pane_depth_ratio * thickness, 0.05 + th / 2, thickness - 0.05 - th / 2))
    # the splay must stay inside the wall face (not through the floor or the ceiling)
    splay = float(min(p.splay_m, max(sill - 0.3, 0.0), max(hi + 0.3 - (sill + h), 0.0) * 0.8))
    leaded = bool(rng.random() < p.leaded_share)
    lights = []
    u0 = u_centre - w / 2 + wl / 2
    for k in range(n_lights):
        lights.append(
            Opening(
                kind="window",
                shape=shape,
                u_m=float(u0 + k * (wl + mullion)),
                sill_m=sill,
                width_m=float(wl),
                spring_m=float(spring),
                radius_m=float(radius),
                pane_depth_m=dp,
                pane_thickness_m=th,
                splay_m=splay if n_lights == 1 else min(splay, mullion / 2 - 0.02),
                leaded=leaded,
                came_pattern=p.came_pattern,
                came_spacing_m=p.came_spacing_m,
                came_width_m=float(rng.uniform(0.008, 0.014)),
                instance=ids(),
            )
        )
    return lights


def door(
    p: ChurchFamilyParams,
    rng: np.random.Generator,
    ids: InstanceCounter,
    u_centre: float,
    top_max: float,
    thickness: float,
) -> Opening:
    w = float(rng.uniform(1.1, 2.0))
    h = float(min(rng.uniform(2.3, 3.4), top_max))
    shape = str(rng.choice(["rect", "round", p.window_style]))
    spring = h - (w / 2 if shape == "round" else 0.0)
    radius = w * 0.8
    if shape == "pointed":
        spring = h - np.sqrt(radius**2 - (radius - w / 2) ** 2)
    if spring < 1.8:
        shape, spring = "rect", h
    leaf = float(rng.uniform(0.05, 0.08))
    return Opening(
        kind="door",
        shape=shape,
        u_m=float(u_centre),
        sill_m=0.0,
        width_m=w,
        spring_m=float(spring),
        radius_m=radius,
        pane_depth_m=float(rng.uniform(0.3, 0.7) * (thickness - leaf) + leaf / 2),
        pane_thickness_m=leaf,
        is_open=bool(rng.random() < p.open_door_share),
        instance=ids(),
    )


def arch(u_centre: float, width: float, top: float, shape: str) -> Opening:
    """An unglazed arch (arcade bay, chancel arch) from the floor to ``top``."""
    rise = {"rect": 0.0, "round": width / 2, "pointed": np.sqrt(width**2 - (width / 2) ** 2)}[shape]
    spring = top - rise
    if spring < 1.8:
        shape, spring = "rect", top
    return Opening("arch", shape, float(u_centre), 0.0, float(width), float(spring), float(width))


def bay_windows(
    p: ChurchFamilyParams,
    rng: np.random.Generator,
    ids: InstanceCounter,
    bays: list[tuple[float, float]],
    z_range: tuple[float, float],
    thickness: float,
    doors: dict[int, Opening],
) -> list[Opening]:
    """One window per bay (above or instead of a door where the bay has one)."""
    out: list[Opening] = []
    for k, (a, b) in enumerate(bays):
        lo = z_range[0]
        if k in doors:
            out.append(doors[k])
            lo = max(lo, doors[k].top_m + 0.6)
        if z_range[1] - lo < 0.8:
            continue
        jitter = float(rng.uniform(-0.1, 0.1)) * (b - a)
        out += window_lights(
            p,
            rng,
            ids,
            (a + b) / 2 + jitter,
            (b - a) - 0.9 - 2 * p.splay_m,
            (lo, z_range[1]),
            thickness,
        )
    return out
