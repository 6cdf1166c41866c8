"""Tests of the synthetic walled complex (Kasepuhan-like) generator."""

from __future__ import annotations

import laspy
import numpy as np
import pyogrio
import pytest
import shapely
from shapely.geometry import box

from pyheracles.errors import InputError
from pyheracles.synthetic.complex_scene import (
    ComplexSceneParams,
    ground_height,
    kasepuhan_scene,
    write_scene,
)

N = 80_000


@pytest.fixture(scope="module")
def scene():
    return kasepuhan_scene(ComplexSceneParams(n_points=N, seed=3))


def _feature(scene, layer, fid):
    gdf = scene.layers[layer]
    return gdf.loc[gdf["fid"] == fid].geometry.iloc[0]


def _inst(scene, fid):
    obj = scene.reference_objects
    return int(obj.loc[obj["fid"] == fid, "instance"].iloc[0])


def test_cloud_size_crs_and_location(scene):
    cloud = scene.cloud
    assert len(cloud) == N
    assert cloud.crs.to_epsg() == 32749
    centre = cloud.world_xyz().mean(axis=0)
    assert abs(centre[0] - 215_000) < 10 and abs(centre[1] - 9_253_000) < 10
    lo, hi = cloud.bounds()
    assert np.allclose(hi[:2] - lo[:2], [140, 200], atol=0.2)
    relief = np.ptp(ground_height(cloud.xyz[:, 0], cloud.xyz[:, 1]))
    assert 2.0 < relief < 6.0  # "a few metres" of relief
    assert len(scene.reference_instance) == N and scene.reference_instance.dtype == np.int32
    assert scene.ground.dtype == bool and len(scene.ground) == N


def test_deterministic_and_seeded():
    a = kasepuhan_scene(ComplexSceneParams(n_points=5_000, seed=7))
    b = kasepuhan_scene(ComplexSceneParams(n_points=5_000, seed=7))
    c = kasepuhan_scene(ComplexSceneParams(n_points=5_000, seed=8))
    assert np.array_equal(a.cloud.xyz, b.cloud.xyz)
    assert np.array_equal(a.reference_instance, b.reference_instance)
    assert not np.array_equal(a.cloud.xyz, c.cloud.xyz)


def test_labels_balance_and_objects_table(scene):
    obj = scene.reference_objects
    assert list(obj.columns[:3]) == ["instance", "layer", "fid"]
    assert obj["instance"].is_unique and obj["instance"].min() == 1
    counts = np.bincount(scene.reference_instance, minlength=obj["instance"].max() + 1)
    assert np.array_equal(counts[obj["instance"]], obj["n_points"])
    assert counts.sum() == N  # every point in exactly one object or in instance 0
    assert not np.any(scene.ground & (scene.reference_instance > 0))
    # every layer row has exactly one reference object, in order
    for layer, gdf in scene.layers.items():
        rows = obj[obj["layer"] == layer]
        assert rows["fid"].tolist() == gdf["fid"].tolist()
        assert rows["feature_index"].tolist() == list(range(len(gdf)))
    # ground points lie on the terrain (noise 2 cm)
    g = scene.cloud.xyz[scene.ground]
    dz = g[:, 2] - ground_height(g[:, 0], g[:, 1])
    assert np.abs(dz).max() < 0.02 * 6
    # a good share of ground, buildings and walls; some clutter/trees (instance 0, not ground)
    assert 0.5 < scene.ground.mean() < 0.85
    other = ~scene.ground & (scene.reference_instance == 0)
    assert 0.02 < other.mean() < 0.2


def test_layers_attributes_and_special_geometries(scene):
    layers = scene.layers
    assert sorted(layers) == ["building", "gate", "wall"]
    for gdf in layers.values():
        assert gdf.crs.to_epsg() == 32749
        assert {"fid", "name", "function", "period"} <= set(gdf.columns)
        assert gdf.is_valid.all()
        assert gdf["fid"].is_unique
    kinds = set(layers["building"].geom_type) | set(layers["gate"].geom_type)
    assert "MultiPolygon" in kinds
    courtyard = _feature(scene, "building", "B11")
    assert courtyard.geom_type == "Polygon" and len(courtyard.interiors) == 1
    # row buildings touch without overlapping
    assert _feature(scene, "building", "B13").touches(_feature(scene, "building", "B14"))
    assert _feature(scene, "building", "B15").touches(_feature(scene, "building", "B16"))


def test_demolished_and_partly_outside(scene):
    w = scene.cloud.world_xyz()
    demolished = _feature(scene, "building", "B20")
    assert not shapely.contains_xy(demolished, w[:, 0], w[:, 1]).any()
    assert scene.reference_objects.set_index("fid").loc["B20", "n_points"] == 0
    cut = _feature(scene, "building", "B19")
    inside = cut.intersection(scene.extent).area / cut.area
    assert 0.3 < inside < 0.8
    pts = scene.reference_instance == _inst(scene, "B19")
    assert pts.sum() > 100
    assert w[pts, 0].max() <= scene.extent.bounds[2] + 0.15  # 6 sigma of noise


def test_digitising_error_is_realistic(scene):
    # true roof outline of B17 (Museum Pusaka): wall rectangle + 0.8 m eaves, in world
    ox, oy = scene.cloud.offset[:2]
    truth = box(29.2 + ox, 21.2 + oy, 46.8 + ox, 30.8 + oy)
    gis = _feature(scene, "building", "B17")
    d = shapely.hausdorff_distance(truth, gis)
    assert 0.05 < d < 0.45
    assert truth.intersection(gis).area / truth.area > 0.95


def test_reference_points_match_their_features(scene):
    w = scene.cloud.world_xyz()
    obj = scene.reference_objects
    for _, row in obj[obj["n_points"] > 0].iterrows():
        geom = scene.layers[row["layer"]].geometry.iloc[row["feature_index"]]
        pts = scene.reference_instance == row["instance"]
        inside = shapely.contains_xy(geom.buffer(0.6), w[pts, 0], w[pts, 1])
        assert inside.mean() > 0.97, row["fid"]


def test_survey_visibility(scene):
    w = scene.cloud.world_xyz()
    # no ground under the roof of a closed building
    museum = _feature(scene, "building", "B17").buffer(-1.0)
    assert not shapely.contains_xy(museum, w[scene.ground, 0], w[scene.ground, 1]).any()
    # ...but the inner courtyard of B11 shows ground
    court = shapely.Polygon(_feature(scene, "building", "B11").interiors[0]).buffer(-1.0)
    assert shapely.contains_xy(court, w[scene.ground, 0], w[scene.ground, 1]).sum() > 50
    # walls are seen on both faces: W04 runs along y = 120 (local)
    pts = scene.cloud.xyz[scene.reference_instance == _inst(scene, "W04")]
    top = ground_height(pts[:, 0], pts[:, 1]) + 2.2
    facade = pts[:, 2] < top - 0.3
    assert (facade & (pts[:, 1] < 119.85)).sum() > 20
    assert (facade & (pts[:, 1] > 120.15)).sum() > 20
    # tree crowns overhang roofs: unlabelled, non-ground points inside building polygons
    keraton = _feature(scene, "building", "B11")
    clutter = ~scene.ground & (scene.reference_instance == 0)
    assert shapely.contains_xy(keraton, w[clutter, 0], w[clutter, 1]).sum() > 30


def test_density_scales_with_n_points():
    small = kasepuhan_scene(ComplexSceneParams(n_points=20_000, seed=1))
    big = kasepuhan_scene(ComplexSceneParams(n_points=80_000, seed=1))
    share_s = np.bincount(small.reference_instance, minlength=40)[1:33] / 20_000
    share_b = np.bincount(big.reference_instance, minlength=40)[1:33] / 80_000
    assert np.allclose(share_s, share_b, atol=0.006)


@pytest.mark.parametrize(
    "kwargs", [{"n_points": 10}, {"noise_m": -1.0}, {"crown_penetration": 2.0}]
)
def test_bad_parameters(kwargs):
    with pytest.raises(InputError):
        kasepuhan_scene(ComplexSceneParams(**kwargs))


def test_write_scene_round_trip(tmp_path):
    scene = kasepuhan_scene(ComplexSceneParams(n_points=6_000, seed=2))
    paths = write_scene(scene, tmp_path / "out")
    assert set(paths) >= {"cloud", "building", "wall", "gate", "objects"}
    las = laspy.read(paths["cloud"])
    assert len(las.points) == 6_000
    assert np.array_equal(np.asarray(las["reference_instance"]), scene.reference_instance)
    assert np.array_equal(np.asarray(las.classification) == 2, scene.ground)
    assert np.allclose(las.xyz, scene.cloud.world_xyz(), atol=0.0006)
    assert las.header.parse_crs().to_epsg() == 32749
    for layer in ("building", "wall", "gate"):
        gdf = pyogrio.read_dataframe(paths[layer])
        assert len(gdf) == len(scene.layers[layer])
        assert gdf.crs.to_epsg() == 32749
    assert not list((tmp_path / "out").glob(".*part*"))
