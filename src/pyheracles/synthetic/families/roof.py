"""The ``roof`` scene family: timber roof frames scanned from inside (step 2b, beams).

Each draw builds an attic: a floor between two masonry eaves walls and two
gable walls, a timber frame (king-post, queen-post, collar or simple rafter
roof; see :mod:`~pyheracles.synthetic.families.roof_frame`) with purlins,
ridge, wall plates on the wall heads, X braces and common rafters under the
boarding that covers the roof, a chimney, stored planks and loose timbers on
the floor and a ladder leaning on a post
(:mod:`~pyheracles.synthetic.families.roof_room`).  One to four terrestrial
laser scanner stations stand inside the frame and scan full domes; the
non-beam surfaces make most of the cloud, many members are seen on one face
only and far ends of long members are sparse.

Reference: every member is one instance of class ``beam`` with its ``role``
(tie, rafter, post, strut, purlin, ridge, plate, brace, common_rafter,
collar) and its true cuboid in ``scene.objects`` (centre, axis, up, side,
width, height, length, ``deflection_m``, ``twist_deg``, ``n_points``,
``faces_seen`` and points per face); the true joints (pairs of members,
point, type ``L``/``T``/``X``/``foot``) are in ``params["joints"]`` (and
``extras["joints"]``).  Everything else is instance 0 with its class
(``floor``, ``wall``, ``boarding``, ``chimney``, ``loose_timber``,
``ladder``).

Point density: one angular step for all stations, calibrated on a coarse
probe scan so that the cloud holds about ``n_points``: the drawn surface
density (2500-8000 points per m2 of floor, walls, boarding and members, a
mean spacing of 1.1-2 cm) times the attic's surfaces, kept in 0.3-1.5 M
points (what the beams step takes in 2-25 s).  With full domes from 1-4
stations this is a step of 0.2-0.7 degrees, 3.5-12 cm at 10 m (the nearest
neighbour spacing on surfaces 2-5 m away is 5-10 mm along the scan lines).
The issue's 5-15 mm at 10 m (a real scanner's setting) means 5-20 M rays per
station; set ``spacing_10m_m`` to get it, at that cost.

Named members: the project's three benchmark roofs of
:mod:`pyheracles.synthetic.truss` (king-post trusses, beams only) are
``layout="truss2_3scan_200k"``, ``"truss2_2scan_150k"`` and
``"truss3_3scan_300k"``, scanned by the simulator from the same stations.

Examples
--------
>>> from pyheracles.synthetic.families import simulate
>>> sim = simulate("roof", 0, n_points=200_000, n_stations=1)  # doctest: +SKIP
>>> sorted({o["role"] for o in sim.scene.objects if o["class"] == "beam"})  # doctest: +SKIP
['brace', 'common_rafter', 'plate', 'post', 'purlin', 'rafter', 'ridge', 'strut', 'tie']
"""

from __future__ import annotations

import re
from dataclasses import asdict, dataclass, fields, replace
from typing import Any

import numpy as np

from pyheracles.errors import InputError
from pyheracles.synthetic.families.roof_frame import (
    FRAME_TYPES,
    Member,
    RoofLevels,
    build_frame,
    deform,
    draw_sections,
    member_between,
)
from pyheracles.synthetic.families.roof_room import (
    Box,
    add_room,
    place_chimney,
    place_clutter,
    place_ladder,
    place_stations,
)
from pyheracles.synthetic.families.roof_truth import FACE_MIN_POINTS, faces_seen, find_joints
from pyheracles.synthetic.families.simulation import (
    Simulation,
    apply_overrides,
    check_noise_draw,
    scan_generator,
)
from pyheracles.synthetic.scanner import Outliers, ScanResult, TLSStation, scan
from pyheracles.synthetic.scene import STONE, TIMBER, Scene

__all__ = ["NAMED_LAYOUTS", "RoofFamilyParams", "draw", "resolve_params"]

#: Named members: the benchmark roofs of :mod:`pyheracles.synthetic.truss`.
NAMED_LAYOUTS = {
    "truss2_3scan_200k": {"n_trusses": 2, "n_scanners": 3, "n_points": 200_000},
    "truss2_2scan_150k": {"n_trusses": 2, "n_scanners": 2, "n_points": 150_000},
    "truss3_3scan_300k": {"n_trusses": 3, "n_scanners": 3, "n_points": 300_000},
}

#: Elevation window of the stations, degrees (a 30 degree blind cone under the tripod).
ELEVATION_DEG = (-60.0, 90.0)
#: Cloud sizes a draw keeps to (what the beams step takes in 2-25 s).
N_POINTS_RANGE = (300_000, 1_500_000)
#: Angular step of the probe scan that calibrates the station step, degrees.
PROBE_STEP_DEG = 1.0


@dataclass(frozen=True)
class RoofFamilyParams:
    """Drawn quantities of a roof (None: drawn from the range given).

    Attributes
    ----------
    layout
        ``"random"`` (drawn) or one of :data:`NAMED_LAYOUTS`.
    frame_type
        ``king_post`` (30 %), ``queen_post`` (25 %), ``collar`` (25 %),
        ``simple_rafter`` (20 %).
    span_m
        Clear span between the eaves walls, 4-12 m.
    length_m
        Inside length, gable to gable, 4-16 m.
    pitch_deg
        Roof slope, 30-60 degrees (30-50 for queen posts).
    truss_spacing_m
        Principal trusses (or tied couples) every 2.5-4.5 m.
    rafter_spacing_m
        Common rafters (or couples) every 0.45-0.9 m.
    n_purlins
        Purlins per side on king / queen post trusses, 1-2.
    has_ridge
        Couple roofs: a ridge (60 %); truss roofs always have one.
    has_common_rafters
        King / queen post roofs: common rafters on the purlins under the
        boarding (75 %); otherwise the boarding lies on two purlins per side.
    tie_bottom_m
        Masonry wall head (= tie beams' bottom) above the floor: 0.3-1.6 m
        (65 %), or -0.2-0 m (35 %: the floor boards are laid between the tie
        beams, which show their top and the upper part of their sides; kept
        above -0.7 x the tie height).
    wall_thickness_m
        Eaves walls 0.4-0.9 m; gable walls 0.35-0.7 m.
    section_scale
        Factor on the nominal sections of every role, 0.8-1.2 (all 8-35 cm).
    bent_share, twisted_share
        Share of members bent (sag 5-30 mm), 0-0.3, or twisted (1-4 degrees), 0-0.15.
    brace_share
        Share of bays with X braces, 0.4-1.
    has_chimney
        A chimney through the roof (60 %).
    n_loose_timber, n_plank_stacks
        Timbers lying on the floor, 0-6; stacks of planks, 0-3.
    has_ladder
        A ladder leaning on a post (60 %).
    n_stations
        Scanner stations inside the frame, 1-4.
    tripod_height_m
        Scanner height above the floor, 1.2-1.8 m.
    surface_density_per_m2
        Points per square metre of surface aimed at, 2500-8000.
    n_points
        Cloud size aimed at; None: the density times the attic's surface
        area, kept in 0.3-1.5 M points (recorded).
    spacing_10m_m
        Station point spacing at 10 m; None: set from ``n_points`` (recorded).
    noise_m
        Range noise sigma, 2-5 mm.
    outlier_share
        Gross errors, 0.1-1 % of the points.
    noise_draw
        0 (default): the draw's own scan; k > 0: the same scene scanned again with
        the k-th other random numbers (detection, noise, mixed pixels, outliers), to
        check that a rule holds over the noise of a scene, not one draw of it.
    """

    layout: str = "random"
    frame_type: str | None = None
    span_m: float | None = None
    length_m: float | None = None
    pitch_deg: float | None = None
    truss_spacing_m: float | None = None
    rafter_spacing_m: float | None = None
    n_purlins: int | None = None
    has_ridge: bool | None = None
    has_common_rafters: bool | None = None
    tie_bottom_m: float | None = None
    wall_thickness_m: float | None = None
    section_scale: float | None = None
    bent_share: float | None = None
    twisted_share: float | None = None
    brace_share: float | None = None
    has_chimney: bool | None = None
    n_loose_timber: int | None = None
    n_plank_stacks: int | None = None
    has_ladder: bool | None = None
    n_stations: int | None = None
    tripod_height_m: float | None = None
    surface_density_per_m2: float | None = None
    n_points: int | None = None
    spacing_10m_m: float | None = None
    noise_m: float | None = None
    outlier_share: float | None = None
    noise_draw: int = 0


def _drawn(rng: np.random.Generator) -> dict[str, Any]:
    """Every drawn field, always in the same order (overrides do not shift the stream)."""
    frame = str(rng.choice(FRAME_TYPES, p=[0.3, 0.25, 0.25, 0.2]))
    pitch = float(rng.uniform(30, 60))
    return {
        "frame_type": frame,
        "span_m": float(rng.uniform(4, 12)),
        "length_m": float(rng.uniform(4, 16)),
        "pitch_deg": pitch if frame != "queen_post" else 30 + (pitch - 30) * 2 / 3,
        "truss_spacing_m": float(rng.uniform(2.5, 4.5)),
        "rafter_spacing_m": float(rng.uniform(0.45, 0.9)),
        "n_purlins": int(rng.integers(1, 3)),
        "has_ridge": bool(rng.random() < 0.6),
        "has_common_rafters": bool(rng.random() < 0.75),
        "tie_bottom_m": float(
            rng.uniform(-0.2, 0.0) if rng.random() < 0.35 else rng.uniform(0.3, 1.6)
        ),
        "wall_thickness_m": float(rng.uniform(0.4, 0.9)),
        "section_scale": float(rng.uniform(0.8, 1.2)),
        "bent_share": float(rng.uniform(0, 0.3)),
        "twisted_share": float(rng.uniform(0, 0.15)),
        "brace_share": float(rng.uniform(0.4, 1.0)),
        "has_chimney": bool(rng.random() < 0.6),
        "n_loose_timber": int(rng.integers(0, 7)),
        "n_plank_stacks": int(rng.integers(0, 4)),
        "has_ladder": bool(rng.random() < 0.6),
        "n_stations": int(rng.integers(1, 5)),
        "tripod_height_m": float(rng.uniform(1.2, 1.8)),
        "surface_density_per_m2": float(rng.uniform(2500, 8000)),
        "noise_m": float(rng.uniform(0.002, 0.005)),
        "outlier_share": float(rng.uniform(0.001, 0.01)),
    }


def _validate(p: RoofFamilyParams) -> None:
    if p.layout != "random" and p.layout not in NAMED_LAYOUTS:
        raise InputError(
            f"roof layout {p.layout!r} is unknown",
            hint=f"choose random or one of {', '.join(NAMED_LAYOUTS)}",
        )
    if p.frame_type not in FRAME_TYPES:
        raise InputError(
            f"roof frame_type {p.frame_type!r} is unknown",
            hint=f"choose one of {', '.join(FRAME_TYPES)}",
        )
    checks = {
        "span_m": (2.0, 30.0),
        "length_m": (2.5, 40.0),
        "pitch_deg": (15.0, 70.0),
        "truss_spacing_m": (1.0, 8.0),
        "rafter_spacing_m": (0.3, 2.0),
        "n_purlins": (1, 2),
        "tie_bottom_m": (-0.3, 3.0),
        "wall_thickness_m": (0.2, 1.5),
        "section_scale": (0.5, 1.5),
        "bent_share": (0.0, 1.0),
        "twisted_share": (0.0, 1.0),
        "brace_share": (0.0, 1.0),
        "n_loose_timber": (0, 30),
        "n_plank_stacks": (0, 10),
        "n_stations": (1, 8),
        "tripod_height_m": (0.5, 2.5),
        "surface_density_per_m2": (100.0, 100_000.0),
        "noise_m": (0.0, 0.05),
        "outlier_share": (0.0, 0.2),
    }
    check_noise_draw(p.noise_draw, "roof")
    if p.n_points is not None:
        checks["n_points"] = (10_000, 50_000_000)
    if p.spacing_10m_m is not None:
        checks["spacing_10m_m"] = (0.001, 0.5)
    for name, (lo, hi) in checks.items():
        v = getattr(p, name)
        whole = isinstance(lo, int) and isinstance(hi, int)
        kind = int if whole else int | float
        if isinstance(v, bool) or not isinstance(v, kind) or not lo <= v <= hi:
            raise InputError(
                f"roof {name} must be {'a whole number' if whole else 'a number'} in "
                f"[{lo}, {hi}], got {v!r}"
            )
    for name in ("has_ridge", "has_common_rafters", "has_chimney", "has_ladder"):
        if not isinstance(getattr(p, name), bool):
            raise InputError(f"roof {name} must be true or false, got {getattr(p, name)!r}")


def resolve_params(seed: int, **overrides: Any) -> RoofFamilyParams:
    """Every parameter of draw ``seed``: the drawn values with ``overrides`` over them.

    Raises
    ------
    InputError
        An unknown parameter or a value out of its range.
    """
    values = _drawn(np.random.default_rng(seed))
    base = apply_overrides(RoofFamilyParams(), overrides, "roof")
    given = {f.name for f in fields(base) if getattr(base, f.name) is not None}
    p = replace(base, **{k: v for k, v in values.items() if k not in given})
    _validate(p)
    return p


def draw(seed: int, **overrides: Any) -> Simulation:
    """Draw roof number ``seed`` and scan it.

    Parameters
    ----------
    seed
        Draw number; the same seed gives the same scene and points.
    **overrides
        Fields of :class:`RoofFamilyParams` to fix (``n_stations=2``,
        ``frame_type="collar"``, ``layout="truss2_3scan_200k"`` ...).

    Returns
    -------
    Simulation
        ``clouds["cloud"]`` in the scene frame; ``params`` holds every drawn
        value, the frame description, the station plan and the joints.

    Raises
    ------
    InputError
        An unknown override or a value out of its range.
    """
    p = resolve_params(seed, **overrides)
    if p.layout != "random":
        return _draw_named(seed, p)
    geo = np.random.default_rng([seed, 1])
    lv = _levels(p, geo)
    members, info = build_frame(
        lv,
        geo,
        truss_spacing=p.truss_spacing_m,
        rafter_spacing=p.rafter_spacing_m,
        n_purlins=p.n_purlins,
        brace_share=p.brace_share,
    )
    tie_x = [float(m.centre[0]) for m in members if m.role == "tie"]
    scene = Scene()
    gable_t = float(geo.uniform(0.35, 0.7))
    chimney, trimmed = place_chimney(lv, members, geo, tie_x) if p.has_chimney else (None, set())
    members = [m for m in members if m.group < 0 or m.group not in trimmed]
    members = deform(members, geo, p.bent_share, p.twisted_share)
    extra = [chimney] if chimney is not None else []
    stations = place_stations(lv, members, extra, p.n_stations, p.tripod_height_m, geo)
    if not stations:
        raise InputError(
            f"roof seed {seed}: no free place for a scanner station",
            hint="choose another seed or a larger span",
        )
    # the frame, then the surroundings
    for i, m in enumerate(members, start=1):
        scene.add_triangles(
            m.triangles(), instance=i, class_name="beam", part=m.role, material=TIMBER
        )
        scene.objects.append(m.to_object(i))
    add_room(scene, lv, tie_x, gable_t)
    if chimney is not None:
        scene.add_box(
            chimney.centre, chimney.size, class_name="chimney", part="chimney", material=STONE
        )
        scene.objects.append({"instance": 0, "class": "chimney", "box": chimney.to_json()})
    obstacles = [Box.of(m) for m in members] + extra
    clutter = place_clutter(scene, lv, obstacles, stations, geo, p.n_loose_timber, p.n_plank_stacks)
    ladder = (
        place_ladder(scene, lv, members, extra + clutter, stations, geo) if p.has_ladder else None
    )
    # the survey: the station step that gives the cloud size aimed at
    area = _surface_area(lv, members)
    n_target = p.n_points or int(np.clip(p.surface_density_per_m2 * area, *N_POINTS_RANGE))
    step = _station_step(scene, stations, p, seed, n_target)
    acqs = [
        TLSStation(
            tuple(float(v) for v in s),
            step_deg=step,
            elevation_deg=ELEVATION_DEG,
            noise_m=p.noise_m,
            noise_per_m=0.0,
        )
        for s in stations
    ]
    g_scan = scan_generator(seed, p.noise_draw, np.random.default_rng([seed, 2]), "roof")
    res = scan(scene, acqs, outliers=Outliers(share=p.outlier_share), rng=g_scan)
    _record_visibility(scene, members, res)
    joints = find_joints(members)
    params = {
        **{k: v for k, v in asdict(p).items()},
        "spacing_10m_m": float(10 * np.radians(step)),
        "step_deg": float(step),
        "n_points": n_target,
        "surface_area_m2": area,
        "n_points_obtained": len(res),
        "n_members": len(members),
        "members_by_role": _count_roles(members),
        "sections_m": {k: list(v) for k, v in lv.sections.items()},
        "gable_thickness_m": gable_t,
        "frame": info,
        "stations": [s.tolist() for s in stations],
        "chimney": chimney is not None,
        "trimmed_groups": len(trimmed),
        "n_clutter_boxes": len(clutter),
        "ladder_on": None if ladder is None else ladder["leans_on"],
        "face_min_points": FACE_MIN_POINTS,
        "joints": joints,
    }
    return Simulation(
        family="roof",
        seed=seed,
        scene=scene,
        clouds={"cloud": res},
        transforms={"cloud": np.eye(4)},
        params=params,
        extras={"members": members, "joints": joints, "levels": lv},
    )


def _levels(p: RoofFamilyParams, rng: np.random.Generator) -> RoofLevels:
    sections = draw_sections(rng, p.section_scale, p.frame_type)
    return RoofLevels(
        frame_type=p.frame_type,
        half=p.span_m / 2,
        wall_t=p.wall_thickness_m,
        z_w=max(p.tie_bottom_m, -0.7 * sections["tie"][1]),
        length=p.length_m,
        pitch_deg=p.pitch_deg,
        sections=sections,
        plate_inset=float(rng.uniform(0.0, 0.05)),
        overhang=float(rng.uniform(0.2, 0.4)),
        boarding_t=float(rng.uniform(0.02, 0.03)),
        has_ridge=bool(p.has_ridge) or p.frame_type in ("king_post", "queen_post"),
        has_commons=bool(p.has_common_rafters) or p.frame_type in ("collar", "simple_rafter"),
    )


def _surface_area(lv: RoofLevels, members: list[Member]) -> float:
    """Area seen from inside, m2: floor, boarding, eaves walls, gables, members' sides."""
    L = lv.length
    floor = L * 2 * lv.half
    boarding = 2 * L * lv.eta_eave / lv.cos
    walls = 2 * L * max(lv.z_tt, 0.1)
    rise = float(lv.underside(0.0)) - lv.z_tt
    gables = 2 * (2 * lv.half * max(lv.z_tt, 0.0) + lv.half * rise)
    timber = sum(2 * (m.width + m.height) * m.length for m in members)
    return float(floor + boarding + walls + gables + timber)


def _count_roles(members: list[Member]) -> dict[str, int]:
    out: dict[str, int] = {}
    for m in members:
        out[m.role] = out.get(m.role, 0) + 1
    return out


def _station_step(
    scene: Scene, stations: list[np.ndarray], p: RoofFamilyParams, seed: int, n_target: int
) -> float:
    """Angular step (degrees): from ``spacing_10m_m``, or calibrated on a probe scan."""
    if p.spacing_10m_m is not None:
        return float(np.degrees(p.spacing_10m_m / 10.0))
    probe = [
        TLSStation(
            tuple(float(v) for v in s),
            step_deg=PROBE_STEP_DEG,
            elevation_deg=ELEVATION_DEG,
            mixed_pixel_share=0.0,
        )
        for s in stations
    ]
    n_probe = len(scan(scene, probe, rng=np.random.default_rng([seed, 3])))
    return float(PROBE_STEP_DEG * np.sqrt(max(n_probe, 1) / n_target))


def _record_visibility(scene: Scene, members: list[Member], res: ScanResult) -> None:
    """Add ``n_points``, ``faces_seen`` and points per face to every member's object."""
    good = ~res.outlier
    inst = res.instance[good]
    xyz = res.xyz[good]
    order = np.argsort(inst, kind="stable")
    bounds = np.searchsorted(inst[order], np.arange(len(members) + 2))
    by_instance = {o["instance"]: o for o in scene.objects if o["class"] == "beam"}
    for i, m in enumerate(members, start=1):
        pts = xyz[order[bounds[i] : bounds[i + 1]]]
        n_seen, per = faces_seen(m, pts)
        by_instance[i].update(n_points=len(pts), faces_seen=n_seen, points_per_face=per)


# ----------------------------------------------------------------------------- named roofs
def _draw_named(seed: int, p: RoofFamilyParams) -> Simulation:
    """A benchmark roof of :mod:`pyheracles.synthetic.truss` scanned by the simulator."""
    from pyheracles.synthetic.truss import TrussParams, default_scanners, truss_beams

    tp = TrussParams(**NAMED_LAYOUTS[p.layout])
    beams = truss_beams(tp)
    scene = Scene()
    members = []
    for i, b in enumerate(beams, start=1):
        kind = re.sub(r"\d*[lr]?$", "", b.name)
        role = {"king_post": "post"}.get(kind, kind)
        a0, a1 = b.centre - b.axis * b.length / 2, b.centre + b.axis * b.length / 2
        m = member_between(b.name, role, a0, a1, b.width, b.height, b.up)
        members.append(m)
        scene.add_triangles(
            m.triangles(), instance=i, class_name="beam", part=role, material=TIMBER
        )
        scene.objects.append(m.to_object(i))
    stations = default_scanners(tp)
    quiet = {
        "noise_m": tp.noise_m,
        "noise_per_m": 0.0,
        "mixed_pixel_share": 0.0,
        "detection": 1e-9,
        "grazing_limit_deg": 0.5,
    }
    probe = [TLSStation(tuple(s), step_deg=PROBE_STEP_DEG, **quiet) for s in stations]
    n_probe = len(scan(scene, probe, rng=np.random.default_rng([seed, 3])))
    step = float(PROBE_STEP_DEG * np.sqrt(max(n_probe, 1) / tp.n_points))
    res = scan(
        scene,
        [TLSStation(tuple(s), step_deg=step, **quiet) for s in stations],
        rng=scan_generator(seed, p.noise_draw, np.random.default_rng([seed, 2]), "roof"),
    )
    _record_visibility(scene, members, res)
    joints = find_joints(members)
    params = {
        "layout": p.layout,
        **NAMED_LAYOUTS[p.layout],
        "frame_type": "king_post",
        "span_m": tp.span_m,
        "length_m": (tp.n_trusses - 1) * tp.truss_spacing_m + 0.9,
        "pitch_deg": tp.pitch_deg,
        "noise_m": tp.noise_m,
        "tie_bottom_m": None,
        "bent_share": 0.0,
        "twisted_share": 0.0,
        "n_points_obtained": len(res),
        "frame": {
            "n_trusses": tp.n_trusses,
            "truss_x_m": [i * tp.truss_spacing_m for i in range(tp.n_trusses)],
        },
        "n_stations": len(stations),
        "step_deg": step,
        "spacing_10m_m": float(10 * np.radians(step)),
        "n_members": len(members),
        "members_by_role": _count_roles(members),
        "stations": stations.tolist(),
        "face_min_points": FACE_MIN_POINTS,
        "joints": joints,
    }
    return Simulation(
        family="roof",
        seed=seed,
        scene=scene,
        clouds={"cloud": res},
        transforms={"cloud": np.eye(4)},
        params=params,
        extras={"members": members, "joints": joints},
    )
