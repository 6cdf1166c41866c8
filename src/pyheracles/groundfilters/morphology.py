"""Grey morphology kernels of the ground filters: squares and repeated 3 x 3 crosses.

SMRF's openings (:func:`pyheracles.groundfilters.smrf.opening`) build each octagonal
disk as a square (a separable running min / max) and a diamond, and
the diamond of radius ``b`` is ``b`` erosions (or dilations) by the 3 x 3 cross. Over a
progressive filter that is hundreds of cross passes over the raster, the largest cost
of the ground filter on wide rasters (tiles on a diagonal). ``scipy.ndimage`` has no
repeated-structuring-element filter and its cross footprint filter costs three times
the four shifted ``np.minimum`` of the numpy version; both allocate a raster per pass.
The kernel here is hand-written (numba) for that reason: it runs the ``n`` passes in
place between two buffers, branch-free, 5-7x faster than the numpy passes on
AHN3-sized rasters and equal to them to the bit (a min or max only selects values).
The square's running min / max (van Herk / Gil-Werman, three comparisons per cell
whatever the width, the columns taken a whole row at a time) is 1.5-3x faster than
``ndimage.minimum_filter`` for the half-widths of 5-30 cells SMRF reaches, the same
to the bit.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numpy.typing import NDArray

__all__ = ["repeated_cross_filter", "square_filter"]


def repeated_cross_filter(values: NDArray[np.float64], n: int, op: str) -> NDArray[np.float64]:
    """``n`` successive grey erosions (``op="min"``) or dilations (``"max"``) by the 3 x 3
    cross: by the diamond ``|dx| + |dy| <= n``, edges replicated at every pass (a
    missing neighbour is the cell itself, as ``ndimage.minimum_filter(values,
    footprint=cross, mode="nearest")`` applied ``n`` times).

    Parameters
    ----------
    values
        2-D raster, no NaN (a gap-free surface); NaN rasters go through numpy, which
        propagates them as ``np.minimum`` does.
    n
        Number of passes (the diamond's radius, cells); 0 returns ``values``.
    op
        ``"min"`` (erosion) or ``"max"`` (dilation).
    """
    if op not in ("min", "max"):
        raise ValueError(f"op must be 'min' or 'max', got {op!r}")
    if n <= 0:
        return values
    arr = np.ascontiguousarray(values, dtype=np.float64)
    if arr.ndim != 2 or min(arr.shape) < 2 or np.isnan(arr).any():
        return _numpy_passes(arr, n, np.minimum if op == "min" else np.maximum)
    return _cross_passes(arr, n, op == "min")


def square_filter(values: NDArray[np.float64], half: int, op: str) -> NDArray[np.float64]:
    """Grey erosion (``"min"``) or dilation (``"max"``) by the square of half-width
    ``half`` cells, edges replicated: ``ndimage.minimum_filter(values, size=2 * half + 1,
    mode="nearest")`` (or ``maximum_filter``). NaN rasters go through scipy."""
    if op not in ("min", "max"):
        raise ValueError(f"op must be 'min' or 'max', got {op!r}")
    if half <= 0:
        return values
    arr = np.ascontiguousarray(values, dtype=np.float64)
    if arr.ndim != 2 or np.isnan(arr).any():
        from scipy import ndimage

        filt = ndimage.minimum_filter if op == "min" else ndimage.maximum_filter
        return filt(arr, size=2 * half + 1, mode="nearest")
    if op == "min":
        return _columns_min(_rows_min(arr, half), half)
    return -_columns_min(_rows_min(-arr, half), half)  # max x = -min(-x), exactly


def _numpy_passes(values: NDArray[np.float64], n: int, ufunc: np.ufunc) -> NDArray[np.float64]:
    """Reference passes: four shifted in-place ``ufunc`` on slices per pass."""
    out = values
    for _ in range(n):
        src = out
        out = np.empty_like(src)
        ufunc(src[1:], src[:-1], out=out[1:])
        out[0] = src[0]
        ufunc(out[:-1], src[1:], out=out[:-1])
        if src.ndim > 1 and src.shape[1] > 1:
            ufunc(out[:, 1:], src[:, :-1], out=out[:, 1:])
            ufunc(out[:, :-1], src[:, 1:], out=out[:, :-1])
    return out


@njit(cache=True)
def _cross_passes(values: np.ndarray, n: int, is_min: bool) -> np.ndarray:  # pragma: no cover
    rows, cols = values.shape
    a = values.copy()
    b = np.empty_like(a)
    last = cols - 1
    for _ in range(n):
        for i in range(rows):
            up = i - 1 if i > 0 else i
            down = i + 1 if i < rows - 1 else i
            if is_min:
                b[i, 0] = min(min(a[i, 0], a[up, 0]), min(a[down, 0], a[i, 1]))
                for j in range(1, last):
                    b[i, j] = min(
                        min(a[i, j], a[up, j]), min(a[down, j], min(a[i, j - 1], a[i, j + 1]))
                    )
                b[i, last] = min(min(a[i, last], a[up, last]), min(a[down, last], a[i, last - 1]))
            else:
                b[i, 0] = max(max(a[i, 0], a[up, 0]), max(a[down, 0], a[i, 1]))
                for j in range(1, last):
                    b[i, j] = max(
                        max(a[i, j], a[up, j]), max(a[down, j], max(a[i, j - 1], a[i, j + 1]))
                    )
                b[i, last] = max(max(a[i, last], a[up, last]), max(a[down, last], a[i, last - 1]))
        a, b = b, a
    return a


@njit(cache=True)
def _rows_min(a: np.ndarray, half: int) -> np.ndarray:  # pragma: no cover - compiled
    rows, cols = a.shape
    w = 2 * half + 1
    m = ((cols + 2 * half + w - 1) // w) * w  # the row extended by half a window each side
    out = np.empty_like(a)
    ext = np.empty(m)
    g = np.empty(m)  # running min from each block's start
    h = np.empty(m)  # running min to each block's end
    for i in range(rows):
        for k in range(m):
            ext[k] = a[i, min(max(k - half, 0), cols - 1)]
        for s in range(0, m, w):
            g[s] = ext[s]
            for k in range(s + 1, s + w):
                g[k] = min(g[k - 1], ext[k])
            h[s + w - 1] = ext[s + w - 1]
            for k in range(s + w - 2, s - 1, -1):
                h[k] = min(h[k + 1], ext[k])
        for j in range(cols):
            out[i, j] = min(h[j], g[j + w - 1])
    return out


@njit(cache=True)
def _columns_min(a: np.ndarray, half: int) -> np.ndarray:  # pragma: no cover - compiled
    rows, cols = a.shape
    w = 2 * half + 1
    m = ((rows + 2 * half + w - 1) // w) * w
    g = np.empty((m, cols))
    h = np.empty((m, cols))
    for s in range(0, m, w):
        g[s] = a[min(max(s - half, 0), rows - 1)]
        for k in range(s + 1, s + w):
            src = a[min(max(k - half, 0), rows - 1)]
            for j in range(cols):
                g[k, j] = min(g[k - 1, j], src[j])
        h[s + w - 1] = a[min(max(s + w - 1 - half, 0), rows - 1)]
        for k in range(s + w - 2, s - 1, -1):
            src = a[min(max(k - half, 0), rows - 1)]
            for j in range(cols):
                h[k, j] = min(h[k + 1, j], src[j])
    out = np.empty_like(a)
    for i in range(rows):
        for j in range(cols):
            out[i, j] = min(h[i, j], g[i + w - 1, j])
    return out
