"""Tests of shared neighbourhoods: kNN, normals, curvature, PCA features."""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.errors import InputError
from pyheracles.geometry import neighbours
from pyheracles.geometry.neighbours import (
    build_tree,
    estimate_normals,
    knn,
    local_pca,
    pca_features,
    point_spacing,
    symmetric_eigen3,
)


def _tilted_plane(n: int, normal: np.ndarray, noise_m: float, rng: np.random.Generator):
    normal = normal / np.linalg.norm(normal)
    u = np.cross(normal, [0.0, 0.0, 1.0] if abs(normal[2]) < 0.9 else [1.0, 0.0, 0.0])
    u /= np.linalg.norm(u)
    v = np.cross(normal, u)
    ab = rng.uniform(-1.0, 1.0, size=(n, 2))
    pts = ab[:, :1] * u + ab[:, 1:] * v + 1000.0  # large-ish local coordinates
    return pts + rng.normal(scale=noise_m, size=pts.shape)


def test_knn_matches_brute_force_and_includes_self():
    rng = np.random.default_rng(1)
    xyz = rng.uniform(size=(500, 3))
    dist, idx = knn(xyz, 6)
    assert idx.shape == (500, 6)
    assert np.array_equal(idx[:, 0], np.arange(500))
    full = np.linalg.norm(xyz[:, None] - xyz[None], axis=2)
    brute = np.sort(full, axis=1)[:, :6]
    np.testing.assert_allclose(dist, brute, atol=1e-12)
    # a shared tree gives the same answer; k larger than N is clipped
    d2, _ = knn(xyz, 6, tree=build_tree(xyz))
    np.testing.assert_allclose(d2, dist)
    assert knn(xyz[:4], 10)[1].shape == (4, 4)


def test_normals_of_noisy_plane_are_accurate():
    rng = np.random.default_rng(2)
    true_n = np.array([0.3, -0.5, 0.81])
    true_n /= np.linalg.norm(true_n)
    xyz = _tilted_plane(20000, true_n, 0.0005, rng)
    normals, curv = estimate_normals(xyz, k=24)
    ang = np.degrees(np.arccos(np.clip(np.abs(normals @ true_n), 0, 1)))
    assert np.median(ang) < 2.0
    assert np.all(np.isclose(np.linalg.norm(normals, axis=1), 1.0))
    assert curv.max() < 0.05
    # curvature is the surface variation: isotropic blob -> about 1/3
    blob = rng.normal(size=(3000, 3))
    _, c_blob = estimate_normals(blob, k=50)
    assert 0.15 < np.median(c_blob) <= 1 / 3 + 1e-12


def test_curvature_matches_eigh_reference_and_viewpoint_orientation():
    rng = np.random.default_rng(3)
    xyz = rng.normal(size=(2000, 3)) * [1.0, 0.5, 0.05]
    k = 12
    _, idx = knn(xyz, k)
    nb = xyz[idx] - xyz[idx].mean(axis=1, keepdims=True)
    cov = np.einsum("nki,nkj->nij", nb, nb) / k
    w, v = np.linalg.eigh(cov)
    pca = local_pca(xyz, k=k)
    np.testing.assert_allclose(pca.eigenvalues, w, rtol=1e-8, atol=1e-12)
    np.testing.assert_allclose(np.abs(np.sum(pca.normals * v[:, :, 0], axis=1)), 1.0, atol=1e-8)
    np.testing.assert_allclose(pca.curvature, w[:, 0] / w.sum(axis=1), rtol=1e-8, atol=1e-12)
    vp = np.array([0.0, 0.0, 10.0])
    normals, _ = estimate_normals(xyz, k=k, viewpoint=vp)
    assert np.all(np.sum(normals * (vp - xyz), axis=1) >= 0)


def test_symmetric_eigen3_handles_degenerate_matrices():
    # identity (all equal), diag with a double eigenvalue, zeros, random
    rng = np.random.default_rng(4)
    a = rng.normal(size=(200, 3, 3))
    mats = np.concatenate(
        [np.eye(3)[None], np.diag([1.0, 1.0, 2.0])[None], np.zeros((1, 3, 3)), a @ a.swapaxes(1, 2)]
    )
    up = np.column_stack(
        [mats[:, 0, 0], mats[:, 1, 1], mats[:, 2, 2], mats[:, 0, 1], mats[:, 0, 2], mats[:, 1, 2]]
    )
    vals, vmin, vmax = symmetric_eigen3(up)
    w, _ = np.linalg.eigh(mats)
    np.testing.assert_allclose(vals, np.maximum(w, 0), atol=1e-10)
    for m, lam, vec in ((mats, vals[:, 0], vmin), (mats, vals[:, 2], vmax)):
        resid = np.einsum("nij,nj->ni", m, vec) - lam[:, None] * vec
        assert np.abs(resid).max() < 1e-8
    assert np.allclose(np.linalg.norm(vmin, axis=1), 1.0)
    vals2, vmin2, none = symmetric_eigen3(up, directions=False)
    assert none is None
    np.testing.assert_allclose(vals2, vals)
    resid = np.einsum("nij,nj->ni", mats, vmin2) - vals2[:, :1] * vmin2
    assert np.abs(resid).max() < 1e-8


def test_duplicates_are_flagged_not_nan():
    xyz = np.repeat(np.array([[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]), 20, axis=0)
    normals, curv = estimate_normals(xyz, k=8)
    assert np.all(np.isfinite(normals)) and np.all(np.isfinite(curv))
    assert np.allclose(normals, 0.0) and np.allclose(curv, 1 / 3)
    with pytest.raises(InputError, match="same location"):
        point_spacing(xyz[:20])


def test_bad_input_raises_input_error():
    with pytest.raises(InputError, match="NaN"):
        estimate_normals(np.array([[0.0, 0.0, np.nan]] * 5))
    with pytest.raises(InputError, match="shape"):
        knn(np.zeros((5, 2)), 3)
    with pytest.raises(InputError, match="at least 3"):
        estimate_normals(np.zeros((2, 3)))
    with pytest.raises(InputError, match="KD-tree holds"):
        knn(np.zeros((5, 3)), 2, tree=build_tree(np.zeros((6, 3))))


def test_point_spacing_and_features():
    g = np.stack(np.meshgrid(np.arange(30.0), np.arange(30.0)), -1).reshape(-1, 2) * 0.01
    xyz = np.column_stack([g, np.zeros(len(g))])
    assert point_spacing(xyz) == pytest.approx(0.01)
    pca = local_pca(xyz, k=9)
    feats = pca_features(pca.eigenvalues)
    inner = (g.min(axis=1) > 0.015) & (g.max(axis=1) < 0.275)
    np.testing.assert_allclose(feats["scattering"][inner], 0.0, atol=1e-12)
    total = feats["linearity"] + feats["planarity"] + feats["scattering"]
    np.testing.assert_allclose(total, 1.0)
    line = np.column_stack([np.arange(100.0), np.zeros(100), np.zeros(100)])
    lin = pca_features(local_pca(line, k=5).eigenvalues)["linearity"]
    np.testing.assert_allclose(lin, 1.0)


def _reference_pca(xyz: np.ndarray, k: int):
    """Exact k-NN PCA from scipy's cKDTree and numpy's eigh (the reference)."""
    from scipy.spatial import cKDTree

    dist, idx = cKDTree(xyz).query(xyz, k=k)
    nb = xyz[idx] - xyz[idx].mean(axis=1, keepdims=True)
    w, v = np.linalg.eigh(np.einsum("nki,nkj->nij", nb, nb) / k)
    return dist, w, v


def _clouds(rng: np.random.Generator) -> dict[str, np.ndarray]:
    from pyheracles.synthetic.truss import TrussParams, make_truss_roof

    n = 6000
    gap = rng.normal(scale=0.02, size=(n, 3))
    gap[: n // 2] += [50.0, 0.0, 0.0]  # two clusters 50 m apart
    gap[::500] += rng.uniform(-20, 20, size=(n // 500, 3))  # isolated points
    return {
        "uniform": rng.random((n, 3)),
        "slab": rng.random((n, 3)) * [10.0, 10.0, 0.002],
        "line": np.column_stack([rng.random(n) * 100.0, 1e-4 * rng.random((n, 2))]),
        "clusters_and_outliers": gap + 1000.0,
        "scan": make_truss_roof(TrussParams(n_points=20_000, n_trusses=2), rng=3).xyz,
    }


@pytest.mark.parametrize("k", [3, 16])
def test_octree_search_equals_exact_knn_pca(k, monkeypatch):
    monkeypatch.setattr(neighbours, "_COMPILED_FROM", 0)  # the compiled search for every size
    rng = np.random.default_rng(7)
    for name, xyz in _clouds(rng).items():
        _, w, v = _reference_pca(xyz, k)
        pca = local_pca(xyz, k=k)
        # the exact k-NN set (no ties in these clouds): same eigenvalues
        scale = w[:, 2:].clip(1e-300)
        err = np.abs(pca.eigenvalues - np.maximum(w, 0)) / scale
        assert err.max() < 1e-9, name
        curv = w[:, 0] / w.sum(axis=1)
        np.testing.assert_allclose(pca.curvature, curv, atol=1e-9, err_msg=name)
        # normals equal up to sign where the smallest eigenvalue is well separated
        sep = (w[:, 1] - w[:, 0]) > 1e-6 * w[:, 2]
        cos = np.abs(np.sum(pca.normals * v[:, :, 0], axis=1))
        assert np.all(cos[sep] > 1 - 1e-9), name


@pytest.mark.parametrize("compiled_from", [0, 10**9])
def test_octree_search_handles_duplicates_small_clouds_and_a_given_tree(compiled_from, monkeypatch):
    monkeypatch.setattr(neighbours, "_COMPILED_FROM", compiled_from)  # both searches
    rng = np.random.default_rng(8)
    base = rng.random((300, 3)) * [1.0, 1.0, 0.01]
    xyz = np.vstack([base, base, base[:50]])  # every point twice, some three times
    _, w, _ = _reference_pca(xyz, 12)
    pca = local_pca(xyz, k=12, tree=build_tree(xyz))
    np.testing.assert_allclose(pca.curvature, w[:, 0] / w.sum(axis=1), atol=1e-9)
    # fewer points than k: every point uses all of them
    few = rng.random((5, 3))
    n5, c5 = estimate_normals(few, k=16)
    centred = few - few.mean(axis=0)
    w5, v5 = np.linalg.eigh(centred.T @ centred / 5)
    np.testing.assert_allclose(c5, w5[0] / w5.sum(), atol=1e-12)
    np.testing.assert_allclose(np.abs(n5 @ v5[:, 0]), 1.0, atol=1e-9)
    with pytest.raises(InputError, match="KD-tree holds"):
        local_pca(xyz, k=12, tree=build_tree(xyz[:10]))


def test_octree_knn_table_equals_the_kd_tree_query() -> None:
    """The compiled search's neighbour table (region growing's, issue 13 speed) is
    scipy's: same indices in the same order and the same distances to the bit, on
    a scan-like cloud of clustered density; with exact duplicates only tied
    neighbours may be swapped, and every distance stays the same."""
    from pyheracles.geometry.neighbours import octree_knn

    rng = np.random.default_rng(7)
    dense = rng.normal(0, 0.05, (20000, 3))
    sparse = rng.uniform(-10, 10, (5000, 3))
    xyz = np.vstack([dense, sparse, [[50.0, 50.0, 50.0]]])  # and one isolated point
    for k in (1, 7, 24):
        d0, i0 = knn(xyz, k)
        d1, i1 = octree_knn(xyz, k)
        assert np.array_equal(i0, i1) and np.array_equal(d0, d1)
    dup = np.vstack([xyz[:3000], xyz[:500]])
    d0, i0 = knn(dup, 16)
    d1, i1 = octree_knn(dup, 16)
    assert np.array_equal(d0, d1)
    assert np.array_equal(np.sort(dup[i0], axis=1), np.sort(dup[i1], axis=1))


def test_octree_search_stays_fast_where_sparse_cells_border_dense_ones() -> None:
    """Roof draw 1 (issue 13): the first 50 k points of its scan took 2.9 s (the whole
    region-growing input: minutes) because twelve halvings of the distance threshold
    left hundreds of candidates, dropped one maximum at a time.  The search is exact
    and takes a fraction of a second."""
    import time

    from pyheracles.geometry.neighbours import octree_knn
    from pyheracles.synthetic.families import simulate

    xyz = simulate("roof", 1).clouds["cloud"].xyz[:50_000]
    octree_knn(xyz[:2000], 24)  # compiled
    start = time.perf_counter()
    dist, idx = octree_knn(xyz, 24)
    assert time.perf_counter() - start < 1.5
    d0, i0 = knn(xyz, 24)
    assert np.array_equal(dist, d0)
    assert np.array_equal(np.sort(i0, axis=1), np.sort(idx, axis=1))
