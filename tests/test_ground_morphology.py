"""The compiled kernels of SMRF's disks (cross passes, squares) equal scipy's filters."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from pyheracles.groundfilters.morphology import repeated_cross_filter

CROSS = ndimage.generate_binary_structure(2, 1)


@pytest.mark.parametrize("shape", [(2, 2), (2, 9), (9, 2), (37, 23), (64, 201)])
@pytest.mark.parametrize("op", ["min", "max"])
def test_repeated_cross_is_scipys_cross_filter_n_times(shape: tuple[int, int], op: str) -> None:
    rng = np.random.default_rng(sum(shape))
    values = rng.normal(size=shape).cumsum(axis=0) + rng.integers(0, 3, size=shape)
    filt = ndimage.minimum_filter if op == "min" else ndimage.maximum_filter
    expected = values
    for n in range(1, 8):
        expected = filt(expected, footprint=CROSS, mode="nearest")
        assert np.array_equal(repeated_cross_filter(values, n, op), expected), n


def test_zero_passes_one_row_and_nan_rasters() -> None:
    values = np.arange(12.0).reshape(3, 4)
    assert repeated_cross_filter(values, 0, "min") is values
    row = np.array([[3.0, 1.0, 2.0, 5.0]])
    assert np.array_equal(repeated_cross_filter(row, 1, "min"), [[1.0, 1.0, 1.0, 2.0]])
    holed = values.copy()
    holed[1, 1] = np.nan
    out = repeated_cross_filter(holed, 1, "max")
    assert np.isnan(out[1, 1]) and np.isnan(out[0, 1]) and out[2, 3] == 11.0
    with pytest.raises(ValueError, match="op must be"):
        repeated_cross_filter(values, 1, "mean")


@pytest.mark.parametrize("shape", [(1, 1), (1, 7), (7, 1), (2, 2), (37, 23), (100, 301)])
@pytest.mark.parametrize("op", ["min", "max"])
def test_square_filter_is_scipys(shape: tuple[int, int], op: str) -> None:
    from pyheracles.groundfilters.morphology import square_filter

    rng = np.random.default_rng(shape[0] * 1000 + shape[1])
    values = rng.normal(size=shape).cumsum(axis=0)
    filt = ndimage.minimum_filter if op == "min" else ndimage.maximum_filter
    for half in (1, 2, 5, 13, 40):
        expected = filt(values, size=2 * half + 1, mode="nearest")
        assert np.array_equal(square_filter(values, half, op), expected), half
    holed = values.copy()
    holed.flat[0] = np.nan  # through scipy
    assert np.array_equal(square_filter(holed, 2, op), filt(holed, size=5, mode="nearest"),
                          equal_nan=True)  # fmt: skip
