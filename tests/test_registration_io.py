"""Point lists, transform.json, exact transformation of clouds, check point reports."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from pyheracles.cloud import PointCloud
from pyheracles.errors import InputError
from pyheracles.registration.checkpoints import check_points, plot_residual_map
from pyheracles.registration.points import (
    PointList,
    pair_points,
    read_points,
    write_points,
)
from pyheracles.registration.similarity import estimate_similarity, similarity_matrix
from pyheracles.registration.transform import (
    apply_to_cloud,
    apply_to_points,
    invert,
    read_transform_json,
    write_transform_json,
)


def _write(tmp_path: Path, name: str, text: str) -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


def test_read_points_with_sigmas_and_leading_zero_ids(tmp_path: Path) -> None:
    p = _write(
        tmp_path,
        "gcp.csv",
        "ID;E;N;H;sX;sY;sZ\n007;1049817.412;6842301.118;148.305;0.005;0.005;0.008\n"
        "008;1049820.000;6842310.5;149.0;0.005;0.005;0.008\n",
    )
    pts = read_points(p)
    assert pts.ids == ("007", "008")
    assert pts.xyz[0, 0] == 1049817.412
    np.testing.assert_allclose(pts.sigma[0], [0.005, 0.005, 0.008])


def test_read_points_whitespace_and_no_sigma(tmp_path: Path) -> None:
    p = _write(tmp_path, "a.txt", "name x y z\nA 1 2 3\nB 4 5 6\n")
    pts = read_points(p)
    assert pts.sigma is None and len(pts) == 2


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("id,X,Y,Z\nA,1,2,3\nA,4,5,6\n", "duplicated point ids: 'A'"),
        ("id,X,Y\nA,1,2\n", "missing column"),
        ("id,X,Y,Z\nA,1,two,3\n", "non-numeric"),
        ("id,X,Y,Z\n", "no points"),
        ("id,X,Y,Z,sX,sY,sZ\nA,1,2,3,-1,0,0\n", "standard deviations"),
    ],
)
def test_bad_point_lists(tmp_path: Path, text: str, match: str) -> None:
    p = _write(tmp_path, "bad.csv", text)
    with pytest.raises(InputError, match=match) as exc:
        read_points(p)
    assert "bad.csv" in str(exc.value)


def test_pairing_unmatched_ids() -> None:
    a = PointList(("1", "2", "3", "4"), np.zeros((4, 3)), source="a.csv")
    b = PointList(("2", "3", "4", "5"), np.ones((4, 3)), source="b.csv")
    with pytest.raises(InputError, match=r"'1' only in a.csv; '5' only in b.csv"):
        pair_points(a, b)
    pairs = pair_points(a, b, unmatched="ignore")
    assert pairs.ids == ("2", "3", "4") and pairs.only_in_a == ("1",)
    with pytest.raises(InputError, match="only 3 point id"):
        pair_points(a, b, unmatched="ignore", min_pairs=4)


def test_points_round_trip(tmp_path: Path) -> None:
    pts = PointList(("a", "b"), [[452000.1234, 5400000.5678, 12.3], [1, 2, 3]], sigma=0.01)
    write_points(tmp_path / "p.csv", pts)
    back = read_points(tmp_path / "p.csv")
    np.testing.assert_allclose(back.xyz, pts.xyz, atol=1e-4)
    np.testing.assert_allclose(back.sigma, 0.01)


def test_apply_to_cloud_keeps_large_coordinates_exact() -> None:
    rng = np.random.default_rng(0)
    world = rng.uniform(0, 30, (1000, 3)) + np.array([1049800.0, 6842300.0, 140.0])
    cloud = PointCloud.from_world(world)
    T = similarity_matrix([-1000.25, 250.5, 3.0], [0.001, -0.002, 0.7], 1.0001)
    moved = apply_to_cloud(cloud, T)
    expected = apply_to_points(T, world)
    # the reference itself is float64 on 7-digit numbers: agreement to 1e-7 m
    np.testing.assert_allclose(moved.world_xyz(), expected, atol=1e-7)
    assert np.abs(moved.xyz).max() < 100  # local coordinates stay small
    back = apply_to_cloud(moved, invert(T), offset=cloud.offset)
    np.testing.assert_allclose(back.xyz, cloud.xyz, atol=1e-8)


def test_transform_json_round_trip(tmp_path: Path) -> None:
    rng = np.random.default_rng(2)
    T = similarity_matrix([10, 20, 30], [0.1, 0.2, 0.3], 0.999)
    src = rng.uniform(-5, 5, (8, 3))
    res = estimate_similarity(src, apply_to_points(T, src) + rng.normal(0, 0.001, (8, 3)))
    path = write_transform_json(tmp_path / "transform.json", res.T_target_source, result=res)
    data = json.loads(path.read_text())
    assert set(data["estimation"]["std"]) == {"tx", "ty", "tz", "omega", "phi", "kappa", "scale"}
    np.testing.assert_allclose(read_transform_json(path), res.T_target_source)
    assert data["scale"] == pytest.approx(0.999, abs=1e-3)
    (tmp_path / "bad.json").write_text("{}")
    with pytest.raises(InputError, match="T_target_source"):
        read_transform_json(tmp_path / "bad.json")


def test_checkpoint_report_and_map(tmp_path: Path) -> None:
    rng = np.random.default_rng(4)
    ref = rng.uniform(0, 40, (9, 3)) + np.array([1049800.0, 6842300.0, 0.0])
    v = rng.normal(0, 0.01, (9, 3))
    rep = check_points(ref, ref - v, ids=[f"CP{i}" for i in range(9)])
    np.testing.assert_allclose(rep.residuals, v, atol=1e-9)
    assert rep.rms["3d"] == pytest.approx(np.sqrt(np.mean(np.sum(v**2, axis=1))))
    png = plot_residual_map(rep, tmp_path / "map.png")
    assert png.read_bytes()[:4] == b"\x89PNG"
    assert rep.to_dict()["points"][0]["id"] == "CP0"
    with pytest.raises(InputError, match="no check points"):
        check_points(np.zeros((0, 3)), np.zeros((0, 3)))


def test_apply_to_cloud_keeps_extra_bytes_and_vlrs_but_not_the_old_crs(tmp_path: Path) -> None:
    import laspy
    from pyproj import CRS

    from pyheracles.io import read_cloud, write_cloud

    n = 200
    rng = np.random.default_rng(3)
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.add_extra_dims([laspy.ExtraBytesParams("reflectance_db", "f4")])
    header.vlrs.append(laspy.VLR("survey", 7, "station log", b"station A, 2026-11-30"))
    header.add_crs(CRS.from_epsg(2056))
    header.scales = np.full(3, 0.001)
    header.offsets = np.array([2600000.0, 1200000.0, 400.0])
    las = laspy.LasData(header)
    xyz = rng.uniform(0, 20, (n, 3)) + header.offsets
    las.x, las.y, las.z = xyz.T
    las.reflectance_db = rng.uniform(-20, 0, n).astype(np.float32)
    las.intensity = rng.integers(1, 60000, n).astype(np.uint16)
    las.write(tmp_path / "in.las")

    cloud = read_cloud(tmp_path / "in.las")
    T = similarity_matrix([-2599990.0, -1199990.0, -400.0], [0.0, 0.0, 0.3], 1.0)
    moved = apply_to_cloud(cloud, T)  # a local frame: no CRS
    write_cloud(moved, tmp_path / "out.las")
    back = laspy.read(tmp_path / "out.las")
    np.testing.assert_allclose(back.reflectance_db, las.reflectance_db)
    np.testing.assert_array_equal(back.intensity, las.intensity)
    log = b"station A, 2026-11-30"
    assert any(v.user_id == "survey" and v.record_data == log for v in back.vlrs)
    assert back.header.parse_crs() is None  # the Swiss grid no longer describes the points
    # the source cloud's header is untouched
    assert cloud.las_header.parse_crs() is not None

    moved_to = apply_to_cloud(cloud, similarity_matrix([0, 0, 0], [0, 0, 0], 1.0), crs="EPSG:2056")
    write_cloud(moved_to, tmp_path / "same.las")
    assert laspy.read(tmp_path / "same.las").header.parse_crs().to_epsg() == 2056
