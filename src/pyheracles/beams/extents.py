"""Compiled statistics of a band's offsets across many directions.

Why hand-written (numba): the straight bands of a facet are found by looking at
the offsets of its points across each of many directions (:mod:`pyheracles.beams.bands`):

- :func:`offset_histograms`, the Hough accumulator of ``best_direction`` (180
  directions x 4,000 points per band): numpy made several ``(points,
  directions)`` temporaries of offsets and bin numbers;
- :func:`extreme_order_statistics`, for ``sharpest_direction``: for each of 41-81
  directions the 0.5 % and 99.5 % quantiles of up to 3,000 offsets, i.e. the
  15-16 smallest and largest of them, where ``np.quantile`` partitions every
  direction's offsets in full; two small sorted buffers read each offset once.

The offsets are computed as numpy computes ``-x * sin(a) + y * cos(a)`` (no fused
multiply-add without ``fastmath``), with the sines and cosines taken by numpy, so
the histograms, the order statistics and the quantiles interpolated from them
are numpy's to the bit.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numpy.typing import NDArray

__all__ = ["extreme_order_statistics", "offset_histograms"]


@njit(cache=True)
def extreme_order_statistics(
    x: NDArray[np.float64],
    y: NDArray[np.float64],
    sin_a: NDArray[np.float64],
    cos_a: NDArray[np.float64],
    lo_prev: int,
    lo_next: int,
    hi_prev: int,
    hi_next: int,
) -> NDArray[np.float64]:
    """Order statistics of ``-x * sin_a[j] + y * cos_a[j]`` for every direction ``j``.

    Returns ``(len(sin_a), 4)``: the ``lo_prev``-th, ``lo_next``-th, ``hi_prev``-th
    and ``hi_next``-th smallest values (0-based ranks among ``len(x)``), with
    ``lo_prev <= lo_next < hi_prev <= hi_next`` or the ranks of a tiny set.
    """
    m = x.shape[0]
    n_low = lo_next + 1  # the smallest values up to rank lo_next
    n_high = m - hi_prev  # the largest values down to rank hi_prev
    low = np.empty(max(n_low, 1))
    high = np.empty(max(n_high, 1))
    out = np.empty((sin_a.shape[0], 4))
    for a in range(sin_a.shape[0]):
        sa, ca = sin_a[a], cos_a[a]
        nl = 0
        nh = 0
        for i in range(m):
            v = (-x[i]) * sa + y[i] * ca
            # low: ascending, the n_low smallest so far
            if nl < n_low:
                j = nl
                nl += 1
            elif v < low[nl - 1]:
                j = nl - 1
            else:
                j = -1
            if j >= 0:
                while j > 0 and low[j - 1] > v:
                    low[j] = low[j - 1]
                    j -= 1
                low[j] = v
            # high: ascending, the n_high largest so far
            if nh < n_high:
                j = nh
                nh += 1
                while j > 0 and high[j - 1] > v:
                    high[j] = high[j - 1]
                    j -= 1
                high[j] = v
            elif v > high[0]:
                j = 0
                while j + 1 < nh and high[j + 1] < v:
                    high[j] = high[j + 1]
                    j += 1
                high[j] = v
        out[a, 0] = low[lo_prev]
        out[a, 1] = low[lo_next]
        out[a, 2] = high[0]
        out[a, 3] = high[hi_next - hi_prev]
    return out


@njit(cache=True)
def offset_histograms(
    x: NDArray[np.float64],
    y: NDArray[np.float64],
    sin_a: NDArray[np.float64],
    cos_a: NDArray[np.float64],
    bin_m: float,
) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """Histograms of the offsets ``-x * sin_a[j] + y * cos_a[j]`` for every direction.

    Returns ``acc`` (``(len(sin_a), n_bins)``: counts of bins ``bin_m`` wide from each
    direction's smallest offset, one number of bins for all) and those smallest
    offsets: the Hough accumulator of :func:`~pyheracles.beams.bands.best_direction`
    without its ``(points, directions)`` temporaries (the same numbers).
    """
    n_a = sin_a.shape[0]
    m = x.shape[0]
    smin = np.empty(n_a)
    n_bins = 1
    for a in range(n_a):
        sa, ca = sin_a[a], cos_a[a]
        lo = np.inf
        hi = -np.inf
        for i in range(m):
            v = (-x[i]) * sa + y[i] * ca
            lo = min(lo, v)
            hi = max(hi, v)
        smin[a] = lo
        n_bins = max(n_bins, int((hi - lo) / bin_m) + 1)
    acc = np.zeros((n_a, n_bins), np.int64)
    for a in range(n_a):
        sa, ca, lo = sin_a[a], cos_a[a], smin[a]
        for i in range(m):
            v = (-x[i]) * sa + y[i] * ca
            acc[a, int((v - lo) / bin_m)] += 1
    return acc, smin
