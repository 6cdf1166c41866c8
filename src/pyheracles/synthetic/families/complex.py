"""The ``complex`` family: walled heritage complexes seen from the air, with their GIS layers.

Step 1 (complex -> buildings) and the ground filters are measured on it.  A
draw is a walled complex on a survey tile of 90-220 m a side: a perimeter
wall cut by gates, internal walls with their gates (split gates whose two
towers flank an opening, roofed gates; walls abut the gates), closed
buildings (hipped, gabled, flat with parapet, two-tier *joglo* roofs, eaves;
1-3 storeys; L-shaped wings, courtyard buildings with a hole, rows of units
sharing party walls) and open pavilions (columns on a platform), each on a
plinth or a raised platform of 0.3-1.5 m; trees whose crowns overhang roofs
and walls (porous foliage: several returns per pulse), clutter (benches,
lamps, planters, cars, unmapped sheds and kiosks); sloping, hilly and
terraced ground.  It is scanned by an airborne LiDAR survey
(:class:`~pyheracles.synthetic.scanner.AirborneSurvey`): 2-4 overlapping
strips at a random heading, 0.1-20 points per m^2, plus gross outliers.

The GIS layers ``building``, ``wall`` and ``gate`` are digitised from the
true footprints (plan outline of roofs, platforms, wall runs, gate towers)
with a drawing error of 0-0.5 m; they carry attributes, among them the
64-bit integer ``object_id``, and are in a projected CRS (RD New, UTM 31N,
UTM 49S or Lambert-93) with a large offset (``sim.crs``, ``sim.offset``:
world = local + offset).  A few buildings of the GIS are demolished (no
points), a few stick out of the survey tile.

Reference (``truth.npz`` / the scan's labels): ``instance`` = the GIS
feature (buildings, then walls, then gates, from 1, in layer order),
``class_id`` = the scene's class code (``ground`` for the terrain, ``tree``
and ``clutter`` with instance 0), ``outlier`` for gross errors.

``extras``: ``layers`` (name -> GeoDataFrame, world coordinates),
``reference_objects`` (instance, layer, fid, feature_index, name, object_id,
n_points), ``extent`` (the survey tile, world), ``survey`` (derived flight
figures) and ``write_extras(outdir)``, which writes ``layers.gpkg`` (one
GeoPackage, one layer per class: ``building``, ``wall``, ``gate``; read with
``read_layer(path, "building")`` or ``--layer building=layers.gpkg:building``)
and ``reference_objects.csv``.

Named members
-------------
``draw(seed, layout="kasepuhan")`` is the demo complex of ``heracles demo``
(:func:`pyheracles.synthetic.complex_scene.kasepuhan_scene`; Murtiyoso 2020,
chapter 5), scanned through the same airborne simulator; the seed drives
its random parts (trees, clutter, digitising, the scan) and ``n_points``
its density.  ``heracles demo --seed 0`` is ``draw(0, layout="kasepuhan",
n_points=400000)``.

Examples
--------
>>> sim = draw(3, width_m=90.0, depth_m=90.0, density_per_m2=1.0)  # doctest: +SKIP
>>> sorted(sim.extras["layers"])  # doctest: +SKIP
['building', 'gate', 'wall']
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import Any

import numpy as np
from shapely import affinity
from shapely.geometry import box

from pyheracles.errors import InputError
from pyheracles.synthetic.families.complex_build import plan_strips
from pyheracles.synthetic.families.complex_draw import draw_layout
from pyheracles.synthetic.families.complex_layout import (
    Layout,
    building_footprint,
    gate_footprint,
    wall_footprint,
)
from pyheracles.synthetic.families.complex_model import (
    build_scene,
    digitise,
    gis_layers,
)
from pyheracles.synthetic.families.simulation import Simulation, apply_overrides
from pyheracles.synthetic.scanner import Outliers, ScanResult, scan

__all__ = [
    "CRS_CHOICES",
    "LAYOUTS",
    "RANGES",
    "ComplexFamilyParams",
    "draw",
    "draw_params",
    "write_layers",
]

#: Named layouts: a random complex, or the demo complex.
LAYOUTS = ("random", "kasepuhan")
#: Projected CRSs a draw may use, with the range of its local origin (easting, northing).
CRS_CHOICES: dict[str, tuple[tuple[float, float], tuple[float, float]]] = {
    "EPSG:28992": ((20_000.0, 270_000.0), (310_000.0, 610_000.0)),  # RD New
    "EPSG:32631": ((300_000.0, 700_000.0), (5_400_000.0, 6_000_000.0)),  # UTM 31N
    "EPSG:32749": ((200_000.0, 800_000.0), (9_100_000.0, 9_400_000.0)),  # UTM 49S
    "EPSG:2154": ((300_000.0, 1_000_000.0), (6_200_000.0, 7_000_000.0)),  # Lambert-93
}


@dataclass(frozen=True)
class ComplexFamilyParams:
    """Drawn quantities of a ``complex`` draw; ``None`` = drawn from the range given.

    Layout
    ------
    layout : ``random`` (default) or ``kasepuhan`` (the demo; then only
        ``n_points`` may be set, default 400 000).
    width_m, depth_m : survey tile, 90-220 m.
    orientation_deg : the enclosure's axes from the x axis, 0-90.
    margin_m : between the perimeter wall and the tile edge, 6-25 m (buildings,
        trees and clutter stand there too).
    enclosure_aspect : half-length ratio of the enclosure (relative to the tile), 0.75-1.33.
    n_buildings : 4-36 GIS building features (rows count one per unit).
    n_edge_buildings : 0-2 more, cut by the tile edge.
    n_demolished : 0-2 buildings in the GIS but not on the ground.
    pavilion_share : 0-0.6 open pavilions (columns on a platform).
    building_size_m : largest building side, 8-35 m (smallest 3.5 m).
    storeys_max : 1-3.
    flat_roof_share, gabled_share : 0-0.4 each (the rest hipped / joglo).
    eaves_max_m : largest roof overhang, 0-1.5 m.
    platform_share : 0-1 of closed buildings on a raised platform (the others
        on a plinth; pavilions always on a platform).
    platform_height_max_m : 0.3-1.5 m (each base 0.3 m to this).
    platform_margin_max_m : 0-2 m, how far a platform reaches beyond the walls.
    wall_height_m : 1.2-4 m; wall_thickness_m : 0.25-1.0 m.
    n_internal_walls : 0-3; n_gates : 1-5 perimeter gates.
    split_gate_share : 0-1; gate_height_m : 3-8 m.
    n_trees : 0-60; tree_over_roof_share : 0-0.6; crown_radius_max_m : 2.5-7 m;
    crown_penetration : 0.1-0.6 (share of pulses reaching below a crown).
    n_clutter : 0-80.
    slope_pct : 0-20 %; relief_m : 0-5 m (hills); n_terraces : 0-3;
    terrace_step_m : 0.5-3 m; riser_deg : 35-80 (terrace edge slope).

    Survey and GIS
    --------------
    density_per_m2 : 0.1-20 points per m^2 on open ground, log-uniform.
    n_strips : 2-4; overlap : 0.2-0.5; heading_deg : 0-180; half_fov_deg : 15-30.
    noise_m : 0.02-0.08 (range noise); outlier_share : 0.001-0.01.
    digitising_error_m : 0-0.5 m (largest shift of an outline).
    crs : one of :data:`CRS_CHOICES`; easting_m, northing_m : the local
        origin in it; height_m : 0-400 m.
    """

    layout: str = "random"
    n_points: int | None = None
    width_m: float | None = None
    depth_m: float | None = None
    orientation_deg: float | None = None
    margin_m: float | None = None
    enclosure_aspect: float | None = None
    n_buildings: int | None = None
    n_edge_buildings: int | None = None
    n_demolished: int | None = None
    pavilion_share: float | None = None
    building_size_m: float | None = None
    storeys_max: int | None = None
    flat_roof_share: float | None = None
    gabled_share: float | None = None
    eaves_max_m: float | None = None
    platform_share: float | None = None
    platform_height_max_m: float | None = None
    platform_margin_max_m: float | None = None
    wall_height_m: float | None = None
    wall_thickness_m: float | None = None
    n_internal_walls: int | None = None
    n_gates: int | None = None
    split_gate_share: float | None = None
    gate_height_m: float | None = None
    n_trees: int | None = None
    tree_over_roof_share: float | None = None
    crown_radius_max_m: float | None = None
    crown_penetration: float | None = None
    n_clutter: int | None = None
    slope_pct: float | None = None
    relief_m: float | None = None
    n_terraces: int | None = None
    terrace_step_m: float | None = None
    riser_deg: float | None = None
    density_per_m2: float | None = None
    n_strips: int | None = None
    overlap: float | None = None
    heading_deg: float | None = None
    half_fov_deg: float | None = None
    noise_m: float | None = None
    outlier_share: float | None = None
    digitising_error_m: float | None = None
    crs: str | None = None
    easting_m: float | None = None
    northing_m: float | None = None
    height_m: float | None = None


#: name -> (kind, low, high): ``u`` uniform, ``i`` integer (inclusive), ``log`` log-uniform.
RANGES: dict[str, tuple[str, float, float]] = {
    "width_m": ("u", 90.0, 220.0),
    "depth_m": ("u", 90.0, 220.0),
    "orientation_deg": ("u", 0.0, 90.0),
    "margin_m": ("u", 6.0, 25.0),
    "enclosure_aspect": ("u", 0.75, 1.33),
    "n_buildings": ("i", 4, 36),
    "n_edge_buildings": ("i", 0, 2),
    "n_demolished": ("i", 0, 2),
    "pavilion_share": ("u", 0.0, 0.6),
    "building_size_m": ("u", 8.0, 35.0),
    "storeys_max": ("i", 1, 3),
    "flat_roof_share": ("u", 0.0, 0.4),
    "gabled_share": ("u", 0.0, 0.4),
    "eaves_max_m": ("u", 0.0, 1.5),
    "platform_share": ("u", 0.0, 1.0),
    "platform_height_max_m": ("u", 0.3, 1.5),
    "platform_margin_max_m": ("u", 0.0, 2.0),
    "wall_height_m": ("u", 1.2, 4.0),
    "wall_thickness_m": ("u", 0.25, 1.0),
    "n_internal_walls": ("i", 0, 3),
    "n_gates": ("i", 1, 5),
    "split_gate_share": ("u", 0.0, 1.0),
    "gate_height_m": ("u", 3.0, 8.0),
    "n_trees": ("i", 0, 60),
    "tree_over_roof_share": ("u", 0.0, 0.6),
    "crown_radius_max_m": ("u", 2.5, 7.0),
    "crown_penetration": ("u", 0.1, 0.6),
    "n_clutter": ("i", 0, 80),
    "slope_pct": ("u", 0.0, 20.0),
    "relief_m": ("u", 0.0, 5.0),
    "n_terraces": ("i", 0, 3),
    "terrace_step_m": ("u", 0.5, 3.0),
    "riser_deg": ("u", 35.0, 80.0),
    "density_per_m2": ("log", 0.1, 20.0),
    "n_strips": ("i", 2, 4),
    "overlap": ("u", 0.2, 0.5),
    "heading_deg": ("u", 0.0, 180.0),
    "half_fov_deg": ("u", 15.0, 30.0),
    "noise_m": ("u", 0.02, 0.08),
    "outlier_share": ("u", 0.001, 0.01),
    "digitising_error_m": ("u", 0.0, 0.5),
    "height_m": ("u", 0.0, 400.0),
}
_INT_FIELDS = {k for k, (kind, _, _) in RANGES.items() if kind == "i"}


def draw_params(given: ComplexFamilyParams, rng: np.random.Generator) -> ComplexFamilyParams:
    """Fill every ``None`` field of ``given`` from its range (:data:`RANGES`).

    Every field is drawn, in a fixed order, whether it is given or not, so
    fixing one field does not change the others.
    """
    drawn: dict[str, Any] = {}
    for name, (kind, lo, hi) in RANGES.items():
        if kind == "i":
            v: Any = int(rng.integers(int(lo), int(hi) + 1))
        elif kind == "log":
            v = float(np.exp(rng.uniform(np.log(lo), np.log(hi))))
        else:
            v = float(rng.uniform(lo, hi))
        drawn[name] = v
    crs = str(rng.choice(sorted(CRS_CHOICES)))
    u = rng.random(2)
    drawn["crs"] = given.crs or crs
    (e0, e1), (n0, n1) = CRS_CHOICES.get(drawn["crs"], ((1e5, 9e5), (1e6, 9e6)))
    drawn["easting_m"] = float(np.round(e0 + u[0] * (e1 - e0), 2))
    drawn["northing_m"] = float(np.round(n0 + u[1] * (n1 - n0), 2))
    out = {f.name: getattr(given, f.name) for f in fields(given)}
    for name, v in drawn.items():
        if out[name] is None:
            out[name] = v
    return ComplexFamilyParams(**out)


def _validate(p: ComplexFamilyParams) -> None:
    if p.layout not in LAYOUTS:
        raise InputError(f"unknown complex layout {p.layout!r}",
                         hint=f"choose one of {', '.join(LAYOUTS)}")  # fmt: skip
    if p.n_points is not None:
        raise InputError("n_points applies to layout='kasepuhan' only",
                         hint="use --set density_per_m2=VALUE for a random complex")  # fmt: skip
    for name in _INT_FIELDS:
        v = getattr(p, name)
        if isinstance(v, bool) or not isinstance(v, int | np.integer):
            raise InputError(f"{name} must be a whole number, got {v!r}")
    checks = {
        "width_m": p.width_m >= 40, "depth_m": p.depth_m >= 40,
        "density_per_m2": 0 < p.density_per_m2 <= 200, "n_strips": 1 <= p.n_strips <= 8,
        "overlap": 0 <= p.overlap <= 0.6, "half_fov_deg": 5 <= p.half_fov_deg <= 40,
        "n_buildings": p.n_buildings >= 0, "n_gates": p.n_gates >= 1,
        "margin_m": 2 <= p.margin_m < min(p.width_m, p.depth_m) / 2 - 10,
        "digitising_error_m": 0 <= p.digitising_error_m <= 5,
        "outlier_share": 0 <= p.outlier_share < 0.5, "noise_m": p.noise_m >= 0,
        "crown_penetration": 0 < p.crown_penetration < 1,
        "platform_height_max_m": p.platform_height_max_m >= 0,
    }  # fmt: skip
    bad = [k for k, ok in checks.items() if not ok]
    if bad:
        raise InputError(f"complex parameter {bad[0]} = {getattr(p, bad[0])!r} is out of range",
                         hint="see ComplexFamilyParams for the ranges")  # fmt: skip
    if p.crs not in CRS_CHOICES:
        raise InputError(f"unknown crs {p.crs!r}", hint=f"choose one of {', '.join(CRS_CHOICES)}")


def _footprints(layout: Layout) -> dict[str, Any]:
    out = {b.fid: building_footprint(b) for b in layout.buildings}
    out.update({w.fid: wall_footprint(w, layout.frame) for w in layout.walls})
    out.update({g.fid: gate_footprint(g) for g in layout.gates})
    return out


def write_layers(layers: dict[str, Any], objects: Any, outdir: str | Path) -> dict[str, Path]:
    """Write ``layers.gpkg`` (one layer per class) and ``reference_objects.csv``, atomically.

    The string feature ids stay in a field named ``fid``; the GeoPackage's own
    key is ``ogc_fid``.  ``object_id`` is written as a 64-bit integer field.
    """
    from pyheracles.io.atomic import atomic_path
    from pyheracles.io.vector import GPKG_VERSION

    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    target = out / "layers.gpkg"
    with atomic_path(target) as tmp:
        for k, (name, gdf) in enumerate(layers.items()):
            gdf.to_file(tmp, layer=name, driver="GPKG", engine="pyogrio",
                        layer_options={"FID": "ogc_fid"}, append=k > 0,
                        dataset_options={"VERSION": GPKG_VERSION} if k == 0 else None)  # fmt: skip
    table = out / "reference_objects.csv"
    with atomic_path(table) as tmp:
        objects.to_csv(tmp, index=False)
    return {"layers": target, "reference_objects": table}


def _crop(res: ScanResult, bounds: tuple[float, float, float, float]) -> ScanResult:
    """The delivered tile: points inside the survey bounds."""
    x0, y0, x1, y1 = bounds
    x, y = res.xyz[:, 0], res.xyz[:, 1]
    return res.subset((x >= x0) & (x <= x1) & (y >= y0) & (y <= y1))


def draw(seed: int, **overrides: Any) -> Simulation:
    """Draw member ``seed`` of the complex family and scan it from the air.

    Parameters
    ----------
    seed
        Draw number (the random generator's seed).
    **overrides
        Fields of :class:`ComplexFamilyParams` to fix.

    Returns
    -------
    Simulation
        One cloud ``"cloud"`` (local coordinates; ``sim.offset`` and
        ``sim.crs`` give the world), the drawn parameters, and the GIS
        layers in ``extras``.
    """
    given = apply_overrides(ComplexFamilyParams(), overrides, "complex")
    if given.layout == "kasepuhan":
        return _kasepuhan(seed, given, overrides)
    rng = np.random.default_rng(seed)
    p = draw_params(given, rng)
    _validate(p)
    layout = draw_layout(p, rng)
    scene = build_scene(layout, rng, terrain_cell_m=0.5 if p.n_terraces else 1.0)
    survey, plan = plan_strips(
        layout.bounds, density_per_m2=p.density_per_m2, n_strips=p.n_strips,
        overlap=p.overlap, heading_deg=p.heading_deg, half_fov_deg=p.half_fov_deg,
        noise_m=p.noise_m, line_ratio=float(rng.uniform(0.7, 1.4)),
    )  # fmt: skip
    res = _crop(scan(scene, survey, outliers=Outliers(share=p.outlier_share), rng=rng),
                layout.bounds)  # fmt: skip
    groups = {**layout.building_groups, **layout.wall_groups}
    digitised = digitise(_footprints(layout), groups, p.digitising_error_m, rng)
    good = ~res.outlier
    counts = np.bincount(res.instance[good], minlength=len(digitised) + 1)
    offset = (p.easting_m, p.northing_m, p.height_m)
    layers, objects = gis_layers(layout, digitised, offset[:2], p.crs, counts)
    area = (layout.bounds[2] - layout.bounds[0]) * (layout.bounds[3] - layout.bounds[1])
    first = good & (res.return_number == 1)
    ground = good & (res.class_id == scene.class_code("ground"))
    params = asdict(p)
    params.update({
        "measured_density_per_m2": float(first.sum() / area),
        "n_points_scanned": len(res),
        "n_gis_buildings": len(layers["building"]), "n_gis_walls": len(layers["wall"]),
        "n_gis_gates": len(layers["gate"]), "n_trees_placed": len(layout.trees),
        "n_clutter_placed": len(layout.clutter), "ground_share": float(ground.mean()),
        **{f"survey_{k}": v for k, v in plan.items()},
    })  # fmt: skip
    extent = box(*layout.bounds)
    extras = {
        "layers": layers,
        "reference_objects": objects,
        "extent": affinity.translate(extent, offset[0], offset[1]),
        "survey": plan,
        "write_extras": lambda outdir: write_layers(layers, objects, outdir),
    }
    return Simulation("complex", seed, scene, {"cloud": res}, {"cloud": np.eye(4)}, params,
                      extras, p.crs, offset)  # fmt: skip


def _kasepuhan(seed: int, given: ComplexFamilyParams, overrides: dict[str, Any]) -> Simulation:
    """The demo complex (fixed layout) through the airborne simulator."""
    from pyheracles.synthetic.complex_scene import ComplexSceneParams, kasepuhan_simulation

    extra = sorted(set(overrides) - {"layout", "n_points"})
    if extra:
        raise InputError(f"layout='kasepuhan' is a fixed complex; {extra[0]!r} cannot be set",
                         hint="only --set n_points=N (the density) applies to it")  # fmt: skip
    n = 400_000 if given.n_points is None else given.n_points
    return kasepuhan_simulation(ComplexSceneParams(n_points=int(n), seed=seed))
