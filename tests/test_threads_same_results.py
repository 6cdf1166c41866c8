"""Work spread over threads gives what the plain loop gives (issue 12, speed of
``heracles supports`` on 10 M points): :func:`pyheracles.threads.map_threads`, the LAS
record's fields written in blocks of points and the record read field by field, against
a plain reference on a small input with more than one thread and more than one block."""

from __future__ import annotations

from pathlib import Path

import laspy
import numpy as np
import pytest

import pyheracles.io.las as las_io
from pyheracles.io import read_cloud, write_cloud
from pyheracles.threads import map_threads, n_workers

N = 3000


def test_map_threads_keeps_order_and_raises() -> None:
    items = list(range(50))
    assert map_threads(lambda k: k * k, items, workers=3) == [k * k for k in items]
    assert map_threads(lambda k: k, [], workers=2) == []

    def bad(k: int) -> int:
        if k == 7:
            raise ValueError("seven")
        return k

    with pytest.raises(ValueError, match="seven"):
        map_threads(bad, items, workers=2)


def test_n_workers_follows_the_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("HERACLES_THREADS", "1")
    assert n_workers() == 1
    monkeypatch.setenv("HERACLES_THREADS", "3")
    assert n_workers() == 3


def _las(path: Path, rng: np.random.Generator) -> None:
    """LAS 1.4 format 6 with every kind of field set: whole fields, bit fields sharing a
    byte, floats."""
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.scales, header.offsets = [0.001] * 3, [100.0, 200.0, 0.0]
    las = laspy.LasData(header)
    las.x = rng.uniform(100, 110, N)
    las.y = rng.uniform(200, 210, N)
    las.z = rng.uniform(0, 5, N)
    las.intensity = rng.integers(1, 60000, N).astype(np.uint16)
    las.return_number = rng.integers(1, 4, N).astype(np.uint8)
    las.number_of_returns = np.full(N, 4, dtype=np.uint8)
    las.synthetic = rng.integers(0, 2, N).astype(np.uint8)
    las.scanner_channel = rng.integers(0, 4, N).astype(np.uint8)
    las.classification = rng.integers(0, 20, N).astype(np.uint8)
    las.gps_time = rng.uniform(0, 1e5, N)
    las.write(path)


def test_record_written_and_read_on_threads_as_in_a_loop(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    _las(tmp_path / "in.las", np.random.default_rng(3))
    labels = {"instance": np.arange(N, dtype=np.int32) % 7, "class_id": np.ones(N, np.uint8)}
    monkeypatch.setattr(las_io, "_MIN_BLOCK", 100)  # several blocks of points
    clouds, records = [], []
    for threads in ("1", "3"):
        monkeypatch.setenv("HERACLES_THREADS", threads)
        cloud = read_cloud(tmp_path / "in.las")
        path = write_cloud(cloud, tmp_path / f"out{threads}.las", labels)
        clouds.append(cloud)
        records.append(laspy.read(path).points.array)
    one, three = clouds
    np.testing.assert_array_equal(one.xyz, three.xyz)
    np.testing.assert_array_equal(one.offset, three.offset)
    assert one.attributes.keys() == three.attributes.keys()
    for name, values in one.attributes.items():
        assert values.dtype == three.attributes[name].dtype, name
        np.testing.assert_array_equal(values, three.attributes[name], err_msg=name)
    # the plain reference: the file read back holds the input's fields and the labels
    src = laspy.read(tmp_path / "in.las")
    np.testing.assert_array_equal(records[0], records[1])
    back = laspy.read(tmp_path / "out3.las")
    for name in src.point_format.dimension_names:
        np.testing.assert_array_equal(np.asarray(back[name]), np.asarray(src[name]), name)
    np.testing.assert_array_equal(np.asarray(back["instance"]), labels["instance"])


def test_fill_record_in_blocks_is_setting_each_field(monkeypatch: pytest.MonkeyPatch) -> None:
    rng = np.random.default_rng(5)
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.add_extra_dims([laspy.ExtraBytesParams("instance", "i4")])
    columns = {
        "X": rng.integers(-(10**6), 10**6, N).astype(np.int32),
        "intensity": rng.integers(0, 60000, N).astype(np.uint16),
        "return_number": rng.integers(1, 8, N).astype(np.uint8),
        "number_of_returns": rng.integers(1, 8, N).astype(np.uint8),
        "overlap": rng.integers(0, 2, N).astype(np.uint8),
        "instance": rng.integers(-5, 500, N).astype(np.int32),
    }
    plain = laspy.ScaleAwarePointRecord.zeros(N, header=header)
    for name, values in columns.items():
        plain[name] = values
    monkeypatch.setattr(las_io, "_MIN_BLOCK", 64)
    monkeypatch.setenv("HERACLES_THREADS", "4")
    blocks = laspy.ScaleAwarePointRecord.zeros(N, header=header)
    las_io._fill_record(blocks, columns)
    assert plain.array.tobytes() == blocks.array.tobytes()
