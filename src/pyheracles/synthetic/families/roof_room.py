"""What surrounds the ``roof`` family's frames: masonry, floor, boarding, clutter, stations.

Everything here is reference instance 0 with its own class (``floor``,
``wall``, ``boarding``, ``chimney``, ``loose_timber``, ``ladder``): the
surfaces a beam segmentation must leave alone, which make most of the cloud.
Clutter is placed by rejection: a candidate that comes within a few
centimetres of a member, the chimney, another piece or a scanner's tripod is
drawn again (oriented-box separating-axis tests).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import shapely
from numpy.typing import ArrayLike, NDArray

from pyheracles.synthetic.families.boxes import obb_distance_to_point, obb_overlap_many
from pyheracles.synthetic.families.roof_frame import Member, RoofLevels
from pyheracles.synthetic.scene import STONE, TIMBER, Scene

__all__ = [
    "Box",
    "add_room",
    "place_chimney",
    "place_clutter",
    "place_ladder",
    "place_stations",
]

Array = NDArray[np.float64]
X = np.array([1.0, 0.0, 0.0])
Z = np.array([0.0, 0.0, 1.0])


@dataclass(frozen=True)
class Box:
    """An oriented box of the surroundings: centre, rows (unit axes), full size."""

    centre: Array
    rows: Array
    size: Array

    @property
    def half(self) -> Array:
        return 0.5 * np.asarray(self.size, float)

    def to_json(self) -> dict[str, Any]:
        return {
            "centre": np.asarray(self.centre).tolist(),
            "rows": np.asarray(self.rows).tolist(),
            "size": np.asarray(self.size).tolist(),
        }

    @staticmethod
    def of(member: Member) -> Box:
        return Box(member.centre, member.rows, 2 * member.half_extents)


def _box(centre: ArrayLike, size: ArrayLike, rows: ArrayLike | None = None) -> Box:
    return Box(
        np.asarray(centre, float),
        np.eye(3) if rows is None else np.asarray(rows, float),
        np.asarray(size, float),
    )


def _add(scene: Scene, b: Box, **ref: Any) -> None:
    scene.add_box(b.centre, b.size, frame=b.rows, **ref)


def _hits(b: Box, obstacles: list[Box], tol: float) -> list[int]:
    """Indices of the obstacles ``b`` comes within ``tol`` of (bounding-sphere prefilter)."""
    if not obstacles:
        return []
    C = np.array([o.centre for o in obstacles])
    rad = np.array([np.linalg.norm(o.half) for o in obstacles])
    near = np.flatnonzero(
        np.linalg.norm(C - b.centre, axis=1) <= rad + np.linalg.norm(b.half) + tol
    )
    if len(near) == 0:
        return []
    R = np.array([obstacles[i].rows for i in near])
    H = np.array([obstacles[i].half for i in near])
    ok = obb_overlap_many(b.centre, b.rows, b.half, C[near], R, H, tol)
    return [int(i) for i in near[ok]]


# ----------------------------------------------------------------------------- masonry etc.
def add_room(scene: Scene, lv: RoofLevels, tie_x: list[float], gable_t: float) -> None:
    """Floor, eaves walls (built up between the tie beams), gable walls and the boarding."""
    L, half, t = lv.length, lv.half, lv.wall_t
    w_tie = lv.sections["tie"][0]
    floor = _box([L / 2, 0.0, -0.05], [L, 2 * half, 0.1])
    scene.add_box(
        floor.centre, floor.size, faces=("+z",), class_name="floor", part="floor", material=TIMBER
    )
    scene.objects.append(
        {
            "instance": 0,
            "class": "floor",
            "plane": {"point": [L / 2, 0.0, 0.0], "normal": [0.0, 0.0, 1.0]},
            "box": floor.to_json(),
        }
    )
    x_lo, x_hi = -gable_t, L + gable_t
    for sgn in (-1.0, 1.0):
        yc = sgn * (half + t / 2)
        lower = _box([(x_lo + x_hi) / 2, yc, (lv.z_w - 0.3) / 2], [x_hi - x_lo, t, lv.z_w + 0.3])
        _add(scene, lower, class_name="wall", part="eaves_wall", material=STONE)
        scene.objects.append(
            {"instance": 0, "class": "wall", "part": "eaves_wall", "box": lower.to_json()}
        )
        # the wall head is built up between the tie beams' ends, to the ties' top
        cuts = sorted(tie_x)
        edges = [x_lo] + [v for x in cuts for v in (x - w_tie / 2, x + w_tie / 2)] + [x_hi]
        for a, b in zip(edges[::2], edges[1::2], strict=True):
            if b - a > 0.01:
                head = _box([(a + b) / 2, yc, (lv.z_w + lv.z_tt) / 2], [b - a, t, lv.z_tt - lv.z_w])
                _add(scene, head, class_name="wall", part="wall_head", material=STONE)
    yo = half + t
    zr = lambda eta: float(lv.underside(eta)) + lv.boarding_t / lv.cos + 0.02  # noqa: E731
    poly = shapely.Polygon([(-yo, -0.3), (yo, -0.3), (yo, zr(yo)), (0.0, zr(0.0)), (-yo, zr(yo))])
    rows = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
    for x0 in (-gable_t, L):
        scene.add_prism(
            poly,
            [x0, 0.0, 0.0],
            rows,
            gable_t,
            class_name="wall",
            part="gable_wall",
            material=STONE,
        )
        scene.objects.append(
            {
                "instance": 0,
                "class": "wall",
                "part": "gable_wall",
                "plane": {
                    "point": [x0 + (gable_t if x0 < 0 else 0.0), 0.0, 0.0],
                    "normal": [1.0, 0.0, 0.0],
                },
                "thickness_m": gable_t,
            }
        )
    # boarding: one slab per slope on the common rafters, from the eaves to past the apex
    e0, e1 = lv.eta_eave, -0.05
    for sgn in (-1.0, 1.0):
        n, d = lv.normal(sgn), lv.upslope(sgn)
        em = (e0 + e1) / 2
        c = np.array([L / 2, sgn * em, float(lv.underside(em))]) + n * lv.boarding_t / 2
        b = _box(c, [(e0 - e1) / lv.cos, x_hi - x_lo, lv.boarding_t], np.vstack([d, X, n]))
        _add(scene, b, class_name="boarding", part="boarding", material=TIMBER)
        scene.objects.append(
            {
                "instance": 0,
                "class": "boarding",
                "plane": {"point": [L / 2, 0.0, float(lv.underside(0.0))], "normal": n.tolist()},
                "box": b.to_json(),
            }
        )


def place_chimney(
    lv: RoofLevels, members: list[Member], rng: np.random.Generator, tie_x: list[float]
) -> tuple[Box | None, set[int]]:
    """A masonry stack from the floor through the roof, in a bay; trims common rafters.

    Returns the chimney (or None when no free place was found) and the groups of
    members it removes (common rafters and the collars of their couples).
    """
    removable = {"common_rafter", "collar"}
    boxes = [Box.of(m) for m in members]
    L, half = lv.length, lv.half
    for _ in range(60):
        a = rng.uniform(0.45, 0.9)
        x = rng.uniform(a / 2 + 0.05, L - a / 2 - 0.05)
        if tie_x and np.min(np.abs(np.asarray(tie_x) - x)) < a / 2 + 0.35:
            continue
        y = rng.uniform(-half + a / 2 + 0.25, half - a / 2 - 0.25)
        top = float(lv.underside(abs(y) - a / 2)) + 1.0
        ch = _box([x, y, (top - 0.1) / 2], [a, a, top + 0.1])
        hit = _hits(ch, boxes, 0.03)
        if any(members[i].role not in removable or members[i].group < 0 for i in hit):
            continue
        return ch, {members[i].group for i in hit}
    return None, set()


def _inside_floor(b: Box, lv: RoofLevels, margin: float = 0.1) -> bool:
    s = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    corners = b.centre + (s * b.half) @ b.rows
    return bool(
        (corners[:, 0] > margin).all()
        and (corners[:, 0] < lv.length - margin).all()
        and (np.abs(corners[:, 1]) < lv.half - margin).all()
    )


def _tripods(stations: list[Array]) -> list[Box]:
    return [_box([p[0], p[1], p[2] / 2], [1.0, 1.0, p[2] + 0.2]) for p in stations]


def place_clutter(
    scene: Scene,
    lv: RoofLevels,
    obstacles: list[Box],
    stations: list[Array],
    rng: np.random.Generator,
    n_loose: int,
    n_stacks: int,
) -> list[Box]:
    """Loose timbers and stacks of planks lying on the floor (class ``loose_timber``)."""
    placed: list[Box] = []
    blockers = obstacles + _tripods(stations)
    for kind, count in (("loose", n_loose), ("stack", n_stacks)):
        for _ in range(count):
            for _try in range(40):
                pieces = _loose(rng) if kind == "loose" else _stack(rng)
                c = np.array([rng.uniform(0, lv.length), rng.uniform(-lv.half, lv.half), 0.0])
                yaw = rng.uniform(0, np.pi)
                Rz = np.array(
                    [[np.cos(yaw), -np.sin(yaw), 0], [np.sin(yaw), np.cos(yaw), 0], [0, 0, 1.0]]
                )
                moved = [Box(c + Rz @ p.centre, p.rows @ Rz.T, p.size) for p in pieces]
                if not all(_inside_floor(b, lv) for b in moved):
                    continue
                if any(_hits(b, blockers + placed, 0.05) for b in moved):
                    continue
                for b in moved:
                    _add(
                        scene, b, class_name="loose_timber", part=f"{kind}_timber", material=TIMBER
                    )
                    scene.objects.append(
                        {
                            "instance": 0,
                            "class": "loose_timber",
                            "part": f"{kind}_timber",
                            "box": b.to_json(),
                        }
                    )
                placed += moved
                break
    return placed


def _loose(rng: np.random.Generator) -> list[Box]:
    """A timber lying on the floor (on its wide or its narrow face)."""
    w, h = rng.uniform(0.08, 0.25), rng.uniform(0.08, 0.25)
    length = rng.uniform(1.0, 4.0)
    return [_box([0.0, 0.0, h / 2 + 0.002], [length, w, h])]


def _stack(rng: np.random.Generator) -> list[Box]:
    """A stack of 3-10 planks, one or two per layer, slightly out of line."""
    n = int(rng.integers(3, 11))
    t, w, length = rng.uniform(0.022, 0.05), rng.uniform(0.15, 0.3), rng.uniform(2.0, 4.5)
    per = int(rng.integers(1, 3))
    out = []
    for k in range(n):
        for j in range(per):
            dy = (j - (per - 1) / 2) * (w + 0.01) + rng.uniform(-0.02, 0.02)
            dx = rng.uniform(-0.05, 0.05)
            a = rng.uniform(-0.03, 0.03)
            rows = np.array([[np.cos(a), np.sin(a), 0], [-np.sin(a), np.cos(a), 0], [0, 0, 1.0]])
            out.append(_box([dx, dy, k * (t + 0.001) + t / 2 + 0.002], [length, w, t], rows))
    return out


def place_ladder(
    scene: Scene,
    lv: RoofLevels,
    members: list[Member],
    obstacles: list[Box],
    stations: list[Array],
    rng: np.random.Generator,
) -> dict[str, Any] | None:
    """A ladder leaning on a post (or a collar or tie), clear of everything else.

    ``obstacles`` are the non-member boxes (chimney, clutter); the members are
    checked apart, all but the one the ladder leans on.
    """
    targets = [i for i, m in enumerate(members) if m.role == "post"]
    targets += [i for i, m in enumerate(members) if m.role == "collar" and m.centre[2] < 5.5]
    targets += [i for i, m in enumerate(members) if m.role == "tie" and m.centre[2] > 1.0]
    if not targets:
        return None
    blockers = obstacles + _tripods(stations)
    member_boxes = [Box.of(m) for m in members]
    for _ in range(40):
        i = int(rng.choice(targets))
        m = members[i]
        lo, hi = m.centre[2] - m.length / 2, m.centre[2] + m.length / 2
        if m.role == "post":
            z_top = rng.uniform(lv.z_tt + 0.6, max(lv.z_tt + 0.7, hi - 0.15))
        elif m.role == "collar":
            z_top = m.centre[2]
        else:
            z_top = m.centre[2] + m.height / 2 - 0.05
        if not lo - 1 < z_top < 6.0:
            continue
        sgn = rng.choice([-1.0, 1.0])
        y = m.centre[1] + (rng.uniform(-0.6, 0.6) if m.role != "post" else 0.0)
        if abs(y) > lv.half - 0.5:
            continue
        alpha = np.radians(rng.uniform(68, 78))
        top = np.array([m.centre[0] + sgn * (m.width / 2 + 0.04), y, z_top])
        length = z_top / np.sin(alpha)
        foot = top + np.array([sgn * length * np.cos(alpha), 0.0, -z_top])
        parts = _ladder_parts(foot, top)
        others = member_boxes[:i] + member_boxes[i + 1 :]
        if not (0.1 < foot[0] < lv.length - 0.1 and abs(foot[1]) < lv.half - 0.35):
            continue
        if any(_hits(b, others + blockers, 0.01) for b in parts):
            continue
        for b in parts:
            _add(scene, b, class_name="ladder", part="ladder", material=TIMBER)
        desc = {
            "instance": 0,
            "class": "ladder",
            "leans_on": m.name,
            "foot": foot.tolist(),
            "top": top.tolist(),
            "boxes": [b.to_json() for b in parts],
        }
        scene.objects.append(desc)
        return desc
    return None


def _ladder_parts(foot: Array, top: Array) -> list[Box]:
    """Two rails and rungs every 28 cm between ``foot`` and ``top`` (rails along ``x-z``)."""
    axis = (top - foot) / np.linalg.norm(top - foot)
    across = np.array([0.0, 1.0, 0.0])
    up = np.cross(axis, across)
    rows = np.vstack([axis, across, up])
    length = float(np.linalg.norm(top - foot))
    mid = (foot + top) / 2
    parts = [Box(mid + s * 0.21 * across, rows, np.array([length, 0.045, 0.07])) for s in (-1, 1)]
    for k in range(1, int(length / 0.28)):
        p = foot + k * 0.28 * axis
        parts.append(Box(p, np.vstack([across, axis, up]), np.array([0.42, 0.035, 0.035])))
    return parts


def place_stations(
    lv: RoofLevels,
    members: list[Member],
    extra: list[Box],
    n: int,
    height: float,
    rng: np.random.Generator,
) -> list[Array]:
    """Scanner stations inside the frame: a plan along the roof, clear of every member.

    Stations are spread along ``x`` (staggered across the span); each is
    nudged until its optical centre is 35 cm and its tripod 20 cm from any
    member, 40 cm under the boarding.
    """
    boxes = [Box.of(m) for m in members] + extra
    L, half = lv.length, lv.half
    out: list[Array] = []
    for i in range(n):
        x0 = L * (i + 0.5) / n
        y0 = (1 if i % 2 else -1) * rng.uniform(0.05, 0.4) * half
        for k in range(200):
            spread = min(1.0, 0.1 + k / 60)
            x = float(np.clip(x0 + rng.normal(0, spread * L / (2 * n)), 0.5, L - 0.5))
            y = float(np.clip(y0 + rng.normal(0, spread * half / 2), -half + 0.5, half - 0.5))
            p = np.array([x, y, height])
            if float(lv.underside(abs(y))) - height < 0.4:
                continue
            if any(np.linalg.norm(p[:2] - q[:2]) < 1.0 for q in out):
                continue
            if _clear(p, boxes):
                out.append(p)
                break
    return out


def _clear(p: Array, boxes: list[Box]) -> bool:
    for b in boxes:
        if np.linalg.norm(b.centre - p) > np.linalg.norm(b.half) + 0.5 + p[2]:
            continue
        if obb_distance_to_point(b.centre, b.rows, b.half, p) < 0.35:
            return False
        for z in np.arange(0.1, p[2], 0.25):
            if obb_distance_to_point(b.centre, b.rows, b.half, [p[0], p[1], z]) < 0.2:
                return False
    return True
