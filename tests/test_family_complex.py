"""The ``complex`` scene family: walled complexes from the air, with GIS layers."""

from __future__ import annotations

from dataclasses import fields
from pathlib import Path

import laspy
import numpy as np
import pyogrio
import pytest
import shapely

from pyheracles.errors import InputError
from pyheracles.synthetic.families import simulate
from pyheracles.synthetic.families.complex import (
    CRS_CHOICES,
    RANGES,
    ComplexFamilyParams,
    draw,
    draw_params,
)

#: A small, quick member: a 100 m tile at 2 points per m^2, trees over roofs, platforms.
SMALL = {
    "width_m": 100.0, "depth_m": 100.0, "density_per_m2": 2.0, "n_buildings": 8,
    "n_trees": 12, "tree_over_roof_share": 0.5, "n_clutter": 10, "pavilion_share": 0.4,
    "n_demolished": 1, "n_edge_buildings": 1,
}  # fmt: skip


@pytest.fixture(scope="module")
def sim():
    return draw(4, **SMALL)


def test_deterministic_per_seed() -> None:
    kw = {**SMALL, "density_per_m2": 0.5, "n_trees": 3}
    a, b, c = draw(2, **kw), draw(2, **kw), draw(3, **kw)
    ra, rb = a.clouds["cloud"], b.clouds["cloud"]
    assert np.array_equal(ra.xyz, rb.xyz) and np.array_equal(ra.instance, rb.instance)
    assert a.params == b.params
    assert len(ra) != len(c.clouds["cloud"]) or not np.array_equal(ra.xyz, c.clouds["cloud"].xyz)


def test_parameters_drawn_within_their_ranges() -> None:
    for seed in range(40):
        p = draw_params(ComplexFamilyParams(), np.random.default_rng(seed))
        for name, (kind, lo, hi) in RANGES.items():
            v = getattr(p, name)
            assert lo <= v <= hi, (seed, name, v)
            assert isinstance(v, int) == (kind == "i"), name
        assert p.crs in CRS_CHOICES
        (e0, e1), (n0, n1) = CRS_CHOICES[p.crs]
        assert e0 <= p.easting_m <= e1 and n0 <= p.northing_m <= n1
    # wide ranges: the density spans two orders of magnitude over a few dozen draws
    dens = [draw_params(ComplexFamilyParams(), np.random.default_rng(s)).density_per_m2
            for s in range(60)]  # fmt: skip
    assert min(dens) < 0.3 and max(dens) > 8


def test_overrides_fix_one_field_only() -> None:
    base = draw_params(ComplexFamilyParams(), np.random.default_rng(5))
    fixed = draw_params(ComplexFamilyParams(n_trees=7), np.random.default_rng(5))
    assert fixed.n_trees == 7
    assert all(getattr(base, f.name) == getattr(fixed, f.name)
               for f in fields(base) if f.name != "n_trees")  # fmt: skip


@pytest.mark.parametrize(
    ("overrides", "match"),
    [
        ({"n_tree": 3}, "no parameter 'n_tree'"),
        ({"layout": "castle"}, "unknown complex layout"),
        ({"n_points": 1000}, "kasepuhan' only"),
        ({"layout": "kasepuhan", "n_trees": 3}, "fixed complex"),
        ({"density_per_m2": -1.0}, "out of range"),
        ({"n_gates": 2.5}, "whole number"),
        ({"crs": "EPSG:4326"}, "unknown crs"),
    ],
)
def test_bad_overrides_are_refused(overrides, match) -> None:
    with pytest.raises(InputError, match=match):
        simulate("complex", 0, **overrides)


def test_reference_is_consistent(sim) -> None:
    res, scene = sim.clouds["cloud"], sim.scene
    objects = {o["instance"]: o for o in scene.objects}
    inst = np.unique(res.instance)
    assert set(inst[inst > 0]) <= set(objects)
    for k in inst[inst > 0]:  # every object point carries its feature's class
        codes = np.unique(res.class_id[res.instance == k])
        assert [scene.class_names[int(c)] for c in codes] == [objects[k]["class"]]
    # trees, clutter and the terrain belong to no object; outliers to nothing
    for name in ("ground", "tree", "clutter"):
        m = res.class_id == scene.class_code(name)
        assert m.any() and not res.instance[m].any(), name
    assert res.outlier.any()
    assert not res.instance[res.outlier].any() and not res.class_id[res.outlier].any()
    assert 0.001 <= res.outlier.mean() <= 0.012
    ground = res.class_id == scene.class_code("ground")
    assert 0.4 < ground.mean() < 0.97
    # the reference table counts the points of each feature, in layer order
    ro = sim.extras["reference_objects"]
    counts = np.bincount(res.instance[~res.outlier], minlength=int(ro["instance"].max()) + 1)
    assert np.array_equal(counts[ro["instance"]], ro["n_points"])
    for layer, gdf in sim.extras["layers"].items():
        assert ro.loc[ro["layer"] == layer, "fid"].tolist() == gdf["fid"].tolist()


def test_airborne_survey(sim) -> None:
    res, p = sim.clouds["cloud"], sim.params
    assert 2 <= p["n_strips"] <= 4
    assert len(np.unique(res.point_source_id)) == p["n_strips"]
    assert 0.8 * p["density_per_m2"] < p["measured_density_per_m2"] < 1.3 * p["density_per_m2"]
    # crowns are porous: pulses through them give several returns, ground below them too
    tree = res.class_id == sim.scene.class_code("tree")
    assert (res.number_of_returns[tree] > 1).mean() > 0.2
    ground = res.class_id == sim.scene.class_code("ground")
    assert (ground & (res.number_of_returns > 1)).sum() > 20
    assert (res.return_number <= res.number_of_returns).all()
    # the tile is what is delivered: no point outside it
    x0, y0, x1, y1 = 0.0, 0.0, p["width_m"], p["depth_m"]
    assert res.xyz[:, 0].min() >= x0 and res.xyz[:, 0].max() <= x1
    assert res.xyz[:, 1].min() >= y0 and res.xyz[:, 1].max() <= y1


def test_buildings_platforms_gates_and_trees(sim) -> None:
    res, scene = sim.clouds["cloud"], sim.scene
    parts = {scene.part_names[int(k)] for k in np.unique(res.part)}
    assert {"roof", "platform", "column", "wall", "crown"} <= parts
    assert parts & {"tower", "gate_roof"}
    bases = [o["base_height_m"] for o in scene.objects if o.get("base_height_m") is not None]
    assert min(bases) >= 0.15 and max(bases) <= 1.5 + 4.0  # 0.3-1.5 m, more down a slope
    # gates are flanked by walls: each gate's true footprint touches a wall run
    walls = [shapely.from_wkt(o["footprint"]) for o in scene.objects if o["class"] == "wall"]
    for o in scene.objects:
        if o["class"] == "gate":
            gate = shapely.from_wkt(o["footprint"])
            assert min(gate.distance(w) for w in walls) < 0.35, o["fid"]
    # some tree crowns overhang roofs: tree points inside building footprints, above 2 m
    fps = shapely.union_all(
        [
            shapely.from_wkt(o["footprint"])
            for o in scene.objects
            if o["class"] == "building" and o["status"] == "extant"
        ]
    )
    tree = res.class_id == scene.class_code("tree")
    assert shapely.contains_xy(fps, res.xyz[tree, 0], res.xyz[tree, 1]).sum() > 20


def test_gis_layers(sim) -> None:
    layers, ro = sim.extras["layers"], sim.extras["reference_objects"]
    assert sorted(layers) == ["building", "gate", "wall"]
    ox, oy = sim.offset[:2]
    assert abs(ox) > 1e4 and abs(oy) > 1e5
    err = sim.params["digitising_error_m"]
    by_fid = {o["fid"]: o for o in sim.scene.objects}
    for gdf in layers.values():
        assert gdf.crs.to_string() == sim.crs and gdf.crs.is_projected
        assert gdf.is_valid.all() and gdf["fid"].is_unique
        assert gdf["object_id"].dtype == np.int64 and (gdf["object_id"] > 2**32).all()
        for fid, geom in zip(gdf["fid"], gdf.geometry, strict=True):
            truth = shapely.affinity.translate(shapely.from_wkt(by_fid[fid]["footprint"]), ox, oy)
            assert shapely.hausdorff_distance(truth, geom) < err + 0.15, fid
    # a demolished building is in the GIS with no point; one building sticks out of the tile
    status = layers["building"].set_index("fid")["status"]
    demolished = status[status == "demolished"].index
    assert len(demolished) == 1
    assert ro.set_index("fid").loc[demolished[0], "n_points"] == 0
    extent = sim.extras["extent"]
    out = layers["building"].geometry.difference(extent).area
    assert (out > 1.0).any()


def test_kasepuhan_is_a_member() -> None:
    from pyheracles.synthetic.complex_scene import ComplexSceneParams, kasepuhan_scene

    sim = draw(1, layout="kasepuhan", n_points=20_000)
    scene = kasepuhan_scene(ComplexSceneParams(n_points=20_000, seed=1))
    res = sim.clouds["cloud"]
    assert len(res) == 20_000 and sim.crs == "EPSG:32749"
    assert np.allclose(res.xyz + np.asarray(sim.offset), scene.cloud.world_xyz())
    assert np.array_equal(res.instance, scene.reference_instance)
    assert sorted(sim.extras["layers"]) == sorted(scene.layers)
    assert sim.params["layout"] == "kasepuhan" and sim.params["seed"] == 1


def test_cli_writes_a_draw(tmp_path: Path) -> None:
    from pyheracles.cli import main
    from pyheracles.io import read_layer

    out = tmp_path / "c0"
    args = [
        "simulate",
        "--family",
        "complex",
        "--seed",
        "0",
        "-o",
        str(out),
        "--set",
        "width_m=90",
        "--set",
        "depth_m=90",
        "--set",
        "density_per_m2=1.0",
    ]
    assert main(args) == 0  # fmt: skip
    for name in ("cloud.laz", "truth.npz", "scene.json", "preview.png", "layers.gpkg",
                 "reference_objects.csv"):  # fmt: skip
        assert (out / name).is_file(), name
    las = laspy.read(out / "cloud.laz")
    truth = np.load(out / "truth.npz")
    assert len(las.points) == len(truth["instance"]) == len(truth["outlier"])
    assert las.header.parse_crs().is_projected
    assert {"building", "wall", "gate"} == {name for name, _ in pyogrio.list_layers(
        out / "layers.gpkg")}  # fmt: skip
    b = read_layer(out / "layers.gpkg", "building")
    assert b["object_id"].dtype == np.int64
    # the layers lie on the cloud (same CRS, world coordinates)
    xmin, ymin, xmax, ymax = b.total_bounds
    assert las.x.min() - 20 < xmin and xmax < las.x.max() + 20
    assert las.y.min() - 20 < ymin and ymax < las.y.max() + 20
