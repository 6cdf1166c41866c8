"""Building plans of the ``supports`` family: where the supports, walls and clutter go.

A layout turns the drawn parameters into a :class:`Plan` (specs only, no
triangles; clutter and debris placed by
:mod:`~pyheracles.synthetic.families.supports_clutter`);
:func:`~pyheracles.synthetic.families.supports_build.build_plan` then builds it
into a :class:`~pyheracles.synthetic.scene.Scene` and returns the reference
rows and the footprints of the solids (for the station plan).

Layouts
-------
``nave``
    Walls with doors and windows around two or four rows of free supports;
    engaged columns or responds on the long walls; flat, vaulted or timber
    ceiling (or an attic).
``hypostyle``
    A grid of 3 to 8 rows of supports inside walls; a wider central aisle of
    larger supports.
``portico``
    One or two rows of columns in front of a back wall with doors and
    windows; side walls ending in antae; usually an attic whose eaves hang
    below the column tops.
``peristyle``
    Columns round the perimeter of a rectangle, a cella (walls ending in
    antae, columns in antis) inside; roofed (attic) or a roofless ruin.
``kiosk``
    An open grid of columns and piers under an attic, no walls.

A ``ruin`` state makes any of them roofless, with broken and leaning columns,
low walls with ragged tops and fallen drums.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import shapely
from numpy.typing import NDArray

from pyheracles.synthetic.families.supports_clutter import place_clutter, place_debris
from pyheracles.synthetic.families.supports_fabric import Opening, WallSpec
from pyheracles.synthetic.families.supports_parts import ColumnShape, SupportSpec

__all__ = ["GENERAL_LAYOUTS", "Plan", "column_shape", "foot_half", "general_plan"]

Array = NDArray[np.float64]

GENERAL_LAYOUTS = ("nave", "hypostyle", "portico", "peristyle", "kiosk")


@dataclass
class Plan:
    """What a layout decided: specs of every element, in metres (floor at z = 0).

    ``rect`` is the rectangle under the ceiling or attic; ``inside`` the area where
    interior stations may stand; ``outline`` the building's footprint.
    """

    supports: list[SupportSpec] = field(default_factory=list)
    walls: list[WallSpec] = field(default_factory=list)
    rect: tuple[float, float, float, float] = (0.0, 0.0, 1.0, 1.0)
    z_top: float = 3.0
    ceiling: str = "none"
    lines_x: Array | None = None
    lines_y: Array | None = None
    vault_rise_m: float = 1.0
    attic: dict[str, float] | None = None
    platform_m: float = 0.0  # floor raised above the ground (a stylobate)
    platform_rect: tuple[float, float, float, float] | None = None
    clutter: list[dict[str, Any]] = field(default_factory=list)
    debris: list[dict[str, float]] = field(default_factory=list)
    inside: shapely.Polygon | None = None
    enclosed: bool = False
    margin_m: float = 4.0
    blocks: list[dict[str, Any]] = field(default_factory=list)  # dais, low walls as boxes


# ------------------------------------------------------------------------------ shapes
def column_shape(
    p: Any, r: float, rng: np.random.Generator, *, style: str | None = None
) -> ColumnShape:
    """The column profile of radius ``r`` for the drawn style parameters ``p``."""
    style = style or p.shaft_style
    if style == "mixed":
        style = str(rng.choice(["smooth", "tapered", "entasis", "fluted"]))
    r1 = r if style == "smooth" else r * p.taper_ratio
    entasis = p.entasis_ratio * r if style == "entasis" else 0.0
    flutes = p.flutes if style == "fluted" else 0
    depth = p.flute_depth_ratio * r if flutes else 0.0
    plinth_half = p.plinth_ratio * r if p.plinth else 0.0
    plinth_h = max(0.08, p.plinth_height_ratio * r) if p.plinth else 0.0
    base_h = max(0.05, 0.3 * r) if p.plinth else 0.0
    cap_h = max(0.08, 0.45 * r) if p.capital else 0.0
    abacus_half = p.abacus_ratio * r1 if p.capital else 0.0
    abacus_h = max(0.06, 0.3 * r) if p.capital else 0.0
    return ColumnShape(
        r, r1, entasis, flutes, depth, plinth_half, plinth_h, base_h, cap_h, abacus_half, abacus_h
    )


def foot_half(p: Any, r: float) -> float:
    """Half width of a column's widest square part (or its shaft), metres."""
    return max(
        1.25 * r, p.plinth_ratio * r if p.plinth else 0.0, p.abacus_ratio * r if p.capital else 0.0
    )


def _free_support(
    p: Any,
    x: float,
    y: float,
    r: float,
    group: str,
    rng: np.random.Generator,
    *,
    pier: bool,
    z0: float = 0.0,
) -> list[SupportSpec]:
    """A column, a pier or a pair of twin columns at ``(x, y)``."""
    H = p.column_height_m
    if pier:
        w = p.pier_width_m * r / p.column_radius_m
        d = max(0.3, w / p.pier_aspect)
        proj = 0.1 * min(w, d) if p.capital else 0.0
        return [
            SupportSpec(
                "pier",
                x,
                y,
                z0,
                H,
                pier_width_m=max(w, 0.3),
                pier_depth_m=d,
                pier_projection_m=proj,
                pier_plinth_height_m=0.25 * min(w, d) if p.plinth else 0.0,
                pier_capital_height_m=0.2 * min(w, d) if p.capital else 0.0,
                yaw_deg=p.pier_yaw_deg,
                group=group,
            )
        ]
    shape = column_shape(p, r, rng)
    if rng.random() < p.twin_share:
        g = r + p.twin_gap_m / 2  # axis to the plane between the twins
        out = []
        for sx in (-1, 1):
            cut = {"+x": g} if sx < 0 else {"-x": -g}
            out.append(
                SupportSpec("column", x + sx * g, y, z0, H, column=shape, cuts=cut, group="twin")
            )
        return out
    return [SupportSpec("column", x, y, z0, H, column=shape, group=group)]


def _wall_support(
    p: Any,
    x: float,
    y: float,
    normal: tuple[float, float],
    r: float,
    rng: np.random.Generator,
    *,
    respond: bool,
    group: str,
) -> SupportSpec:
    """An engaged column or a respond (pier) on a wall face at ``(x, y)``."""
    yaw = float(np.degrees(np.arctan2(normal[1], normal[0]))) - 90.0
    H = p.column_height_m
    if respond:
        w = max(0.3, p.pier_width_m * r / p.column_radius_m)
        d = max(0.3, w / p.pier_aspect)
        return SupportSpec(
            "pier",
            x + normal[0] * d / 2,
            y + normal[1] * d / 2,
            0.0,
            H,
            pier_width_m=w,
            pier_depth_m=d,
            yaw_deg=yaw,
            pier_capital_height_m=0.2 * min(w, d) if p.capital else 0.0,
            pier_projection_m=0.1 * min(w, d) if p.capital else 0.0,
            cuts={"-y": -d / 2},
            group=group,
        )
    off = p.engaged_offset_ratio * r
    shape = column_shape(p, r, rng)
    return SupportSpec(
        "engaged_column",
        x + normal[0] * off,
        y + normal[1] * off,
        0.0,
        H,
        column=shape,
        yaw_deg=yaw,
        wall_offset_m=off,
        cuts={"-y": -off},
        group=group,
    )


# ------------------------------------------------------------------------------ walls
def _openings(
    p: Any,
    length: float,
    height: float,
    bays: list[tuple[float, float]],
    rng: np.random.Generator,
    *,
    doors: int,
) -> list[Opening]:
    """Doors (from the floor) and windows (in the bays between supports)."""
    out: list[Opening] = []
    taken: list[tuple[float, float]] = []
    for _ in range(doors):
        w = rng.uniform(1.0, 2.5)
        if length < w + 1.0:
            break
        u0 = rng.uniform(0.5, length - w - 0.5)
        if any(u0 < b + 0.3 and u0 + w > a - 0.3 for a, b in taken):
            continue
        out.append(Opening("door", u0, u0 + w, 0.0, min(rng.uniform(2.1, 3.8), height - 0.5)))
        taken.append((u0, u0 + w))
    if p.windows_per_bay == 0:
        return out
    sill = min(p.window_sill_m, height - 1.5)
    head = min(sill + p.window_height_m, height - 0.4)
    if head - sill < 0.5:
        return out
    for a, b in bays:
        span = b - a
        n = p.windows_per_bay
        w = min(span * 0.8 / n, rng.uniform(0.5, 2.0))
        if w < 0.4:
            continue
        for k in range(n):
            c = a + span * (k + 0.5) / n
            u0, u1 = c - w / 2, c + w / 2
            if (
                u0 < 0.3
                or u1 > length - 0.3
                or any(u0 < tb + 0.2 and u1 > ta - 0.2 for ta, tb in taken)
            ):
                continue
            out.append(Opening("window", u0, u1, sill, head, glazed=bool(p.glazed)))
            taken.append((u0, u1))
    return out


def _ragged(height: float, length: float, rng: np.random.Generator) -> tuple[float, ...]:
    """The top of a ruined wall: heights at points every ~1 m."""
    n = max(2, int(length) + 1)
    h = height * rng.uniform(0.25, 1.0, n)
    return tuple(float(v) for v in np.maximum(h, 0.3))


def _room_walls(
    p: Any,
    rect: tuple[float, float, float, float],
    height: float,
    xs: Array,
    ys: Array,
    rng: np.random.Generator,
    *,
    ruin: bool,
    skip: tuple[str, ...] = (),
) -> list[WallSpec]:
    """Four walls round ``rect`` (inner faces on it), counter-clockwise, corners filled."""
    x0, y0, x1, y1 = rect
    t = p.wall_thickness_m
    sides = {
        "south": ((x0, y0), (1.0, 0.0), x1 - x0, xs - x0),
        "east": ((x1, y0), (0.0, 1.0), y1 - y0, ys - y0),
        "north": ((x1, y1), (-1.0, 0.0), x1 - x0, x1 - xs[::-1]),
        "west": ((x0, y1), (0.0, -1.0), y1 - y0, y1 - ys[::-1]),
    }
    walls = []
    for name, (a, d, L, marks) in sides.items():
        if name in skip:
            continue
        edges = np.r_[0.0, marks, L]
        bays = [(float(edges[i]), float(edges[i + 1])) for i in range(len(edges) - 1)]
        long_side = L >= max(x1 - x0, y1 - y0) - 1e-9
        doors = int(rng.integers(0, 2)) if long_side else int(rng.integers(1, p.doors + 1))
        ops = _openings(p, L, height, bays if long_side else [], rng, doors=doors)
        top: float | tuple[float, ...] = _ragged(height, L + t, rng) if ruin else height
        walls.append(WallSpec(a, d, L + t, t, 0.0, top, ops))
    return walls


# ------------------------------------------------------------------------------ layouts
def _grid(
    n_along: int, n_across: int, bay: float, aisle: float, mx: float, my: float
) -> tuple[Array, Array, tuple[float, float, float, float]]:
    xs = mx + bay * np.arange(n_along)
    ys = my + aisle * np.arange(n_across)
    rect = (0.0, 0.0, float(xs[-1] + mx), float(ys[-1] + my))
    return xs, ys, rect


def general_plan(p: Any, rng: np.random.Generator) -> Plan:
    """The plan of a drawn member of one of :data:`GENERAL_LAYOUTS`."""
    ruin = p.state == "ruin"
    r_main = p.column_radius_m
    radii = [r_main * s for s in p.size_ratios]
    r2 = radii[1] if len(radii) > 1 else r_main
    r3 = radii[2] if len(radii) > 2 else r2
    plan = Plan(z_top=p.column_height_m)
    foot = foot_half(p, r_main)
    mx = foot + p.side_clearance_m
    my = mx
    layout = p.layout
    n_al, n_ac = p.n_per_row, p.n_rows
    if layout == "portico":
        my = p.aisle_m
    xs, ys, rect = _grid(n_al, n_ac, p.bay_m, p.aisle_m, mx, my)
    x0, y0, x1, y1 = rect
    sup: list[SupportSpec] = []

    def is_pier(group: str) -> bool:
        return bool(rng.random() < p.pier_share) and group != "in_antis"

    if layout in ("nave", "hypostyle", "kiosk"):
        mid = (n_ac - 1) / 2
        for j, y in enumerate(ys):
            central = abs(j - mid) <= 0.5
            for i, x in enumerate(xs):
                if layout == "hypostyle":  # a central aisle of larger supports
                    group = "main" if central else "aisle"
                elif layout == "nave":  # the alternating system: strong and weak supports
                    group = "main" if i % 2 == 0 else "aisle"
                else:  # kiosk: stronger corners
                    corner = i in (0, n_al - 1) and j in (0, n_ac - 1)
                    group = "main" if corner else "aisle"
                r = r_main if group == "main" else r2
                sup += _free_support(p, float(x), float(y), r, group, rng, pier=is_pier(group))
    elif layout == "portico":
        for j, y in enumerate(ys[::-1]):  # the front row (largest y) first
            group = "main" if j == 0 else "aisle"
            r = r_main if j == 0 else r2
            for x in xs:
                sup += _free_support(p, float(x), float(y), r, group, rng, pier=is_pier("main"))
        rect = (x0, 0.0, x1, float(ys[-1]) + foot)
    elif layout == "peristyle":
        for j, y in enumerate(ys):
            for i, x in enumerate(xs):
                corner = i in (0, n_al - 1) and j in (0, n_ac - 1)
                if i in (0, n_al - 1) or j in (0, n_ac - 1):  # angle columns are stouter
                    r = r_main if corner else r2
                    group = "main" if corner else "aisle"
                    sup += _free_support(p, float(x), float(y), r, group, rng, pier=is_pier(group))
    if layout in ("kiosk", "peristyle"):  # the entablature stands on the supports
        rect = (
            float(xs[0]) - foot,
            float(ys[0]) - foot,
            float(xs[-1]) + foot,
            float(ys[-1]) + foot,
        )
    plan.rect = rect
    x0, y0, x1, y1 = rect
    # walls
    walled = layout in ("nave", "hypostyle", "portico")
    H = p.column_height_m
    if walled:
        wall_h = H + (p.vault_rise_m + 0.3 if p.ceiling == "vault" and not p.attic else 0.0)
        if ruin:
            wall_h = H * p.ruin_wall_ratio
        skip = ("north",) if layout == "portico" else ()
        plan.walls = _room_walls(
            p, rect, wall_h, xs, ys if layout != "portico" else ys[:0], rng, ruin=ruin, skip=skip
        )
        plan.enclosed = layout != "portico"
        # engaged columns / responds on the long walls, in line with the supports
        if layout in ("nave", "hypostyle") and (p.engaged or p.responds):
            for x in xs:
                for yw, nrm in ((y0, (0.0, 1.0)), (y1, (0.0, -1.0))):
                    respond = p.responds and (not p.engaged or rng.random() < 0.5)
                    sup.append(
                        _wall_support(p, float(x), yw, nrm, r3, rng, respond=respond, group="wall")
                    )
        if layout == "portico" and p.antae:
            # side walls end in antae at the front row
            w = max(p.wall_thickness_m + 0.2, 0.5)
            d = max(0.5, w * 0.8)
            for xa, sign in ((x0, 1.0), (x1, -1.0)):
                cx = xa - sign * p.wall_thickness_m / 2
                yend = y1 - 0.0
                sup.append(
                    SupportSpec(
                        "pier",
                        cx,
                        yend + d / 2,
                        0.0,
                        H,
                        pier_width_m=w,
                        pier_depth_m=d,
                        cuts={"-y": -d / 2},
                        group="anta",
                        pier_capital_height_m=0.15 if p.capital else 0.0,
                        pier_projection_m=0.08 if p.capital else 0.0,
                    )
                )
            t = p.wall_thickness_m
            rect = (x0 - t, -t, x1 + t, y1 + d)
            plan.rect = rect
    if layout == "peristyle" and p.antae and n_al >= 4 and n_ac >= 4:
        _cella(p, plan, xs, ys, r2, rng, sup, ruin)
    plan.supports = sup
    # ceilings / attic
    ceiling = "none" if ruin else p.ceiling
    if (p.attic or ceiling == "attic") and not ruin:
        plan.attic = {
            "entablature_m": p.entablature_m,
            "overhang_m": p.overhang_m,
            "eave_drop_m": p.eave_drop_m,
        }
        ceiling = "attic"
    plan.ceiling = ceiling
    plan.lines_x = xs
    plan.lines_y = ys
    plan.vault_rise_m = p.vault_rise_m
    if p.platform_m > 0:
        plan.platform_m = p.platform_m
        e = foot + 0.5
        plan.platform_rect = (
            min(rect[0], xs[0] - e),
            min(rect[1], ys[0] - e),
            max(rect[2], xs[-1] + e),
            max(rect[3], ys[-1] + e),
        )
    plan.inside = shapely.box(*plan.rect)
    _leaning_and_broken(p, plan, rng, ruin)
    place_clutter(p, plan, rng)
    if ruin:
        place_debris(p, plan, rng)
    return plan


def _cella(
    p: Any,
    plan: Plan,
    xs: Array,
    ys: Array,
    r: float,
    rng: np.random.Generator,
    sup: list[SupportSpec],
    ruin: bool,
) -> None:
    """Cella inside a peristyle: three walls, antae at the open end, columns in antis."""
    cx0, cx1 = float(xs[1]), float(xs[-2])
    cy0, cy1 = float(ys[1]), float(ys[-2])
    t = p.wall_thickness_m
    H = p.column_height_m
    h = H * (p.ruin_wall_ratio if ruin else 1.0)

    def top(length: float) -> float | tuple[float, ...]:
        return _ragged(h, length, rng) if ruin else h

    d = max(0.5, 0.8 * t)  # depth of the antae along the walls
    x_open = cx0 + d
    L = cx1 - x_open
    if L < 2.0 or (cy1 - cy0 - 2 * t) / 3 < 2 * foot_half(p, r) + 0.3:
        return  # no room for a cella with columns in antis
    plan.walls += [
        WallSpec((x_open, cy0 + t), (1.0, 0.0), L + t, t, 0.0, top(L + t)),
        WallSpec((cx1, cy0 + t), (0.0, 1.0), cy1 - cy0 - 2 * t + t, t, 0.0, top(cy1 - cy0)),
        WallSpec((cx1, cy1 - t), (-1.0, 0.0), L, t, 0.0, top(L)),
    ]
    w = t + 0.2
    for yc in (cy0 + t / 2, cy1 - t / 2):
        sup.append(
            SupportSpec(
                "pier",
                x_open - d / 2,
                yc,
                0.0,
                H,
                pier_width_m=d,
                pier_depth_m=w,
                cuts={"+x": d / 2},
                group="anta",
                pier_capital_height_m=0.15 if p.capital else 0.0,
                pier_projection_m=0.08 if p.capital else 0.0,
            )
        )
    for k in (1, 2):
        y = cy0 + t + (cy1 - cy0 - 2 * t) * k / 3
        sup.append(
            SupportSpec(
                "column",
                x_open - d / 2,
                y,
                0.0,
                H,
                column=column_shape(p, r, rng),
                group="in_antis",
            )
        )


def _leaning_and_broken(p: Any, plan: Plan, rng: np.random.Generator, ruin: bool) -> None:
    """Break and tilt some free columns (ruins; leaning also under open sky)."""
    open_sky = plan.ceiling == "none"
    for s in plan.supports:
        if s.klass == "engaged_column" or s.group in ("anta", "wall"):
            continue
        if ruin and rng.random() < p.broken_share:
            shaft0 = 0.15 * s.height_m
            s.broken_at_m = float(rng.uniform(shaft0, 0.9 * s.height_m))
        if (
            s.klass == "column"
            and open_sky
            and s.group != "twin"
            and (rng.random() < p.leaning_share)
        ):
            s.tilt_deg = float(rng.uniform(1.0, p.lean_max_deg))
            s.lean_azimuth_deg = float(rng.uniform(0, 360))
