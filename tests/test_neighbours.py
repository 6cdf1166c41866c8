"""Tests of shared neighbourhoods: kNN, normals, curvature, PCA features."""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.errors import InputError
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
