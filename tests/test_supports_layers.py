"""Per-group medians and quantiles (a support's layers, a beam's slices) equal numpy's."""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.geometry.groups import group_medians, group_quantiles


@pytest.mark.parametrize("seed", range(6))
def test_layer_statistics_equal_numpy_per_layer(seed: int) -> None:
    rng = np.random.default_rng(seed)
    for trial in range(200):
        n = int(rng.integers(1, 30))
        size = int(rng.integers(1, 300))
        values = rng.normal(size=size)
        if trial % 3 == 0:  # ties: values on a 1 dm grid
            values = np.round(values, 1)
        if trial % 25 == 0:
            values[rng.integers(0, size)] = np.nan
        layer = rng.integers(0, n, size)
        med, q90 = group_medians(values, layer, n), group_quantiles(values, layer, n, 0.9)
        for i in range(n):
            v = values[layer == i]
            if len(v) == 0:
                assert np.isnan(med[i]) and np.isnan(q90[i])
                continue
            with np.errstate(invalid="ignore"):
                want_med, want_q = np.median(v), np.quantile(v, 0.9)
            # the same floating-point numbers, not merely close ones
            assert want_med == med[i] or (np.isnan(want_med) and np.isnan(med[i]))
            assert want_q == q90[i] or (np.isnan(want_q) and np.isnan(q90[i]))
