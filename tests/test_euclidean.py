"""Euclidean clustering: exact single linkage and voxel components."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.cluster import DBSCAN

from pyheracles import InputError
from pyheracles.segment.euclidean import euclidean_clusters, voxel_clusters


def _blobs(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    centres = np.array([[0, 0, 0], [10, 0, 0], [0, 10, 5]], dtype=float)
    sizes = [3000, 2000, 500]
    pts = np.vstack([c + rng.normal(0, 0.5, (n, 3)) for c, n in zip(centres, sizes, strict=True)])
    truth = np.repeat([1, 2, 3], sizes)
    return pts, truth


def test_exact_clusters_recover_blobs_ordered_by_size(rng) -> None:
    pts, truth = _blobs(rng)
    labels = euclidean_clusters(pts, 0.8, min_points=50)
    # the three big blobs, labelled by decreasing size; stragglers are noise
    for k in (1, 2, 3):
        values, counts = np.unique(labels[truth == k], return_counts=True)
        assert values[np.argmax(counts)] == k
        assert counts.max() / (truth == k).sum() > 0.97


def test_exact_equals_dbscan_with_min_samples_one(rng) -> None:
    pts = rng.uniform(0, 20, (3000, 3))
    ours = euclidean_clusters(pts, 1.0)
    ref = DBSCAN(eps=1.0, min_samples=1).fit_predict(pts)
    # same partition: a bijection between label sets
    pairs = np.unique(np.column_stack([ours, ref]), axis=0)
    assert len(pairs) == len(np.unique(ours)) == len(np.unique(ref))


def test_voxel_clusters_link_close_and_split_far_points() -> None:
    line = np.column_stack([np.arange(0, 10, 0.1), np.zeros(100), np.zeros(100)])
    far = line + [0, 5, 0]
    labels = voxel_clusters(np.vstack([line, far]), 0.2)
    assert set(labels[:100]) == {1} or set(labels[:100]) == {2}
    assert labels[0] != labels[100]
    assert len(np.unique(labels)) == 2


def test_min_points_and_empty_input(rng) -> None:
    pts = np.vstack([rng.normal(0, 0.1, (100, 3)), [[50.0, 50, 50]]])
    labels = euclidean_clusters(pts, 0.5, min_points=5)
    assert labels[-1] == 0 and (labels[:-1] == 1).all()
    assert euclidean_clusters(np.zeros((0, 3)), 1.0).shape == (0,)
    assert voxel_clusters(np.zeros((0, 3)), 1.0).shape == (0,)
    with pytest.raises(InputError, match="distance must be > 0"):
        euclidean_clusters(pts, 0.0)
