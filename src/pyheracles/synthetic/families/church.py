"""The ``church`` scene family: churches scanned inside and outside, each cloud in its own frame.

For registration (QC-2).  A draw builds a church (nave, optional aisles,
polygonal apse and tower; walls 0.4-1.2 m thick; round-headed, pointed and
rectangular windows, some mullioned, some leaded with small quarries held by
cames, the glass 1-4 cm thick recessed in deep, often splayed reveals; doors,
pews, altar, benches; uneven ground with gravestones outside), places sphere
targets (control and check points) and scans it twice:

* ``interior``: several TLS stations inside (a registered union), with a
  fine scan of each target a station sees;
* ``exterior``: photogrammetry (stereo pairs on a terrestrial ring and a
  higher ring, plus close-up views of each target; glass gives no match) or
  TLS stations around the building;
* in 60 % of the draws, window detail scans in both clouds (a finer region
  scan, or oblique close-up pairs of photographs, of each window).

Stations, rays and budgets: :mod:`~pyheracles.synthetic.families.church_survey`;
the building: :mod:`~pyheracles.synthetic.families.church_layout` (walls and
openings through :mod:`~pyheracles.synthetic.families.church_geometry`); the
site (furniture, ground, gravestones): :mod:`~pyheracles.synthetic.families.church_site`.

Glass (:data:`~pyheracles.synthetic.scene.GLASS`) returns few and weak TLS
points; most beams go through and return from what lies behind.

Each cloud is given in its OWN frame: ``sim.clouds[name].xyz`` are cloud
coordinates and ``sim.transforms[name]`` is the rigid ``T_scene_cloud``
(rotation about z only for a levelled cloud, small tilts too otherwise;
translation of up to several hundred metres).

Reference (``sim.scene.objects``): every wall, window light (outline on the
pane mid-plane in 3D, pane plane, glass thickness, sharp and bounding-box
corners), door, furniture item, target.  ``sim.extras``: ``control``,
``check`` (surveyed, scene frame), ``targets_measured`` (approximate centres
per cloud frame), ``targets_true`` (table), ``ties_manual`` (window corners
picked in each cloud), ``window_corners``, ``target_radius_m``,
``pane_thickness_m``, ``T_exterior_interior`` and ``write_extras(outdir)``,
which writes the CSV files of :mod:`~pyheracles.synthetic.families.church_targets`.

Named member: ``draw(seed, layout="thesis")`` is the case of thesis chapter 3
(Murtiyoso 2020) and of :func:`pyheracles.synthetic.church.make_church`: a
30 x 12 x 10 m rectangular shell, 0.6 m walls, 8 + 8 + 4 + 4 rectangular
windows with 2 cm panes at mid-wall, one interior station, photogrammetry
outside; the rest is drawn from ``seed``.

Examples
--------
>>> from pyheracles.synthetic.families import simulate
>>> sim = simulate("church", 3, n_interior_stations=2, exterior_kind="tls")  # doctest: +SKIP
>>> sorted(sim.clouds)  # doctest: +SKIP
['exterior', 'interior']
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pyheracles.errors import InputError
from pyheracles.synthetic.families.church_layout import build_church
from pyheracles.synthetic.families.church_site import add_gravestones
from pyheracles.synthetic.families.church_survey import (
    RAY_BUDGET_EXTERIOR,
    exterior_stations,
    interior_stations,
    photo_acquisitions,
    ring_points,
    sources_by_station,
    tls_acquisitions,
    tls_step,
    to_cloud_frame,
)
from pyheracles.synthetic.families.church_targets import (
    add_targets,
    choose_targets,
    manual_ties,
    survey_points,
    window_corner_table,
    write_target_files,
)
from pyheracles.synthetic.families.simulation import (
    Simulation,
    apply_overrides,
    check_noise_draw,
    scan_generator,
)
from pyheracles.synthetic.scanner import Outliers, RayCaster, scan

__all__ = ["RANGES", "THESIS", "ChurchFamilyParams", "draw", "draw_params"]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class ChurchFamilyParams:
    """Drawn parameters of a church (``None`` = drawn from the range in :data:`RANGES`).

    Attributes
    ----------
    layout
        ``"free"`` (everything drawn) or ``"thesis"`` (the named thesis case).
    nave_length_m, nave_width_m, nave_height_m
        Outer length and width of the nave, eaves height (15-45, 7-14, 6-16 m).
    wall_thickness_m
        0.4-1.2 m.
    roof_pitch_deg
        30-55 deg.
    aisles, aisle_width_m, aisle_height_m
        Side aisles (30 %), their outer width (2.5-5 m) and eaves height (3.5-6 m).
    apse, apse_facets, apse_ratio
        Polygonal apse (50 %) of 3, 5 or 7 facets, outer radius / half nave width (0.55-0.9).
    tower, tower_size_m
        ``"none"``, ``"west"`` or ``"south"``; square side 4-8 m.
    n_bays, n_gable_windows
        Bays along the nave (one window each; 3-10), windows per free gable (0-3).
    window_style, style_mix
        Main head shape (``rect``, ``round``, ``pointed``) and the share of windows
        of another shape (0-0.4).
    window_width_m, window_height_m, size_spread
        Typical window width (0.6-2 m) and height (1.5-5 m), relative spread (0.05-0.25).
    mullion_share
        Share of wide windows split into 2-3 lights by mullions (0-0.5).
    leaded_share, came_pattern, came_spacing_m
        Share of leaded lights (0-1), ``grid`` or ``diamond`` quarries, their size (0.1-0.3 m).
    pane_thickness_m
        Glass thickness, 1-4 cm.
    pane_depth_ratio
        Depth of the pane mid-plane from the outer face / wall thickness (0.15-0.85).
    splay_m
        Widening of the reveals towards the inside, each side (0, or 0.05-0.35 m).
    n_doors, open_door_share
        Doors (1-3) and the probability that one stands open (0-0.5).
    pews
        Pews in the nave (85 %).
    ground_relief_m, ground_slope, n_gravestones
        Mounds and hollows (0.05-0.8 m), site slope (0-0.08), gravestones (0-40).
    exterior_kind
        ``"photogrammetry"`` or ``"tls"``.
    n_interior_stations, n_exterior_stations, n_cameras
        Interior TLS stations (2-6), exterior TLS stations (4-10), photographs (30-70,
        in stereo pairs).
    interior_step_deg, exterior_step_deg
        TLS angular step (0.1-0.3 deg; coarsened to stay within :data:`RAY_BUDGET`).
    detail_scans, detail_spacing_m
        Window detail scans (60 %): a finer region scan (TLS) or a close-up stereo
        pair (photographs) of each window, at 8-25 mm (coarsened to the detail budget).
    camera_distance_m
        Distance of the terrestrial photographs from the walls (6-14 m).
    interior_levelled, exterior_levelled, max_tilt_deg
        Whether each cloud's frame is levelled (70 % / 50 %), largest tilt otherwise (0.2-2.5 deg).
    interior_frame, exterior_frame
        ``(tx, ty, tz, omega_deg, phi_deg, kappa_deg)`` of ``T_scene_cloud``
        (translation up to 600 m horizontally, 60 m vertically).
    target_radius_m
        Sphere radius: 0.05, 0.0725 or 0.1 m.
    n_interior_targets, n_exterior_targets
        Spheres inside (6-10) and outside (5-10).
    control_sigma_m, pick_sigma_m
        Survey sigma of the target centres (2-4 mm), manual tie pick sigma (5-15 mm).
    outlier_share
        Gross errors per cloud (0.001-0.01).
    noise_draw
        0 (default): the draw's own scan; k > 0: the same scene scanned again with
        the k-th other random numbers (detection, noise, mixed pixels, outliers), to
        check that a rule holds over the noise of a scene, not one draw of it.
    """

    layout: str | None = None
    nave_length_m: float | None = None
    nave_width_m: float | None = None
    nave_height_m: float | None = None
    wall_thickness_m: float | None = None
    roof_pitch_deg: float | None = None
    aisles: bool | None = None
    aisle_width_m: float | None = None
    aisle_height_m: float | None = None
    apse: bool | None = None
    apse_facets: int | None = None
    apse_ratio: float | None = None
    tower: str | None = None
    tower_size_m: float | None = None
    n_bays: int | None = None
    n_gable_windows: int | None = None
    window_style: str | None = None
    style_mix: float | None = None
    window_width_m: float | None = None
    window_height_m: float | None = None
    size_spread: float | None = None
    mullion_share: float | None = None
    leaded_share: float | None = None
    came_pattern: str | None = None
    came_spacing_m: float | None = None
    pane_thickness_m: float | None = None
    pane_depth_ratio: float | None = None
    splay_m: float | None = None
    n_doors: int | None = None
    open_door_share: float | None = None
    pews: bool | None = None
    ground_relief_m: float | None = None
    ground_slope: float | None = None
    n_gravestones: int | None = None
    exterior_kind: str | None = None
    n_interior_stations: int | None = None
    n_exterior_stations: int | None = None
    n_cameras: int | None = None
    interior_step_deg: float | None = None
    detail_scans: bool | None = None
    detail_spacing_m: float | None = None
    exterior_step_deg: float | None = None
    camera_distance_m: float | None = None
    interior_levelled: bool | None = None
    exterior_levelled: bool | None = None
    max_tilt_deg: float | None = None
    interior_frame: tuple[float, ...] | None = None
    exterior_frame: tuple[float, ...] | None = None
    target_radius_m: float | None = None
    n_interior_targets: int | None = None
    n_exterior_targets: int | None = None
    control_sigma_m: float | None = None
    pick_sigma_m: float | None = None
    outlier_share: float | None = None
    noise_draw: int = 0


#: Ranges drawn from: ``(low, high)`` uniform floats, ``("int", lo, hi)`` integers
#: (inclusive), ``("p", share)`` booleans, ``("choice", options, weights)``.
RANGES: dict[str, Any] = {
    "nave_length_m": (15.0, 45.0),
    "nave_width_m": (7.0, 14.0),
    "nave_height_m": (6.0, 16.0),
    "wall_thickness_m": (0.4, 1.2),
    "roof_pitch_deg": (30.0, 55.0),
    "aisles": ("p", 0.3),
    "aisle_width_m": (2.5, 5.0),
    "aisle_height_m": (3.5, 6.0),
    "apse": ("p", 0.5),
    "apse_facets": ("choice", (3, 5, 7), (0.3, 0.5, 0.2)),
    "apse_ratio": (0.55, 0.9),
    "tower": ("choice", ("none", "west", "south"), (0.4, 0.4, 0.2)),
    "tower_size_m": (4.0, 8.0),
    "n_bays": ("int", 3, 10),
    "n_gable_windows": ("int", 0, 3),
    "window_style": ("choice", ("rect", "round", "pointed"), (0.3, 0.35, 0.35)),
    "style_mix": (0.0, 0.4),
    "window_width_m": (0.6, 2.0),
    "window_height_m": (1.5, 5.0),
    "size_spread": (0.05, 0.25),
    "mullion_share": (0.0, 0.5),
    "leaded_share": (0.0, 1.0),
    "came_pattern": ("choice", ("grid", "diamond"), (0.5, 0.5)),
    "came_spacing_m": (0.1, 0.3),
    "pane_thickness_m": (0.01, 0.04),
    "pane_depth_ratio": (0.15, 0.85),
    "splay_m": (0.05, 0.35),
    "n_doors": ("int", 1, 3),
    "open_door_share": (0.0, 0.5),
    "pews": ("p", 0.85),
    "ground_relief_m": (0.05, 0.8),
    "ground_slope": (0.0, 0.08),
    "n_gravestones": ("int", 0, 40),
    "exterior_kind": ("choice", ("photogrammetry", "tls"), (0.5, 0.5)),
    "n_interior_stations": ("int", 2, 6),
    "n_exterior_stations": ("int", 4, 10),
    "n_cameras": ("int", 30, 70),
    "interior_step_deg": (0.1, 0.3),
    "detail_scans": ("p", 0.6),
    "detail_spacing_m": (0.008, 0.025),
    "exterior_step_deg": (0.1, 0.3),
    "camera_distance_m": (6.0, 14.0),
    "interior_levelled": ("p", 0.7),
    "exterior_levelled": ("p", 0.5),
    "max_tilt_deg": (0.2, 2.5),
    "target_radius_m": ("choice", (0.05, 0.0725, 0.1), (0.25, 0.5, 0.25)),
    "n_interior_targets": ("int", 6, 10),
    "n_exterior_targets": ("int", 5, 10),
    "control_sigma_m": (0.002, 0.004),
    "pick_sigma_m": (0.005, 0.015),
    "outlier_share": (0.001, 0.01),
}

#: The thesis case (chapter 3): fixed fields of ``layout="thesis"``.
THESIS: dict[str, Any] = {
    "nave_length_m": 30.0,
    "nave_width_m": 12.0,
    "nave_height_m": 10.0,
    "wall_thickness_m": 0.6,
    "aisles": False,
    "apse": False,
    "tower": "none",
    "n_bays": 8,
    "n_gable_windows": 4,
    "window_style": "rect",
    "style_mix": 0.0,
    "window_width_m": 1.3,
    "window_height_m": 2.7,
    "size_spread": 0.3,
    "mullion_share": 0.0,
    "leaded_share": 0.0,
    "pane_thickness_m": 0.02,
    "pane_depth_ratio": 0.5,
    "splay_m": 0.0,
    "n_doors": 1,
    "open_door_share": 0.0,
    "pews": False,
    "ground_relief_m": 0.05,
    "ground_slope": 0.0,
    "n_gravestones": 0,
    "exterior_kind": "photogrammetry",
    "n_interior_stations": 1,
    "target_radius_m": 0.0725,
    "n_interior_targets": 11,
    "n_exterior_targets": 15,
}

_CHOICES = {k: v[1] for k, v in RANGES.items() if isinstance(v[0], str) and v[0] == "choice"}
_CHOICES["layout"] = ("free", "thesis")


def _draw_value(rng: np.random.Generator, spec: Any) -> Any:
    kind = spec[0]
    if kind == "p":
        return bool(rng.random() < spec[1])
    if kind == "int":
        return int(rng.integers(spec[1], spec[2] + 1))
    if kind == "choice":
        opts, w = spec[1], np.asarray(spec[2], float)
        return opts[int(rng.choice(len(opts), p=w / w.sum()))]
    return float(rng.uniform(spec[0], spec[1]))


def _frame(rng: np.random.Generator, levelled: bool, max_tilt: float) -> tuple[float, ...]:
    """``(tx, ty, tz, omega, phi, kappa)`` of a random rigid frame (degrees)."""
    t = rng.uniform([-600.0, -600.0, -60.0], [600.0, 600.0, 60.0])
    tilt = (0.0, 0.0) if levelled else tuple(rng.uniform(-max_tilt, max_tilt, 2))
    return (*map(float, t), float(tilt[0]), float(tilt[1]), float(rng.uniform(0.0, 360.0)))


def draw_params(seed: int, **overrides: Any) -> ChurchFamilyParams:
    """The parameters of draw ``seed`` (every field drawn, then ``overrides`` applied).

    Every field is drawn whether fixed or not, so that fixing one leaves the others.

    Raises
    ------
    InputError
        An unknown parameter or an impossible value.
    """
    fixed = apply_overrides(ChurchFamilyParams(), overrides, "church")
    check_noise_draw(fixed.noise_draw, "church")
    for k, allowed in _CHOICES.items():
        v = getattr(fixed, k)
        if v is not None and v not in allowed:
            raise InputError(
                f"church parameter {k}={v!r} is not one of {', '.join(map(str, allowed))}"
            )
    rng = np.random.default_rng(seed)
    drawn: dict[str, Any] = {"layout": "free"}
    for name, spec in RANGES.items():
        drawn[name] = _draw_value(rng, spec)
    if rng.random() < 0.4:
        drawn["splay_m"] = 0.0
    frames = {}
    for side in ("interior", "exterior"):
        lev = overrides.get(f"{side}_levelled", drawn[f"{side}_levelled"])
        tilt = overrides.get("max_tilt_deg", drawn["max_tilt_deg"])
        frames[f"{side}_frame"] = _frame(rng, bool(lev), float(tilt))
    drawn.update(frames)
    if (fixed.layout or "free") == "thesis":
        drawn.update(THESIS)
        drawn["layout"] = "thesis"
    values = {f.name: getattr(fixed, f.name) for f in fields(fixed)}
    merged = {k: (drawn[k] if v is None else v) for k, v in values.items()}
    for k in ("interior_frame", "exterior_frame"):
        try:
            merged[k] = tuple(float(x) for x in merged[k])
        except (TypeError, ValueError):
            merged[k] = ()
        if len(merged[k]) != 6:
            raise InputError(
                f"church parameter {k} needs 6 numbers (tx, ty, tz, omega, phi, kappa)"
            )
    p = ChurchFamilyParams(**merged)
    _check(p)
    return p


def _check(p: ChurchFamilyParams) -> None:
    positive = (
        "nave_length_m",
        "nave_width_m",
        "nave_height_m",
        "wall_thickness_m",
        "window_width_m",
        "window_height_m",
        "pane_thickness_m",
        "target_radius_m",
        "interior_step_deg",
        "exterior_step_deg",
    )
    for k in positive:
        if not getattr(p, k) > 0:
            raise InputError(f"church parameter {k} must be positive, got {getattr(p, k)}")
    if p.nave_width_m < 4.0 or p.nave_length_m < 8.0:
        raise InputError("a church nave needs at least 8 m x 4 m")
    if not 0.05 < p.pane_depth_ratio < 0.95:
        raise InputError(f"pane_depth_ratio must be in (0.05, 0.95), got {p.pane_depth_ratio}")
    if p.n_interior_stations < 1 or p.n_bays < 1:
        raise InputError("n_interior_stations and n_bays must be at least 1")


# ----------------------------------------------------------------------------- draw
def draw(seed: int, **overrides: Any) -> Simulation:
    """Draw church ``seed``: build, place stations and targets, scan inside and outside.

    Parameters
    ----------
    seed
        Draw number (deterministic).
    **overrides
        Fields of :class:`ChurchFamilyParams` to fix.

    Raises
    ------
    InputError
        An unknown parameter or an impossible value.
    """
    p = draw_params(seed, **overrides)
    rng = np.random.default_rng([seed, 1])
    plan, ids = build_church(p, rng)
    scene = plan.scene
    # stations and views, gravestones clear of them, targets where they are seen
    st_in = interior_stations(p, plan, rng)
    if p.exterior_kind == "tls":
        st_ex = exterior_stations(p, plan, rng)
        views_ex = st_ex
    else:
        st_ex = np.empty((0, 3))
        ring_xy = ring_points(plan, p.camera_distance_m, p.n_cameras, rng)
        views_ex = np.column_stack([ring_xy, plan.terrain.height(ring_xy) + 1.6])
    add_gravestones(scene, plan, rng, p.n_gravestones, np.vstack([st_in, views_ex]), ids)
    need = 1 if p.exterior_kind == "tls" else 2
    chosen = choose_targets(
        plan,
        rng,
        p.target_radius_m,
        p.n_interior_targets,
        p.n_exterior_targets,
        st_in,
        views_ex,
        need,
    )
    targets = add_targets(scene, plan, chosen, p.target_radius_m, rng, ids)
    # acquisitions: main scans, target fine scans, window detail scans
    detail = p.detail_spacing_m if p.detail_scans else None
    caster = RayCaster(scene)
    step_in = tls_step(p.interior_step_deg, len(st_in), 150.0)
    acq_in, owner_in = tls_acquisitions(
        st_in, step_in, (-60.0, 90.0), targets.centre, p.target_radius_m, plan, detail, caster
    )
    step_ex = None
    if p.exterior_kind == "tls":
        step_ex = tls_step(p.exterior_step_deg, len(st_ex), 135.0, RAY_BUDGET_EXTERIOR)
        acq_ex, owner_ex = tls_acquisitions(
            st_ex, step_ex, (-60.0, 75.0), targets.centre, p.target_radius_m, plan, detail, caster
        )
    else:
        outside = targets.centre[np.array([s == "exterior" for s in targets.side], bool)]
        acq_ex = photo_acquisitions(p, plan, rng, outside, detail, caster)
        owner_ex = list(range(1, len(acq_ex) + 1))
    del caster
    clouds_scene = {}
    g_scan = scan_generator(seed, p.noise_draw, rng, "church")
    for name, acq, owner in (("interior", acq_in, owner_in), ("exterior", acq_ex, owner_ex)):
        res = scan(scene, acq, outliers=Outliers(share=p.outlier_share), rng=g_scan)
        clouds_scene[name] = sources_by_station(res, owner)
    clouds, transforms = {}, {}
    for name, res in clouds_scene.items():
        clouds[name], transforms[name] = to_cloud_frame(res, getattr(p, f"{name}_frame"))
    # reference points
    srng = np.random.default_rng([seed, 2])
    pts = survey_points(targets, clouds_scene, transforms, p.control_sigma_m, srng)
    corners = window_corner_table(scene.objects)
    ties = manual_ties(
        corners, scene.class_names, scene.part_names, clouds_scene, transforms, p.pick_sigma_m, srng
    )
    T_ei = np.linalg.inv(transforms["exterior"]) @ transforms["interior"]
    extras: dict[str, Any] = {
        "control": pts["control"],
        "check": pts["check"],
        "targets_measured": pts["picks"],
        "targets_true": pts["table"],
        "ties_manual": ties,
        "window_corners": corners,
        "target_radius_m": p.target_radius_m,
        "pane_thickness_m": p.pane_thickness_m,
        "T_exterior_interior": T_ei,
        "stations": {"interior": st_in.tolist(), "exterior": st_ex.tolist()},
    }
    extras["write_extras"] = lambda outdir: write_target_files(extras, outdir)
    params = asdict(p)
    params.update(
        interior_step_effective_deg=step_in,
        exterior_step_effective_deg=step_ex,
        heights_m=plan.heights,
        counts=plan.counts,
        n_targets={
            "interior": int(sum(s == "interior" for s in targets.side)),
            "exterior": int(sum(s == "exterior" for s in targets.side)),
        },
    )
    return Simulation(
        family="church",
        seed=seed,
        scene=scene,
        clouds=clouds,
        transforms=transforms,
        params=params,
        extras=extras,
    )
