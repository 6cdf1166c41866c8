"""Step 1: GIS-aided segmentation (thesis chapter 5, MATLAB ``shapeseg``)."""

from __future__ import annotations

from pathlib import Path

import geopandas as gpd
import numpy as np
import pytest
import shapely
from pyproj import CRS

from pyheracles import InputError, PointCloud
from pyheracles.complex import ComplexParams, prepare_layers, segment_complex
from pyheracles.evaluate import evaluate_by_feature, evaluate_objects

E0, N0 = 215000.0, 9253000.0  # UTM 49S, 7-digit northings
CRS_UTM = CRS.from_epsg(32749)


def _box_points(rng, x0, y0, x1, y1, z0, z1, density=40.0, walls_z0=None) -> np.ndarray:
    """Roof (top) and four walls of a box, sampled at ``density`` points per m^2.

    ``walls_z0`` gives the bottom of each wall (S, E, N, W), e.g. the roof
    height of the lower neighbour for a party wall; ``None`` for no wall."""
    area_top = (x1 - x0) * (y1 - y0)
    top = np.column_stack(
        [rng.uniform(x0, x1, int(area_top * density)), rng.uniform(y0, y1, int(area_top * density))]
    )
    top = np.column_stack([top, np.full(len(top), z1)])
    walls = []
    bottoms = walls_z0 if walls_z0 is not None else (z0, z0, z0, z0)
    for ((ax, ay), (bx, by)), zb in zip(
        [((x0, y0), (x1, y0)), ((x1, y0), (x1, y1)), ((x1, y1), (x0, y1)), ((x0, y1), (x0, y0))],
        bottoms,
        strict=True,
    ):
        if zb is None or zb >= z1:
            continue
        length = np.hypot(bx - ax, by - ay)
        m = int(length * (z1 - zb) * density * 0.3)
        t = rng.uniform(0, 1, m)
        walls.append(
            np.column_stack([ax + t * (bx - ax), ay + t * (by - ay), rng.uniform(zb, z1, m)])
        )
    return np.vstack([top, *walls])


@pytest.fixture
def row_houses(rng):
    """Flat ground, three touching row houses, a courtyard building with a hole,
    a two-part building (multipolygon), a low wall, a tree, and a polygon with no points."""
    ground = np.column_stack(
        [rng.uniform(0, 80, 60000), rng.uniform(0, 60, 60000), rng.normal(0, 0.01, 60000)]
    )
    parts = {
        # row houses: a party wall is seen only above the lower neighbour's roof
        "h1": _box_points(rng, 10, 10, 16, 20, 0, 6, walls_z0=(0, None, 0, 0)),
        "h2": _box_points(rng, 16, 10, 22, 20, 0, 8, walls_z0=(0, 6.5, 0, 6)),
        "h3": _box_points(rng, 22, 10, 28, 20, 0, 6.5, walls_z0=(0, 0, 0, None)),
        "court": np.vstack(
            [
                _box_points(rng, 40, 10, 60, 14, 0, 5),
                _box_points(rng, 40, 26, 60, 30, 0, 5),
                _box_points(rng, 40, 14, 44, 26, 0, 5),
                _box_points(rng, 56, 14, 60, 26, 0, 5),
            ]
        ),
        "twin": np.vstack(
            [_box_points(rng, 10, 40, 14, 44, 0, 3), _box_points(rng, 20, 40, 24, 44, 0, 3)]
        ),
        "wall": _box_points(rng, 0, 55, 80, 55.4, 0, 2),
    }
    crown = rng.normal(0, 1, (3000, 3))
    crown = crown / np.linalg.norm(crown, axis=1, keepdims=True) * rng.uniform(0, 3, (3000, 1))
    tree = crown + [34, 30, 7]
    ground_xy = ground[:, :2]
    inside_any = np.zeros(len(ground), bool)
    for x0, y0, x1, y1 in [(10, 10, 28, 20), (40, 10, 60, 30), (10, 40, 14, 44), (20, 40, 24, 44)]:
        inside_any |= (
            (ground_xy[:, 0] > x0)
            & (ground_xy[:, 0] < x1)
            & (ground_xy[:, 1] > y0)
            & (ground_xy[:, 1] < y1)
        )
    ground = ground[
        ~inside_any
        | (
            (ground_xy[:, 0] > 44)
            & (ground_xy[:, 0] < 56)
            & (ground_xy[:, 1] > 14)
            & (ground_xy[:, 1] < 26)
        )
    ]
    names = list(parts)
    xyz = np.vstack([ground, tree, *parts.values()])
    truth = np.concatenate(
        [
            np.zeros(len(ground) + len(tree), int),
            *[np.full(len(p), k + 1) for k, p in enumerate(parts.values())],
        ]
    )
    is_ground = np.zeros(len(xyz), bool)
    is_ground[: len(ground)] = True
    cloud = PointCloud.from_world(xyz + [E0, N0, 0], crs=CRS_UTM)
    off = lambda g: shapely.affinity.translate(g, E0, N0)  # noqa: E731
    court = shapely.box(40, 10, 60, 30).difference(shapely.box(44, 14, 56, 26))
    buildings = gpd.GeoDataFrame(
        {"name": ["h1", "h2", "h3", "court", "twin", "ghost"], "height_class": [1, 2, 1, 1, 0, 0]},
        geometry=[
            off(shapely.box(10, 10, 16, 20)),
            off(shapely.box(16, 10, 22, 20)),
            off(shapely.box(22, 10, 28, 20)),
            off(court),
            off(shapely.MultiPolygon([shapely.box(10, 40, 14, 44), shapely.box(20, 40, 24, 44)])),
            off(shapely.box(70, 30, 75, 35)),
        ],
        crs=CRS_UTM,
    )
    walls = gpd.GeoDataFrame(
        {"name": ["wall"], "material": ["brick"]},
        geometry=[off(shapely.box(0, 54.9, 80, 55.5))],
        crs=CRS_UTM,
    )
    return cloud, {"building": buildings, "wall": walls}, truth, names, is_ground


def test_row_houses_objects_balance_and_attributes(row_houses) -> None:
    cloud, layers, truth, names, is_ground = row_houses
    layers = prepare_layers(layers, cloud)
    res = segment_complex(cloud, layers, ComplexParams(ground="auto"))
    seg = res.segmentation
    counts = seg.check_balance()
    assert counts["objects"] + counts["ground"] + counts["remainder"] == len(cloud)
    # lowest objects first: the wall layer before the buildings
    assert res.layer_order == ("wall", "building")
    objs = seg.objects.set_index("name")
    assert set(objs.index) == {"h1", "h2", "h3", "court", "twin", "wall"}  # no ghost
    assert any("1 of 6 features got no points" in w for w in seg.warnings)
    assert objs.loc["wall", "material"] == "brick" and objs.loc["h2", "height_class"] == 2
    assert objs.loc["h2", "height"] == pytest.approx(8.0, abs=0.3)
    assert objs.loc["wall", "class"] == "wall" and objs.loc["h1", "class"] == "building"
    # per-object scores against the truth: touching houses never share points
    keys = {int(r.instance): names.index(name) + 1 for name, r in objs.iterrows()}
    pred = np.array([keys.get(i, 0) for i in range(seg.instance.max() + 1)])[seg.instance]
    ev = evaluate_objects(pred, truth)
    assert ev.objects["f1"].min() > 0.97, ev.objects[["reference", "precision", "recall", "f1"]]
    # the tree crown stays in the remainder, ground points are ground
    assert np.mean(seg.ground[is_ground]) > 0.98


def test_layer_outside_cloud_is_a_clear_error(row_houses) -> None:
    cloud, layers, *_ = row_houses
    far = layers["building"].set_geometry(layers["building"].translate(5000, 0))
    far.attrs["source"] = "far.gpkg"
    with pytest.raises(InputError, match=r"far\.gpkg: layer 'building': no polygon overlaps"):
        prepare_layers({"building": far}, cloud)


def test_crs_mismatch_needs_reprojection(row_houses) -> None:
    cloud, layers, *_ = row_houses
    wgs = layers["building"].to_crs(4326)
    with pytest.raises(InputError, match="differs from the cloud"):
        prepare_layers({"building": wgs}, cloud)
    ok = prepare_layers({"building": wgs}, cloud, reproject=True)
    assert ok["building"].crs.equals(CRS_UTM)


def test_bad_parameters_and_inputs(row_houses) -> None:
    cloud, layers, *_ = row_houses
    with pytest.raises(InputError, match="unknown ground method 'magic'"):
        ComplexParams(ground="magic")
    with pytest.raises(InputError, match="buffer_m must be > 0"):
        ComplexParams(buffer_m=-1)
    with pytest.raises(InputError, match="no points"):
        segment_complex(PointCloud(np.zeros((0, 3))), layers)
    nan = PointCloud(np.array([[0.0, 0, 0]] * 20 + [[np.nan, 0, 0]]))
    with pytest.raises(InputError, match="NaN"):
        segment_complex(nan, layers)
    with pytest.raises(InputError, match="must name each layer once"):
        segment_complex(cloud, prepare_layers(layers, cloud), ComplexParams(layer_order=("wall",)))
    with pytest.raises(InputError, match="needs an ASPRS classification"):
        segment_complex(cloud, prepare_layers(layers, cloud), ComplexParams(ground="class"))


def test_demo_scene_scores() -> None:
    from pyheracles.synthetic.complex_scene import ComplexSceneParams, kasepuhan_scene

    scene = kasepuhan_scene(ComplexSceneParams(n_points=150_000))
    res = segment_complex(scene.cloud, prepare_layers(scene.layers, scene.cloud))
    seg = res.segmentation
    seg.check_balance()
    ro = scene.reference_objects
    ev = evaluate_by_feature(seg.instance, seg.objects, scene.reference_instance, ro)
    f1 = ev.objects["f1"].dropna()
    assert np.median(f1) > 0.94, ev.objects[["object", "f1"]]
    assert f1.min() > 0.75
    assert res.layer_order[-1] == "building"


def test_ahn3_tile_buildings(shared_data: Path) -> None:
    from pyheracles.evaluate import reference_from_polygons
    from pyheracles.io import read_cloud, read_layer

    cloud = read_cloud(shared_data / "delft_ahn3" / "ahn3_tile1.laz")
    bgt = shared_data / "delft_ahn3" / "bgt"
    layers = {
        "building": read_layer(bgt / "bgt_pand.sqlite"),
        "wall": read_layer(bgt / "bgt_scheiding.sqlite"),
    }
    from dataclasses import replace

    cloud = replace(cloud, crs=layers["building"].crs)
    layers = prepare_layers(layers, cloud)
    res = segment_complex(cloud, layers, ComplexParams(ground="class"))
    seg = res.segmentation
    seg.check_balance()
    cls = cloud.attributes["classification"]
    ref = reference_from_polygons(
        cloud.world_xyz()[:, :2], cls == 6, layers["building"], buffer_m=1.0
    )
    b = seg.objects[seg.objects["class"] == "building"]
    pred_keys = dict(zip(b["instance"].astype(int), b["source_fid"].astype(int), strict=True))
    pred = np.zeros(len(cloud), np.int64)
    in_b = np.isin(seg.instance, b["instance"].to_numpy())
    pred[in_b] = np.array([pred_keys[i] + 1 for i in seg.instance[in_b]])
    ev = evaluate_objects(pred, ref)
    f1 = ev.objects["f1"].dropna().to_numpy()
    assert np.median(f1) > 0.97 and np.mean(f1 >= 0.9) >= 0.9  # the targets


def test_hedge_beside_a_shed_stays_out(rng) -> None:
    """A hedge against a shed mostly stays out of it: its foliage-like points off the
    footprint do not join (half a buffer out, more than twice as many would)."""
    ground = np.column_stack(
        [rng.uniform(0, 20, 5000), rng.uniform(0, 20, 5000), rng.normal(0, 0.01, 5000)]
    )
    ground = ground[~((ground[:, 0] > 8) & (ground[:, 0] < 12) & (ground[:, 1] > 8))
                    | (ground[:, 1] > 11)]  # fmt: skip
    shed = _box_points(rng, 8, 8, 12, 11, 0, 2.5, density=15.0)
    hedge = np.column_stack(
        [rng.uniform(12.3, 13.8, 1500), rng.uniform(7, 12, 1500), rng.uniform(0.2, 2.0, 1500)]
    )
    xyz = np.vstack([ground, shed, hedge])
    is_shed = np.r_[
        np.zeros(len(ground), bool), np.ones(len(shed), bool), np.zeros(len(hedge), bool)
    ]
    is_hedge = np.r_[np.zeros(len(ground) + len(shed), bool), np.ones(len(hedge), bool)]
    cloud = PointCloud.from_world(xyz + [E0, N0, 0], crs=CRS_UTM)
    layer = gpd.GeoDataFrame(
        {"name": ["shed"]},
        geometry=[shapely.affinity.translate(shapely.box(8, 8, 12, 11), E0, N0)],
        crs=CRS_UTM,
    )
    layers = prepare_layers({"building": layer}, cloud)
    common = dict(ground="none", buffer_m=1.0, cluster_distance_m=0.6)
    seg = segment_complex(cloud, layers, ComplexParams(**common)).segmentation
    seg.check_balance()
    taken = ((seg.instance == 1) & is_hedge).sum()
    loose = ComplexParams(**common, scatter_offset_m=0.5)
    seg_loose = segment_complex(cloud, layers, loose).segmentation
    taken_loose = ((seg_loose.instance == 1) & is_hedge).sum()
    assert taken < 0.1 * is_hedge.sum() and taken < 0.6 * taken_loose
    assert ((seg.instance == 1) & is_shed).sum() > 0.97 * is_shed.sum()
    with pytest.raises(InputError, match="scatter_offset_m must be >= 0"):
        ComplexParams(scatter_offset_m=-0.1)
