"""The ``terrain`` scene family: draws, reference, landforms, outliers, CLI."""

from __future__ import annotations

from dataclasses import fields

import numpy as np
import pytest

from pyheracles.errors import InputError
from pyheracles.synthetic.families import simulate
from pyheracles.synthetic.families.terrain import (
    MAX_PULSES,
    RANGES,
    TerrainFamilyParams,
    build_relief,
    draw,
    resolve_params,
)
from pyheracles.synthetic.families.terrain_relief import TAGS, slope_deg

SMALL = {"side_m": 150.0, "density_per_m2": 0.5}
# a small draw with every landform and object kind present
RICH = {
    "side_m": 160.0,
    "density_per_m2": 2.0,
    "river_depth_m": 4.0,
    "n_bridges": 2,
    "tree_cover": 0.3,
    "shrub_cover": 0.2,
    "canopy_core": 0.3,
    "n_low_clusters": 2,
    "low_cluster_depth_m": 6.0,
    "terrace_step_m": 2.0,
    "max_slope_deg": 40.0,
    "n_strips": 3,
    "water_reflectance": 0.002,
    "building_max_size_m": 60.0,
    "n_buildings": 3,
    "n_platforms": 1,
    "n_embankments": 1,
    "n_ridges": 1,
}


@pytest.fixture(scope="module")
def rich():
    return draw(2, **RICH)


def _code(sim, name: str) -> int:
    return sim.scene.class_code(name)


def _terrain_height(sim, xy: np.ndarray) -> np.ndarray:
    t = sim.extras["terrain"]
    from scipy.interpolate import RegularGridInterpolator

    return RegularGridInterpolator((t["y"], t["x"]), t["z"])(xy[:, ::-1])


def test_same_seed_same_points() -> None:
    a = draw(5, **SMALL)
    b = draw(5, **SMALL)
    ra, rb = a.clouds["cloud"], b.clouds["cloud"]
    assert len(ra) > 1000
    np.testing.assert_array_equal(ra.xyz, rb.xyz)
    np.testing.assert_array_equal(ra.class_id, rb.class_id)
    np.testing.assert_array_equal(ra.outlier, rb.outlier)
    assert a.params == b.params
    c = draw(6, **SMALL)
    assert len(c.clouds["cloud"]) != len(ra) or not np.array_equal(c.clouds["cloud"].xyz, ra.xyz)


def test_drawn_parameters_stay_in_their_ranges() -> None:
    seen_river = seen_terraces = 0
    for seed in range(60):
        p = resolve_params(seed, {})
        for f in fields(TerrainFamilyParams):
            lo, hi = RANGES[f.name]
            if f.name in ("river_depth_m", "terrace_step_m") and p[f.name] == 0:
                continue  # absent from this draw
            assert lo <= p[f.name] <= hi, (seed, f.name, p[f.name])
        assert p["density_per_m2"] * p["side_m"] ** 2 <= MAX_PULSES * 1.0001 or p["side_m"] == 150
        assert p["n_strips"] in (2, 3, 4)
        if p["river_depth_m"] == 0:
            assert p["n_bridges"] == 0
        seen_river += p["river_depth_m"] > 0
        seen_terraces += p["terrace_step_m"] > 0
    # both kinds of draw occur
    assert 10 < seen_river < 55 and 10 < seen_terraces < 55


def test_overrides_fix_values_and_unknown_ones_are_refused() -> None:
    sim = draw(3, **SMALL, river_depth_m=0.0, n_buildings=0, n_strips=2)
    res = sim.clouds["cloud"]
    assert sim.params["side_m"] == 150.0 and sim.params["n_buildings"] == 0
    assert not (res.class_id == _code(sim, "water")).any()
    assert not (res.class_id == _code(sim, "building")).any()
    assert len(np.unique(res.point_source_id)) == 2
    with pytest.raises(InputError, match="side_mm") as err:
        draw(0, side_mm=100)
    assert "side_m" in str(err.value)
    with pytest.raises(InputError, match="tree_cover"):
        draw(0, tree_cover=2.0)
    with pytest.raises(InputError, match="whole number"):
        draw(0, n_strips=2.5)
    with pytest.raises(InputError):
        simulate("terrain", -1)


def test_reference_is_consistent(rich) -> None:
    res = rich.clouds["cloud"]
    scene = rich.scene
    objects = {o["instance"]: o for o in scene.objects}
    inst = np.unique(res.instance)
    assert all(int(i) in objects for i in inst if i != 0)
    for i in inst[inst != 0]:
        cls = np.unique(res.class_id[res.instance == i])
        assert [scene.class_names[int(c)] for c in cls] == [objects[int(i)]["class"]]
    ground = res.class_id == _code(rich, "ground")
    assert (res.instance[ground] == 0).all()
    assert (res.instance[~ground & ~res.outlier] != 0).all()
    assert (res.instance[res.outlier] == 0).all() and (res.class_id[res.outlier] == 0).all()
    assert (res.class_id[~res.outlier] != 0).all()
    share = res.outlier.mean()
    assert 0.0005 < share < 0.03
    parts = {scene.part_names[int(p)] for p in np.unique(res.part[res.outlier])}
    assert {"outlier_low_cluster", "outlier_isolated"} <= parts
    # points inside the survey square, coordinates in the scene frame
    side = rich.params["side_m"]
    assert res.xyz[:, :2].min() >= 0 and res.xyz[:, :2].max() <= side
    assert (res.return_number <= res.number_of_returns).all()


def test_every_kind_of_object_and_landform_is_there(rich) -> None:
    res = rich.clouds["cloud"]
    names = {rich.scene.class_names[int(c)] for c in np.unique(res.class_id)}
    assert {
        "ground",
        "vegetation",
        "low_vegetation",
        "building",
        "bridge",
        "water",
        "car",
        "wall",
    } <= names
    tags = rich.extras["terrain"]["tags"]
    for tag in ("steep", "crest", "breakline", "platform", "river_bank", "terrace", "vegetated"):
        assert (tags & TAGS[tag]).any(), tag
    sizes = [max(o["box"]["size"][:2]) for o in rich.scene.objects if o["class"] == "building"]
    assert max(sizes) == pytest.approx(60.0)


def test_slopes_reach_45_degrees() -> None:
    p = resolve_params(
        4,
        {
            "max_slope_deg": 45.0,
            "regional_slope_deg": 5.0,
            "n_ridges": 0,
            "terrace_step_m": 0.0,
            "n_embankments": 0,
            "n_platforms": 0,
            "river_depth_m": 0.0,
            "side_m": 200.0,
            "density_per_m2": 1.0,
        },
    )
    relief, _ = build_relief(p, np.random.default_rng(0), 5.0)
    sl = slope_deg(relief.z, relief.cell_m)
    assert 40 < np.percentile(sl, 99.5) < 50
    flat = resolve_params(
        4,
        {
            "max_slope_deg": 0.0,
            "regional_slope_deg": 0.0,
            "n_ridges": 0,
            "terrace_step_m": 0.0,
            "n_embankments": 0,
            "n_platforms": 0,
            "river_depth_m": 0.0,
        },
    )
    relief, _ = build_relief(flat, np.random.default_rng(0), 5.0)
    assert np.ptp(relief.z) < 1e-6


def test_vegetation_gives_several_returns_and_ground_beneath(rich) -> None:
    res = rich.clouds["cloud"]
    veg = res.class_id == _code(rich, "vegetation")
    assert res.number_of_returns[veg].max() >= 3
    ground = res.class_id == _code(rich, "ground")
    under = ground & (res.return_number > 1)
    assert under.sum() > 100  # last returns through the crowns reach the ground
    shrub = res.class_id == _code(rich, "low_vegetation")
    h = res.xyz[shrub, 2] - _terrain_height(rich, res.xyz[shrub, :2])
    assert np.percentile(h, 95) < 2.5 and np.median(h) > 0.2


def test_water_gives_few_returns_and_bridges_span_the_cut(rich) -> None:
    res = rich.clouds["cloud"]
    water = rich.scene.objects[[o["class"] for o in rich.scene.objects].index("water")]
    n_water = (res.class_id == _code(rich, "water")).sum()
    ground = (res.class_id == _code(rich, "ground")).sum()
    side = rich.params["side_m"]
    ground_density = ground / (side**2 - water["area_m2"])
    assert n_water / water["area_m2"] < 0.3 * ground_density
    bridge = res.class_id == _code(rich, "bridge")
    deck = bridge & (res.return_number == 1)
    above = res.xyz[deck, 2] - _terrain_height(rich, res.xyz[deck, :2])
    assert deck.sum() > 50 and np.percentile(above, 75) > 1.0  # the deck spans the cut


def test_low_outlier_cluster_lies_under_the_terrain(rich) -> None:
    res = rich.clouds["cloud"]
    code = rich.scene.part_code("outlier_low_cluster")
    low = res.outlier & (res.part == code)
    depth = _terrain_height(rich, res.xyz[low, :2]) - res.xyz[low, 2]
    clusters = rich.params["low_clusters"]
    assert len(clusters) == 2
    assert low.sum() == sum(c["points"] for c in clusters)
    assert 3.0 < np.median(depth) < 9.0


def test_survey_density_strips_and_crs(rich) -> None:
    res = rich.clouds["cloud"]
    assert len(np.unique(res.point_source_id)) == 3
    pulses = rich.params["measured_pulse_density_per_m2"]
    assert 0.6 * RICH["density_per_m2"] < pulses < 1.4 * RICH["density_per_m2"]
    assert rich.crs.startswith("EPSG:326")
    e, n, z = rich.offset
    assert 300_000 <= e <= 700_000 and 4_000_000 <= n <= 6_200_000 and 0 <= z <= 1500


def test_cli_writes_the_draw(tmp_path) -> None:
    import laspy

    from pyheracles.cli import main

    out = tmp_path / "t0"
    code = main(
        [
            "simulate",
            "--family",
            "terrain",
            "--seed",
            "0",
            "-o",
            str(out),
            "--set",
            "side_m=150",
            "--set",
            "density_per_m2=0.3",
        ]
    )
    assert code in (0, None)
    for name in ("cloud.laz", "truth.npz", "scene.json", "preview.png", "dem_truth.npz"):
        assert (out / name).is_file(), name
    las = laspy.read(out / "cloud.laz")
    truth = np.load(out / "truth.npz")
    assert len(las.points) == len(truth["class_id"]) == len(truth["outlier"])
    sim = draw(0, side_m=150.0, density_per_m2=0.3)
    res = sim.clouds["cloud"]
    np.testing.assert_array_equal(truth["class_id"], res.class_id)
    xyz = np.column_stack([las.x, las.y, las.z]) - np.asarray(sim.offset)
    np.testing.assert_allclose(xyz, res.xyz, atol=2e-4)
    assert las.header.parse_crs().to_epsg() == int(sim.crs.split(":")[1])
    dem = np.load(out / "dem_truth.npz")
    assert dem["z"].shape == (len(dem["y"]), len(dem["x"]))
