"""The project's four named building scenes as plans of the ``supports`` family.

The geometry of :mod:`pyheracles.synthetic.buildings` (Murtiyoso 2020, ch. 6.2
hard cases), so that ``draw(seed, layout=name)`` scans it through the
simulator with a drawn survey:

``pavilion``
    Ten rectangular piers, four columns (two on a dais), entablature with a
    flat soffit and a hip roof (the attic).
``temple``
    A peristyle of 8 x 4 columns on a stylobate, some broken, low cella walls,
    two antae, two columns in antis, fallen drums; roofless.
``hall``
    Eight columns and eight engaged half-columns under groin vaults.
``choir``
    Three pairs of twin columns sharing plinth and abacus, three single
    columns, an iron fence touching the twins, chairs (two leaning on
    columns), a sign post; flat ceiling, three walls.
"""

from __future__ import annotations

import numpy as np
import shapely

from pyheracles.synthetic.families.supports_fabric import WallSpec
from pyheracles.synthetic.families.supports_layouts import Plan
from pyheracles.synthetic.families.supports_parts import ColumnShape, SupportSpec

__all__ = ["named_plan"]


def _classic(r: float, *, capital: bool = True, base: bool = True) -> ColumnShape:
    """The old generator's column: plinth 1.3 r (0.15 m), base ring, echinus, abacus."""
    return ColumnShape(
        r, r,
        plinth_half_m=1.3 * r if base else 0.0, plinth_height_m=0.15 if base else 0.0,
        base_height_m=0.1 if base else 0.0,
        capital_height_m=0.2 if capital else 0.0,
        abacus_half_m=1.3 * r if capital else 0.0, abacus_height_m=0.15 if capital else 0.0,
    )  # fmt: skip


def _pier(
    x: float,
    y: float,
    w: float,
    d: float,
    z0: float,
    h: float,
    *,
    capital: bool = True,
    group: str = "main",
    cuts: dict[str, float] | None = None,
) -> SupportSpec:
    return SupportSpec(
        "pier",
        x,
        y,
        z0,
        h,
        pier_width_m=w,
        pier_depth_m=d,
        pier_projection_m=0.1 if capital else 0.0,
        pier_capital_height_m=0.15 if capital else 0.0,
        group=group,
        cuts=cuts or {},
    )


def _pavilion() -> Plan:
    top = 4.0
    sup = [_pier(x, y, 0.6, 0.6, 0.0, top) for x in (0.3, 4.1, 7.9, 11.7) for y in (0.3, 7.7)]
    sup += [_pier(x, 4.0, 0.6, 0.6, 0.0, top) for x in (0.3, 11.7)]
    sup += [
        SupportSpec("column", x, 4.0, z0, top - z0, column=_classic(0.22))
        for x, z0 in ((2.2, 0.0), (5.0, 0.4), (7.0, 0.4), (9.8, 0.0))
    ]
    rect = (-0.6, -0.6, 12.6, 8.6)
    return Plan(
        supports=sup, rect=rect, z_top=top, ceiling="attic",
        attic={"entablature_m": 0.8, "overhang_m": 0.0, "slope": 0.6},
        blocks=[{"class": "floor", "part": "dais", "lo": (4.0, 2.5, 0.0), "hi": (8.0, 5.5, 0.4)}],
        inside=shapely.box(0.0, 0.0, 12.0, 8.0), margin_m=3.0,
    )  # fmt: skip


def _temple() -> Plan:
    heights = [6.0, 6.0, 4.2, 6.0, 3.2, 6.0, 6.0, 5.1]
    sup = []
    k = 0
    for i in range(8):
        for j in range(4):
            if 0 < j < 3 and 0 < i < 7:
                continue
            h = heights[k % len(heights)]
            k += 1
            sup.append(
                SupportSpec(
                    "column",
                    1.5 + 3 * i,
                    1.5 + 3 * j,
                    0.0,
                    6.0,
                    column=_classic(0.4),
                    broken_at_m=h if h < 6.0 else None,
                )
            )
    sup += [
        _pier(5.5, y, 1.0, 0.8, 0.0, 5.4, capital=False, group="anta", cuts={"+x": 0.5})
        for y in (3.9, 8.1)
    ]
    sup += [
        SupportSpec("column", 5.5, y, 0.0, 5.4, column=_classic(0.3), group="in_antis")
        for y in (5.3, 6.7)
    ]
    walls = [
        WallSpec((6.0, 4.3), (1.0, 0.0), 13.0, 0.8, 0.0, 1.0),
        WallSpec((18.2, 4.3), (0.0, 1.0), 3.4, 0.8, 0.0, 1.0),
        WallSpec((19.0, 7.7), (-1.0, 0.0), 13.0, 0.8, 0.0, 1.0),
    ]
    debris = [
        {"x": 10.0, "y": 10.4, "r": 0.4, "length": 1.0, "yaw": 0.0},
        {"x": 14.0, "y": 1.9, "r": 0.4, "length": 1.0, "yaw": 0.0},
    ]
    return Plan(
        supports=sup,
        walls=walls,
        rect=(0.0, 0.0, 24.0, 12.0),
        z_top=6.0,
        ceiling="none",
        platform_m=0.6,
        platform_rect=(0.0, 0.0, 24.0, 12.0),
        debris=debris,
        inside=shapely.box(0.0, 0.0, 24.0, 12.0),
        margin_m=1.5,
    )


def _hall() -> Plan:
    spring = 5.0
    xs = np.array([4.0, 8.0, 12.0, 16.0])
    ys = np.array([10 / 3, 20 / 3])
    sup = [
        SupportSpec("column", float(x), float(y), 0.0, spring, column=_classic(0.3))
        for x in xs
        for y in ys
    ]
    eng = ColumnShape(0.25, 0.25, capital_height_m=0.2)
    for x in xs:
        for yw, yaw in ((0.0, 0.0), (10.0, 180.0)):
            sup.append(
                SupportSpec(
                    "engaged_column",
                    float(x),
                    yw,
                    0.0,
                    spring,
                    column=eng,
                    yaw_deg=yaw,
                    group="wall",
                )
            )
    t = 0.6
    walls = [
        WallSpec((0.0, 0.0), (1.0, 0.0), 20.0 + t, t, 0.0, 8.0),
        WallSpec((20.0, 0.0), (0.0, 1.0), 10.0 + t, t, 0.0, 8.0),
        WallSpec((20.0, 10.0), (-1.0, 0.0), 20.0 + t, t, 0.0, 8.0),
        WallSpec((0.0, 10.0), (0.0, -1.0), 10.0 + t, t, 0.0, 8.0),
    ]
    return Plan(
        supports=sup,
        walls=walls,
        rect=(0.0, 0.0, 20.0, 10.0),
        z_top=spring,
        ceiling="vault",
        lines_x=xs,
        lines_y=ys,
        vault_rise_m=1.5,
        enclosed=True,
        inside=shapely.box(0.0, 0.0, 20.0, 10.0),
        margin_m=2.0,
    )


def _choir() -> Plan:
    ceil, r2, rail_y = 6.0, 0.17, 3.0
    twin = ColumnShape(
        r2,
        r2,
        plinth_half_m=0.26,
        plinth_height_m=0.3,
        abacus_half_m=0.26,
        abacus_height_m=0.3,
        square_aspect=0.25 / 0.26,
    )
    sup = []
    for x in (4.0, 8.0, 12.0):
        sup.append(
            SupportSpec(
                "column", x - 0.24, rail_y, 0.0, ceil, column=twin, cuts={"+x": 0.24}, group="twin"
            )
        )
        sup.append(
            SupportSpec(
                "column", x + 0.24, rail_y, 0.0, ceil, column=twin, cuts={"-x": -0.24}, group="twin"
            )
        )
    sup += [
        SupportSpec("column", x, 7.0, 0.0, ceil, column=_classic(0.25)) for x in (4.0, 8.0, 12.0)
    ]
    clutter = [
        {
            "kind": "fence",
            "x": 0.5,
            "y": rail_y,
            "yaw": 0.0,
            "reach": 13.0,
            "height": 3.0,
            "touch": True,
        }
    ]
    chairs = [(x, y) for x in np.arange(1.5, 13.0, 0.8) for y in (5.0, 5.8)]
    chairs += [(8.0, 7.0 + 0.25 + 0.03 + 0.23), (4.0, 7.0 - 0.25 - 0.03 - 0.23)]
    clutter += [
        {"kind": "chair", "x": float(x), "y": float(y), "yaw": 0.0, "touch": False}
        for x, y in chairs
    ]
    clutter.append({"kind": "sign", "x": 12.45, "y": 7.3, "yaw": 0.0, "touch": True})
    t = 0.5
    walls = [
        WallSpec((0.0, 0.0), (1.0, 0.0), 14.0 + t, t, 0.0, 7.0),
        WallSpec((14.0, 0.0), (0.0, 1.0), 10.0 + t, t, 0.0, 7.0),
        WallSpec((14.0, 10.0), (-1.0, 0.0), 14.0, t, 0.0, 7.0),
    ]
    return Plan(
        supports=sup,
        walls=walls,
        rect=(0.0, 0.0, 14.0, 10.0),
        z_top=ceil,
        ceiling="flat",
        clutter=clutter,
        enclosed=True,
        inside=shapely.box(0.0, 0.0, 14.0, 10.0),
        margin_m=2.0,
    )


_PLANS = {"pavilion": _pavilion, "temple": _temple, "hall": _hall, "choir": _choir}


def named_plan(name: str) -> Plan:
    """The plan of one of the named scenes (``pavilion``, ``temple``, ``hall``, ``choir``)."""
    if name not in _PLANS:
        raise ValueError(f"named scene must be one of {', '.join(_PLANS)}; got {name!r}")
    return _PLANS[name]()
