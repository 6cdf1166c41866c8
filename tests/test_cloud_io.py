"""PointCloud, LAS/LAZ/PLY/text readers and writers, atomic writes, provenance."""

from __future__ import annotations

import json
from pathlib import Path

import laspy
import numpy as np
import pytest
from pyproj import CRS

from pyheracles import InputError, PointCloud
from pyheracles.io import read_cloud, write_cloud
from pyheracles.io.atomic import atomic_path
from pyheracles.provenance import write_run_json


def _rd_cloud(rng: np.random.Generator, n: int = 1000) -> PointCloud:
    world = np.column_stack(
        [85000 + rng.uniform(0, 100, n), 447000 + rng.uniform(0, 100, n), rng.uniform(-2, 30, n)]
    )
    world = np.round(world, 3)
    return PointCloud.from_world(
        world,
        attributes={"intensity": rng.integers(0, 5000, n).astype(np.uint16)},
        crs=CRS.from_epsg(28992),
    )


def test_from_world_keeps_millimetres_on_national_grid() -> None:
    world = np.array([[85000.001, 447000.002, 1.003], [85123.456, 447654.321, 12.345]])
    pc = PointCloud.from_world(world)
    assert np.abs(pc.xyz).max() < 1000  # local frame
    np.testing.assert_allclose(pc.world_xyz(), world, atol=1e-9)


def test_validate_rejects_empty_and_nan() -> None:
    with pytest.raises(InputError, match="no points"):
        PointCloud(np.zeros((0, 3)), source="empty.laz").validate()
    bad = PointCloud(np.array([[0.0, 0, 0], [np.nan, 1, 1]]), source="nan.laz")
    with pytest.raises(InputError, match=r"nan\.laz: the point cloud has 1 points with NaN"):
        bad.validate()


def test_attribute_length_is_checked() -> None:
    with pytest.raises(InputError, match="attribute 'a' has 2 values for 3 points"):
        PointCloud(np.zeros((3, 3)), attributes={"a": np.zeros(2)})


@pytest.mark.parametrize("suffix", [".laz", ".las"])
def test_las_round_trip_exact_with_extra_dims(tmp_path: Path, rng, suffix: str) -> None:
    pc = _rd_cloud(rng)
    inst = rng.integers(0, 50, len(pc)).astype(np.int32)
    cls = rng.integers(0, 5, len(pc)).astype(np.uint8)
    path = write_cloud(pc, tmp_path / f"c{suffix}", {"instance": inst, "class_id": cls})
    back = read_cloud(path)
    np.testing.assert_array_equal(np.round(back.world_xyz(), 3), np.round(pc.world_xyz(), 3))
    assert np.abs(back.world_xyz() - pc.world_xyz()).max() < 5e-4
    np.testing.assert_array_equal(back.attributes["instance"], inst)
    assert back.attributes["instance"].dtype == np.int32
    np.testing.assert_array_equal(back.attributes["class_id"], cls)
    np.testing.assert_array_equal(back.attributes["intensity"], pc.attributes["intensity"])
    assert back.crs is not None and back.crs.to_epsg() == 28992
    header = laspy.read(path).header
    assert str(header.version) == "1.4"
    assert not list(tmp_path.glob(".*part*"))  # no temporary file left


def test_truncated_laz_is_a_clear_error(tmp_path: Path, rng) -> None:
    path = write_cloud(_rd_cloud(rng, 20000), tmp_path / "c.laz")
    data = path.read_bytes()
    cut = tmp_path / "cut.laz"
    cut.write_bytes(data[: len(data) // 2])
    with pytest.raises(InputError, match=r"cut\.laz"):
        read_cloud(cut)


def test_unknown_extension_and_missing_file(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="unknown point cloud extension"):
        read_cloud(tmp_path / "x.abc")
    with pytest.raises(InputError, match="file not found"):
        read_cloud(tmp_path / "missing.laz")


def test_ply_binary_round_trip(tmp_path: Path, rng) -> None:
    pc = _rd_cloud(rng, 500)
    path = write_cloud(pc, tmp_path / "c.ply", {"label": np.arange(500, dtype=np.int32)})
    back = read_cloud(path)
    np.testing.assert_allclose(back.world_xyz(), pc.world_xyz(), atol=1e-9)
    np.testing.assert_array_equal(back.attributes["label"], np.arange(500))


def test_ply_ascii_with_faces_and_truncation(tmp_path: Path) -> None:
    text = (
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
        "property float z\nproperty uchar red\nelement face 1\n"
        "property list uchar int vertex_indices\nend_header\n"
        "0 0 0 10\n1 0 0 20\n0 1 0.5 30\n3 0 1 2\n"
    )
    path = tmp_path / "a.ply"
    path.write_text(text)
    pc = read_cloud(path)
    assert len(pc) == 3
    np.testing.assert_array_equal(pc.attributes["red"], [10, 20, 30])
    path.write_text(text.split("0 1 0.5")[0])
    with pytest.raises(InputError, match="truncated or malformed PLY"):
        read_cloud(path)


def test_text_cloud_with_and_without_header(tmp_path: Path) -> None:
    a = tmp_path / "a.xyz"
    a.write_text("1 2 3\n4 5 6\n")
    pc = read_cloud(a)
    np.testing.assert_allclose(pc.world_xyz(), [[1, 2, 3], [4, 5, 6]])
    b = tmp_path / "b.csv"
    b.write_text("X,Y,Z,Intensity\n1,2,3,7\n4,5,6,8\n")
    pc = read_cloud(b)
    np.testing.assert_array_equal(pc.attributes["intensity"], [7, 8])
    c = tmp_path / "c.txt"
    c.write_text("1 2\n3 4\n")
    with pytest.raises(InputError, match="at least 3 columns"):
        read_cloud(c)


def test_real_ply_and_laz(shared_data: Path) -> None:
    bunny = read_cloud(shared_data / "bunny" / "bun000.ply")
    assert len(bunny) == 40256
    ahn = read_cloud(shared_data / "delft_ahn3" / "ahn3_tile1.laz")
    assert len(ahn) == 640510
    lo, hi = ahn.bounds()
    assert 84800 < lo[0] < hi[0] < 85001 and 447400 < lo[1] < hi[1] < 447650


def test_atomic_path_removes_temp_on_error(tmp_path: Path) -> None:
    target = tmp_path / "out.txt"
    with pytest.raises(RuntimeError), atomic_path(target) as tmp:
        tmp.write_text("partial")
        raise RuntimeError("boom")
    assert not target.exists()
    assert list(tmp_path.iterdir()) == []


def test_run_json_records_inputs_and_parameters(tmp_path: Path) -> None:
    src = tmp_path / "in.txt"
    src.write_text("abc")
    path = write_run_json(
        tmp_path / "out", step="test", parameters={"a": 1}, inputs=[src], counts={"total": 3}
    )
    rec = json.loads(path.read_text())
    assert rec["step"] == "test" and rec["parameters"] == {"a": 1}
    assert rec["inputs"][0]["bytes"] == 3
    assert rec["inputs"][0]["sha256"].startswith("ba7816bf")


def test_e57_two_scans_are_merged(tmp_path: Path, rng) -> None:
    pye57 = pytest.importorskip("pye57")
    path = tmp_path / "two.e57"
    e57 = pye57.E57(str(path), mode="w")
    first = {k: rng.uniform(0, 1, 50) for k in ("cartesianX", "cartesianY", "cartesianZ")}
    e57.write_scan_raw(first)
    e57.write_scan_raw({k: v + 100 for k, v in first.items()})
    e57.close()
    pc = read_cloud(path)
    assert len(pc) == 100
    np.testing.assert_array_equal(np.bincount(pc.attributes["scan_index"]), [50, 50])
    np.testing.assert_allclose(pc.world_xyz()[:50, 0], first["cartesianX"], atol=1e-9)
    np.testing.assert_allclose(pc.world_xyz()[50:, 0], first["cartesianX"] + 100, atol=1e-9)
    bad = tmp_path / "bad.e57"
    bad.write_bytes(b"ASTM-E57" + b"\0" * 100)
    with pytest.raises(InputError, match=r"bad\.e57: cannot read as E57"):
        read_cloud(bad)


# ----------------------------------------------------------------------------- issue 15, defect 5
def _nan_world(n: int = 10, bad: tuple[int, ...] = (2, 5, 7)) -> np.ndarray:
    world = np.column_stack([85000 + np.arange(n), 447000 + np.arange(n), np.arange(n) * 0.5])
    world[list(bad), bad[0] % 3] = np.nan
    world[bad[-1], 2] = np.inf
    return world


def _assert_one_nan_error(exc: pytest.ExceptionInfo, name: str, count: int, total: int) -> None:
    text = str(exc.value)
    assert text.startswith(str(exc.value.path)) and exc.value.path.endswith(name)
    assert f"{count} of {total} points have NaN or infinite coordinates" in text
    assert "remove them first" in text


@pytest.mark.parametrize("suffix", [".xyz", ".csv", ".txt", ".pts"])
def test_text_readers_reject_nan_once_naming_file_count_and_fix(tmp_path: Path, suffix) -> None:
    path = tmp_path / f"holes{suffix}"
    sep = "," if suffix == ".csv" else " "
    np.savetxt(path, _nan_world(), delimiter=sep, fmt="%.3f")
    with pytest.raises(InputError) as exc:
        read_cloud(path)
    _assert_one_nan_error(exc, path.name, 3, 10)


def test_ply_reader_rejects_nan(tmp_path: Path) -> None:
    from pyheracles.io.ply import write_ply

    good = PointCloud.from_world(np.nan_to_num(_nan_world()))
    path = write_ply(good, tmp_path / "holes.ply")
    raw = bytearray(path.read_bytes())
    body = raw.index(b"end_header\n") + len(b"end_header\n")
    table = np.frombuffer(bytes(raw[body:]), dtype="<f8").reshape(10, 3).copy()
    table[[2, 5, 7], [2, 2, 2]] = np.nan
    path.write_bytes(bytes(raw[:body]) + table.tobytes())
    with pytest.raises(InputError) as exc:
        read_cloud(path)
    _assert_one_nan_error(exc, "holes.ply", 3, 10)


def test_e57_reader_rejects_nan(tmp_path: Path, monkeypatch) -> None:
    pye57 = pytest.importorskip("pye57")
    world = _nan_world()
    path = tmp_path / "holes.e57"
    e57 = pye57.E57(str(path), mode="w")
    good = np.nan_to_num(world, posinf=0.0)
    e57.write_scan_raw({k: good[:, i].copy() for i, k in enumerate(("cartesianX",
                        "cartesianY", "cartesianZ"))})  # fmt: skip
    e57.close()
    read_scan = pye57.E57.read_scan

    def with_holes(self, *args, **kwargs):  # libE57 writes no NaN: put them in on reading
        data = read_scan(self, *args, **kwargs)
        for i, k in enumerate(("cartesianX", "cartesianY", "cartesianZ")):
            data[k] = world[:, i].copy()
        return data

    monkeypatch.setattr(pye57.E57, "read_scan", with_holes)
    with pytest.raises(InputError) as exc:
        read_cloud(path)
    _assert_one_nan_error(exc, "holes.e57", 3, 10)


def test_las_with_non_finite_header_is_a_clear_error(tmp_path: Path) -> None:
    las = laspy.LasData(laspy.LasHeader(point_format=6, version="1.4"))
    las.X = np.arange(5)
    las.write(tmp_path / "nanoffset.las")
    raw = bytearray((tmp_path / "nanoffset.las").read_bytes())
    raw[155:163] = np.array([np.nan]).tobytes()  # the header's x offset
    (tmp_path / "nanoffset.las").write_bytes(bytes(raw))
    with pytest.raises(InputError, match=r"nanoffset\.las: invalid header scales"):
        read_cloud(tmp_path / "nanoffset.las")


def test_from_world_and_writers_reject_nan(tmp_path: Path) -> None:
    with pytest.raises(InputError) as exc:
        PointCloud.from_world(_nan_world(), source="made.csv")
    _assert_one_nan_error(exc, "made.csv", 3, 10)
    bad = PointCloud(_nan_world(), source="made.csv")  # built directly: caught on writing
    for suffix in (".laz", ".ply", ".csv"):
        with pytest.raises(InputError, match=r"made\.csv: 3 of 10 points have NaN"):
            write_cloud(bad, tmp_path / f"out{suffix}")
    assert not list(tmp_path.iterdir())  # nothing written, not at the LAS offset either


@pytest.mark.parametrize("name", ["scans", "scans.laz"])
def test_a_folder_is_not_a_point_cloud_file(tmp_path: Path, rng, name: str) -> None:
    folder = tmp_path / name
    folder.mkdir()
    write_cloud(_rd_cloud(rng, 10), folder / "a.laz")
    with pytest.raises(InputError, match="is a folder, not a point cloud file") as exc:
        read_cloud(folder)
    assert str(folder) in str(exc.value) and "a.laz" in str(exc.value)
    assert "(1 point cloud file there)" in str(exc.value)
    write_cloud(_rd_cloud(rng, 10), folder / "b.ply")
    with pytest.raises(InputError, match=r"\(2 point cloud files there\)"):
        read_cloud(folder)
    from pyheracles.io.las import read_las
    from pyheracles.io.ply import read_ply
    from pyheracles.io.text import read_text

    for reader in (read_las, read_ply, read_text):
        with pytest.raises(InputError, match="is a folder, not a point cloud file"):
            reader(folder)


def test_all_points_at_one_location_names_the_file() -> None:
    pc = PointCloud.from_world(np.tile([85000.0, 447000.0, 2.0], (6, 1)), source="flat.xyz")
    with pytest.raises(InputError, match=r"^flat\.xyz: all 6 points of the point cloud are at"):
        pc.validate()


@pytest.mark.parametrize("command", ["ground", "register"])
def test_cli_commands_reject_nan_clouds_with_exit_code_2(tmp_path: Path, command: str, capsys):
    from pyheracles.cli import main

    path = tmp_path / "holes.xyz"
    np.savetxt(path, _nan_world(), fmt="%.3f")
    good = tmp_path / "good.xyz"
    np.savetxt(good, np.nan_to_num(_nan_world()), fmt="%.3f")
    args = {
        "ground": ["ground", str(path), "-o", str(tmp_path / "out")],
        "register": ["register", str(path), str(good), "--auto", "-o", str(tmp_path / "out")],
    }[command]
    assert main(args) == 2
    err = " ".join(capsys.readouterr().err.split())
    assert "holes.xyz" in err and "3 of 10 points have NaN" in err and "remove them first" in err
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())
