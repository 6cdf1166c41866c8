"""Benchmarks of registration and georeferencing (issue 5).

Run ``python benchmarks/bench_registration.py [section ...]`` with sections
``montecarlo``, ``church``, ``icp``, ``bunny`` (default: all).  Prints JSON lines.
"""

from __future__ import annotations

import sys

import numpy as np

from _common import SHARED_DATA, emit, timer
from pyheracles.registration.similarity import (
    ESTIMATORS,
    PARAMETER_NAMES,
    SimilarityParams,
    estimate_similarity,
    similarity_matrix,
)


def bench_montecarlo(runs: int = 300, seed: int = 2026) -> None:
    """Normalised parameter errors and blunder detection rates (>= 200 runs)."""
    rng = np.random.default_rng(seed)
    sigma = 0.01  # 1 cm per coordinate
    true = np.array([452103.25, 5411020.5, 148.2, 0.012, -0.008, 1.1, 1.00025])
    T = similarity_matrix(true[:3], true[3:6], true[6])
    src = rng.uniform([-15, -8, 0], [15, 8, 12], (12, 3))  # one fixed geometry
    z = np.zeros((runs, 7))
    s0 = np.zeros(runs)
    with timer() as t:
        for i in range(runs):
            tgt = src @ T[:3, :3].T + T[:3, 3] + rng.normal(0.0, sigma, src.shape)
            res = estimate_similarity(src, tgt, SimilarityParams(sigma_m=sigma))
            est = np.array([res.parameters[k] for k in PARAMETER_NAMES])
            sd = np.array([res.std[k] for k in PARAMETER_NAMES])
            z[i] = (est - true) / sd
            s0[i] = res.sigma0
    spread = z.std(axis=0)
    for k, name in enumerate(PARAMETER_NAMES):
        emit(
            dataset="montecarlo_12pairs_1cm",
            metric=f"normalised_error_std_{name}",
            value=float(spread[k]),
            target="0.8-1.25",
            reached=bool(0.8 <= spread[k] <= 1.25),
            runs=runs,
            time_s=t.s,
            points_per_s=None,
        )
    emit(dataset="montecarlo_12pairs_1cm", metric="mean_sigma0", value=float(s0.mean()), runs=runs)
    for est_name in ESTIMATORS:
        hits = 0
        false_alarms = 0
        with timer() as t:
            for _ in range(runs):
                src_b = rng.uniform([-15, -8, 0], [15, 8, 12], (12, 3))
                tgt = src_b @ T[:3, :3].T + T[:3, 3] + rng.normal(0.0, sigma, src_b.shape)
                bad = int(rng.integers(12))
                d = rng.normal(size=3)
                tgt[bad] += 0.10 * d / np.linalg.norm(d)
                res = estimate_similarity(
                    src_b, tgt, SimilarityParams(estimator=est_name, sigma_m=sigma)
                )
                hits += bool(res.outliers[bad])
                false_alarms += int(res.outliers.sum()) - bool(res.outliers[bad])
        emit(
            dataset="montecarlo_12pairs_1cm_10cm_blunder",
            metric=f"blunder_detection_rate_{est_name}",
            value=hits / runs,
            target=">=0.95",
            reached=hits / runs >= 0.95,
            false_alarms_per_run=false_alarms / runs,
            runs=runs,
            time_s=t.s,
            points_per_s=None,
        )


SECTIONS = {"montecarlo": bench_montecarlo}

if __name__ == "__main__":
    wanted = sys.argv[1:] or list(SECTIONS)
    del SHARED_DATA  # used by the real-data sections
    for name in wanted:
        SECTIONS[name]()
