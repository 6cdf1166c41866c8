"""Tests of the similarity (Helmert) adjustment and its robust estimators."""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.errors import DegenerateGeometryError, InputError
from pyheracles.registration.similarity import (
    ESTIMATORS,
    SimilarityParams,
    estimate_similarity,
    similarity_matrix,
)

TRUE = {"t": [452103.25, 5411020.5, 148.2], "angles": [0.012, -0.008, 1.1], "scale": 1.00025}


def _pairs(rng: np.random.Generator, n: int = 12, sigma: float = 0.01):
    T = similarity_matrix(TRUE["t"], TRUE["angles"], TRUE["scale"])
    src = rng.uniform([-15, -8, 0], [15, 8, 12], (n, 3))
    tgt = src @ T[:3, :3].T + T[:3, 3] + rng.normal(0.0, sigma, (n, 3))
    return src, tgt, T


def test_exact_recovery_large_coordinates() -> None:
    rng = np.random.default_rng(0)
    src, _, T = _pairs(rng, sigma=0.0)
    tgt = src @ T[:3, :3].T + T[:3, 3]
    res = estimate_similarity(src, tgt)
    np.testing.assert_allclose(res.T_target_source, T, atol=1e-8)
    assert res.parameters["scale"] == pytest.approx(TRUE["scale"], abs=1e-10)
    assert res.redundancy == 3 * 12 - 7
    assert np.abs(res.residuals).max() < 1e-6


def test_rigid_has_six_parameters_and_unit_scale() -> None:
    rng = np.random.default_rng(1)
    T = similarity_matrix([5, 6, 7], [0.3, -0.2, 2.5], 1.0)
    src = rng.uniform(-5, 5, (6, 3))
    tgt = src @ T[:3, :3].T + T[:3, 3] + rng.normal(0, 0.002, (6, 3))
    res = estimate_similarity(src, tgt, SimilarityParams(with_scale=False))
    assert res.parameters["scale"] == 1.0 and res.std["scale"] == 0.0
    assert res.redundancy == 18 - 6
    assert res.parameter_names == ("tx", "ty", "tz", "omega", "phi", "kappa")
    np.testing.assert_allclose(res.T_target_source[:3, :3], T[:3, :3], atol=2e-3)


def test_monte_carlo_normalised_errors_have_unit_spread() -> None:
    """Reported standard deviations match the actual spread of the estimates."""
    rng = np.random.default_rng(42)
    true = [*TRUE["t"], *TRUE["angles"], TRUE["scale"]]
    names = ("tx", "ty", "tz", "omega", "phi", "kappa", "scale")
    # fixed design, new noise each run (the std devs refer to one geometry)
    src, _, T = _pairs(rng)
    z = []
    for _ in range(150):
        tgt = src @ T[:3, :3].T + T[:3, 3] + rng.normal(0.0, 0.01, src.shape)
        res = estimate_similarity(src, tgt)
        z.append([(res.parameters[k] - t) / res.std[k] for k, t in zip(names, true, strict=True)])
    spread = np.std(np.array(z), axis=0)
    assert np.all((spread > 0.8) & (spread < 1.25)), spread
    # and sigma0 is about 1 for correctly weighted observations (sigma_m = 1 cm)
    assert 0.8 < res.sigma0 < 1.3


@pytest.mark.parametrize("estimator", ESTIMATORS)
def test_blunder_flagged_by_every_estimator(estimator: str) -> None:
    rng = np.random.default_rng(7)
    hits = 0
    false_alarms = 0
    for _ in range(20):
        src, tgt, _T = _pairs(rng)
        bad = int(rng.integers(12))
        direction = rng.normal(size=3)
        tgt[bad] += 0.10 * direction / np.linalg.norm(direction)
        res = estimate_similarity(src, tgt, SimilarityParams(estimator=estimator))
        hits += bool(res.outliers[bad])
        false_alarms += int(res.outliers.sum() - res.outliers[bad])
        # after rejection the transform is clean
        clean = np.delete(np.arange(12), bad)
        assert np.abs(res.residuals[clean]).max() < 0.06
    assert hits >= 19
    assert false_alarms <= 3


def test_parameter_correlations_are_a_valid_matrix() -> None:
    rng = np.random.default_rng(3)
    src, tgt, _ = _pairs(rng)
    res = estimate_similarity(src, tgt)
    np.testing.assert_allclose(np.diag(res.correlation), 1.0, atol=1e-12)
    assert np.all(np.abs(res.correlation) <= 1.0 + 1e-12)
    d = res.to_dict()
    assert d["redundancy"] == 29 and len(d["points"]) == 12
    # large translation is strongly correlated with the rotations (lever arm)
    assert np.abs(res.correlation[0:3, 3:6]).max() > 0.5


def test_sigmas_weight_the_points() -> None:
    rng = np.random.default_rng(5)
    src, tgt, _T = _pairs(rng, sigma=0.0)
    tgt = tgt.copy()
    tgt[0] += [0.05, 0, 0]
    sig = np.full(12, 0.001)
    sig[0] = 1.0  # a point with a huge sigma barely influences the fit
    res = estimate_similarity(src, tgt, target_sigma=sig)
    assert abs(res.residuals[0, 0] - 0.05) < 1e-3


def test_too_few_pairs() -> None:
    with pytest.raises(InputError, match="at least 3 point pairs"):
        estimate_similarity(np.zeros((2, 3)), np.zeros((2, 3)))


def test_collinear_points() -> None:
    line = np.outer(np.arange(5.0), [1, 2, 3])
    with pytest.raises(DegenerateGeometryError, match="collinear"):
        estimate_similarity(line, line + 1)


def test_coincident_points() -> None:
    with pytest.raises(DegenerateGeometryError, match="coincide"):
        estimate_similarity(np.ones((4, 3)), np.ones((4, 3)))


def test_unknown_estimator_lists_choices() -> None:
    with pytest.raises(InputError, match="danish"):
        SimilarityParams(estimator="ransac")
