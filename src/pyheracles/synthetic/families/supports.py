"""Scene family ``supports``: buildings with 4 to 80 columns, piers and engaged columns.

Each draw is a building (issue 11) scanned through the one simulator:
columns of radius 0.15-1.5 m, smooth, tapering, with entasis or fluted (12-24
flutes), in two or more sizes; square plinths and abaci 1.5-2.5 r (half
width); twin columns sharing plinth and abacus; engaged columns with their
axis on or in front of the wall face (the wall beside them in their shadow);
rectangular piers and antae seen on 1 to 4 faces; broken and leaning columns
(1-6 deg); walls with doors, windows and deep reveals; flat, vaulted, timber
or no ceilings (roofless ruins); attics whose eaves hang below the tops of
the supports; clutter touching supports (sign posts, pulpits, scaffolding
tubes, fences, chairs, benches, pews); terrestrial stations inside and
outside, few or many, and photogrammetry in some draws; gross outliers in
every draw, with isolated points 0.2 m to ``outlier_below_m`` below the floor
(more than 1 m in many draws).

Survey resolution: a full-dome station costs ``360 x 150 / step^2`` rays, so
the issue's 5-15 mm at 10 m (0.029-0.086 deg) would give 7-65 M rays per
station; a draw keeps to 0.3-3 M points and at most 5 M rays, so full domes
use the step the point budget allows (0.03-0.3 deg = 5 mm-5.2 cm at 10 m,
finer with fewer stations; usually 2-5 cm), exterior stations often scan only
the building's sector, and a third of the draws add a detail station that
scans a window round one support at the issue's 5-15 mm at 10 m.

Layouts (see :mod:`~pyheracles.synthetic.families.supports_layouts`):
``nave``, ``hypostyle``, ``portico``, ``peristyle``, ``kiosk``, each intact or
a ``ruin``.  The project's four named scenes of
:mod:`pyheracles.synthetic.buildings` are members: ``draw(seed,
layout="pavilion" | "temple" | "hall" | "choir")`` builds their geometry
(:mod:`~pyheracles.synthetic.families.supports_named`; the column base
mouldings differ slightly) and scans it with the drawn survey.

Reference
---------
Every support is one instance (1..K) with class ``column``, ``pier`` or
``engaged_column``; its true primitive is its row of ``scene.objects`` (see
:mod:`~pyheracles.synthetic.families.supports_parts`: axis base point and
direction, radius bottom/top/mean, box width/depth/yaw, ``z_bottom``,
``z_top``, ``tilt_deg``, ``lean_m``, ``lean_azimuth_deg``, part heights).
Everything else has instance 0 and a class: ``attic`` (entablature, soffit,
roof, eaves: what the attic split must remove; its row in ``scene.objects``
gives ``z_base`` and ``z_eaves``), ``wall``, ``window``, ``floor``,
``ground``, ``ceiling``, ``clutter``, ``debris``; one row per such class with
``instance`` 0 is in ``scene.objects`` too.  Outliers and mixed pixels have
class 0 (``none``) and ``outlier`` True.

Examples
--------
>>> sim = draw(3, layout="kiosk", n_per_row=2, n_rows=2, pier_share=0.0, survey="tls",
...            n_stations_inside=1, n_stations_outside=1, tls_step_deg=0.3,
...            detail_scan=False)  # doctest: +SKIP
>>> sorted({o["class"] for o in sim.scene.objects if o["instance"] > 0})  # doctest: +SKIP
['column']
"""

from __future__ import annotations

import zlib
from dataclasses import asdict, dataclass, fields
from typing import Any

import numpy as np
import shapely

from pyheracles.errors import InputError
from pyheracles.synthetic.families.simulation import (
    Simulation,
    apply_overrides,
    check_noise_draw,
    scan_generator,
)
from pyheracles.synthetic.families.supports_build import build_plan
from pyheracles.synthetic.families.supports_layouts import (
    GENERAL_LAYOUTS,
    Plan,
    foot_half,
    general_plan,
)
from pyheracles.synthetic.families.supports_parts import SUPPORT_CLASSES
from pyheracles.synthetic.families.supports_survey import DOME, plan_survey
from pyheracles.synthetic.scanner import Outliers, scan

__all__ = ["NAMED_LAYOUTS", "SupportsFamilyParams", "draw", "draw_params"]

NAMED_LAYOUTS = ("pavilion", "temple", "hall", "choir")
CLUTTER_KINDS = ("sign", "pulpit", "scaffold", "fence", "chair", "bench", "pew")
MAX_SUPPORTS = 80
MIN_SUPPORTS = 4
MIN_STEP_DEG, MAX_STEP_DEG = 0.03, 0.3  # full-dome step: 5 mm ... 5.2 cm at 10 m
MAX_RAYS = 5e6  # the cost of a draw is its number of rays
MAX_POINTS = 3e6
MAX_LENGTH_M, MAX_WIDTH_M = 50.0, 30.0  # axis extent of the support grid
OUTSIDE_WINDOW_SHARE = 0.35  # rays of an exterior sector scan relative to a full dome


@dataclass(frozen=True)
class SupportsFamilyParams:
    """Drawn quantities of a ``supports`` building (None = drawn from its range).

    Building
        ``layout`` (nave, hypostyle, portico, peristyle, kiosk; or a named scene:
        pavilion, temple, hall, choir), ``state`` (intact, ruin: roofless, broken
        and leaning columns, ragged low walls, fallen drums), ``n_per_row`` (2-16
        supports per row), ``n_rows`` (1-8 rows; the count of supports is kept in
        4-80), ``bay_m`` / ``aisle_m`` (axis spacing along / across, from the
        column footprint), ``side_clearance_m`` (0.8-3 m from the outer supports
        to the walls), ``platform_m`` (floor raised 0-1.2 m over the ground).
    Columns
        ``column_radius_m`` (0.15-1.5, log-uniform), ``size_ratios`` (radii of
        the other groups: aisle, wall, in antis; 1-3 sizes, 0.45-0.85),
        ``column_height_m`` (2.5-15, 9-20 radii), ``shaft_style`` (smooth,
        tapered, entasis, fluted, mixed), ``taper_ratio`` (top / bottom radius
        0.75-0.97), ``entasis_ratio`` (swelling 0.005-0.025 r), ``flutes``
        (12-24), ``flute_depth_ratio`` (0.02-0.06 r), ``plinth`` / ``capital``
        (present), ``plinth_ratio`` / ``abacus_ratio`` (half width 1.5-2.5 r),
        ``plinth_height_ratio`` (0.25-0.6 r), ``twin_share`` (share of column
        positions with twins, 0 or 0.15-1), ``twin_gap_m`` (0.04-0.3),
        ``broken_share`` (ruins 0.1-0.5), ``leaning_share`` (open sky 0-0.4),
        ``lean_max_deg`` (1-6).
    Piers and wall supports
        ``pier_share`` (0 or 0.2-1 of the free supports), ``pier_width_m``
        (0.3-2.0), ``pier_aspect`` (1-2.5), ``pier_yaw_deg`` (0, or 5-45),
        ``engaged`` (engaged columns on the long walls), ``engaged_offset_ratio``
        (axis 0-0.5 r in front of the face), ``responds`` (piers against the
        walls), ``antae`` (wall ends).
    Walls, ceilings, attic
        ``wall_thickness_m`` (0.3-1.5: deep reveals), ``doors`` (1-3 on short
        walls), ``windows_per_bay`` (0-2), ``window_sill_m`` (0.6-3),
        ``window_height_m`` (1-3.5), ``glazed``, ``ruin_wall_ratio`` (0.3-0.9 of
        the column height), ``ceiling`` (flat, vault, timber, none; ``attic`` when there is one),
        ``vault_rise_m`` (0.15-0.5 of the aisle), ``attic``, ``entablature_m``
        (0.4-1.2), ``overhang_m`` (0.8-2.5), ``eave_drop_m`` (eaves 0.1-1.2 m
        below the support tops).
    Clutter
        ``clutter`` (kinds among sign, pulpit, scaffold, fence, chair, bench,
        pew), ``clutter_count`` (0-24), ``clutter_touch_share`` (0.3-1).
    Survey
        ``survey`` (tls, tls+photo, photo), ``station_spacing_m`` (4-30 m,
        log-uniform: many to few stations), ``n_stations_inside`` (floor area /
        spacing^2, 1-8 in closed buildings, 0-4 in open ones),
        ``n_stations_outside`` (0-2 round closed buildings, perimeter / spacing,
        2-6, round open ones), ``outside_window`` (exterior stations scan only
        the building's sector, about 0.35 of a dome), ``station_plan`` (planned,
        random), ``tripod_height_m`` (1.2-1.8), ``points_target`` (0.3-3 M, at
        least what the stations give at the coarsest step: sets ``tls_step_deg``,
        0.03-0.3 deg = 5 mm-5.2 cm at 10 m; at most 5 M rays in all, which caps
        the stations at about 5 full domes inside, 8 outside), ``noise_m`` (range noise 1.5-5 mm),
        ``noise_per_m`` (0-0.1 mm/m), ``detail_scan`` (a window scan round one
        support at ``detail_step_deg`` 0.029-0.086 deg = 5-15 mm at 10 m),
        ``outside_reach_m`` (exterior stations 1.5-3 to 12 m from the building),
        ``photo_pixel_step`` (8-12 for photogrammetry alone, 12-16 with TLS),
        ``n_photo_positions`` (4-8 camera positions inside and out, two views
        each, matched in blocks of 2), ``photo_sigma_m`` (5-12 mm),
        ``outlier_share`` (0.1-1 %, log-uniform), ``outlier_below_m`` (0.3-2.5:
        isolated points that far below the lowest surface).
    noise_draw
        0 (default): the draw's own scan; k > 0: the same scene scanned again with
        the k-th other random numbers (detection, noise, mixed pixels, outliers), to
        check that a rule holds over the noise of a scene, not one draw of it.
    """

    layout: str | None = None
    state: str | None = None
    column_radius_m: float | None = None
    size_ratios: tuple[float, ...] | None = None
    column_height_m: float | None = None
    shaft_style: str | None = None
    taper_ratio: float | None = None
    entasis_ratio: float | None = None
    flutes: int | None = None
    flute_depth_ratio: float | None = None
    plinth: bool | None = None
    plinth_ratio: float | None = None
    plinth_height_ratio: float | None = None
    capital: bool | None = None
    abacus_ratio: float | None = None
    twin_share: float | None = None
    twin_gap_m: float | None = None
    pier_share: float | None = None
    pier_width_m: float | None = None
    pier_aspect: float | None = None
    pier_yaw_deg: float | None = None
    engaged: bool | None = None
    engaged_offset_ratio: float | None = None
    responds: bool | None = None
    antae: bool | None = None
    n_per_row: int | None = None
    n_rows: int | None = None
    side_clearance_m: float | None = None
    bay_m: float | None = None
    aisle_m: float | None = None
    platform_m: float | None = None
    broken_share: float | None = None
    leaning_share: float | None = None
    lean_max_deg: float | None = None
    wall_thickness_m: float | None = None
    doors: int | None = None
    windows_per_bay: int | None = None
    window_sill_m: float | None = None
    window_height_m: float | None = None
    glazed: bool | None = None
    ruin_wall_ratio: float | None = None
    ceiling: str | None = None
    vault_rise_m: float | None = None
    attic: bool | None = None
    entablature_m: float | None = None
    overhang_m: float | None = None
    eave_drop_m: float | None = None
    clutter: tuple[str, ...] | None = None
    clutter_count: int | None = None
    clutter_touch_share: float | None = None
    survey: str | None = None
    n_stations_inside: int | None = None
    n_stations_outside: int | None = None
    station_plan: str | None = None
    tripod_height_m: float | None = None
    points_target: float | None = None
    tls_step_deg: float | None = None
    noise_m: float | None = None
    noise_per_m: float | None = None
    detail_scan: bool | None = None
    detail_step_deg: float | None = None
    outside_reach_m: float | None = None
    photo_pixel_step: int | None = None
    photo_sigma_m: float | None = None
    outlier_share: float | None = None
    outlier_below_m: float | None = None
    outside_window: bool | None = None
    station_spacing_m: float | None = None
    n_photo_positions: int | None = None
    noise_draw: int = 0


def _pick(u: float, options: tuple[Any, ...], weights: tuple[float, ...] | None = None) -> Any:
    w = np.ones(len(options)) if weights is None else np.asarray(weights, float)
    c = np.cumsum(w / w.sum())
    return options[int(min(np.searchsorted(c, u, side="right"), len(options) - 1))]


def _lin(u: float, lo: float, hi: float) -> float:
    return float(lo + (hi - lo) * u)


def _log(u: float, lo: float, hi: float) -> float:
    return float(np.exp(np.log(lo) + (np.log(hi) - np.log(lo)) * u))


def draw_params(seed: int, **overrides: Any) -> SupportsFamilyParams:
    """All parameters of draw ``seed``: drawn in a fixed order, overrides kept.

    Every field has its own random numbers (from the seed and its name), used
    whether it is overridden or not, and fields drawn after it see its final
    value (a fixed radius changes the bays that depend on it, not the
    unrelated draws).
    """
    overrides = {k: tuple(x) if isinstance(x, list) else x for k, x in overrides.items()}
    base = apply_overrides(SupportsFamilyParams(), overrides, "supports")
    _check_choices(base)
    if base.n_stations_inside == 0 and base.n_stations_outside == 0 and base.survey != "photo":
        raise InputError(
            "supports family: n_stations_inside=0 and n_stations_outside=0 leave no station",
            hint="give at least one station, or --set survey=photo for photogrammetry only",
        )
    names = [f.name for f in fields(SupportsFamilyParams)]
    # each field its own stream (seed, crc32 of its name): adding a field changes no draw
    U = {n: np.random.default_rng([seed, zlib.crc32(n.encode())]).random(8) for n in names}
    v: dict[str, Any] = {}

    def get(name: str, make: Any) -> Any:
        given = getattr(base, name)
        v[name] = given if given is not None else make(U[name])
        return v[name]

    layout = get("layout", lambda u: _pick(u[0], GENERAL_LAYOUTS, (0.25, 0.2, 0.2, 0.2, 0.15)))
    named = layout in NAMED_LAYOUTS
    ruin_p = {"peristyle": 0.5, "kiosk": 0.1}.get(layout, 0.25)
    get("state", lambda u: "ruin" if u[0] < ruin_p and not named else "intact")
    ruin = v["state"] == "ruin"
    r = get("column_radius_m", lambda u: _log(u[0], 0.15, 1.5))
    get(
        "size_ratios",
        lambda u: tuple(
            [1.0, _lin(u[1], 0.45, 0.85), _lin(u[2], 0.45, 0.85)][
                : _pick(u[0], (1, 2, 3), (0.35, 0.45, 0.2))
            ]
        ),
    )
    get("column_height_m", lambda u: float(np.clip(r * _lin(u[0], 9, 20), 2.5, 15.0)))
    get("shaft_style", lambda u: _pick(u[0], ("smooth", "tapered", "entasis", "fluted", "mixed")))
    get("taper_ratio", lambda u: _lin(u[0], 0.75, 0.97))
    get("entasis_ratio", lambda u: _lin(u[0], 0.005, 0.025))
    get("flutes", lambda u: int(12 + np.floor(u[0] * 13)))
    get("flute_depth_ratio", lambda u: _lin(u[0], 0.02, 0.06))
    get("plinth", lambda u: bool(u[0] < 0.65))
    get("plinth_ratio", lambda u: _lin(u[0], 1.5, 2.5))
    get("plinth_height_ratio", lambda u: _lin(u[0], 0.25, 0.6))
    get("capital", lambda u: bool(u[0] < 0.7))
    get("abacus_ratio", lambda u: _lin(u[0], 1.5, 2.5))
    get("twin_share", lambda u: 0.0 if u[0] < 0.6 else _lin(u[1], 0.15, 1.0))
    get("twin_gap_m", lambda u: _lin(u[0], 0.04, 0.3))
    get("pier_share", lambda u: 0.0 if u[0] < 0.5 else _lin(u[1], 0.2, 1.0))
    get("pier_width_m", lambda u: float(np.clip(2 * r * _lin(u[0], 0.8, 1.6), 0.3, 2.0)))
    get("pier_aspect", lambda u: _lin(u[0], 1.0, 2.5))
    get("pier_yaw_deg", lambda u: 0.0 if u[0] < 0.8 else _lin(u[1], 5.0, 45.0))
    walled = layout in ("nave", "hypostyle")
    get("engaged", lambda u: bool(walled and u[0] < 0.6))
    get("engaged_offset_ratio", lambda u: _lin(u[0], 0.0, 0.5))
    get("responds", lambda u: bool(walled and u[0] < 0.3))
    get("antae", lambda u: bool(u[0] < 0.6))
    _grid_params(get, v, layout, r)
    get("platform_m", lambda u: 0.0 if u[0] < 0.5 else _lin(u[1], 0.15, 1.2))
    get("broken_share", lambda u: _lin(u[0], 0.1, 0.5) if ruin else 0.0)
    get("leaning_share", lambda u: 0.0 if u[1] < 0.3 else _lin(u[0], 0.05, 0.4))
    get("lean_max_deg", lambda u: _lin(u[0], 1.0, 6.0))
    get("wall_thickness_m", lambda u: _lin(u[0], 0.3, 1.5))
    get("doors", lambda u: int(1 + np.floor(u[0] * 3)))
    get("windows_per_bay", lambda u: int(np.floor(u[0] * 3)))
    get("window_sill_m", lambda u: _lin(u[0], 0.6, 3.0))
    get("window_height_m", lambda u: _lin(u[0], 1.0, 3.5))
    get("glazed", lambda u: bool(u[0] < 0.5))
    get("ruin_wall_ratio", lambda u: _lin(u[0], 0.3, 0.9))
    attic_p = {
        "kiosk": 0.7,
        "portico": 0.6,
        "peristyle": 0.6,
        "nave": 0.25,
        "hypostyle": 0.15,
    }.get(layout, 0.0)
    get("attic", lambda u: bool(u[0] < attic_p and not ruin))
    get(
        "ceiling",
        lambda u: (
            "none"
            if ruin
            else "attic"
            if v["attic"]
            else _pick(u[0], ("flat", "vault", "timber", "none"), (0.3, 0.3, 0.3, 0.1))
        ),
    )
    get("vault_rise_m", lambda u: _lin(u[0], 0.15, 0.5) * v["aisle_m"])
    get("entablature_m", lambda u: _lin(u[0], 0.4, 1.2))
    get("overhang_m", lambda u: _lin(u[0], 0.8, 2.5))
    get("eave_drop_m", lambda u: _lin(u[0], 0.1, 1.2))
    get("clutter", lambda u: tuple(k for k, x in zip(CLUTTER_KINDS, u, strict=False) if x < 0.35))
    get("clutter_count", lambda u: int(np.floor(u[0] * 25)) if v["clutter"] else 0)
    get("clutter_touch_share", lambda u: _lin(u[0], 0.3, 1.0))
    _survey_params(get, v, layout, ruin)
    check_noise_draw(base.noise_draw, "supports")
    v["noise_draw"] = base.noise_draw
    p = SupportsFamilyParams(**v)
    _check_ranges(p)
    return p


#: Allowed values of the categorical parameters.
CHOICES: dict[str, tuple[str, ...]] = {
    "layout": GENERAL_LAYOUTS + NAMED_LAYOUTS,
    "state": ("intact", "ruin"),
    "shaft_style": ("smooth", "tapered", "entasis", "fluted", "mixed"),
    "ceiling": ("flat", "vault", "timber", "none", "attic"),
    "survey": ("tls", "tls+photo", "photo"),
    "station_plan": ("planned", "random"),
}


def _check_choices(p: SupportsFamilyParams) -> None:
    """Refuse unknown categorical values (the error lists the allowed ones)."""
    for name, allowed in CHOICES.items():
        value = getattr(p, name)
        if value is not None and value not in allowed:
            raise InputError(
                f"supports family: {name}={value!r} is not allowed",
                hint=f"choose one of {', '.join(allowed)}",
            )
    if p.clutter is not None:
        bad = [k for k in p.clutter if k not in CLUTTER_KINDS]
        if bad or isinstance(p.clutter, str):
            raise InputError(
                f"supports family: unknown clutter {bad or p.clutter!r}",
                hint=f"a list among {', '.join(CLUTTER_KINDS)}",
            )


def _check_ranges(p: SupportsFamilyParams) -> None:
    """Refuse impossible numbers (a fixed value outside what the geometry allows)."""
    positive = (
        "column_radius_m",
        "column_height_m",
        "bay_m",
        "aisle_m",
        "wall_thickness_m",
        "tls_step_deg",
        "detail_step_deg",
        "tripod_height_m",
        "station_spacing_m",
    )
    for name in positive:
        if not getattr(p, name) > 0:
            raise InputError(f"supports family: {name} must be > 0, got {getattr(p, name)}")
    shares = (
        "twin_share",
        "pier_share",
        "broken_share",
        "leaning_share",
        "clutter_touch_share",
        "outlier_share",
    )
    for name in shares:
        if not 0 <= getattr(p, name) <= 1:
            raise InputError(f"supports family: {name} must be in [0, 1], got {getattr(p, name)}")
    if p.n_per_row < 1 or p.n_rows < 1:
        raise InputError("supports family: n_per_row and n_rows must be >= 1")
    if (
        p.n_stations_inside < 0
        or p.n_stations_outside < 0
        or (p.n_stations_inside + p.n_stations_outside == 0)
    ):
        raise InputError("supports family: at least one station (inside or outside)")
    if not 0 <= p.lean_max_deg <= 30:
        raise InputError(f"supports family: lean_max_deg must be in [0, 30], got {p.lean_max_deg}")


def _grid_params(get: Any, v: dict[str, Any], layout: str, r: float) -> None:
    """Rows, supports per row and spacings; the support count kept in 4-80."""

    class _P:  # the footprint only needs these
        plinth, capital = v["plinth"], v["capital"]
        plinth_ratio, abacus_ratio = v["plinth_ratio"], v["abacus_ratio"]

    foot = foot_half(_P, r)
    if v["twin_share"] > 0:
        foot += r + v["twin_gap_m"] / 2
    rows_range = {
        "nave": (2, 4),
        "hypostyle": (3, 8),
        "portico": (1, 2),
        "peristyle": (4, 8),
        "kiosk": (2, 4),
    }.get(layout, (2, 2))
    per_range = {
        "nave": (3, 12),
        "hypostyle": (3, 10),
        "portico": (4, 12),
        "peristyle": (4, 16),
        "kiosk": (2, 6),
    }.get(layout, (2, 2))
    get("side_clearance_m", lambda u: _lin(u[0], 0.8, 3.0))
    get("bay_m", lambda u: max(2 * foot + _lin(u[0], 0.4, 2.5), r * _lin(u[1], 3.0, 6.0)))
    get("aisle_m", lambda u: max(2 * foot + _lin(u[0], 1.0, 3.5), r * _lin(u[1], 4.0, 8.0)))
    max_per = max(per_range[0], int(MAX_LENGTH_M / v["bay_m"]) + 1)
    max_rows = max(rows_range[0], int(MAX_WIDTH_M / v["aisle_m"]) + 1)
    n_rows = get(
        "n_rows",
        lambda u: int(
            np.clip(
                rows_range[0] + np.floor(u[0] * (rows_range[1] - rows_range[0] + 1)),
                rows_range[0],
                min(rows_range[1], max_rows),
            )
        ),
    )
    if layout == "nave" and v["n_rows"] == 3:
        v["n_rows"] = n_rows = 4 if max_rows >= 4 else 2
    walls = 2 if layout in ("nave", "hypostyle") else 0

    twins = 2 if v["twin_share"] > 0 else 1  # a twin position holds two columns

    def count(n_per: int) -> int:
        if layout == "peristyle":
            return twins * (2 * (n_per + n_rows) - 4) + 4
        return n_per * (twins * n_rows + walls) + (2 if layout == "portico" else 0)

    def per(u: Any) -> int:
        n = int(per_range[0] + np.floor(u[0] * (per_range[1] - per_range[0] + 1)))
        n = int(np.clip(n, per_range[0], min(per_range[1], max_per)))
        while n > 2 and count(n) > MAX_SUPPORTS:
            n -= 1
        while count(n) < MIN_SUPPORTS:
            n += 1
        return n

    get("n_per_row", per)


NAMED_EXTENT_M = {
    "pavilion": (12.0, 8.0),
    "temple": (24.0, 12.0),
    "hall": (20.0, 10.0),
    "choir": (14.0, 10.0),
}


def _extent(v: dict[str, Any], layout: str) -> tuple[float, float]:
    """Length and width of the building the grid parameters give, metres."""
    if layout in NAMED_EXTENT_M:
        return NAMED_EXTENT_M[layout]
    L = 2 * v["side_clearance_m"] + (v["n_per_row"] - 1) * v["bay_m"]
    W = 2 * v["side_clearance_m"] + (v["n_rows"] - 1) * v["aisle_m"]
    return float(L), float(W)


def _survey_params(get: Any, v: dict[str, Any], layout: str, ruin: bool) -> None:
    """Stations, step (from the point budget), noise, photogrammetry, outliers."""
    enclosed = layout in ("nave", "hypostyle", "hall", "choir") and not ruin
    get(
        "survey",
        lambda u: _pick(
            u[0],
            ("tls", "tls+photo", "photo"),
            (0.7, 0.15, 0.15) if not enclosed else (0.85, 0.15, 0.0),
        ),
    )
    many = 8
    L, W = _extent(v, layout)
    get("station_spacing_m", lambda u: _log(u[0], 4.0, 30.0))
    sp = v["station_spacing_m"]
    n_area = round(L * W / sp**2)
    get(
        "n_stations_inside",
        lambda u: (
            int(np.clip(n_area, 1, many))
            if enclosed
            else int(np.clip(round(0.5 * n_area), 0, 4))
            if u[0] < 0.6
            else 0
        ),
    )
    get(
        "n_stations_outside",
        lambda u: (
            int(np.floor(u[0] * 3)) if enclosed else int(np.clip(round(2 * (L + W) / sp), 2, 6))
        ),
    )
    get("outside_window", lambda u: bool(u[0] < 0.6))
    w_out = OUTSIDE_WINDOW_SHARE if v["outside_window"] else 1.0
    dome = DOME[0] * DOME[1]
    n_in, n_out = v["n_stations_inside"], v["n_stations_outside"]
    if n_in + n_out == 0:
        n_in, n_out = (1, 0) if enclosed else (0, 1)

    def hit_rate(n_in: int, n_out: int) -> float:  # share of the rays that return
        domes = n_in + n_out * w_out
        share_in = n_in / max(domes, 1e-9)
        return (0.95 if v["ceiling"] != "none" else 0.6) * share_in + 0.4 * (1 - share_in)

    # the budget (3 M points, 5 M rays) caps the full domes the coarsest step allows
    def too_many(n_in: int, n_out: int) -> bool:
        rays = min(MAX_RAYS, MAX_POINTS / hit_rate(n_in, n_out))
        return (n_in + n_out * w_out) * dome / MAX_STEP_DEG**2 > rays

    while too_many(n_in, n_out) and n_in + n_out > 1:
        if n_out > (0 if n_in else 1):
            n_out -= 1
        else:
            n_in -= 1
    v["n_stations_inside"], v["n_stations_outside"] = n_in, n_out
    domes = n_in + n_out * w_out
    hit = hit_rate(n_in, n_out)
    get("station_plan", lambda u: "planned" if u[0] < 0.65 else "random")
    get("tripod_height_m", lambda u: _lin(u[0], 1.2, 1.8))
    # the budget: at least what the stations give at the coarsest step, at most 3 M points
    lo = min(MAX_POINTS, max(3e5, domes * dome / MAX_STEP_DEG**2 * hit))
    get("points_target", lambda u: _log(u[0], lo, max(lo, MAX_POINTS)))
    rays = min(v["points_target"] / hit, MAX_RAYS)
    get(
        "tls_step_deg",
        lambda u: float(np.clip(np.sqrt(domes * dome / rays), MIN_STEP_DEG, MAX_STEP_DEG)),
    )
    get("noise_m", lambda u: _lin(u[0], 0.0015, 0.005))
    get("noise_per_m", lambda u: _lin(u[0], 0.0, 0.0001))
    get("detail_scan", lambda u: bool(u[0] < 0.35))
    get("detail_step_deg", lambda u: float(np.rad2deg(_lin(u[0], 0.005, 0.015) / 10.0)))
    get("outside_reach_m", lambda u: _lin(u[0], 3.0, 12.0))
    photo_only = v["survey"] == "photo"
    get("photo_pixel_step", lambda u: int((8 if photo_only else 12) + np.floor(u[0] * 5)))
    get("n_photo_positions", lambda u: int(4 + np.floor(u[0] * 5)))
    get("photo_sigma_m", lambda u: _lin(u[0], 0.005, 0.012))
    get("outlier_share", lambda u: _log(u[0], 0.001, 0.01))
    get("outlier_below_m", lambda u: _lin(u[0], 0.3, 2.5))


def _bounds(plan: Plan) -> tuple[float, float, float, float]:
    """Footprint bounds of supports, walls and attic."""
    geoms = [shapely.box(*plan.rect)]
    geoms += [shapely.Point(s.x, s.y).buffer(1.0) for s in plan.supports]
    geoms += [w.footprint() for w in plan.walls]
    b = shapely.union_all(geoms).bounds
    if plan.attic is not None:
        o = plan.attic["overhang_m"]
        b = (b[0] - o, b[1] - o, b[2] + o, b[3] + o)
    return tuple(float(x) for x in b)  # type: ignore[return-value]


def _class_rows(scene: Any, rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """One ``instance`` 0 row per non-support class present in the scene."""
    have = {r["class"] for r in rows if r["instance"] == 0}
    used = set(np.unique(scene.triangle_class).tolist())
    out = []
    for code, name in scene.class_names.items():
        if code in used and name not in SUPPORT_CLASSES and name not in have:
            out.append({"instance": 0, "class": name})
    return out


def draw(seed: int, **overrides: Any) -> Simulation:
    """Draw member ``seed`` of the ``supports`` family and scan it.

    Parameters
    ----------
    seed
        Draw number; the same seed and overrides give the same points.
    **overrides
        Fields of :class:`SupportsFamilyParams` to fix (unknown names raise
        :class:`~pyheracles.errors.InputError` with the closest name).

    Returns
    -------
    Simulation
        ``clouds["cloud"]`` in the scene frame (identity transform), the scene
        with ``scene.objects`` (supports 1..K, then class rows), ``params`` (all
        drawn values) and ``extras["stations"]``.
    """
    p = draw_params(seed, **overrides)
    ss = np.random.SeedSequence(seed)
    g_plan, g_build, g_survey, g_scan = (np.random.default_rng(s) for s in ss.spawn(4))
    if p.layout in NAMED_LAYOUTS:
        from pyheracles.synthetic.families.supports_named import named_plan

        plan = named_plan(p.layout)
    else:
        plan = general_plan(p, g_plan)
    scene, rows, solids = build_plan(plan, g_build)
    scene.objects = rows + _class_rows(scene, rows)
    outliers = Outliers(share=p.outlier_share, below_m=p.outlier_below_m)
    sv = plan_survey(p, plan, solids, _bounds(plan), g_survey)
    g_scan = scan_generator(seed, p.noise_draw, g_scan, "supports")
    res = scan(scene, sv.acquisitions, outliers=outliers, rng=g_scan)
    params = asdict(p)
    params["n_supports"] = sum(1 for r in rows if r["class"] in SUPPORT_CLASSES)
    params["floor_z_m"] = float(plan.platform_m)
    return Simulation(
        family="supports",
        seed=seed,
        scene=scene,
        clouds={"cloud": res},
        transforms={"cloud": np.eye(4)},
        params=params,
        extras={"stations": sv.stations, "plan": plan},
    )
