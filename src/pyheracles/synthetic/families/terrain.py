"""The ``terrain`` scene family: hard ground for ground filters, seen from the air.

Each draw builds a square of terrain 150-400 m wide as a heightfield with a wide range of
landforms (:mod:`~pyheracles.synthetic.families.terrain_relief`): flat ground to slopes
of 45 deg, sharp crests and ridges, terraces and embankments with 1-4 m steps, raised flat
platforms, a river cut with its water and bridges over it; and on it
(:mod:`~pyheracles.synthetic.families.terrain_objects`) dense vegetation, preferably on
the slopes (porous tree crowns giving several returns, with dense cores no pulse passes;
low shrubs of 0.5-2 m), buildings up to 60 m long, free-standing walls and cars.  An
airborne survey of 2-4 overlapping strips (0.1-20 pulses/m^2 over the area) scans it
(:mod:`~pyheracles.synthetic.families.terrain_scan`); gross errors are added: the
scanner's isolated points and clusters, clusters of points several metres under the
terrain (multipath) and isolated points just under it.  The cloud is in the scene frame
(metres, the square's lower-left corner at the origin); the simulation carries a UTM CRS
and the offset of that corner (easting, northing, elevation).

Reference (ISPRS filter test convention, bare earth): class ``ground`` for the terrain,
ground under vegetation and bridges included (instance 0); every other surface is an
object: ``vegetation`` (trees: crown, leaves, core, trunk), ``low_vegetation``
(shrubs), ``building``, ``wall``, ``car``, ``bridge`` (deck, parapets, piers) and
``water`` (the river's surface; the benchmark leaves it out of the score, like AHN3's
class 9).  Platforms, terraces and embankments are earth: ground.  Outliers have
``outlier`` True, instance and class 0; their parts are ``outlier_isolated``,
``outlier_cluster`` (the scanner's), ``outlier_low_cluster`` and ``outlier_low``.

Besides the scene, ``sim.extras["terrain"]`` holds the true relief (grid ``x``, ``y``,
``z``, scene frame), its bit flags per vertex (``tags``, names in ``tag_names``:
steep, crest, breakline, platform, river_bank, terrace, embankment, vegetated) and the low outlier
clusters; ``write_simulation`` writes them to ``dem_truth.npz``.

Examples
--------
>>> from pyheracles.synthetic.families import simulate
>>> sim = simulate("terrain", 0, side_m=150.0, density_per_m2=0.5)  # doctest: +SKIP
>>> sim.params["n_strips"] in (2, 3, 4)  # doctest: +SKIP
True
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

import numpy as np

from pyheracles.errors import InputError
from pyheracles.synthetic.families.simulation import Simulation, apply_overrides
from pyheracles.synthetic.families.terrain_objects import (
    Occupancy,
    add_bridges,
    add_buildings,
    add_cars,
    add_shrubs,
    add_trees,
    add_walls,
    add_water,
    vegetation_mask,
)
from pyheracles.synthetic.families.terrain_relief import (
    TAGS,
    Relief,
    add_embankment,
    add_platform,
    add_ridge,
    add_terraces,
    band_limited_hills,
    carve_river,
    heightfield_triangles,
    mark_discs,
    terrain_tags,
)
from pyheracles.synthetic.families.terrain_scan import add_low_outliers, crop, survey_plan
from pyheracles.synthetic.scanner import Outliers, scan
from pyheracles.synthetic.scene import GROUND, Material, Scene

__all__ = [
    "MAX_PULSES",
    "RANGES",
    "TerrainFamilyParams",
    "build_relief",
    "build_scene",
    "draw",
    "resolve_params",
]

#: Pulses a draw aims at, at most: a drawn side shrinks so that density x area stays under.
MAX_PULSES = 1_200_000

#: Drawn range of every numeric field (min, max); counts are whole numbers.  Terraces and
#: the river are absent from part of the draws (``terrace_step_m`` / ``river_depth_m`` 0).
RANGES: dict[str, tuple[float, float]] = {
    "side_m": (150.0, 400.0),
    "density_per_m2": (0.1, 20.0),
    "n_strips": (2, 4),
    "overlap": (0.2, 0.5),
    "half_fov_deg": (15.0, 30.0),
    "heading_deg": (0.0, 180.0),
    "speed_mps": (40.0, 70.0),
    "noise_m": (0.02, 0.08),
    "regional_slope_deg": (0.0, 15.0),
    "max_slope_deg": (0.0, 45.0),
    "hill_wavelength_m": (40.0, 200.0),
    "n_ridges": (0, 2),
    "ridge_height_m": (3.0, 20.0),
    "ridge_flank_deg": (15.0, 45.0),
    "terrace_step_m": (1.0, 4.0),
    "n_embankments": (0, 2),
    "embankment_height_m": (1.0, 4.0),
    "n_platforms": (0, 3),
    "platform_height_m": (1.0, 3.0),
    "river_depth_m": (2.0, 6.0),
    "river_width_m": (6.0, 25.0),
    "water_reflectance": (0.001, 0.02),
    "n_bridges": (0, 2),
    "tree_cover": (0.0, 0.5),
    "shrub_cover": (0.0, 0.3),
    "canopy_core": (0.0, 0.6),
    "n_buildings": (0, 12),
    "building_max_size_m": (10.0, 60.0),
    "n_walls": (0, 8),
    "n_cars": (0, 30),
    "outlier_share": (0.001, 0.01),
    "n_low_clusters": (0, 2),
    "low_cluster_depth_m": (2.0, 8.0),
    "low_outlier_share": (0.0, 0.002),
    "utm_zone": (29, 37),
    "easting_m": (300_000.0, 700_000.0),
    "northing_m": (4_000_000.0, 6_200_000.0),
    "elevation_m": (0.0, 1500.0),
}

_LOG_UNIFORM = {"density_per_m2"}


@dataclass(frozen=True)
class TerrainFamilyParams:
    """Drawn quantities of a ``terrain`` draw (None = drawn from :data:`RANGES`).

    Parameters
    ----------
    side_m
        Side of the square area, metres (150-400; shrunk so that ``density_per_m2 *
        side_m**2 <= MAX_PULSES`` when drawn).
    density_per_m2
        Pulses per m^2 over the area, all strips together (0.1-20, log-uniform).
    n_strips, overlap, half_fov_deg, heading_deg, speed_mps, noise_m
        Flight plan: 2-4 strips, side overlap 0.2-0.5, half scan angle 15-30 deg,
        heading 0-180 deg from x, ground speed 40-70 m/s, range noise 2-8 cm.
    regional_slope_deg
        Slope of the regional plane, 0-15 deg.
    max_slope_deg
        Steepest slope of the hills (99.5th percentile), 0-45 deg.
    hill_wavelength_m
        Shortest wavelength of the hills, 40-200 m.
    n_ridges, ridge_height_m, ridge_flank_deg
        Sharp-crested ridges: 0-2, 3-20 m high, flanks 15-45 deg.
    terrace_step_m
        Step of the terraces over half the area, 1-4 m; 0 = no terraces (half the draws).
    n_embankments, embankment_height_m
        Dikes / road banks: 0-2, 1-4 m high.
    n_platforms, platform_height_m
        Raised flat pads: 0-3, 1-3 m above the terrain under them.
    river_depth_m, river_width_m, water_reflectance
        River cut (in 60 % of the draws; depth 0 = none): 2-6 m deep, floor 6-25 m
        wide; water reflectance 0.001-0.02 (few returns).
    n_bridges
        Bridges over the river, 0-2.
    tree_cover, shrub_cover, canopy_core
        Share of the area under tree crowns (0-0.5) and shrubs (0-0.3), both more likely
        on slopes; opaque core of the crowns as a share of their radii (0-0.6).
    n_buildings, building_max_size_m
        Buildings (0-12, tried; fewer when no free spot); length of the first, 10-60 m.
    n_walls, n_cars
        Free-standing walls (0-8) and cars (0-30).
    outlier_share
        The scanner's gross errors (isolated high and low points, clusters), 0.1-1 %.
    n_low_clusters, low_cluster_depth_m
        Clusters of points under the terrain (multipath), 0-2, 2-8 m down.
    low_outlier_share
        Isolated points 0.3-10 m under the local terrain, share of the points, 0-0.2 %.
    utm_zone, easting_m, northing_m, elevation_m
        CRS (WGS 84 / UTM north ``utm_zone``) and the offset of the area's lower-left
        corner (and of z = 0: the terrain's mean height).
    """

    side_m: float | None = None
    density_per_m2: float | None = None
    n_strips: int | None = None
    overlap: float | None = None
    half_fov_deg: float | None = None
    heading_deg: float | None = None
    speed_mps: float | None = None
    noise_m: float | None = None
    regional_slope_deg: float | None = None
    max_slope_deg: float | None = None
    hill_wavelength_m: float | None = None
    n_ridges: int | None = None
    ridge_height_m: float | None = None
    ridge_flank_deg: float | None = None
    terrace_step_m: float | None = None
    n_embankments: int | None = None
    embankment_height_m: float | None = None
    n_platforms: int | None = None
    platform_height_m: float | None = None
    river_depth_m: float | None = None
    river_width_m: float | None = None
    water_reflectance: float | None = None
    n_bridges: int | None = None
    tree_cover: float | None = None
    shrub_cover: float | None = None
    canopy_core: float | None = None
    n_buildings: int | None = None
    building_max_size_m: float | None = None
    n_walls: int | None = None
    n_cars: int | None = None
    outlier_share: float | None = None
    n_low_clusters: int | None = None
    low_cluster_depth_m: float | None = None
    low_outlier_share: float | None = None
    utm_zone: int | None = None
    easting_m: float | None = None
    northing_m: float | None = None
    elevation_m: float | None = None


_INT_FIELDS = {f.name for f in fields(TerrainFamilyParams) if f.name.startswith("n_")} | {
    "utm_zone"
}


def _draw_all(rng: np.random.Generator) -> dict[str, Any]:
    """One value per field, always drawn in the same order (overrides do not shift others)."""
    out: dict[str, Any] = {}
    for f in fields(TerrainFamilyParams):
        lo, hi = RANGES[f.name]
        if f.name in _INT_FIELDS:
            out[f.name] = int(rng.integers(int(lo), int(hi) + 1))
        elif f.name in _LOG_UNIFORM:
            out[f.name] = float(np.exp(rng.uniform(np.log(lo), np.log(hi))))
        else:
            out[f.name] = float(rng.uniform(lo, hi))
    # landforms present in only part of the draws
    if rng.random() < 0.5:
        out["terrace_step_m"] = 0.0
    else:
        out["terrace_step_m"] = float(rng.uniform(*RANGES["terrace_step_m"]))
    if rng.random() >= 0.6:
        out["river_depth_m"] = 0.0
        out["n_bridges"] = 0
    out["easting_m"] = round(out["easting_m"], 2)
    out["northing_m"] = round(out["northing_m"], 2)
    out["elevation_m"] = round(out["elevation_m"], 2)
    return out


def resolve_params(seed: int, overrides: dict[str, Any]) -> dict[str, Any]:
    """Every parameter of draw ``seed``: the drawn values with ``overrides`` over them.

    Raises
    ------
    InputError
        An unknown parameter or a value outside what the family can build.
    """
    given = apply_overrides(TerrainFamilyParams(), overrides, "terrain")
    p = _draw_all(np.random.default_rng([seed, 11]))
    for f in fields(given):
        v = getattr(given, f.name)
        if v is not None:
            p[f.name] = v
    _validate(p)
    if "side_m" not in overrides and p["density_per_m2"] * p["side_m"] ** 2 > MAX_PULSES:
        p["side_m"] = float(max(RANGES["side_m"][0], np.sqrt(MAX_PULSES / p["density_per_m2"])))
    if p["river_depth_m"] <= 0:
        p["n_bridges"] = 0
    return p


def _validate(p: dict[str, Any]) -> None:
    """Refuse override values outside what the family can build."""
    for name, v in p.items():
        if isinstance(v, bool) or not isinstance(v, int | float) or not np.isfinite(v):
            raise InputError(f"terrain parameter {name} must be a number, got {v!r}")
        if name in _INT_FIELDS and int(v) != v:
            raise InputError(f"terrain parameter {name} must be a whole number, got {v!r}")
    checks = {
        "side_m": (20.0, 2000.0),
        "density_per_m2": (0.01, 100.0),
        "n_strips": (1, 10),
        "overlap": (0.0, 0.85),
        "half_fov_deg": (1.0, 40.0),
        "noise_m": (0.0, 1.0),
        "max_slope_deg": (0.0, 60.0),
        "regional_slope_deg": (0.0, 30.0),
        "hill_wavelength_m": (5.0, 2000.0),
        "tree_cover": (0.0, 0.9),
        "shrub_cover": (0.0, 0.9),
        "canopy_core": (0.0, 0.95),
        "outlier_share": (0.0, 0.2),
        "low_outlier_share": (0.0, 0.2),
        "water_reflectance": (0.0, 1.0),
        "building_max_size_m": (5.0, 150.0),
        "terrace_step_m": (0.0, 10.0),
        "river_depth_m": (0.0, 20.0),
        "river_width_m": (1.0, 100.0),
        "speed_mps": (1.0, 200.0),
        "utm_zone": (1, 60),
    }
    for name, (lo, hi) in checks.items():
        if not (lo <= p[name] <= hi):
            raise InputError(f"terrain parameter {name}={p[name]!r} outside [{lo:g}, {hi:g}]")
    for name in _INT_FIELDS:
        if p[name] < 0:
            raise InputError(f"terrain parameter {name} must be >= 0, got {p[name]!r}")
    if p["n_strips"] * (1 - p["overlap"]) <= 0.2:
        raise InputError("n_strips * (1 - overlap) must exceed 0.2 to cover the area")


def build_relief(
    p: dict[str, Any], rng: np.random.Generator, margin_m: float
) -> tuple[Relief, dict[str, Any]]:
    """The heightfield over ``[-margin, side + margin]^2`` and its landform records."""
    side = p["side_m"]
    # fine cells where the points are dense enough to show them (and the area is small)
    cell = 0.5 if p["density_per_m2"] >= 4 and side <= 300 else 1.0
    x = np.arange(-margin_m, side + margin_m + cell / 2, cell)
    X, Y = np.meshgrid(x, x)
    a = rng.uniform(0, 2 * np.pi)
    z = np.tan(np.deg2rad(p["regional_slope_deg"])) * (np.cos(a) * X + np.sin(a) * Y)
    hill_tan = max(
        0.0, np.tan(np.deg2rad(p["max_slope_deg"])) - np.tan(np.deg2rad(p["regional_slope_deg"]))
    )
    z = z + band_limited_hills(X.shape, cell, p["hill_wavelength_m"], hill_tan, rng)
    marks: dict[str, np.ndarray] = {}
    rec: dict[str, Any] = {"ridges": [], "embankments": [], "platforms": []}
    for _ in range(p["n_ridges"]):
        c0 = rng.uniform(0.2, 0.8, 2) * side
        d = rng.uniform(0, np.pi)
        length = rng.uniform(0.4, 1.2) * side
        z = add_ridge(
            z,
            X,
            Y,
            c0,
            d,
            p["ridge_height_m"] * rng.uniform(0.6, 1.0),
            p["ridge_flank_deg"],
            length,
        )
        rec["ridges"].append(
            {"point": c0.tolist(), "direction_deg": float(np.rad2deg(d)), "length_m": float(length)}
        )
    if p["terrace_step_m"] > 0:
        c0 = rng.uniform(0.3, 0.7, 2) * side
        z, marks["terrace"] = add_terraces(
            z, X, Y, cell, c0, rng.uniform(0, 2 * np.pi), p["terrace_step_m"], rng.uniform(55, 80)
        )
    for _ in range(p["n_embankments"]):
        c0 = rng.uniform(0.15, 0.85, 2) * side
        d = rng.uniform(0, np.pi)
        z, m = add_embankment(
            z, X, Y, c0, d, p["embankment_height_m"], rng.uniform(4, 12), rng.uniform(30, 60)
        )
        marks["embankment"] = marks.get("embankment", np.zeros(z.shape, bool)) | m
        rec["embankments"].append({"point": c0.tolist(), "direction_deg": float(np.rad2deg(d))})
    for _ in range(p["n_platforms"]):
        c0 = rng.uniform(0.15, 0.85, 2) * side
        size = (float(rng.uniform(10, 40)), float(rng.uniform(10, 40)))
        z, top, top_z = add_platform(
            z, X, Y, c0, size, rng.uniform(0, np.pi), p["platform_height_m"], rng.uniform(35, 70)
        )
        marks["platform"] = marks.get("platform", np.zeros(z.shape, bool)) | top
        rec["platforms"].append({"center": c0.tolist(), "size_m": list(size), "top_z": top_z})
    river = None
    if p["river_depth_m"] > 0:
        z, river = carve_river(
            z,
            X,
            Y,
            rng,
            width_m=p["river_width_m"],
            depth_m=p["river_depth_m"],
            bank_deg=rng.uniform(25, 60),
            water_depth_m=rng.uniform(0.3, 1.5),
            meander_m=rng.uniform(0, 30),
            direction_rad=rng.uniform(0, np.pi),
        )
    mean = float(z.mean())
    z = z - mean
    if river is not None:
        river.water_z = river.water_z - mean
        river.floor_z = river.floor_z - mean
    relief = Relief(x, x.copy(), z, river=river)
    relief.tags = terrain_tags(relief, marks)
    return relief, rec


def _water_material(reflectance: float) -> Material:
    return Material("water", reflectance, matchable=False)


def build_scene(
    p: dict[str, Any], rng: np.random.Generator, margin_m: float
) -> tuple[Scene, Relief, dict[str, Any]]:
    """The relief and everything on it."""
    relief, rec = build_relief(p, rng, margin_m)
    scene = Scene()
    scene.class_code("ground")
    side = p["side_m"]
    occ = Occupancy(relief, np.zeros(relief.z.shape, bool), 2.0, side - 2.0)
    objects: list[dict[str, Any]] = []

    def nxt() -> int:
        return 1 + max((o["instance"] for o in objects), default=0)

    objects += add_bridges(scene, relief, occ, rng, p["n_bridges"], nxt())
    water_cells, water_obj = add_water(
        scene, relief, nxt(), _water_material(p["water_reflectance"])
    )
    objects += water_obj
    if relief.river is not None:
        occ.taken |= np.isfinite(relief.river.water_z)
    scene.add_triangles(
        heightfield_triangles(relief.x, relief.y, relief.z, ~water_cells),
        instance=0,
        class_name="ground",
        part="terrain",
        material=GROUND,
    )
    objects += add_buildings(
        scene, relief, occ, rng, p["n_buildings"], p["building_max_size_m"], nxt()
    )
    objects += add_walls(scene, relief, occ, rng, p["n_walls"], nxt())
    objects += add_cars(scene, relief, occ, rng, p["n_cars"], nxt())
    trees = vegetation_mask(relief, rng, p["tree_cover"], slope_bias=1.5)
    shrubs = vegetation_mask(relief, rng, p["shrub_cover"], slope_bias=1.0)
    objects += add_trees(
        scene,
        relief,
        occ,
        rng,
        trees,
        p["canopy_core"],
        nxt(),
        segments=14 if p["density_per_m2"] >= 2 else 10,
    )
    objects += add_shrubs(scene, relief, occ, rng, shrubs, nxt())
    scene.objects.extend(objects)
    veg = [o for o in objects if o["class"] in ("vegetation", "low_vegetation")]
    if veg:
        centres = np.array(
            [o["crown"]["center"][:2] if "crown" in o else o["dome"]["base"][:2] for o in veg]
        )
        radii = np.array(
            [o["crown"]["radii"][0] if "crown" in o else o["dome"]["radius_m"] for o in veg]
        )
        relief.tags[mark_discs(relief, centres, radii)] |= TAGS["vegetated"]
    return scene, relief, rec


def draw(seed: int, **overrides: Any) -> Simulation:
    """Draw member ``seed`` of the ``terrain`` family and scan it from the air.

    Parameters
    ----------
    seed
        Draw number (>= 0); the same seed gives the same points.
    **overrides
        Fix fields of :class:`TerrainFamilyParams` (e.g. ``side_m=150``,
        ``density_per_m2=1``, ``river_depth_m=0``).

    Returns
    -------
    Simulation
        One cloud ``"cloud"`` in the scene frame; ``params`` has every drawn value plus
        what was measured on the scan (``measured_density_per_m2``, ``n_points``,
        ``ground_share``, ``outlier_share_measured``).

    Raises
    ------
    InputError
        An unknown parameter or a value outside what the family can build.
    """
    p = resolve_params(seed, dict(overrides))
    rng = np.random.default_rng([seed, 17])
    margin = float(min(40.0, 4.0 + 0.5 * 40.0 * np.tan(np.deg2rad(p["half_fov_deg"]))))
    scene, relief, rec = build_scene(p, rng, margin)
    side = p["side_m"]
    sv = survey_plan(
        side,
        p["density_per_m2"],
        p["n_strips"],
        p["overlap"],
        p["half_fov_deg"],
        p["heading_deg"],
        p["speed_mps"],
        p["noise_m"],
        0.0,
    )
    res = scan(
        scene,
        sv,
        outliers=Outliers(
            share=p["outlier_share"], isolated=0.6, clusters=0.4, reflections=0.0, below_m=3.0
        ),
        rng=np.random.default_rng([seed, 23]),
    )
    res = crop(res, side)
    res, clusters = add_low_outliers(
        res,
        scene,
        relief,
        rng,
        side_m=side,
        n_clusters=p["n_low_clusters"],
        cluster_depth_m=p["low_cluster_depth_m"],
        isolated_share=p["low_outlier_share"],
    )
    g = res.class_id == scene.class_code("ground")
    params = {
        **p,
        "n_points": len(res),
        "measured_density_per_m2": round(len(res) / side**2, 4),
        "measured_pulse_density_per_m2": round(float((res.return_number == 1).sum()) / side**2, 4),
        "ground_share": round(float(g.mean()) if len(res) else 0.0, 4),
        "outlier_share_measured": round(float(res.outlier.mean()) if len(res) else 0.0, 5),
        "n_objects": {
            c: sum(o["class"] == c for o in scene.objects)
            for c in sorted({o["class"] for o in scene.objects})
        },
        "relief_range_m": round(float(np.ptp(relief.z)), 2),
        "landforms": rec,
        "low_clusters": clusters,
        "survey": {
            "altitude_m": sv.altitude_m,
            "strip_density_per_m2": sv.density_per_m2,
            "scan_rate_hz": sv.scan_rate_hz,
        },
    }
    terrain = {
        "x": relief.x,
        "y": relief.y,
        "z": relief.z,
        "tags": relief.tags,
        "tag_names": dict(TAGS),
        "low_clusters": clusters,
    }

    def write_extras(outdir: str | Path) -> dict[str, Path]:
        from pyheracles.io.atomic import atomic_path

        path = Path(outdir) / "dem_truth.npz"
        with atomic_path(path) as tmp, open(tmp, "wb") as fh:
            np.savez_compressed(
                fh,
                x=relief.x,
                y=relief.y,
                z=relief.z,
                tags=relief.tags,
                tag_names=np.array(list(TAGS)),
                tag_bits=np.array(list(TAGS.values())),
            )
        return {"dem_truth": path}

    return Simulation(
        family="terrain",
        seed=seed,
        scene=scene,
        clouds={"cloud": res},
        transforms={"cloud": np.eye(4)},
        params=params,
        extras={"terrain": terrain, "write_extras": write_extras},
        crs=f"EPSG:{32600 + int(p['utm_zone'])}",
        offset=(p["easting_m"], p["northing_m"], p["elevation_m"]),
    )
