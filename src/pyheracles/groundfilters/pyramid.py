"""Compiled steps of the inpainting pyramid: 2 x 2 block means and the coarse fill.

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

__all__ = ["fill_from_coarse", "halve"]


def halve(values: NDArray[np.float64]) -> NDArray[np.float64]:
    """Mean of the known (finite) cells of each 2 x 2 block; NaN where a block has none.

    An odd last row or column makes blocks of its own cells only. Sums are taken as
    ``(a00 + a01) + (a10 + a11)`` with unknown cells as 0.
    """
    arr = np.ascontiguousarray(values, dtype=np.float64)
    return _halve(arr)


def fill_from_coarse(
    out: NDArray[np.float64], unknown: NDArray[np.bool_], coarse: NDArray[np.float64]
) -> None:
    """Write into the ``unknown`` cells of ``out`` (in place) the bilinear value of the
    half-resolution raster ``coarse`` at their centres, edges replicated.

    A fine cell centre lies a quarter of a coarse cell from the nearest coarse centre,
    so each axis is ``0.75 * nearest + 0.25 * next`` (rows first, then columns).
    """
    if not out.flags.c_contiguous or not unknown.flags.c_contiguous:
        raise ValueError("fill_from_coarse needs C-contiguous rasters")
    _fill(out, unknown, np.ascontiguousarray(coarse, dtype=np.float64))


@njit(cache=True)
def _halve(values: np.ndarray) -> np.ndarray:  # pragma: no cover - compiled
    rows, cols = values.shape
    half_rows, half_cols = (rows + 1) // 2, (cols + 1) // 2
    out = np.empty((half_rows, half_cols))
    for bi in range(half_rows):
        i0, i1 = 2 * bi, 2 * bi + 1
        for bj in range(half_cols):
            j0, j1 = 2 * bj, 2 * bj + 1
            count = 0
            z00 = z01 = z10 = z11 = 0.0
            v = values[i0, j0]
            if np.isfinite(v):
                z00 = v
                count += 1
            if j1 < cols:
                v = values[i0, j1]
                if np.isfinite(v):
                    z01 = v
                    count += 1
            if i1 < rows:
                v = values[i1, j0]
                if np.isfinite(v):
                    z10 = v
                    count += 1
                if j1 < cols:
                    v = values[i1, j1]
                    if np.isfinite(v):
                        z11 = v
                        count += 1
            out[bi, bj] = ((z00 + z01) + (z10 + z11)) / count if count > 0 else np.nan
    return out


@njit(cache=True)
def _fill(out: np.ndarray, unknown: np.ndarray, coarse: np.ndarray) -> None:  # pragma: no cover
    rows, cols = out.shape
    crows, ccols = coarse.shape
    for i in range(rows):
        ki = i // 2
        ni = ki - 1 if i % 2 == 0 else ki + 1
        ni = min(max(ni, 0), crows - 1)
        for j in range(cols):
            if not unknown[i, j]:
                continue
            kj = j // 2
            nj = kj - 1 if j % 2 == 0 else kj + 1
            nj = min(max(nj, 0), ccols - 1)
            near = 0.75 * coarse[ki, kj] + 0.25 * coarse[ni, kj]
            side = 0.75 * coarse[ki, nj] + 0.25 * coarse[ni, nj]
            out[i, j] = 0.75 * near + 0.25 * side
