"""The sort of :func:`~pyheracles.geometry.sections.sort_order` on the machine's cores.

Why: every step sorts the heights of the whole cloud once (10 M points: 0.6 s of CPU,
a tenth of the supports step), and numpy sorts on one core.  The keys of
:func:`~pyheracles.geometry.sections.sort_order` hold each value's index in their low
bits, so they are all distinct: two halves sorted on two threads (numpy releases the
interpreter lock while it sorts) and merged give exactly the array that one sort
gives.  The keys, the merge and the gather of the sorted values are compiled loops
(numba, ``nogil``) over blocks of points, on threads; each computes what the numpy
expressions computed (the same float operations in the same order).
"""

from __future__ import annotations

from itertools import pairwise

import numpy as np
from numba import njit
from numpy.typing import NDArray

from pyheracles.threads import map_threads, n_workers

__all__ = ["PARALLEL_MIN", "sorted_keys", "split_keys"]

#: Fewer values than this are sorted on one thread (the threads would cost more).
PARALLEL_MIN = 1_000_000


@njit(nogil=True, cache=True)
def _float_keys(v, lo, scale, bits, key, s, e):  # pragma: no cover - compiled
    for i in range(s, e):
        key[i] = (np.int64((v[i] - lo) * scale) << bits) | i


@njit(nogil=True, cache=True)
def _merge(a, b, out):  # pragma: no cover - compiled
    i = j = k = 0
    while i < len(a) and j < len(b):
        if a[i] < b[j]:
            out[k] = a[i]
            i += 1
        else:
            out[k] = b[j]
            j += 1
        k += 1
    out[k : k + len(a) - i] = a[i:]
    k += len(a) - i
    out[k : k + len(b) - j] = b[j:]


@njit(nogil=True, cache=True)
def _split(key, v, mask, order, srt, s, e):  # pragma: no cover - compiled
    for i in range(s, e):
        o = key[i] & mask
        order[i] = o
        srt[i] = v[o]


def _blocks(n: int) -> list[tuple[int, int]]:
    edges = np.linspace(0, n, max(1, min(n_workers(), 8)) + 1).astype(np.int64)
    return [(int(a), int(b)) for a, b in pairwise(edges)]


def sorted_keys(v: NDArray, lo: float, hi: float, bits: int) -> NDArray[np.int64]:
    """The sorted int64 keys of float values ``v`` (see
    :func:`~pyheracles.geometry.sections.sort_order`): each value quantised over
    ``[lo, hi]`` in the high bits, its index in the low ``bits``."""
    n = len(v)
    span = float(hi) - float(lo)
    scale = (2.0 ** (62 - bits) - 1) / span if span > 0 else 0.0
    key = np.empty(n, dtype=np.int64)
    blocks = _blocks(n)
    map_threads(lambda se: _float_keys(v, float(lo), scale, bits, key, *se), blocks)
    if len(blocks) < 2:
        key.sort()
        return key
    half = n // 2
    parts = [key[:half], key[half:]]
    map_threads(lambda part: part.sort(), parts, workers=2)  # in place, each its own half
    out = np.empty_like(key)
    _merge(parts[0], parts[1], out)
    return out


def split_keys(key: NDArray[np.int64], v: NDArray, bits: int) -> tuple[NDArray[np.intp], NDArray]:
    """Indices (the low ``bits`` of the sorted keys) and the values ``v`` in that order."""
    n = len(key)
    order = np.empty(n, dtype=np.intp)
    srt = np.empty(n, dtype=v.dtype)
    mask = (1 << bits) - 1
    map_threads(lambda se: _split(key, v, mask, order, srt, *se), _blocks(n))
    return order, srt
