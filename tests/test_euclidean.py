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


def _pair_graph_labels(pts: np.ndarray, d: float, min_points: int) -> np.ndarray:
    """The clusters from every pair within ``d`` (KD-tree pairs, scipy components)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    from pyheracles.segment.euclidean import relabel_by_size

    n = len(pts)
    pairs = cKDTree(pts).query_pairs(d, output_type="ndarray")
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    return relabel_by_size(connected_components(graph, directed=False)[1], min_points)


@pytest.mark.parametrize("dim", [2, 3])
def test_cell_grid_gives_the_pair_graph_labels(dim: int) -> None:
    # the same labels, number for number, as the pair list: clouds with duplicates,
    # points on a lattice at exactly the distance, far offsets and sparse stragglers
    rng = np.random.default_rng(7)
    for trial in range(40):
        n = int(rng.integers(1, 2500))
        pts = rng.uniform(0, rng.uniform(0.2, 15), (n, dim)) + rng.uniform(-1e4, 1e4, dim)
        if trial % 4 == 0:
            pts = np.round(pts, 2)  # duplicates and many pairs at round distances
        d = float(rng.uniform(0.01, 0.8))
        m = int(rng.integers(1, 8))
        assert np.array_equal(euclidean_clusters(pts, d, m), _pair_graph_labels(pts, d, m))
    lattice = np.stack(np.meshgrid(*([np.arange(6) * 0.25] * dim)), axis=-1).reshape(-1, dim)
    assert np.array_equal(euclidean_clusters(lattice, 0.25), _pair_graph_labels(lattice, 0.25, 1))


def test_cell_grid_too_large_for_its_keys_uses_the_pairs() -> None:
    from pyheracles.segment.euclidean import grid_components

    # three axes of 10**7 cells each: the grid's keys would overflow 63 bits
    pts = np.array([[0.0, 0, 0], [0.0005, 0, 0], [1e4, 1e4, 1e4], [1e4, 1e4, 1e4 + 0.0005]])
    assert grid_components(pts, 0.001) is None
    assert euclidean_clusters(pts, 0.001).tolist() == [1, 1, 2, 2]


def test_cell_grid_of_a_dense_wall_section_matches_and_is_faster() -> None:
    # a section through a 2 cm scan of a wall and a column: tens of neighbours per point
    # within the distance, where listing the pairs costs most
    import time

    rng = np.random.default_rng(3)
    wall = np.c_[rng.uniform(0, 20, 20_000), rng.normal(0, 0.004, 20_000)]
    ang = rng.uniform(0, 2 * np.pi, 5_000)
    ring = np.c_[5 + 0.4 * np.cos(ang), 2 + 0.4 * np.sin(ang)]
    pts = np.vstack([wall, ring])
    euclidean_clusters(pts[:100], 0.08)  # compiled before timing
    t0 = time.process_time()
    ours = euclidean_clusters(pts, 0.08, 10)
    t_grid = time.process_time() - t0
    t0 = time.process_time()
    ref = _pair_graph_labels(pts, 0.08, 10)
    t_pairs = time.process_time() - t0
    assert np.array_equal(ours, ref)
    assert t_grid < t_pairs
