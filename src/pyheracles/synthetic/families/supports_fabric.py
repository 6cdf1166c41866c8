"""Everything around the supports of the ``supports`` family: walls, floors, ceilings,
the attic, clutter and debris.

All of it has instance 0 (it is not a support) and one of the classes
``wall`` (with the reveals of doors and windows), ``window`` (glass panes),
``floor``, ``ground``, ``ceiling`` (flat slabs, vaults, timber boards and
beams), ``attic`` (entablature, roof, soffit and eaves of a building with an
attic), ``clutter`` (parts ``sign``, ``pulpit``, ``scaffold``, ``fence``,
``chair``, ``bench``, ``pew``) and ``debris`` (fallen drums and blocks).
Functions return the 2D footprints (shapely) of what they add, so that the
station plan can keep the tripods out of solids.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import shapely
import shapely.affinity
from numpy.typing import NDArray

from pyheracles.synthetic.families.supports_shapes import Piece, box, revolve, tube
from pyheracles.synthetic.scene import GLASS, GROUND, METAL, PLASTER, STONE, TIMBER, Scene

__all__ = [
    "Opening",
    "WallSpec",
    "add_attic",
    "add_ceiling",
    "add_clutter_item",
    "add_drum",
    "add_floor",
    "add_wall",
]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class Opening:
    """A door or window in a wall: ``u0..u1`` along the wall, ``v0..v1`` above its foot."""

    kind: str
    u0: float
    u1: float
    v0: float
    v1: float
    glazed: bool = False


@dataclass
class WallSpec:
    """A straight wall whose inner face runs from ``a`` along ``direction`` for ``length_m``;
    its thickness goes to the right of the direction (outside of a counter-clockwise
    room).  ``top`` is its height above ``z0``, or a ragged top (ruins) as heights at
    evenly spaced points."""

    a: tuple[float, float]
    direction: tuple[float, float]
    length_m: float
    thickness_m: float
    z0: float
    top: float | tuple[float, ...]
    openings: list[Opening] = field(default_factory=list)

    def frame(self) -> Array:
        u = np.array([*self.direction, 0.0])
        u /= np.linalg.norm(u)
        w = np.array([u[1], -u[0], 0.0])  # outward
        return np.vstack([u, [0.0, 0.0, 1.0], w])

    def footprint(self) -> shapely.Polygon:
        R = self.frame()
        a = np.array(self.a)
        u, w = R[0, :2], R[2, :2]
        pts = [
            a,
            a + self.length_m * u,
            a + self.length_m * u + self.thickness_m * w,
            a + self.thickness_m * w,
        ]
        return shapely.Polygon(pts)


def add_wall(scene: Scene, wall: WallSpec, material=PLASTER) -> shapely.Polygon:
    """A wall prism with its openings (their sides are the reveals) and glass panes."""
    L = wall.length_m
    if isinstance(wall.top, tuple):
        us = np.linspace(0.0, L, len(wall.top))
        outline = shapely.Polygon(
            [(0.0, 0.0), (L, 0.0), *zip(us[::-1], wall.top[::-1], strict=True)]
        )
    else:
        outline = shapely.box(0.0, 0.0, L, float(wall.top))
    holes = [shapely.box(o.u0, o.v0, o.u1, o.v1) for o in wall.openings]
    poly = outline.difference(shapely.union_all(holes)) if holes else outline
    R = wall.frame()
    origin = np.array([wall.a[0], wall.a[1], wall.z0])
    for part in shapely.get_parts(poly):
        if part.area > 1e-6:
            scene.add_prism(
                part, origin, R, wall.thickness_m, class_name="wall", part="wall", material=material
            )
    for o in wall.openings:
        if o.glazed:
            w = wall.thickness_m / 2
            c = [
                origin + o.u0 * R[0] + o.v0 * R[1] + w * R[2],
                origin + o.u1 * R[0] + o.v0 * R[1] + w * R[2],
                origin + o.u1 * R[0] + o.v1 * R[1] + w * R[2],
                origin + o.u0 * R[0] + o.v1 * R[1] + w * R[2],
            ]
            scene.add_quad(c, class_name="window", part="glass", material=GLASS)
    return wall.footprint()


def add_floor(
    scene: Scene,
    outline: shapely.Polygon,
    z: float,
    *,
    class_name: str = "floor",
    thickness: float = 0.3,
    material=STONE,
) -> None:
    """A floor slab whose top is at ``z`` (its sides are seen when it stands proud)."""
    scene.add_prism(
        outline,
        [0.0, 0.0, z - thickness],
        np.eye(3),
        thickness,
        faces="back",
        class_name=class_name,
        part=class_name,
        material=material,
    )


def add_ground(scene: Scene, bounds: tuple[float, float, float, float], z: float) -> None:
    """The terrain around the building: a flat quad at ``z``."""
    x0, y0, x1, y1 = bounds
    scene.add_quad(
        [[x0, y0, z], [x1, y0, z], [x1, y1, z], [x0, y1, z]],
        class_name="ground",
        part="ground",
        material=GROUND,
    )


def add_ceiling(
    scene: Scene,
    kind: str,
    rect: tuple[float, float, float, float],
    z: float,
    rng: np.random.Generator,
    *,
    lines_x: Array | None = None,
    lines_y: Array | None = None,
    rise: float = 1.5,
    class_name: str = "ceiling",
) -> None:
    """Ceiling over ``rect`` whose underside (vault springing) is at ``z``.

    ``flat``: a slab; ``vault``: groin vaults over the bays between support lines
    (a barrel vault without lines); ``timber``: boards on joists on girders along
    the support lines; ``none``: nothing (roofless).
    """
    x0, y0, x1, y1 = rect
    if kind == "none":
        return
    if kind == "flat":
        scene.add_box(
            [(x0 + x1) / 2, (y0 + y1) / 2, z + 0.15],
            [x1 - x0, y1 - y0, 0.3],
            faces=("-z", "+z"),
            class_name=class_name,
            part="slab",
            material=PLASTER,
        )
        return
    if kind == "vault":
        bx = np.unique(np.r_[x0, [] if lines_x is None else lines_x, x1])
        by = np.unique(np.r_[y0, [] if lines_y is None else lines_y, y1])
        gx = np.linspace(x0, x1, max(8, int((x1 - x0) / 0.2)) + 1)
        gy = np.linspace(y0, y1, max(8, int((y1 - y0) / 0.2)) + 1)
        X, Y = np.meshgrid(gx, gy)
        i = np.clip(np.searchsorted(bx, X) - 1, 0, len(bx) - 2)
        j = np.clip(np.searchsorted(by, Y) - 1, 0, len(by) - 2)
        u = (X - bx[i]) / (bx[i + 1] - bx[i])
        v = (Y - by[j]) / (by[j + 1] - by[j])
        if len(bx) == 2:  # one bay across: a barrel vault along x
            zz = z + rise * np.sin(np.pi * v)
        else:
            zz = z + rise * (1 - (1 - np.sin(np.pi * u)) * (1 - np.sin(np.pi * v)))
        scene.add_heightfield(gx, gy, zz, class_name=class_name, part="vault", material=PLASTER)
        return
    if kind == "timber":
        girder_h = 0.35 + 0.1 * rng.random()
        joist_h, joist_w = 0.2, 0.12
        gap = rng.uniform(0.45, 1.0)
        top = z + girder_h + joist_h
        scene.add_box(
            [(x0 + x1) / 2, (y0 + y1) / 2, top + 0.02],
            [x1 - x0, y1 - y0, 0.04],
            faces=("-z", "+z"),
            class_name=class_name,
            part="boards",
            material=TIMBER,
        )
        for y in np.arange(y0 + gap / 2, y1, gap):
            scene.add_box(
                [(x0 + x1) / 2, y, z + girder_h + joist_h / 2],
                [x1 - x0, joist_w, joist_h],
                faces=("-z", "-y", "+y"),
                class_name=class_name,
                part="joist",
                material=TIMBER,
            )
        for y in [] if lines_y is None else lines_y:
            scene.add_box(
                [(x0 + x1) / 2, y, z + girder_h / 2],
                [x1 - x0, 0.3, girder_h],
                faces=("-z", "-y", "+y", "-x", "+x"),
                class_name=class_name,
                part="girder",
                material=TIMBER,
            )
        return
    raise ValueError(f"unknown ceiling {kind!r}")


def add_attic(
    scene: Scene,
    rect: tuple[float, float, float, float],
    z_top: float,
    *,
    entablature_m: float,
    overhang_m: float,
    eave_drop_m: float | None = None,
    slope: float | None = None,
    roof_thickness_m: float = 0.25,
) -> float:
    """Entablature over the supports and a hip roof whose eaves hang below their tops.

    ``rect`` is the outline of the support lines (and walls); the entablature
    stands on it from ``z_top`` to ``z_top + entablature_m`` with a flat soffit
    inside; the roof rests on it and slopes down beyond it by ``overhang_m`` to
    eaves ``eave_drop_m`` below ``z_top`` (or, given ``slope``, as far as that
    slope takes it).  Returns the height of the eaves.
    """
    x0, y0, x1, y1 = rect
    z_rest = z_top + entablature_m
    if eave_drop_m is not None and overhang_m > 0:
        slope = (entablature_m + eave_drop_m) / overhang_m
    elif slope is None:
        raise ValueError("add_attic needs eave_drop_m (with an overhang) or slope")
    z_eave = z_rest - slope * overhang_m
    cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
    ref = {"class_name": "attic", "material": STONE}
    scene.add_box(
        [cx, cy, z_top + entablature_m / 2],
        [x1 - x0, y1 - y0, entablature_m],
        faces=("-x", "+x", "-y", "+y"),
        part="entablature",
        **ref,
    )
    scene.add_quad(
        [[x0, y0, z_top], [x1, y0, z_top], [x1, y1, z_top], [x0, y1, z_top]], part="soffit", **ref
    )
    X0, Y0, X1, Y1 = x0 - overhang_m, y0 - overhang_m, x1 + overhang_m, y1 + overhang_m
    for dz, part in ((0.0, "roof"), (-roof_thickness_m, "eaves")):
        scene.add_triangles(_hip_roof(X0, Y0, X1, Y1, z_eave + dz, slope), part=part, **ref)
    # fascia boards along the eaves
    e = roof_thickness_m
    for a, b in (
        ((X0, Y0), (X1, Y0)),
        ((X1, Y0), (X1, Y1)),
        ((X1, Y1), (X0, Y1)),
        ((X0, Y1), (X0, Y0)),
    ):
        scene.add_quad(
            [[*a, z_eave - e], [*b, z_eave - e], [*b, z_eave], [*a, z_eave]], part="fascia", **ref
        )
    return z_eave


def _hip_roof(x0: float, y0: float, x1: float, y1: float, z: float, slope: float) -> Array:
    """Four planes of a hip roof over a rectangle, eaves at ``z``."""
    W, D = x1 - x0, y1 - y0
    if W < D:  # ridge along y: swap axes, build, swap back
        t = _hip_roof(y0, x0, y1, x1, z, slope)
        return t[..., [1, 0, 2]]
    h = D / 2
    zr = z + slope * h
    ym = (y0 + y1) / 2
    a, b = [x0, y0, z], [x1, y0, z]
    c, d = [x1, y1, z], [x0, y1, z]
    r0, r1 = [x0 + h, ym, zr], [x1 - h, ym, zr]
    return np.array(
        [[a, b, r1], [a, r1, r0], [c, d, r0], [c, r0, r1], [b, c, r1], [d, a, r0]], float
    )


# ------------------------------------------------------------------------------ clutter
def add_clutter_item(
    scene: Scene,
    kind: str,
    x: float,
    y: float,
    z: float,
    yaw_deg: float,
    rng: np.random.Generator,
    *,
    height_m: float = 0.0,
    reach_m: float = 0.3,
) -> shapely.Polygon:
    """One item of clutter at ``(x, y)`` on the floor at ``z``; returns its footprint.

    ``sign`` (a post with a board), ``pulpit`` (a raised tub on a post; ``height_m``
    is its floor), ``scaffold`` (a tower of tubes, ledgers and a deck around a
    support of half width ``reach_m``, ``height_m`` high), ``fence`` (a rail of
    length ``reach_m`` with bars, ``height_m`` high), ``chair``, ``bench``, ``pew``.
    """
    p = Piece()
    if kind == "sign":
        h = rng.uniform(1.2, 2.2)
        p.add(tube([0, 0, 0], [0, 0, h], 0.025), "sign", METAL)
        p.add(box([-0.3, -0.01, h - 0.45], [0.3, 0.01, h]), "sign", METAL)
        fp = shapely.box(-0.3, -0.05, 0.3, 0.05)
    elif kind == "pulpit":
        h = height_m or rng.uniform(1.2, 2.5)
        p.add(tube([0, 0, 0], [0, 0, h], 0.12, 16), "pulpit", TIMBER)
        p.add(
            box([-0.6, -0.5, h], [0.6, 0.5, h + 1.05], faces=("-x", "+x", "-y", "+y", "-z")),
            "pulpit",
            TIMBER,
        )
        p.add(
            box([-0.55, -0.45, h], [0.55, 0.45, h + 1.0], faces=("-x", "+x", "-y", "+y")),
            "pulpit",
            TIMBER,
        )
        fp = shapely.box(-0.6, -0.5, 0.6, 0.5)
    elif kind == "scaffold":
        a = reach_m
        h = height_m
        corners = [(-a, -a), (a, -a), (a, a), (-a, a)]
        for cx, cy in corners:
            p.add(tube([cx, cy, 0], [cx, cy, h], 0.024), "scaffold", METAL)
        for zl in np.arange(2.0, h, 2.0):
            for k in range(4):
                (ax, ay), (bx, by) = corners[k], corners[(k + 1) % 4]
                p.add(tube([ax, ay, zl], [bx, by, zl], 0.024), "scaffold", METAL)
            p.add(box([-a, -a, zl + 0.03], [-a + 0.6, a, zl + 0.07]), "scaffold", TIMBER)
        fp = shapely.box(-a - 0.05, -a - 0.05, a + 0.05, a + 0.05)
    elif kind == "fence":
        L, h = reach_m, height_m or rng.uniform(0.9, 2.5)
        for zr in (0.1, h / 2, h):
            p.add(tube([0, 0, zr], [L, 0, zr], 0.015, 8), "fence", METAL)
        for u in np.arange(0.1, L, 0.15):
            p.add(tube([u, 0, 0.1], [u, 0, h], 0.008, 6), "fence", METAL)
        fp = shapely.box(0, -0.03, L, 0.03)
    elif kind == "chair":
        for lx in (-0.2, 0.2):
            for ly in (-0.2, 0.2):
                p.add(tube([lx, ly, 0], [lx, ly, 0.45], 0.015, 8), "chair", TIMBER)
        p.add(box([-0.23, -0.23, 0.43], [0.23, 0.23, 0.46]), "chair", TIMBER)
        p.add(box([-0.23, 0.2, 0.46], [0.23, 0.23, 0.95]), "chair", TIMBER)
        fp = shapely.box(-0.25, -0.25, 0.25, 0.25)
    elif kind in ("bench", "pew"):
        L = reach_m
        p.add(box([0, -0.2, 0.42], [L, 0.2, 0.47]), kind, TIMBER)
        for u in (0.05, L - 0.1):
            p.add(box([u, -0.18, 0.0], [u + 0.05, 0.18, 0.42]), kind, TIMBER)
        if kind == "pew":
            p.add(box([0, 0.2, 0.0], [L, 0.24, 1.0]), kind, TIMBER)
            p.add(box([0, -0.25, 0.0], [0.05, 0.25, 1.0]), kind, TIMBER)
            p.add(box([L - 0.05, -0.25, 0.0], [L, 0.25, 1.0]), kind, TIMBER)
        fp = shapely.box(0, -0.25, L, 0.25)
    else:
        raise ValueError(f"unknown clutter {kind!r}")
    p.place(scene, origin=[x, y, z], yaw_deg=yaw_deg, class_name="clutter")
    return shapely.affinity.translate(shapely.affinity.rotate(fp, yaw_deg, origin=(0, 0)), x, y)


def add_drum(
    scene: Scene, x: float, y: float, z: float, radius: float, length: float, yaw_deg: float
) -> shapely.Polygon:
    """A fallen column drum lying on the floor (class ``debris``)."""
    p = Piece()
    side = revolve([-length / 2, length / 2], [radius, radius], segments=64)
    cap = np.concatenate(
        [revolve([h, h], [radius, 0.0], segments=64) for h in (-length / 2, length / 2)]
    )
    rot = np.array([[0, 0, 1.0], [0, 1.0, 0], [-1.0, 0, 0]])  # lay the axis along x
    p.add(np.concatenate([side, cap]) @ rot.T + [0, 0, radius], "drum")
    p.place(scene, origin=[x, y, z], yaw_deg=yaw_deg, class_name="debris")
    fp = shapely.box(-length / 2, -radius, length / 2, radius)
    return shapely.affinity.translate(shapely.affinity.rotate(fp, yaw_deg, origin=(0, 0)), x, y)
