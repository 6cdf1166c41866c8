"""Error propagation into check point residuals: expected RMS and the chi-square test."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from pyheracles.errors import InputError
from pyheracles.registration.checkpoints import propagate_residuals
from pyheracles.registration.similarity import (
    SimilarityParams,
    estimate_similarity,
    similarity_matrix,
)

SIG_CLOUD = 0.004  # target measured in the cloud, per coordinate (cloud units)
SIG_SURVEY = 0.003  # control and check references, metres
T_TRUE = similarity_matrix([1049812.3, 6842367.9, 142.5], [0.02, -0.01, 0.7], 1.25)


def _geometry(rng: np.random.Generator):
    ctrl = rng.uniform([-15, -8, 0], [15, 8, 10], (8, 3))  # cloud frame
    chk = rng.uniform([-15, -8, 0], [15, 8, 10], (4, 3))
    return ctrl, chk


def _split(x: np.ndarray, n_c: int, n_k: int):
    a = 0
    out = []
    for n in (n_c, n_c, n_k, n_k):
        out.append(x[a : a + 3 * n].reshape(n, 3))
        a += 3 * n
    return out  # control in cloud, control world, check in cloud, check reference


def _residual_fn(n_c: int, n_k: int):
    def fn(x: np.ndarray) -> np.ndarray:
        c_cloud, c_world, k_cloud, k_ref = _split(x, n_c, n_k)
        res = estimate_similarity(
            c_cloud,
            c_world,
            SimilarityParams(),
            source_sigma=SIG_CLOUD,
            target_sigma=SIG_SURVEY,
        )
        return (k_ref - res.apply(k_cloud)).reshape(-1)

    return fn


def _truth(ctrl: np.ndarray, chk: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    def world(p: np.ndarray) -> np.ndarray:
        return p @ T_TRUE[:3, :3].T + T_TRUE[:3, 3]

    x = np.concatenate([ctrl.ravel(), world(ctrl).ravel(), chk.ravel(), world(chk).ravel()])
    sig = np.concatenate(
        [
            np.full(ctrl.size, SIG_CLOUD),
            np.full(ctrl.size, SIG_SURVEY),
            np.full(chk.size, SIG_CLOUD),
            np.full(chk.size, SIG_SURVEY),
        ]
    )
    return x, sig


def test_propagated_rms_matches_monte_carlo() -> None:
    rng = np.random.default_rng(11)
    ctrl, chk = _geometry(rng)
    x_true, sig = _truth(ctrl, chk)
    fn = _residual_fn(len(ctrl), len(chk))
    n = len(ctrl) * 6
    groups = {
        "control": np.arange(n),
        "check": np.arange(n, len(x_true)),
    }
    noisy = x_true + rng.normal(size=x_true.shape) * sig
    prop = propagate_residuals(fn, noisy, sig, groups=groups)
    assert prop.n_points == len(chk)
    assert prop.rms_3d == pytest.approx(np.sqrt(np.sum(fn(noisy) ** 2) / len(chk)))
    # the check points alone: sqrt(3 (sigma_ref^2 + (s sigma_cloud)^2)) = 7.3 mm
    by = prop.expected_rms_by_group()
    expected_check = np.sqrt(3 * (SIG_SURVEY**2 + (1.25 * SIG_CLOUD) ** 2))
    assert by["check"] == pytest.approx(expected_check, rel=1e-3)  # estimated scale ~ 1.25
    assert by["control"] > 0.001  # the transform error adds a few mm
    assert np.hypot(by["check"], by["control"]) == pytest.approx(prop.expected_rms_3d)
    # Monte Carlo with the same noise: E[RMS^2] agrees within its sampling error
    ms = []
    for _ in range(300):
        r = fn(x_true + rng.normal(size=x_true.shape) * sig)
        ms.append(np.sum(r**2) / len(chk))
    mc = float(np.sqrt(np.mean(ms)))
    assert mc == pytest.approx(prop.expected_rms_3d, rel=0.06)


def test_chi2_of_check_residuals_is_calibrated() -> None:
    """Under the stated noise the chi-square statistic has mean 3 n (12 here)."""
    rng = np.random.default_rng(5)
    ctrl, chk = _geometry(rng)
    x_true, sig = _truth(ctrl, chk)
    fn = _residual_fn(len(ctrl), len(chk))
    prop = propagate_residuals(fn, x_true + rng.normal(size=x_true.shape) * sig, sig)
    qs, ps = [], []
    for _ in range(200):  # the covariance hardly depends on the realisation: reuse it
        r = fn(x_true + rng.normal(size=x_true.shape) * sig)
        q, dof, p = replace(prop, residuals=r).chi2_test()
        qs.append(q)
        ps.append(p)
    assert dof == 12
    assert np.mean(qs) == pytest.approx(12.0, abs=1.2)  # sd of the mean: sqrt(24 / 200) = 0.35
    assert 0.42 < np.mean(ps) < 0.58  # uniform p-values (sd of the mean 0.02)
    # a 3 cm bias on one check reference is detected
    x = x_true + rng.normal(size=x_true.shape) * sig
    x[-3] += 0.03
    assert propagate_residuals(fn, x, sig).chi2_test()[2] < 0.01


def test_propagation_bad_input() -> None:
    fn = lambda o: o[:3] - o[3:]  # noqa: E731
    with pytest.raises(InputError, match="sigmas"):
        propagate_residuals(fn, np.zeros(6), np.ones(5))
    with pytest.raises(InputError, match="positive"):
        propagate_residuals(fn, np.zeros(6), np.zeros(6))
    with pytest.raises(InputError, match="3 per point"):
        propagate_residuals(lambda o: o[:2], np.zeros(6), np.ones(6))
    pr = propagate_residuals(fn, np.zeros(6), np.full(6, 0.003))
    assert pr.expected_rms_3d == pytest.approx(np.sqrt(3 * 2 * 0.003**2))
