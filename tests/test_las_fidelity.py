"""Every input dimension survives a written cloud (issue 15, defect 10).

The files are built here with laspy: every LAS version 1.1-1.4 and every point
format it allows, every field filled with non-zero values, extra bytes of every
kind (all base types, arrays of 2 and 3, scaled / offset, no-data, unregistered),
VLRs, EVLRs, waveform packets and a COPC-like file.
"""

from __future__ import annotations

import json
import struct
from pathlib import Path

import geopandas as gpd
import laspy
import numpy as np
import pandas as pd
import pytest
import shapely
from laspy.vlrs.vlrlist import VLRList
from pyproj import CRS

from pyheracles.io import read_cloud, write_cloud
from pyheracles.io.results import write_segmentation
from pyheracles.labels import Segmentation

N = 300
_VERSION_FORMATS = [
    ("1.1", 0), ("1.1", 1),
    ("1.2", 0), ("1.2", 1), ("1.2", 2), ("1.2", 3),
    ("1.3", 0), ("1.3", 1), ("1.3", 2), ("1.3", 3), ("1.3", 4), ("1.3", 5),
    *[("1.4", f) for f in range(11)],
]  # fmt: skip
#: LAS 1.4 format that holds every field of a legacy format (writing class codes > 31)
_UPGRADE = {0: 6, 1: 6, 2: 7, 3: 7, 4: 9, 5: 10}
_BASES = ("u1", "i1", "u2", "i2", "u4", "i4", "u8", "i8", "f4", "f8")


def _random_values(dim: laspy.point.dims.DimensionInfo, rng: np.random.Generator, n: int):
    """Non-zero values spanning the field's range."""
    if dim.kind == laspy.DimensionKind.BitField:
        return rng.integers(0, 2**dim.num_bits, n, dtype=np.int64).astype(np.uint8)
    shape = (n,) if dim.num_elements == 1 else (n, dim.num_elements)
    base = np.dtype(dim.type_str()).base
    if dim.kind == laspy.DimensionKind.FloatingPoint:
        return rng.uniform(-1e6, 1e6, shape).astype(base)
    info = np.iinfo(base)
    lo, hi = max(info.min, -(2**40)), min(info.max, 2**40)
    return rng.integers(lo, hi, shape, dtype=np.int64).astype(base)


def _build(
    path: Path,
    version: str,
    fmt: int,
    rng: np.random.Generator,
    extras: list[laspy.ExtraBytesParams] = (),
    vlrs: list = (),
    evlrs: list = (),
) -> laspy.LasData:
    header = laspy.LasHeader(point_format=fmt, version=version)
    header.scales = np.array([0.001, 0.001, 0.01])
    header.offsets = np.array([85000.0, 447000.0, -10.0])
    header.add_crs(CRS.from_epsg(28992))
    if extras:
        header.add_extra_dims(list(extras))
    for vlr in vlrs:
        header.vlrs.append(vlr)
    las = laspy.LasData(header)
    las.points = laspy.ScaleAwarePointRecord.zeros(N, header=header)
    for dim in las.point_format.dimensions:
        if dim.name in ("X", "Y", "Z"):
            las[dim.name] = rng.integers(-(10**6), 10**6, N).astype(np.int32)
        elif dim.is_scaled:
            raw = _random_values(dim, rng, N)
            las.points.array[dim.name] = raw
        else:
            las[dim.name] = _random_values(dim, rng, N)
    if evlrs:
        las.evlrs = VLRList(list(evlrs))
    las.write(path)
    return laspy.read(path)


def _assert_same_fields(src: laspy.LasData, out: laspy.LasData, *, upgraded: bool) -> None:
    """Every dimension of ``src`` is in ``out`` with the same raw values.

    ``upgraded``: the classification was rewritten on purpose (not compared).
    """
    np.testing.assert_array_equal(src.x, out.x)
    np.testing.assert_array_equal(src.y, out.y)
    np.testing.assert_array_equal(src.z, out.z)
    names = set(out.point_format.dimension_names)
    for dim in src.point_format.dimensions:
        name = dim.name
        if name in ("X", "Y", "Z"):
            continue
        if name == "scan_angle_rank" and name not in names:  # format 0-5 upgraded to 6-10
            np.testing.assert_array_equal(np.round(out["scan_angle"] * 0.006), src[name])
            continue
        if name == "classification" and upgraded:
            continue  # rewritten on purpose by the caller
        assert name in names, f"{name} lost"
        if dim.is_standard:
            np.testing.assert_array_equal(np.asarray(out[name]), np.asarray(src[name]), name)
        else:
            np.testing.assert_array_equal(
                out.points.array[name], src.points.array[name], err_msg=name
            )
            got = out.point_format.dimension_by_name(name)
            assert got.type_str() == dim.type_str(), name
            for key in ("scales", "offsets"):
                a, b = getattr(got, key), getattr(dim, key)
                assert (a is None) == (b is None), (name, key)
                if a is not None:
                    np.testing.assert_array_equal(a, b)
    assert "scan_angle_rank" not in set(out.point_format.extra_dimension_names)


@pytest.mark.parametrize(("version", "fmt"), _VERSION_FORMATS, ids=lambda v: str(v))
def test_every_field_of_every_version_and_format_survives(
    tmp_path: Path, rng: np.random.Generator, version: str, fmt: int
) -> None:
    src = _build(tmp_path / "in.las", version, fmt, rng)
    assert np.asarray(src.scan_direction_flag).any() and np.asarray(src.edge_of_flight_line).any()
    pc = read_cloud(tmp_path / "in.las")
    labels = {"instance": np.arange(N, dtype=np.int32), "class_id": np.ones(N, np.uint8)}
    notes: list[str] = []
    out = laspy.read(write_cloud(pc, tmp_path / "out.laz", labels, notes=notes))
    assert str(out.header.version) == "1.4"
    assert out.point_format.id == fmt
    if fmt in (9, 10):  # lazrs garbles their wave packets when the scanner channel changes
        assert len(notes) == 1 and "written uncompressed" in notes[0]
    else:
        assert notes == []
    _assert_same_fields(src, out, upgraded=False)
    np.testing.assert_array_equal(out["instance"], labels["instance"])
    assert out.header.parse_crs().to_epsg() == 28992


@pytest.mark.parametrize("fmt", range(6), ids=lambda f: f"format{f}")
def test_class_codes_above_31_upgrade_legacy_formats_without_loss(
    tmp_path: Path, rng: np.random.Generator, fmt: int
) -> None:
    src = _build(tmp_path / "in.las", "1.3" if fmt > 3 else "1.2", fmt, rng)
    pc = read_cloud(tmp_path / "in.las")
    cls = np.full(N, 64, np.uint8)
    notes: list[str] = []
    path = write_cloud(pc.with_attributes(classification=cls), tmp_path / "o.las", notes=notes)
    out = laspy.read(path)
    assert out.point_format.id == _UPGRADE[fmt]
    assert notes and "class codes above 31" in notes[0]
    np.testing.assert_array_equal(out.classification, cls)
    _assert_same_fields(src, out, upgraded=True)


def _every_extra_kind() -> list[laspy.ExtraBytesParams]:
    params = []
    for base in _BASES:
        params.append(laspy.ExtraBytesParams(f"e_{base}", base, description=f"one {base}"))
        params.append(laspy.ExtraBytesParams(f"a2_{base}", f"2{base}"))
        params.append(laspy.ExtraBytesParams(f"a3_{base}", f"3{base}"))
    params += [
        laspy.ExtraBytesParams("scaled", "i4", scales=[0.01], offsets=[250.0], no_data=[-1]),
        laspy.ExtraBytesParams(
            "scaled3", "3u2", scales=[0.5, 0.25, 0.125], offsets=[1.0, 2.0, 3.0]
        ),
        laspy.ExtraBytesParams("raw_bytes", "7u1", description="undocumented"),
    ]
    return params


@pytest.mark.parametrize(("version", "fmt"), [("1.2", 1), ("1.3", 5), ("1.4", 6), ("1.4", 10)])
def test_extra_bytes_of_every_kind_survive(
    tmp_path: Path, rng: np.random.Generator, version: str, fmt: int
) -> None:
    src = _build(tmp_path / "in.laz", version, fmt, rng, extras=_every_extra_kind())
    pc = read_cloud(tmp_path / "in.laz")
    assert pc.attributes["a3_f8"].shape == (N, 3)
    out = laspy.read(write_cloud(pc, tmp_path / "out.laz", {"instance": np.ones(N, np.int32)}))
    _assert_same_fields(src, out, upgraded=False)
    got = out.point_format.dimension_by_name("e_u2")
    assert got.description == "one u2"


def _unregister_extra_bytes(path: Path) -> None:
    """Rename the Extra Bytes VLR so that its bytes become undocumented (same file size)."""
    data = bytearray(path.read_bytes())
    header_size = struct.unpack_from("<H", data, 94)[0]
    n_vlrs = struct.unpack_from("<I", data, 100)[0]
    pos = header_size
    for _ in range(n_vlrs):
        user = bytes(data[pos + 2 : pos + 18]).rstrip(b"\0")
        record = struct.unpack_from("<H", data, pos + 18)[0]
        length = struct.unpack_from("<H", data, pos + 20)[0]
        if user == b"LASF_Spec" and record == 4:
            data[pos + 2 : pos + 18] = b"test_renamed".ljust(16, b"\0")
        pos += 54 + length
    path.write_bytes(bytes(data))


@pytest.mark.parametrize("fmt", [1, 7])
def test_unregistered_extra_bytes_survive(
    tmp_path: Path, rng: np.random.Generator, fmt: int
) -> None:
    path = tmp_path / "in.las"
    _build(path, "1.4", fmt, rng, extras=[laspy.ExtraBytesParams("junk", "5u1")])
    _unregister_extra_bytes(path)
    src = laspy.read(path)
    assert list(src.point_format.extra_dimension_names) == ["ExtraBytes"]
    out = laspy.read(write_cloud(read_cloud(path), tmp_path / "out.laz"))
    np.testing.assert_array_equal(out.points.array["ExtraBytes"], src.points.array["ExtraBytes"])
    _assert_same_fields(src, out, upgraded=False)


def test_vlrs_and_evlrs_are_kept(tmp_path: Path, rng: np.random.Generator) -> None:
    vlr = laspy.VLR("acme", 42, "survey notes", b"instrument: X7")
    evlr = laspy.VLR("acme", 43, "big table", b"\x01\x02" * 5000)
    _build(tmp_path / "in.laz", "1.4", 8, rng, vlrs=[vlr], evlrs=[evlr])
    out = laspy.read(write_cloud(read_cloud(tmp_path / "in.laz"), tmp_path / "out.laz"))
    mine = [v for v in out.header.vlrs if v.user_id == "acme"]
    assert [(v.record_id, v.record_data) for v in mine] == [(42, b"instrument: X7")]
    assert [(e.user_id, e.record_id, e.record_data) for e in out.evlrs] == [
        ("acme", 43, b"\x01\x02" * 5000)
    ]


def _waveform_descriptor() -> laspy.VLR:
    data = struct.pack("<BBIIdd", 8, 0, 60, 1000, 0.5, 1.0)
    return laspy.VLR("LASF_Spec", 100, "waveform packet", data)


def _waveform_evlr_at(path: Path) -> tuple[int, bytes, bytes]:
    raw = path.read_bytes()
    start = struct.unpack_from("<Q", raw, 227)[0]
    length = struct.unpack_from("<Q", raw, start + 20)[0]
    return start, raw[start + 2 : start + 20], raw[start + 60 : start + 60 + length]


def test_waveform_fields_descriptors_and_internal_data_survive(
    tmp_path: Path, rng: np.random.Generator
) -> None:
    samples = rng.integers(0, 255, 6000).astype(np.uint8).tobytes()
    data = laspy.VLR("LASF_Spec", 65535, "waveform data", samples)
    path = tmp_path / "in.las"
    header_src = _build(path, "1.4", 9, rng, vlrs=[_waveform_descriptor()], evlrs=[data])
    raw = bytearray(path.read_bytes())  # internal waveform: bit 1 and the pointer to the EVLR
    struct.pack_into("<H", raw, 6, struct.unpack_from("<H", raw, 6)[0] | 0b10)
    struct.pack_into("<Q", raw, 227, struct.unpack_from("<Q", raw, 235)[0])
    path.write_bytes(bytes(raw))
    for suffix in (".las", ".laz"):
        out_path = write_cloud(read_cloud(path), tmp_path / f"out{suffix}")
        out = laspy.read(out_path)
        _assert_same_fields(header_src, out, upgraded=False)
        assert out.header.global_encoding.waveform_data_packets_internal
        assert [v.record_id for v in out.header.vlrs if v.user_id == "LASF_Spec"] == [100]
        if suffix == ".las":
            _, ident, payload = _waveform_evlr_at(out_path)
            assert ident == b"LASF_Spec".ljust(16, b"\0") + struct.pack("<H", 65535)
            assert payload == samples


def test_las13_internal_waveform_data_is_carried_into_14(
    tmp_path: Path, rng: np.random.Generator
) -> None:
    path = tmp_path / "in13.las"
    src = _build(path, "1.3", 4, rng, vlrs=[_waveform_descriptor()])
    samples = rng.integers(0, 255, 3000).astype(np.uint8).tobytes()
    raw = bytearray(path.read_bytes())
    start = len(raw)
    raw += struct.pack("<H16sHQ32s", 0, b"LASF_Spec", 65535, len(samples), b"waveform data")
    raw += samples
    struct.pack_into("<H", raw, 6, struct.unpack_from("<H", raw, 6)[0] | 0b10)
    struct.pack_into("<Q", raw, 227, start)
    path.write_bytes(bytes(raw))
    out_path = write_cloud(read_cloud(path), tmp_path / "out.las")
    out = laspy.read(out_path)
    assert out.point_format.id == 4
    _assert_same_fields(src, out, upgraded=False)
    assert _waveform_evlr_at(out_path)[2] == samples


def _copc_like(path: Path, rng: np.random.Generator) -> laspy.LasData:
    info = laspy.VLR("copc", 1, "copc info", struct.pack("<3dddQQdd", 0, 0, 0, 1, 1, 0, 0, 0, 0))
    info_data = info.record_data + b"\0" * (160 - len(info.record_data))
    info = laspy.VLR("copc", 1, "copc info", info_data)
    hierarchy = laspy.VLR("copc", 1000, "copc hierarchy", b"\0" * 32)
    return _build(path, "1.4", 7, rng, vlrs=[info], evlrs=[hierarchy])


def _segmentation(n: int, classes: dict[int, str], class_id: np.ndarray, ground) -> Segmentation:
    instance = class_id.astype(np.int32)  # one object per class
    ids = np.unique(instance[instance > 0])
    objects = pd.DataFrame(
        {
            "instance": ids.astype(np.int32),
            "class": [classes[int(i)] for i in ids],
            "n_points": [int((instance == i).sum()) for i in ids],
        }
    )
    return Segmentation(instance, class_id, classes, objects, ground)


def test_copc_input_is_written_as_plain_laz_and_said_so(
    tmp_path: Path, rng: np.random.Generator
) -> None:
    src = _copc_like(tmp_path / "in.copc.laz", rng)
    pc = read_cloud(tmp_path / "in.copc.laz")
    seg = _segmentation(N, {1: "building"}, (np.arange(N) % 2).astype(np.uint8), None)
    paths = write_segmentation(pc, seg, tmp_path / "out", step="test")
    out = laspy.read(paths["cloud"])
    assert not [v for v in out.header.vlrs if v.user_id == "copc"]
    assert not [e for e in out.evlrs if e.user_id == "copc"]
    _assert_same_fields(src, out, upgraded=True)  # classification rewritten
    run = json.loads(paths["run"].read_text())
    assert any("COPC" in w and "plain LAZ" in w for w in run["warnings"])


def test_segmented_laz_keeps_legacy_flags_and_writes_asprs_codes(
    tmp_path: Path, rng: np.random.Generator
) -> None:
    """The issue's case: LAS 1.2 format 1, building and wall layers, flags non-zero."""
    src = _build(tmp_path / "in.laz", "1.2", 1, rng, extras=_every_extra_kind()[:6])
    pc = read_cloud(tmp_path / "in.laz")
    class_id = (np.arange(N) % 3).astype(np.uint8)  # 0 rest, 1 wall, 2 building
    ground = np.zeros(N, bool)
    ground[class_id == 0] = np.arange(N)[class_id == 0] % 2 == 0
    seg = _segmentation(N, {1: "wall", 2: "building"}, class_id, ground)
    seg = Segmentation(
        seg.instance, seg.class_id, seg.classes,
        gpd.GeoDataFrame(seg.objects, geometry=[shapely.box(0, 0, 1, 1)] * 2, crs=28992),
        ground,
    )  # fmt: skip
    paths = write_segmentation(pc, seg, tmp_path / "out", step="test", per_object="class")
    out = laspy.read(paths["cloud"])
    assert out.point_format.id == 6
    _assert_same_fields(src, out, upgraded=True)
    expected = np.select([ground, class_id == 1, class_id == 2], [2, 64, 6], default=1)
    np.testing.assert_array_equal(out.classification, expected)
    np.testing.assert_array_equal(out["source_class"], src.classification)
    np.testing.assert_array_equal(out.scan_direction_flag, src.scan_direction_flag)
    np.testing.assert_array_equal(out.edge_of_flight_line, src.edge_of_flight_line)
    run = json.loads(paths["run"].read_text())
    assert run["asprs_classes"] == {"ground": 2, "remainder": 1, "wall": 64, "building": 6}
    wall = laspy.read(paths["objects_dir"] / "wall.laz")
    picked = class_id == 1
    np.testing.assert_array_equal(wall.scan_direction_flag, src.scan_direction_flag[picked])
    np.testing.assert_array_equal(wall.gps_time, src.gps_time[picked])
    np.testing.assert_array_equal(wall["source_class"], src.classification[picked])
    np.testing.assert_array_equal(wall["a2_u1"], src["a2_u1"][picked])


def test_building_only_run_keeps_the_source_format(tmp_path: Path, rng) -> None:
    src = _build(tmp_path / "in.las", "1.2", 3, rng)
    pc = read_cloud(tmp_path / "in.las")
    seg = _segmentation(N, {1: "building"}, (np.arange(N) % 2).astype(np.uint8), None)
    out = laspy.read(write_segmentation(pc, seg, tmp_path / "o", step="t")["cloud"])
    assert out.point_format.id == 3  # class 6 fits: no upgrade, scan_angle_rank kept
    _assert_same_fields(src, out, upgraded=True)
    np.testing.assert_array_equal(out.scan_angle_rank, src.scan_angle_rank)
    assert set(np.unique(out.classification)) == {1, 6}


def test_cloud_without_header_keeps_fields_from_attributes(
    tmp_path: Path, rng: np.random.Generator
) -> None:
    """A transformed cloud loses ``las_header``: the fields still choose a format holding them."""
    from dataclasses import replace

    src = _build(tmp_path / "in.las", "1.3", 5, rng, extras=_every_extra_kind()[:9])
    pc = replace(read_cloud(tmp_path / "in.las"), las_header=None)
    out = laspy.read(write_cloud(pc, tmp_path / "out.laz"))
    assert out.point_format.id == 5
    for name in src.point_format.dimension_names:
        if name not in ("X", "Y", "Z"):
            np.testing.assert_array_equal(np.asarray(out[name]), np.asarray(src[name]), name)


def test_attribute_las_cannot_hold_is_a_clear_error(tmp_path: Path) -> None:
    from pyheracles import InputError, PointCloud

    pc = PointCloud(np.zeros((4, 3)), attributes={"normals4": np.zeros((4, 4))})
    with pytest.raises(InputError, match=r"'normals4'.*cannot be stored as LAS extra bytes"):
        write_cloud(pc, tmp_path / "x.laz")
    assert not list(tmp_path.iterdir())
