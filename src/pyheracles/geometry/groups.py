"""Medians and quantiles of values per group (a slice, a layer, a face), in one sort.

numpy's median and linear quantile, term for term, for every group at once: a loop of
a mask and ``np.median`` per group cost a tenth of the supports step (a 13 m column in
5 cm layers has 260 of them) and most of a beam's slicing in the frame.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["group_medians", "group_quantiles"]

Array = NDArray[np.float64]


def _by_group(
    values: Array, group: NDArray[np.integer], n: int
) -> tuple[Array, NDArray[np.intp], NDArray[np.intp], NDArray[np.bool_]]:
    """``values`` sorted by group, then by value; each group's start and count, and
    whether it holds a NaN (numpy's median and quantile are NaN there)."""
    # by value, then stably by group: the order of np.lexsort((values, group)), 4x faster
    # (a stable sort of small integers is a radix sort)
    by_value = np.argsort(values)
    g_sorted = group[by_value]
    key = g_sorted.astype(np.uint16) if n <= 1 << 16 else g_sorted
    order = by_value[np.argsort(key, kind="stable")]
    count = np.bincount(group, minlength=n)
    start = np.concatenate(([0], np.cumsum(count)[:-1]))
    with_nan = np.zeros(n, dtype=bool)
    with_nan[group[np.isnan(values)]] = True
    return values[order], start, count, with_nan


def group_medians(values: Array, group: NDArray[np.integer], n: int) -> Array:
    """Median of ``values`` in each of ``n`` groups (``group``: 0 .. n-1; NaN if empty).

    The same numbers as ``np.median`` per group: the middle value, or the mean of the
    two middle values; NaN where a group holds a NaN.
    """
    out = np.full(n, np.nan)
    if len(values) == 0:
        return out
    v, start, count, with_nan = _by_group(values, group, n)
    has = count > 0
    lo = start[has] + (count[has] - 1) // 2
    hi = start[has] + count[has] // 2
    out[has] = (v[lo] + v[hi]) / 2.0
    out[with_nan] = np.nan
    return out


def group_quantiles(values: Array, group: NDArray[np.integer], n: int, q: float) -> Array:
    """The ``q`` quantile of ``values`` in each of ``n`` groups (NaN if empty).

    numpy's default (linear) quantile, term for term: the order statistics either side
    of ``(count - 1) q`` and numpy's interpolation between them (from the upper one
    when the weight is at least one half), so that comparisons with a threshold come
    out as with ``np.quantile`` per group; a group holding a NaN gives NaN as there.
    """
    out = np.full(n, np.nan)
    if len(values) == 0:
        return out
    v, start, count, with_nan = _by_group(values, group, n)
    has = count > 0
    c = count[has]
    virtual = (c - 1) * q
    prev = np.floor(virtual).astype(np.intp)
    nxt = np.minimum(prev + 1, c - 1)
    gamma = virtual - prev
    a, b = v[start[has] + prev], v[start[has] + nxt]
    diff = b - a
    res = a + diff * gamma
    upper = gamma >= 0.5
    res[upper] = (b - diff * (1 - gamma))[upper]
    out[has] = res
    out[with_nan] = np.nan
    return out
