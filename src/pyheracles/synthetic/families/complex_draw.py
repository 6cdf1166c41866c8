"""Drawing a random walled complex: enclosure, walls and gates, buildings, trees, clutter.

:func:`draw_layout` turns the (fully drawn) parameters of
:class:`~pyheracles.synthetic.families.complex.ComplexFamilyParams` into a
:class:`~pyheracles.synthetic.families.complex_layout.Layout`: the perimeter
wall is a rectangle in the complex frame cut by its gates into wall runs;
internal walls cross the enclosure, abutting the perimeter's inner faces,
each with a gate; buildings are placed by rejection sampling on the free
ground (off walls, gate passages and terrace edges; most inside the walls,
a few outside and across the tile's edge), shrunk when they do not fit;
trees stand beside buildings (crowns over the roofs) or in the open.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np
import shapely
from numpy.typing import NDArray
from shapely.geometry import Polygon, box
from shapely.ops import unary_union

from pyheracles.synthetic.families.complex_build import Placement
from pyheracles.synthetic.families.complex_layout import (
    Building,
    Clutter,
    Gate,
    Layout,
    Part,
    Terrain,
    Tree,
    Wall,
    building_footprint,
    gate_footprint,
    wall_footprint,
)

__all__ = ["draw_layout"]

Array = NDArray[np.float64]


_FUNCTIONS_CLOSED = ("residence", "storeroom", "hall", "museum", "office", "kitchen",
                     "prayer house", "guard house")  # fmt: skip
_FUNCTIONS_PAVILION = ("pavilion", "audience pavilion", "gamelan pavilion", "guard pavilion")


def _terrain(
    p: Any, rng: np.random.Generator, frame: Placement, half: tuple[float, float]
) -> Terrain:
    """Slope, hills and terrace steps (at internal-wall lines or free lines)."""
    ang = rng.uniform(0, 2 * np.pi)
    g = p.slope_pct / 100.0
    w, d = p.width_m, p.depth_m
    n_hills = int(rng.integers(1, 5)) if p.relief_m > 0 else 0
    hills = tuple(
        (float(rng.uniform(0, w)), float(rng.uniform(0, d)),
         float(p.relief_m * rng.uniform(0.4, 1.0) * rng.choice([-1.0, 1.0])),
         float(rng.uniform(10.0, 40.0)))
        for _ in range(n_hills)
    )  # fmt: skip
    steps = []
    for _ in range(p.n_terraces):
        v = float(rng.uniform(-0.8, 0.8) * half[1])
        width = p.terrace_step_m / np.tan(np.deg2rad(p.riser_deg))
        steps.append((v, float(p.terrace_step_m * rng.choice([-1.0, 1.0], p=[0.3, 0.7])),
                      float(max(width, 0.2))))  # fmt: skip
    return Terrain(0.0, (g * np.cos(ang), g * np.sin(ang)), hills, tuple(steps), frame)


def _enclosure(p: Any) -> tuple[Placement, float, float]:
    """The complex frame and the half sizes of the perimeter wall's axis rectangle."""
    a = np.deg2rad(p.orientation_deg)
    c, s = abs(np.cos(a)), abs(np.sin(a))
    hw0, hd0 = p.width_m / 2 - p.margin_m, p.depth_m / 2 - p.margin_m
    k = p.enclosure_aspect * (hw0 / hd0 if c >= s else hd0 / hw0)
    hw, hd = p.width_m / 2 - p.margin_m, p.depth_m / 2 - p.margin_m
    scale = min(hw / (k * c + s), hd / (k * s + c))
    frame = Placement(p.orientation_deg, (p.width_m / 2, p.depth_m / 2))
    # at least 24 m across (a narrow tile turned by 45 deg would leave a sliver)
    return frame, max(float(k * scale), 12.0), max(float(scale), 12.0)


def _ring_point(ring: Array, cum: Array, s: float) -> Array:
    s = s % cum[-1]
    i = int(np.searchsorted(cum, s, side="right") - 1)
    i = min(i, len(ring) - 2)
    t = (s - cum[i]) / (cum[i + 1] - cum[i])
    return ring[i] + t * (ring[i + 1] - ring[i])


def _sub_ring(ring: Array, cum: Array, s0: float, s1: float) -> list[tuple[float, float]]:
    """The part of a closed polyline between arclengths ``s0`` < ``s1`` (may wrap)."""
    total = cum[-1]
    pts = [_ring_point(ring, cum, s0)]
    for k in range(3):  # corners within (s0, s1), over at most two wraps
        for i in range(len(ring) - 1):
            c = cum[i] + k * total
            if s0 < c < s1:
                pts.append(ring[i])
    pts.append(_ring_point(ring, cum, s1))
    return [(float(x), float(y)) for x, y in pts]


def _gate_size(p: Any, rng: np.random.Generator, thickness: float) -> dict[str, Any]:
    split = rng.random() < p.split_gate_share
    depth = thickness + float(rng.uniform(0.6, 2.5))
    if split:
        opening = float(rng.uniform(2.0, 4.0))
        tower = float(rng.uniform(0.8, 2.2))
        return {"gate_type": "split", "width_m": opening + 2 * tower, "depth_m": depth,
                "opening_m": opening,
                "height_m": float(p.gate_height_m * rng.uniform(0.85, 1.15))}  # fmt: skip
    return {"gate_type": "roofed", "width_m": float(rng.uniform(3.0, 6.5)), "depth_m": depth,
            "opening_m": 0.0,
            "height_m": float(p.gate_height_m * rng.uniform(0.6, 0.9))}  # fmt: skip


def _walls_and_gates(
    p: Any, rng: np.random.Generator, A: float, B: float
) -> tuple[list[Wall], list[Gate], list[float], Any]:
    """Perimeter wall cut by gates, internal walls across the enclosure, their gates.

    Returns the walls, the gates (frames relative to the complex frame), the v
    positions of the internal walls and the union of the gate passages (kept free).
    """
    t, h = p.wall_thickness_m, p.wall_height_m
    walls: list[Wall] = []
    gates: list[Gate] = []
    passages = []
    # internal walls along u at v = const, abutting the perimeter's inner faces
    vs: list[float] = []
    for _ in range(p.n_internal_walls):
        for _try in range(20):
            v = float(rng.uniform(-B + 12, B - 12)) if B > 14 else 0.0
            if all(abs(v - o) > 12 for o in vs):
                vs.append(v)
                break
    vs.sort()
    # perimeter: a ring (counter-clockwise from the SW corner), gates away from corners/joints
    ring = np.array([[-A, -B], [A, -B], [A, B], [-A, B], [-A, -B]])
    cum = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(ring, axis=0), axis=1))]
    corners = cum[:-1]
    joints = [float(cum[1] + (v + B)) for v in vs] + [float(cum[3] + (B - v)) for v in vs]
    sizes = [_gate_size(p, rng, t) for _ in range(p.n_gates)]
    pos: list[float] = []
    for sz in sizes:
        for _try in range(200):
            s = float(rng.uniform(0, cum[-1]))
            need = sz["width_m"] / 2 + t + 3.0
            ok = all(min(abs(s - c), cum[-1] - abs(s - c)) > need for c in [*corners, cum[-1]])
            ok &= all(abs(s - j) > need + 1 for j in joints)
            ok &= all(
                min(abs(s - q), cum[-1] - abs(s - q)) > need + w / 2 + 4
                for q, w in zip(pos, [z["width_m"] for z in sizes], strict=False)
            )
            if ok:
                pos.append(s)
                break
        else:
            pos.append(float("nan"))
    placed = [(s, sz) for s, sz in zip(pos, sizes, strict=True) if np.isfinite(s)]
    placed.sort(key=lambda q: q[0])
    for s, sz in placed:
        c = _ring_point(ring, cum, s)
        i = min(int(np.searchsorted(cum, s, side="right") - 1), 3)
        d = ring[i + 1] - ring[i]
        ang = float(np.degrees(np.arctan2(d[1], d[0])))
        gates.append(Gate(f"G{len(gates) + 1:02d}", f"Gapura {len(gates) + 1}",
                          place=Placement(ang, (float(c[0]), float(c[1]))), **sz))  # fmt: skip
    material = str(rng.choice(["red brick", "plastered brick", "coral stone"]))
    for k, (s, sz) in enumerate(placed):
        s_next, sz_next = placed[(k + 1) % len(placed)]
        s0 = s + sz["width_m"] / 2
        s1 = s_next - sz_next["width_m"] / 2 + (cum[-1] if k == len(placed) - 1 else 0.0)
        walls.append(Wall(f"W{len(walls) + 1:02d}", f"Benteng {len(walls) + 1}",
                          "perimeter wall", material, tuple(_sub_ring(ring, cum, s0, s1)),
                          t, h))  # fmt: skip
    if not placed:  # pragma: no cover - the perimeter always takes its gates
        walls.append(Wall("W01", "Benteng 1", "perimeter wall", material,
                          tuple(map(tuple, ring[:-1].tolist())), t, h))  # fmt: skip
    # internal walls, each with one gate at most
    ti, hi = max(0.2, 0.8 * t), max(1.0, 0.85 * h)
    u0, u1 = -A + t / 2, A - t / 2
    for v in vs:
        if rng.random() < 0.85 and (u1 - u0) > 2 * 8.4 + 10:  # a gate where the wall is long
            sz = _gate_size(p, rng, ti)
            uc = float(rng.uniform(u0 + sz["width_m"] / 2 + 4, u1 - sz["width_m"] / 2 - 4))
            gates.append(Gate(f"G{len(gates) + 1:02d}", f"Lawang {len(gates) + 1}",
                              place=Placement(0.0, (uc, v)), **sz))  # fmt: skip
            runs = [((u0, v), (uc - sz["width_m"] / 2, v)), ((uc + sz["width_m"] / 2, v), (u1, v))]
        else:
            runs = [((u0, v), (u1, v))]
        for run in runs:
            walls.append(Wall(f"W{len(walls) + 1:02d}", f"Tembok {len(walls) + 1}",
                              "internal wall", "plastered brick", run, ti, hi))  # fmt: skip
    for g in gates:  # passages through the gates stay free of buildings
        passages.append(g.place.geometry(box(-g.width_m / 2, -g.depth_m / 2 - 6,
                                             g.width_m / 2, g.depth_m / 2 + 6)))  # fmt: skip
    return walls, gates, vs, unary_union(passages) if passages else Polygon()


def _roof_style(p: Any, rng: np.random.Generator, kind: str) -> str:
    u = rng.random()
    if kind == "pavilion":
        return str(rng.choice(["hipped", "pyramid", "joglo", "gabled"], p=[0.4, 0.25, 0.25, 0.1]))
    if u < p.flat_roof_share:
        return "flat"
    if u < p.flat_roof_share + p.gabled_share:
        return "gabled"
    return str(rng.choice(["hipped", "joglo"], p=[0.85, 0.15]))


def _eaves(p: Any, rng: np.random.Generator, style: str) -> float:
    if style == "flat":
        return float(rng.uniform(0.0, min(0.3, p.eaves_max_m)))
    return float(rng.uniform(0.25, 1.0) * p.eaves_max_m)


def _part(
    p: Any,
    rng: np.random.Generator,
    rect: tuple[float, float, float, float],
    kind: str,
    storeys: int,
    style: str | None = None,
    eaves: tuple[float, float, float, float] | None = None,
) -> Part:
    style = style or _roof_style(p, rng, kind)
    e = _eaves(p, rng, style)
    eave_h = float(rng.uniform(2.4, 3.4) * (storeys if kind == "closed" else 1.0))
    pitch = float(rng.uniform(20, 45)) if style != "joglo" else float(rng.uniform(18, 28))
    parapet = float(rng.uniform(0.0, 1.0)) if style == "flat" else 0.0
    return Part(rect, eave_h, style, pitch, eaves or (e, e, e, e), parapet)


def _base(p: Any, rng: np.random.Generator, kind: str) -> dict[str, Any]:
    raised = kind == "pavilion" or rng.random() < p.platform_share
    height = float(rng.uniform(0.3, max(0.3, p.platform_height_max_m)))
    if raised:
        return {
            "base": "platform",
            "base_height_m": height,
            "base_margin_m": float(rng.uniform(0.2, 0.2 + p.platform_margin_max_m)),
        }
    return {"base": "plinth", "base_height_m": height,
            "base_margin_m": float(rng.uniform(0.05, 0.3))}  # fmt: skip


def _building_shapes(p: Any, rng: np.random.Generator, n: int) -> list[dict[str, Any]]:
    """Kinds and parts (building frame, centred) of ``n`` GIS features, before placement."""
    out: list[dict[str, Any]] = []
    lo = 3.5
    hi = max(lo + 1.0, p.building_size_m)
    while len(out) < n:
        kind = "pavilion" if rng.random() < p.pavilion_share else "closed"
        storeys = int(rng.integers(1, p.storeys_max + 1)) if kind == "closed" else 1
        length = float(np.exp(rng.uniform(np.log(lo + 1), np.log(hi))))
        width = float(rng.uniform(lo, min(length, max(lo + 0.5, 0.7 * hi))))
        if kind == "pavilion":
            length = min(length, 22.0)
            width = float(rng.uniform(0.6, 1.0)) * length
        u = rng.random()
        base = _base(p, rng, kind)
        if kind == "closed" and u < 0.12 and length > 14 and width > 11:
            # courtyard building: four wings around a yard (a polygon with a hole)
            wing = float(rng.uniform(3.5, min(7.0, width / 3)))
            L, W = length / 2, width / 2
            e = _eaves(p, rng, "hipped")
            rects = [
                (-L, -W, L, -W + wing),
                (-L, W - wing, L, W),
                (-L, -W + wing, -L + wing, W - wing),
                (L - wing, -W + wing, L, W - wing),
            ]
            eh = float(rng.uniform(2.6, 3.4))
            parts = tuple(Part(r, eh, "hipped", float(rng.uniform(25, 40)), (e, e, e, e))
                          for r in rects)  # fmt: skip
            out.append({"kind": kind, "parts": parts, "storeys": 1, **base,
                        "function": "residence", "group": None})  # fmt: skip
            continue
        if kind == "closed" and u < 0.3 and length > 9:
            # L-shaped: a wing at one end, sticking out on one side
            wing_w = float(rng.uniform(3.5, max(3.6, 0.45 * length)))
            wing_d = float(rng.uniform(3.0, max(3.1, width)))
            sty = _roof_style(p, rng, kind)
            main = _part(
                p, rng, (-length / 2, -width / 2, length / 2, width / 2), kind, storeys, sty
            )
            side = float(rng.choice([-1.0, 1.0]))
            y0, y1 = (
                (width / 2, width / 2 + wing_d) if side > 0 else (-width / 2 - wing_d, -width / 2)
            )
            wing = _part(p, rng, (length / 2 - wing_w, y0, length / 2, y1), kind, storeys, sty)
            out.append(
                {
                    "kind": kind,
                    "parts": (main, wing),
                    "storeys": storeys,
                    **base,
                    "function": str(rng.choice(_FUNCTIONS_CLOSED)),
                    "group": None,
                }
            )
            continue
        if kind == "closed" and u < 0.38 and n - len(out) >= 2:
            # a row of 2-4 units sharing party walls (touching polygons, one group)
            k = int(min(n - len(out), rng.integers(2, 5)))
            depth = float(rng.uniform(5.0, 10.0))
            widths = rng.uniform(4.0, 8.0, k)
            x = -widths.sum() / 2
            e = _eaves(p, rng, "hipped")
            group = f"row{len(out)}"
            for i, wi in enumerate(widths):
                eaves = (e if i == 0 else 0.0, e, e if i == k - 1 else 0.0, e)
                part = _part(
                    p,
                    rng,
                    (float(x), -depth / 2, float(x + wi), depth / 2),
                    kind,
                    1,
                    "hipped",
                    eaves,
                )
                out.append({"kind": kind, "parts": (part,), "storeys": 1, **base,
                            "function": "residence", "group": group,
                            "row_index": i})  # fmt: skip
                x += wi
            continue
        if kind == "pavilion" and u < 0.1:
            # twin pavilions: one feature of two parts (a MultiPolygon in the GIS)
            s = float(rng.uniform(3.5, 6.0))
            gap = float(rng.uniform(4.0, 10.0))
            sty = _roof_style(p, rng, kind)
            parts = tuple(_part(p, rng, (x0, -s / 2, x0 + s, s / 2), kind, 1, sty)
                          for x0 in (-gap / 2 - s, gap / 2))  # fmt: skip
            out.append(
                {
                    "kind": kind,
                    "parts": parts,
                    "storeys": 1,
                    **base,
                    "function": "guard pavilions",
                    "group": None,
                }
            )
            continue
        part = _part(p, rng, (-length / 2, -width / 2, length / 2, width / 2), kind, storeys)
        fn = _FUNCTIONS_PAVILION if kind == "pavilion" else _FUNCTIONS_CLOSED
        out.append(
            {
                "kind": kind,
                "parts": (part,),
                "storeys": storeys,
                **base,
                "function": str(rng.choice(fn)),
                "group": None,
            }
        )
    return out[:n]


def _scaled(parts: tuple[Part, ...], f: float) -> tuple[Part, ...]:
    """Parts with their rectangles scaled by ``f`` about the frame's origin (>= 3.5 m a side)."""
    sides = [min(p.rect[2] - p.rect[0], p.rect[3] - p.rect[1]) for p in parts]
    f = max(f, min(1.0, 3.5 / max(min(sides), 1e-6)))
    return tuple(replace(p, rect=tuple(float(v * f) for v in p.rect)) for p in parts)


def _place_buildings(
    p: Any,
    rng: np.random.Generator,
    shapes: list[dict[str, Any]],
    frame: Placement,
    free: Any,
    extent: Any,
    *,
    placed: list[Building],
    taken: list[Any],
    edge: Any = None,
    inside: tuple[float, float] | None = None,
) -> None:
    """Rejection sampling of positions (rows are placed as one block), appended to ``placed``.

    With ``edge`` (a line), a building must cross it (cut by the survey's edge).
    """
    xmin, ymin, xmax, ymax = extent.bounds
    i = 0
    while i < len(shapes):
        sh = shapes[i]
        block = [sh]
        if sh.get("group"):
            while (
                i + len(block) < len(shapes) and shapes[i + len(block)].get("group") == sh["group"]
            ):
                block.append(shapes[i + len(block)])
        ok = False
        for _try in range(100):
            if _try % 25 == 0:  # the block is made smaller after every 25 failed tries
                if _try:
                    block = [{**b, "parts": _scaled(b["parts"], 0.8)} for b in block]
                probe = [
                    Building(
                        "x",
                        "x",
                        "x",
                        b["kind"],
                        Placement(),
                        b["parts"],
                        b["base"],
                        b["base_height_m"],
                        b["base_margin_m"],
                    )
                    for b in block
                ]
                local = unary_union([building_footprint(b) for b in probe])
            ang = float(rng.choice([0.0, 90.0, 180.0, 270.0]))
            if rng.random() < 0.12:
                ang += float(rng.uniform(-25, 25))
            if inside is not None and rng.random() < 0.85:  # most stand inside the walls
                a, b = inside
                centre = tuple(frame.xy([rng.uniform(-a, a), rng.uniform(-b, b)]))
            else:
                centre = (float(rng.uniform(xmin, xmax)), float(rng.uniform(ymin, ymax)))
            place = Placement(frame.angle_deg + ang, centre)
            fp = place.geometry(local)
            gap = float(rng.uniform(1.0, 4.0))
            if edge is not None and not fp.intersects(edge):
                continue
            if free.contains(fp) and not any(fp.distance(t) < gap for t in taken):
                ok = True
                break
        if ok:
            taken.append(fp)
            for b in block:
                k = len(placed) + 1
                placed.append(Building(
                    f"B{k:02d}", f"{b['function'].capitalize()} {k}", b["function"], b["kind"],
                    place, b["parts"], b["base"], b["base_height_m"], b["base_margin_m"],
                    storeys=b["storeys"],
                ))  # fmt: skip
        i += len(block)


def _trees(
    p: Any,
    rng: np.random.Generator,
    buildings: list[Building],
    walls_fp: Any,
    blocked: Any,
    bounds: tuple[float, float, float, float],
) -> list[Tree]:
    """Trees: a share beside buildings (crowns over roofs), others in open ground."""
    out: list[Tree] = []
    fps = [building_footprint(b) for b in buildings if b.status == "extant"]
    x0, y0, x1, y1 = bounds
    for _ in range(p.n_trees):
        r = float(rng.uniform(2.0, max(2.1, p.crown_radius_max_m)))
        for _try in range(40):
            if fps and rng.random() < p.tree_over_roof_share:
                fp = fps[int(rng.integers(len(fps)))]
                fp = max(getattr(fp, "geoms", [fp]), key=lambda g: g.area)
                ring = fp.exterior
                pt = ring.interpolate(float(rng.uniform(0, ring.length)))
                out_d = float(rng.uniform(0.6, 0.6 * r + 0.6))
                c = np.array(pt.coords[0])
                ctr = np.array(fp.centroid.coords[0])
                d = c - ctr
                c = c + d / max(np.linalg.norm(d), 1e-9) * out_d
            else:
                c = np.array([rng.uniform(x0 + 2, x1 - 2), rng.uniform(y0 + 2, y1 - 2)])
            if not (x0 < c[0] < x1 and y0 < c[1] < y1):
                continue
            if blocked.distance(shapely.Point(c)) > 0.6:
                break
        else:
            continue
        hz = r * float(rng.uniform(0.55, 0.9))
        out.append(
            Tree(
                float(c[0]),
                float(c[1]),
                r,
                hz,
                float(rng.uniform(2.0, 7.0)),
                float(rng.uniform(0.6, 1.6)),
                float(np.clip(p.crown_penetration * rng.uniform(0.7, 1.3), 0.05, 0.9)),
            )
        )
    return out


_CLUTTER_KINDS = ("bench", "lamp", "planter", "car", "shed", "kiosk")


def _clutter(
    p: Any,
    rng: np.random.Generator,
    blocked: Any,
    frame: Placement,
    bounds: tuple[float, float, float, float],
) -> list[Clutter]:
    """Street furniture and unmapped small structures, mostly near buildings and walls."""
    out: list[Clutter] = []
    x0, y0, x1, y1 = bounds
    near = blocked.buffer(5.0)
    for _ in range(p.n_clutter):
        kind = str(rng.choice(_CLUTTER_KINDS, p=[0.3, 0.2, 0.15, 0.2, 0.08, 0.07]))
        for _try in range(30):
            c = (float(rng.uniform(x0 + 3, x1 - 3)), float(rng.uniform(y0 + 3, y1 - 3)))
            pt = shapely.Point(c)
            clear = 3.0 if kind in ("car", "shed", "kiosk") else 1.0
            if blocked.distance(pt) > clear and (near.contains(pt) or rng.random() < 0.3):
                out.append(Clutter(kind, Placement(frame.angle_deg + float(rng.uniform(0, 180)),
                                                   c)))  # fmt: skip
                blocked = blocked.union(pt.buffer(2.5 if clear > 1 else 0.8))
                break
    return out


def draw_layout(p: Any, rng: np.random.Generator) -> Layout:
    """A random walled complex from the (fully drawn) family parameters ``p``."""
    bounds = (0.0, 0.0, float(p.width_m), float(p.depth_m))
    extent = box(*bounds)
    frame, A, B = _enclosure(p)
    terrain = _terrain(p, rng, frame, (A, B))
    walls, gates_c, vs, passages_c = _walls_and_gates(p, rng, A, B)
    gates = [Gate(g.fid, g.name, g.gate_type, frame.then(g.place), g.width_m, g.depth_m,
                  g.height_m, g.opening_m) for g in gates_c]  # fmt: skip
    walls_fp = unary_union([wall_footprint(w, frame) for w in walls])
    gates_fp = unary_union([gate_footprint(g) for g in gates])
    # free ground for buildings: inside the extent (a few may stick out), off walls,
    # gate passages and terrace risers
    risers = [frame.geometry(box(-A - 50, v - w / 2 - 1.5, A + 50, v + w / 2 + 1.5))
              for v, _h, w in terrain.steps]  # fmt: skip
    blocked = unary_union([walls_fp.buffer(1.0), gates_fp.buffer(1.0),
                           frame.geometry(passages_c), *risers])  # fmt: skip
    free = extent.buffer(-3.0).difference(blocked)
    buildings: list[Building] = []
    taken: list[Any] = []
    shapes = _building_shapes(p, rng, p.n_buildings)
    _place_buildings(
        p,
        rng,
        shapes,
        frame,
        free,
        extent.buffer(6.0),
        placed=buildings,
        taken=taken,
        inside=(A, B),
    )
    if p.n_edge_buildings:  # buildings cut by the survey's edge (partly outside the cloud)
        shapes = [s for s in _building_shapes(p, rng, 3 * p.n_edge_buildings)
                  if not s.get("group")][: p.n_edge_buildings]  # fmt: skip
        free_edge = extent.buffer(12.0).difference(blocked)
        _place_buildings(
            p,
            rng,
            shapes,
            frame,
            free_edge,
            extent.buffer(8.0),
            placed=buildings,
            taken=taken,
            edge=extent.exterior,
        )
    # demolished buildings: in the GIS, not in the scene
    k_dem = min(p.n_demolished, len(buildings))
    for k in rng.choice(len(buildings), k_dem, replace=False) if k_dem else []:
        b = buildings[int(k)]
        buildings[int(k)] = Building(b.fid, b.name, f"{b.function} (demolished)", b.kind,
                                     b.place, b.parts, b.base, b.base_height_m, b.base_margin_m,
                                     status="demolished", storeys=b.storeys)  # fmt: skip
    b_fp = unary_union([building_footprint(b) for b in buildings]) if buildings else Polygon()
    obstacles = unary_union([walls_fp, gates_fp, b_fp])
    trees = _trees(p, rng, buildings, walls_fp, obstacles, bounds)
    trunks = (
        unary_union([shapely.Point(t.x, t.y).buffer(1.0) for t in trees]) if trees else Polygon()
    )
    clutter = _clutter(p, rng, unary_union([obstacles, trunks]), frame, bounds)
    groups = {w.fid: "enclosure" for w in walls} | {g.fid: "enclosure" for g in gates}
    bgroups = {b.fid: b.fid for b in buildings}
    for b in buildings:  # rows share a frame: one digitising shift for the whole row
        same = [o.fid for o in buildings if o.place == b.place]
        bgroups[b.fid] = same[0]
    del vs
    return Layout(bounds, frame, terrain, tuple(buildings), tuple(walls), tuple(gates),
                  tuple(trees), tuple(clutter), groups, bgroups)  # fmt: skip
