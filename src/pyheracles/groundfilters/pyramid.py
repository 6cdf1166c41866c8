"""Compiled steps of the inpainting pyramid: 2 x 2 block means, the coarse fill and the band.

:func:`pyheracles.groundfilters.surface.inpaint` halves a raster with holes, inpaints
the half and brings it back at full resolution into the unknown cells, level by level.
On a mosaic of tiles on a diagonal every level spans a bounding box that is mostly
empty, and the numpy versions of these two steps made a dozen raster-sized temporaries
per level (strided quarters, masks, the two interleaved bilinear passes and a masked
assignment). Hand-written with numba for that reason: one pass each, the same
arithmetic in the same order, so the results are equal to the numpy formulas to the bit
(no fast-math, no fused multiply-add).
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numpy.typing import NDArray

__all__ = ["band_and_fill", "halve"]


def halve(values: NDArray[np.float64]) -> NDArray[np.float64]:
    """Mean of the known (finite) cells of each 2 x 2 block; NaN where a block has none.

    An odd last row or column makes blocks of its own cells only. Sums are taken as
    ``(a00 + a01) + (a10 + a11)`` with unknown cells as 0.
    """
    arr = np.ascontiguousarray(values, dtype=np.float64)
    return _halve(arr)


def band_and_fill(
    out: NDArray[np.float64], coarse: NDArray[np.float64], reach: int
) -> NDArray[np.int64]:
    """Fill the unknown (NaN) cells of ``out`` in place with the bilinear value of the
    half-resolution raster ``coarse`` at their centres (edges replicated; a fine centre
    lies a quarter of a coarse cell from the nearest coarse centre, so each axis is
    ``0.75 * nearest + 0.25 * next``, rows first) and return the flat indices, row-major,
    of the unknown cells with a known cell within ``reach`` cells (chessboard): the band
    the inpainting solves at full resolution.  One pass for the rows' running counts of
    known cells, one for the columns', the fill and the band: the raster-sized masks
    of ``np.isnan``, a square dilation and ``np.nonzero`` cost a mosaic's mostly empty
    raster a dozen passes per level.
    """
    if not out.flags.c_contiguous:
        raise ValueError("band_and_fill needs a C-contiguous raster")
    return _band_and_fill(out, np.ascontiguousarray(coarse, dtype=np.float64), int(reach))


@njit(cache=True)
def _band_and_fill(
    out: np.ndarray, coarse: np.ndarray, reach: int
) -> np.ndarray:  # pragma: no cover
    rows, cols = out.shape
    crows, ccols = coarse.shape
    # known cells within +-reach along each row
    row_hits = np.zeros((rows, cols), dtype=np.int32)
    for i in range(rows):
        count = 0
        for j in range(min(reach, cols)):
            if not np.isnan(out[i, j]):
                count += 1
        for j in range(cols):
            if j + reach < cols and not np.isnan(out[i, j + reach]):
                count += 1
            if j - reach - 1 >= 0 and not np.isnan(out[i, j - reach - 1]):
                count -= 1
            row_hits[i, j] = count
    band = np.empty(rows * cols, dtype=np.int64)
    n = 0
    near = np.zeros(cols, dtype=np.int32)  # row_hits summed over rows i - reach .. i + reach
    for i in range(min(reach, rows)):
        for j in range(cols):
            near[j] += row_hits[i, j]
    for i in range(rows):
        if i + reach < rows:
            for j in range(cols):
                near[j] += row_hits[i + reach, j]
        if i - reach - 1 >= 0:
            for j in range(cols):
                near[j] -= row_hits[i - reach - 1, j]
        ki = i // 2
        ni = ki - 1 if i % 2 == 0 else ki + 1
        ni = min(max(ni, 0), crows - 1)
        for j in range(cols):
            if not np.isnan(out[i, j]):
                continue
            kj = j // 2
            nj = kj - 1 if j % 2 == 0 else kj + 1
            nj = min(max(nj, 0), ccols - 1)
            v_near = 0.75 * coarse[ki, kj] + 0.25 * coarse[ni, kj]
            v_side = 0.75 * coarse[ki, nj] + 0.25 * coarse[ni, nj]
            out[i, j] = 0.75 * v_near + 0.25 * v_side
            if near[j] > 0:
                band[n] = i * cols + j
                n += 1
    return band[:n]


@njit(cache=True)
def _row_pair(values: np.ndarray, i: int, j: int) -> tuple[float, int]:  # pragma: no cover
    """Sum (unknown cells as 0) and count of the known cells ``(i, j)``, ``(i, j + 1)``."""
    rows, cols = values.shape
    a = b = 0.0
    count = 0
    if i < rows:
        v = values[i, j]
        if np.isfinite(v):
            a = v
            count += 1
        if j + 1 < cols:
            v = values[i, j + 1]
            if np.isfinite(v):
                b = v
                count += 1
    return a + b, count


@njit(cache=True)
def _halve(values: np.ndarray) -> np.ndarray:  # pragma: no cover - compiled
    rows, cols = values.shape
    half_rows, half_cols = (rows + 1) // 2, (cols + 1) // 2
    out = np.empty((half_rows, half_cols))
    for bi in range(half_rows):
        for bj in range(half_cols):
            top, n_top = _row_pair(values, 2 * bi, 2 * bj)
            bottom, n_bottom = _row_pair(values, 2 * bi + 1, 2 * bj)
            count = n_top + n_bottom
            out[bi, bj] = (top + bottom) / count if count > 0 else np.nan
    return out
