"""Tests of per-object / ground scores, the polygon reference and ``heracles evaluate``."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
import shapely
import shapely.affinity
from shapely.geometry import box

from pyheracles.errors import InputError
from pyheracles.evaluate import evaluate_objects, ground_scores, reference_from_polygons

# reference: three objects of 40, 30, 20 points plus 10 unlabelled points
REF = np.repeat([1, 2, 3, 0], [40, 30, 20, 10]).astype(np.int32)


def _row(ev, ref_id):
    return ev.objects.set_index("reference").loc[ref_id]


def test_perfect_prediction_with_other_ids():
    pred = np.select([REF == 1, REF == 2, REF == 3], [7, 5, 9], 0)
    ev = evaluate_objects(pred, REF)
    assert ev.objects["reference"].tolist() == [1, 2, 3]
    assert [p for (p,) in ev.objects["predicted"]] == [7, 5, 9]
    np.testing.assert_allclose(ev.objects[["precision", "recall", "f1"]], 1.0)
    np.testing.assert_allclose(ev.objects["unclassified_pct"], 0.0)
    table = ev.table()
    assert table["object"].tolist()[-2:] == ["mean", "median"]
    np.testing.assert_allclose(table.iloc[-2:][["precision", "recall", "f1"]], 1.0)
    assert ev.unmatched.empty


def test_half_prediction():
    pred = REF.copy()
    rng = np.random.default_rng(0)
    for k in (1, 2, 3):  # drop a random half of every object into the remainder
        idx = np.flatnonzero(REF == k)
        pred[rng.choice(idx, len(idx) // 2, replace=False)] = 0
    ev = evaluate_objects(pred, REF)
    np.testing.assert_allclose(ev.objects["precision"], 1.0)
    np.testing.assert_allclose(ev.objects["recall"], 0.5)
    np.testing.assert_allclose(ev.objects["f1"], 2 / 3)
    np.testing.assert_allclose(ev.objects["unclassified_pct"], 50.0)


def test_half_prediction_spilling_into_neighbour():
    # object 1 takes the first half of object 2: precision of 1 drops, recall of 2 drops
    pred = REF.copy()
    pred[np.flatnonzero(REF == 2)[:15]] = 1
    ev = evaluate_objects(pred, REF)
    r1, r2 = _row(ev, 1), _row(ev, 2)
    assert (r1["tp"], r1["fp"], r1["fn"]) == (40, 15, 0)
    assert r1["precision"] == pytest.approx(40 / 55)
    assert (r2["tp"], r2["fp"], r2["fn"]) == (15, 0, 15)
    assert r2["recall"] == pytest.approx(0.5)
    assert r2["unclassified_pct"] == 0.0  # its lost points went to object 1, not to nothing


def test_empty_prediction():
    ev = evaluate_objects(np.zeros_like(REF), REF)
    assert ev.objects["precision"].isna().all()
    np.testing.assert_allclose(ev.objects["recall"], 0.0)
    np.testing.assert_allclose(ev.objects["f1"], 0.0)
    np.testing.assert_allclose(ev.objects["unclassified_pct"], 100.0)
    summ = ev.summary()
    assert np.isnan(summ.loc["mean", "precision"])
    assert summ.loc["median", "recall"] == 0.0
    assert ev.totals()["n_matched"] == 0


def test_mean_and_median_rows():
    # recalls 1.0 (obj 1), 0.5 (obj 2), 0.25 (obj 3); no false positives
    pred = REF.copy()
    pred[np.flatnonzero(REF == 2)[:15]] = 0
    pred[np.flatnonzero(REF == 3)[:15]] = 0
    ev = evaluate_objects(pred, REF)
    table = ev.table().set_index("object")
    assert table.loc["mean", "recall"] == pytest.approx((1.0 + 0.5 + 0.25) / 3)
    assert table.loc["median", "recall"] == pytest.approx(0.5)
    f1 = [1.0, 2 * 0.5 / 1.5, 2 * 0.25 / 1.25]
    assert table.loc["mean", "f1"] == pytest.approx(np.mean(f1))
    assert table.loc["median", "f1"] == pytest.approx(np.median(f1))
    assert table.loc["mean", "unclassified_pct"] == pytest.approx((0 + 50 + 75) / 3)


def test_summary_by_layer():
    pred = REF.copy()
    pred[np.flatnonzero(REF == 2)[:15]] = 0  # object 2: recall 0.5
    objects = pd.DataFrame({"instance": [1, 2, 3], "layer": ["building", "building", "wall"]})
    ev = evaluate_objects(pred, REF, reference_objects=objects)
    per = ev.summary(by="layer")
    assert per.loc[("building", "mean"), "recall"] == pytest.approx(0.75)
    assert per.loc[("wall", "median"), "f1"] == 1.0
    assert ev.to_dict()["summary_by_layer"]["building"]["mean"]["recall"] == pytest.approx(0.75)
    with pytest.raises(InputError):
        ev.summary(by="nope")


def test_count_balance_on_random_labels():
    rng = np.random.default_rng(4)
    ref = rng.integers(0, 12, 5000)
    pred = np.where(rng.random(5000) < 0.7, ref, rng.integers(0, 15, 5000))
    ev = evaluate_objects(pred, ref)
    o = ev.objects
    assert (o["tp"] + o["fn"] == o["n_reference"]).all()
    assert (o["tp"] + o["fp"] == o["n_predicted"]).all()
    assert (o["n_unclassified"] <= o["fn"]).all()
    assert o["n_reference"].sum() == np.count_nonzero(ref)
    matched = {p for t in o["predicted"] for p in t}
    n_pred = np.bincount(pred)
    assert sum(n_pred[p] for p in matched) + ev.unmatched["n_points"].sum() == np.count_nonzero(
        pred
    )
    assert o["n_unclassified"].sum() == np.count_nonzero((pred == 0) & (ref > 0))


def test_overlap_matching_is_one_to_one():
    # one predicted blob covers objects 1 and 2; a small one covers 2's tail
    pred = np.where((REF == 1) | (REF == 2), 4, 0)
    pred[np.flatnonzero(REF == 2)[-5:]] = 6
    ev = evaluate_objects(pred, REF)
    assert _row(ev, 1)["predicted"] == (4,)
    assert _row(ev, 2)["predicted"] == (6,)
    assert _row(ev, 3)["predicted"] == ()
    assert ev.unmatched.empty


def test_key_matching_merges_instances_and_reports_unmatched():
    ref_keys = {1: "B01", 2: "B02", 3: "W01"}
    pred = np.select([REF == 1, REF == 2, REF == 3], [10, 11, 12], 0)
    pred[np.flatnonzero(REF == 1)[:10]] = 13  # a second cluster of B01
    pred[np.flatnonzero(REF == 0)[:4]] = 14  # an object not in the reference
    pred_keys = {10: "B01", 13: "B01", 11: "W01", 12: "B02", 14: "X99"}  # 2 and 3 swapped
    ev = evaluate_objects(pred, REF, match="key", predicted_keys=pred_keys, reference_keys=ref_keys)
    r1 = _row(ev, 1)
    assert r1["key"] == "B01" and r1["predicted"] == (10, 13)
    assert r1["f1"] == 1.0
    # swapped keys: paired by key although they share no point
    assert _row(ev, 2)["tp"] == 0 and _row(ev, 2)["n_predicted"] == 20
    assert _row(ev, 2)["precision"] == 0.0 and _row(ev, 2)["f1"] == 0.0
    assert ev.unmatched["key"].tolist() == ["X99"]
    assert ev.unmatched["n_points"].tolist() == [4]


def test_key_matching_unkeyed_predictions_and_duplicate_keys():
    pred = np.select([REF == 1, REF == 2], [10, 11], 0)
    pred[np.flatnonzero(REF == 0)[:3]] = 12
    ev = evaluate_objects(
        pred, REF, match="key", predicted_keys={10: "a", 11: None}, reference_keys={1: "a", 2: "b"}
    )
    assert _row(ev, 1)["f1"] == 1.0
    assert _row(ev, 2)["predicted"] == () and _row(ev, 2)["n_unclassified"] == 0
    assert sorted(ev.unmatched["n_points"]) == [3, 30]  # 11 (no key) and 12 (not listed)
    assert ev.unmatched["key"].isna().all()
    with pytest.raises(InputError, match="share the key"):
        evaluate_objects(pred, REF, match="key", predicted_keys={}, reference_keys={1: 1, 2: 1})


def test_reference_objects_without_points():
    objects = pd.DataFrame({"instance": [1, 2, 3, 4], "name": ["a", "b", "c", "gone"]})
    ev = evaluate_objects(REF, REF, reference_objects=objects)
    gone = _row(ev, 4)
    assert gone["n_reference"] == 0 and np.isnan(gone["f1"]) and gone["name"] == "gone"
    assert ev.summary().loc["mean", "f1"] == 1.0  # empty objects are not averaged
    assert ev.totals()["n_reference_objects"] == 3
    payload = json.dumps(ev.to_dict())
    assert '"gone"' in payload and "NaN" not in payload


@pytest.mark.parametrize(
    ("pred", "kwargs"),
    [
        (REF[:-1], {}),
        (REF - 1, {}),
        (REF, {"match": "iou"}),
        (REF, {"match": "key"}),
        (REF + 0.5, {}),
    ],
)
def test_bad_input(pred, kwargs):
    with pytest.raises(InputError):
        evaluate_objects(pred, REF, **kwargs)


def test_ground_scores_known_values():
    ref = np.array([True] * 60 + [False] * 40)
    pred = ref.copy()
    pred[:6] = False  # 6 ground points rejected (type I)
    pred[60:64] = True  # 4 object points accepted (type II)
    s = ground_scores(pred, ref)
    assert (s["tp"], s["fp"], s["fn"], s["tn"]) == (54, 4, 6, 36)
    assert s["precision"] == pytest.approx(54 / 58)
    assert s["recall"] == pytest.approx(0.9)
    assert s["type_i"] == pytest.approx(10.0)
    assert s["type_ii"] == pytest.approx(10.0)
    assert s["total"] == pytest.approx(10.0)
    p_exp = (58 * 60 + 42 * 40) / 100**2
    assert s["kappa"] == pytest.approx((0.9 - p_exp) / (1 - p_exp))
    perfect = ground_scores(ref, ref)
    assert perfect["kappa"] == 1.0 and perfect["f1"] == 1.0
    with pytest.raises(InputError):
        ground_scores(pred[:-1], ref)
    with pytest.raises(InputError):
        ground_scores(pred.astype(int), ref)


def test_reference_from_polygons_nearest_wins():
    polys = [box(0, 0, 10, 10), box(12, 0, 20, 10), box(20, 0, 30, 10)]  # 2 and 3 touch
    xy = np.array(
        [
            [5, 5],  # inside 1
            [10.4, 5],  # 0.4 m from 1, 1.6 m from 2 -> 1
            [11.3, 5],  # 1.3 from 1, 0.7 from 2 -> 2
            [5, 10.9],  # 0.9 m outside 1 -> 1
            [5, 11.2],  # 1.2 m outside 1 -> none
            [25, 5],  # inside 3
            [19.99, 5],  # inside 2, 0.01 from 3 -> 2
            [5, 6],  # inside 1 but not a reference point
        ]
    )
    mask = np.array([True] * 7 + [False])
    labels = reference_from_polygons(xy, mask, polys, buffer_m=1.0)
    assert labels.dtype == np.int32
    assert labels.tolist() == [1, 1, 2, 1, 0, 3, 2, 0]
    strict = reference_from_polygons(xy, mask, polys, buffer_m=0.0)
    assert strict.tolist() == [1, 0, 0, 0, 0, 3, 2, 0]


def test_reference_from_polygons_bad_input():
    with pytest.raises(InputError):
        reference_from_polygons(np.zeros((3, 2)), np.ones(2, bool), [box(0, 0, 1, 1)])
    with pytest.raises(InputError):
        reference_from_polygons(np.zeros((3, 2)), np.ones(3, bool), [shapely.Point(0, 0)])
    with pytest.raises(InputError):
        reference_from_polygons(np.zeros((3, 2)), np.ones(3, bool), [box(0, 0, 1, 1)], -1.0)


@pytest.mark.realdata
def test_reference_from_polygons_delft(shared_data):
    import laspy
    import pyogrio

    las = laspy.read(shared_data / "delft_ahn3" / "ahn3_tile1.laz")
    xy = np.column_stack([las.x, las.y])
    cls6 = np.asarray(las.classification) == 6
    pand = pyogrio.read_dataframe(shared_data / "delft_ahn3" / "bgt" / "bgt_pand.sqlite")
    pand = pand[pand.geometry.notna() & ~pand.geometry.is_empty].reset_index(drop=True)
    labels = reference_from_polygons(xy, cls6, pand, buffer_m=1.0)
    assert not labels[~cls6].any()
    # the BGT polygons cover only part of the tile: look at building points near them
    near = shapely.contains_xy(
        shapely.union_all(pand.geometry.values).buffer(10.0), xy[:, 0], xy[:, 1]
    )
    share = np.count_nonzero(labels) / np.count_nonzero(cls6 & near)
    assert share > 0.85  # most building points lie in or next to a BGT footprint
    assert len(np.unique(labels[labels > 0])) > 100  # of the 160 footprints
    # cross-check "inside" with an independent GEOS predicate query (all containing polygons)
    idx6 = np.flatnonzero(cls6)
    i_pt, i_poly = shapely.STRtree(pand.geometry.values).query(
        shapely.points(xy[idx6]), predicate="within"
    )
    inside_any = np.zeros(len(xy), int)
    np.add.at(inside_any, idx6[i_pt], 1)
    first = np.zeros(len(xy), np.int32)
    first[idx6[i_pt]] = i_poly + 1  # only compared where a single polygon contains the point
    single = inside_any == 1
    assert single.sum() > 0.8 * np.count_nonzero(labels)
    np.testing.assert_array_equal(labels[single], first[single])
    # a 0 m buffer keeps exactly the points inside
    strict = reference_from_polygons(xy, cls6, pand, buffer_m=0.0)
    assert np.array_equal(strict > 0, inside_any > 0)


# ----------------------------------------------------------------------------- CLI
@pytest.fixture(scope="module")
def scene_files(tmp_path_factory):
    from pyheracles.synthetic.complex_scene import (
        ComplexSceneParams,
        kasepuhan_scene,
        write_scene,
    )

    scene = kasepuhan_scene(ComplexSceneParams(n_points=20_000, seed=5))
    paths = write_scene(scene, tmp_path_factory.mktemp("scene"))
    return scene, paths


def _write_result(scene, folder, instance, ground):
    from pyheracles.io import write_cloud

    folder.mkdir(parents=True, exist_ok=True)
    cloud = scene.cloud.with_attributes(classification=np.where(ground, 2, 1).astype(np.uint8))
    path = write_cloud(cloud, folder / "segmented.laz", {"instance": instance.astype(np.int32)})
    return path


def test_cli_evaluate_by_key(scene_files, tmp_path):
    from pyheracles.cli import main

    scene, paths = scene_files
    ref = scene.reference_instance
    # predicted ids = reference ids + 100, every 4th point of each object lost
    pred = np.where(ref > 0, ref + 100, 0)
    pred[::4] = 0
    result = _write_result(scene, tmp_path / "res", pred, scene.ground)
    obj = scene.reference_objects
    pd.DataFrame({"instance": obj["instance"] + 100, "fid": obj["fid"]}).to_csv(
        tmp_path / "res" / "objects.csv", index=False
    )
    code = main(["evaluate", str(result), "--reference", str(paths["cloud"]), "--key", "fid"])
    assert code == 0
    table = pd.read_csv(tmp_path / "res" / "evaluation.csv")
    assert table["object"].tolist()[-2:] == ["mean", "median"]
    assert len(table) == len(obj) + 2
    body = table.iloc[:-2].set_index("object")
    assert set(body.index) == set(obj["fid"])
    scored = body[body["n_reference"] > 0]
    np.testing.assert_allclose(scored["precision"], 1.0)
    kept = np.bincount(ref[pred > 0], minlength=len(obj) + 1)
    total = np.bincount(ref, minlength=len(obj) + 1)
    inst = obj.set_index("fid").loc[scored.index, "instance"].to_numpy()
    np.testing.assert_allclose(scored["recall"], kept[inst] / total[inst], rtol=1e-9)
    assert scored["recall"].mean() == pytest.approx(0.75, abs=0.03)
    assert np.isnan(body.loc["B20", "f1"])  # demolished: no reference points
    payload = json.loads((tmp_path / "res" / "evaluation.json").read_text())
    assert payload["match"] == "key"
    assert payload["ground"]["precision"] == 1.0 and payload["ground"]["recall"] == 1.0
    assert payload["totals"]["tp"] + payload["totals"]["fn"] == np.count_nonzero(ref)


def test_cli_evaluate_by_overlap_to_other_folder(scene_files, tmp_path):
    from pyheracles.cli import main

    scene, paths = scene_files
    result = _write_result(scene, tmp_path / "res", scene.reference_instance, scene.ground)
    out = tmp_path / "scores"
    assert main(["evaluate", str(result), "-r", str(paths["cloud"]), "-o", str(out)]) == 0
    table = pd.read_csv(out / "evaluation.csv").set_index("object")
    np.testing.assert_allclose(table.loc[["mean", "median"], ["precision", "recall", "f1"]], 1.0)


def test_cli_evaluate_bad_input(scene_files, tmp_path, capsys):
    from pyheracles.cli import main
    from pyheracles.io import write_cloud

    scene, paths = scene_files
    ref = str(paths["cloud"])
    # fewer points than the reference
    short = write_cloud(
        scene.cloud.subset(np.arange(100)), tmp_path / "short.laz", {"instance": np.zeros(100)}
    )
    assert main(["evaluate", str(short), "--reference", ref]) == 2
    assert "points" in capsys.readouterr().err
    # same points in another order
    perm = np.random.default_rng(0).permutation(len(scene.cloud))
    shuffled = write_cloud(
        scene.cloud.subset(perm), tmp_path / "shuffled.laz", {"instance": np.zeros(len(perm))}
    )
    assert main(["evaluate", str(shuffled), "--reference", ref]) == 2
    # no instance dimension
    plain = write_cloud(scene.cloud, tmp_path / "plain.laz")
    assert main(["evaluate", str(plain), "--reference", ref]) == 2
    # --key without a result objects table, and an unknown key column
    result = _write_result(scene, tmp_path / "res", scene.reference_instance, scene.ground)
    assert main(["evaluate", str(result), "--reference", ref, "--key", "fid"]) == 2
    pd.DataFrame({"instance": [1], "fid": ["B01"]}).to_csv(tmp_path / "res" / "objects.csv")
    assert main(["evaluate", str(result), "--reference", ref, "--key", "nope"]) == 2
    # missing file
    assert main(["evaluate", str(tmp_path / "missing.laz"), "--reference", ref]) == 2


@pytest.mark.realdata
def test_cli_evaluate_delft_polygons(shared_data, tmp_path):
    """Prediction = class-6 points strictly inside the footprints; reference adds 1 m."""
    import laspy
    import pyogrio

    from pyheracles.cli import main
    from pyheracles.io import read_cloud, write_cloud

    tile = shared_data / "delft_ahn3" / "ahn3_tile1.laz"
    pand_path = shared_data / "delft_ahn3" / "bgt" / "bgt_pand.sqlite"
    cloud = read_cloud(tile)
    cls6 = np.asarray(cloud.attributes["classification"]) == 6
    pand = pyogrio.read_dataframe(pand_path)
    strict = reference_from_polygons(cloud.world_xyz(), cls6, pand, buffer_m=0.0)
    res = tmp_path / "res"
    write_cloud(cloud, res / "segmented.laz", {"instance": strict})
    pd.DataFrame({"instance": np.arange(1, len(pand) + 1), "gml_id": pand["gml_id"]}).to_csv(
        res / "objects.csv", index=False
    )
    args = ["evaluate", str(res / "segmented.laz"), "--reference", str(tile)]
    args += ["--reference-polygons", str(pand_path), "--key", "gml_id"]
    assert main(args) == 0
    body = pd.read_csv(res / "evaluation.csv").iloc[:-2]
    scored = body[body["n_reference"] > 0]
    assert len(scored) > 100
    np.testing.assert_allclose(scored["precision"].dropna(), 1.0)
    assert (scored["recall"] <= 1.0).all() and scored["recall"].mean() > 0.8
    assert laspy.read(res / "segmented.laz").header.point_count == len(cloud)


# ----------------------------------------------------------------------------- issue 15
@pytest.fixture
def two_buildings(tmp_path):
    """Reference cloud (UTM 32N, class 6 on two roofs) and a result cloud of the same points."""
    from pyheracles.cloud import PointCloud
    from pyheracles.io import write_cloud

    rng = np.random.default_rng(0)
    xy = rng.uniform(0, 60, (8000, 2))
    a = (np.abs(xy - [15, 15]) < 5).all(axis=1)
    b = (np.abs(xy - [45, 40]) < 6).all(axis=1)
    z = np.where(a | b, 6.0, 0.0)
    origin = np.array([500_000.0, 5_400_000.0, 100.0])
    cls = np.where(a | b, 6, 2).astype(np.uint8)
    cloud = PointCloud.from_world(np.c_[xy, z] + origin, crs="EPSG:32632")
    cloud = cloud.with_attributes(classification=cls)
    ref = write_cloud(cloud, tmp_path / "ref.laz")
    res = write_cloud(cloud, tmp_path / "res" / "segmented.laz",
                      {"instance": (a * 1 + b * 2).astype(np.int32)})  # fmt: skip
    polys = [shapely.box(10, 10, 20, 20), shapely.box(39, 34, 51, 46)]
    polys = [shapely.affinity.translate(p, *origin[:2]) for p in polys]
    return ref, res, polys


def test_cli_reference_polygons_in_another_crs(two_buildings, tmp_path, capsys):
    """Issue 15, defect 8: polygons in another CRS gave an IndexError; now step 1's error,
    or a reprojection with a note when --reproject is given."""
    import geopandas as gpd

    from pyheracles.cli import main

    ref, res, polys = two_buildings
    gdf = gpd.GeoDataFrame({"name": ["A", "B"]}, geometry=polys, crs=32632).to_crs(4326)
    gdf.to_file(tmp_path / "wgs84.gpkg", driver="GPKG")
    args = [
        "evaluate",
        str(res),
        "-r",
        str(ref),
        "--reference-polygons",
        str(tmp_path / "wgs84.gpkg"),
    ]
    assert main(args) == 2
    err = " ".join(capsys.readouterr().err.split())
    assert "layer CRS EPSG:4326 differs from the cloud's EPSG:32632" in err
    assert "--reproject" in err
    assert main([*args, "--reproject"]) == 0
    out = capsys.readouterr().out
    assert "reprojected from EPSG:4326 to EPSG:32632" in " ".join(out.split())
    table = pd.read_csv(res.parent / "evaluation.csv").iloc[:-2]
    np.testing.assert_allclose(table["f1"], 1.0)
    # a cloud without CRS and polygons somewhere else: the overlap check, no IndexError
    from pyheracles.cloud import PointCloud
    from pyheracles.io import read_cloud, write_cloud

    full = read_cloud(ref)
    plain = PointCloud.from_world(full.world_xyz()).with_attributes(
        classification=np.asarray(full.attributes["classification"])
    )
    plain = write_cloud(plain, tmp_path / "nocrs.laz")
    assert read_cloud(plain).crs is None
    assert main(["evaluate", str(res), "-r", str(plain), "--reference-polygons",
                 str(tmp_path / "wgs84.gpkg")]) == 2  # fmt: skip
    assert "no polygon overlaps the cloud" in " ".join(capsys.readouterr().err.split())


def test_cli_self_intersecting_reference_polygons_are_refused(two_buildings, tmp_path, capsys):
    import geopandas as gpd

    from pyheracles.cli import main

    ref, res, polys = two_buildings
    x0, y0 = 500_010.0, 5_400_010.0
    bowtie = shapely.Polygon([(x0, y0), (x0 + 10, y0 + 10), (x0 + 10, y0), (x0, y0 + 10)])
    gdf = gpd.GeoDataFrame({"name": ["A", "B"]}, geometry=[bowtie, polys[1]], crs=32632)
    gdf.to_file(tmp_path / "bowtie.gpkg", driver="GPKG")
    args = [
        "evaluate",
        str(res),
        "-r",
        str(ref),
        "--reference-polygons",
        str(tmp_path / "bowtie.gpkg"),
    ]
    assert main(args) == 2
    err = " ".join(capsys.readouterr().err.split())
    assert "1 invalid polygons (rows [0]: Self-intersection" in err and "--fix-invalid" in err
    assert main([*args, "--fix-invalid"]) == 0
    # the library function says the same
    with pytest.raises(InputError, match="1 invalid polygons"):
        reference_from_polygons(np.zeros((3, 2)), np.ones(3, bool), [bowtie])


def test_reference_from_polygons_that_miss_every_point():
    """No point in any polygon (another CRS, another area): all 0, not an IndexError."""
    labels = reference_from_polygons(
        [[0.5, 0.5], [1.5, 0.5]], [True, True], [box(100, 100, 101, 101)], buffer_m=0.0
    )
    assert labels.tolist() == [0, 0]
    labels = reference_from_polygons([[0.5, 0.5]], [True], [box(100, 100, 101, 101)])
    assert labels.tolist() == [0]
