"""Fields that are all zero are not written into the zeros of a new point record (issue
12, speed of ``heracles supports`` on 10 M points): the file holds the same points, and
the costly strided and bit-field writes of the flags a survey leaves at 0 are skipped."""

from __future__ import annotations

from pathlib import Path

import laspy
import numpy as np
import pytest

import pyheracles.io.las as las_io
from pyheracles.io import read_cloud, write_cloud

N = 500


def _las_with(path: Path, rng: np.random.Generator) -> laspy.LasData:
    """LAS 1.4 format 6: XYZ, intensity, return numbers and a -0.0 GPS time set; the
    other flags and fields 0."""
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.scales, header.offsets = [0.001] * 3, [100.0, 200.0, 0.0]
    las = laspy.LasData(header)
    las.x = rng.uniform(100, 110, N)
    las.y = rng.uniform(200, 210, N)
    las.z = rng.uniform(0, 5, N)
    las.intensity = rng.integers(1, 60000, N).astype(np.uint16)
    las.return_number = np.full(N, 1, dtype=np.uint8)
    las.number_of_returns = rng.integers(1, 3, N).astype(np.uint8)
    las.gps_time = np.full(N, -0.0)  # a float zero with its sign bit set
    las.write(path)
    return laspy.read(path)


def test_zero_fields_are_skipped_and_the_points_are_the_same(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    src = _las_with(tmp_path / "in.las", np.random.default_rng(0))
    cloud = read_cloud(tmp_path / "in.las")
    written: list[str] = []
    fill = las_io._fill_record

    def counting(record, columns):  # the fields set from columns, the others stay 0
        written.extend(columns)
        return fill(record, columns)

    monkeypatch.setattr(las_io, "_fill_record", counting)
    out = laspy.read(write_cloud(cloud, tmp_path / "out.laz"))
    np.testing.assert_array_equal(out.points.array, src.points.array)
    assert np.signbit(np.asarray(out.gps_time)).all()  # floats are written as they are
    assert {"intensity", "return_number", "number_of_returns", "gps_time"} <= set(written)
    zero = {"synthetic", "key_point", "withheld", "overlap", "scanner_channel",
            "scan_direction_flag", "edge_of_flight_line", "user_data", "scan_angle",
            "point_source_id", "classification"}  # fmt: skip
    assert not zero & set(written), zero & set(written)


def test_zero_bit_fields_are_read_as_zeros_without_masking(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Reading: a bit field whose byte is 0 everywhere is made as zeros; the values and
    dtypes are those laspy's mask and shift give, for every dimension."""
    src = _las_with(tmp_path / "in.las", np.random.default_rng(1))
    masked: list[int] = []
    view = laspy.point.dims.SubFieldView
    mask_and_shift = view.masked_array

    def counting(self):  # one call per bit field read through the mask
        masked.append(self.lsb)
        return mask_and_shift(self)

    monkeypatch.setattr(view, "masked_array", counting)
    cloud = read_cloud(tmp_path / "in.las")
    # return_number and number_of_returns share the only non-zero bit-field byte
    assert len(masked) == 2, masked
    monkeypatch.undo()
    for name in src.point_format.dimension_names:
        if name in ("X", "Y", "Z"):
            continue
        ref = np.array(src[name])
        got = cloud.attributes[name]
        assert got.dtype == ref.dtype, name
        assert got.flags.c_contiguous and got.flags.owndata, name
        np.testing.assert_array_equal(got, ref, name)
