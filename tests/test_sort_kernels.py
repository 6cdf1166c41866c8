"""The threaded sort of :func:`~pyheracles.geometry.sections.sort_order`
(:mod:`pyheracles.geometry.sort_kernels`, issue 12 speed) gives exactly the keys, order
and sorted values of the one-thread numpy sort: the keys are distinct (an index in the
low bits), so two sorted halves merged are the sorted whole."""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.geometry import sections, sort_kernels
from pyheracles.geometry.sections import sort_order


def _values(n: int, dtype: type = np.float64) -> np.ndarray:
    rng = np.random.default_rng(4)
    v = rng.normal(0, 3, n).astype(dtype)
    v[::5] = v[7]  # ties keep their input order
    v[::11] = np.nextafter(v[3], np.inf)  # values closer than the quantisation step
    return v


@pytest.mark.parametrize("n", [12, 13, 1000, 50_001])
def test_sorted_keys_and_split_match_numpy(n: int, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("HERACLES_THREADS", "2")
    v = _values(n)
    bits = max(1, (n - 1).bit_length())
    ref = sections._sort_keys(v, v.min(), v.max(), bits, False)
    ref.sort()
    key = sort_kernels.sorted_keys(v, v.min(), v.max(), bits)
    np.testing.assert_array_equal(key, ref)
    order, srt = sort_kernels.split_keys(key, v, bits)
    np.testing.assert_array_equal(order, ref & ((1 << bits) - 1))
    np.testing.assert_array_equal(srt, v[order])
    assert order.dtype == np.intp and srt.dtype == v.dtype


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_sort_order_on_threads_matches_one_thread(
    dtype: type, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(sections, "PARALLEL_MIN", 1000)
    v = _values(300_001, dtype)
    col = np.c_[v, v, v][:, 2]  # a strided column, as the heights of an (N, 3) cloud
    monkeypatch.setenv("HERACLES_THREADS", "1")
    one = sort_order(col)
    monkeypatch.setenv("HERACLES_THREADS", "3")
    three = sort_order(col)
    for a, b in zip(one, three, strict=True):
        np.testing.assert_array_equal(a, b)
        assert a.dtype == b.dtype
    np.testing.assert_array_equal(one[0], np.argsort(v, kind="stable"))
