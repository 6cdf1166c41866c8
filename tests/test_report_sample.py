"""The report of a run samples the labelled cloud the run still holds, and gives the same
sample as from the file it wrote: the same points, labels, ground flags and CRS, the
coordinates to the file's resolution (the report of a 10 M-point run no longer
decompresses the cloud it has just written)."""

from __future__ import annotations

import gc

import numpy as np
import pandas as pd

from pyheracles.cloud import PointCloud
from pyheracles.io import results
from pyheracles.io.results import write_segmentation, written_labels
from pyheracles.labels import Segmentation
from pyheracles.report.folder import sample_cloud

OFFSET = np.array([1_000_000.0, 6_000_000.0, 100.0])


def test_sample_from_memory_equals_sample_from_file(tmp_path) -> None:
    rng = np.random.default_rng(0)
    n = 40_000
    xyz = np.round(rng.uniform(0, 50, (n, 3)), 3)
    inst = np.where(rng.random(n) < 0.4, rng.integers(1, 30, n), 0).astype(np.int32)
    inst[:5] = 31  # an object of five points keeps them all
    ground = (inst == 0) & (xyz[:, 2] < 10)
    ids, counts = np.unique(inst[inst > 0], return_counts=True)
    objects = pd.DataFrame({"instance": ids, "class": "building", "n_points": counts})
    seg = Segmentation(instance=inst, class_id=(inst > 0).astype(np.uint8),
                       classes={1: "building"}, objects=objects, ground=ground)  # fmt: skip
    cloud = PointCloud(xyz, offset=OFFSET, crs="EPSG:2154")
    path = write_segmentation(cloud, seg, tmp_path / "run", step="test")["cloud"]
    assert written_labels(path) is not None
    held = sample_cloud(path, max_points=5_000)
    del cloud, seg  # what the caller dropped is not kept: the file is read
    gc.collect()
    assert written_labels(path) is None
    read = sample_cloud(path, max_points=5_000)
    assert held.n_total == read.n_total == n
    assert np.array_equal(held.instance, read.instance)
    assert np.array_equal(held.ground, read.ground) and held.ground.any()
    assert np.array_equal(held.origin, read.origin) and held.crs == read.crs
    assert np.abs(held.xyz - read.xyz).max() < 1e-3
    assert set(held.instance[held.instance == 31].tolist()) == {31}
    assert (held.instance == 31).sum() == 5


def test_a_changed_file_is_read_again(tmp_path) -> None:
    xyz = np.random.default_rng(1).uniform(0, 5, (1000, 3))
    inst = np.zeros(1000, np.int32)
    seg = Segmentation(instance=inst, class_id=np.zeros(1000, np.uint8), classes={},
                       objects=pd.DataFrame({"instance": []}))  # fmt: skip
    cloud = PointCloud(xyz, offset=OFFSET)
    path = write_segmentation(cloud, seg, tmp_path / "run", step="test")["cloud"]
    assert written_labels(path) is not None
    path.write_bytes(path.read_bytes() + b"\0")
    assert written_labels(path) is None
    assert written_labels(tmp_path / "elsewhere.laz") is None
    assert results.written_labels(path) is None
