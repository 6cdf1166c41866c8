"""Compiled per-edge terms of the kNN graph of region growing.

Why hand-written (numba): for every point ``i`` and neighbour ``j`` the growth
needs ``|n_i . n_j|`` and the larger of the two distances of each point to the
other's tangent plane.  In numpy this is a handful of ``(n, k, 3)`` float32
temporaries (gathered normals, positions, differences, products); the loop
below reads each neighbour's position and normal once and writes two numbers.
It sums the float32 products in numpy's order (``x + y`` then ``+ z``) and numba
does not fuse multiply and add without ``fastmath``, so the values equal the
numpy formulas to the bit.
"""

from __future__ import annotations

import os

import numba
import numpy as np
from numba import njit, prange
from numpy.typing import NDArray

if "NUMBA_THREADING_LAYER" not in os.environ and "NUMBA_THREADING_LAYER_PRIORITY" not in os.environ:
    # as in pyheracles.geometry.knn_kernels: no warning about an old system TBB
    numba.config.THREADING_LAYER_PRIORITY = ["omp", "workqueue", "tbb"]

__all__ = ["knn_edge_terms"]


@njit(cache=True, parallel=True)
def knn_edge_terms(
    pos: NDArray[np.float32],
    nrm: NDArray[np.float32],
    nbr: NDArray[np.int64],
    cosang: NDArray[np.float32],
    resid: NDArray[np.float32],
) -> None:
    """Fill ``cosang[i, c]`` and ``resid[i, c]`` for the edge ``i -> nbr[i, c]``.

    ``pos`` and ``nrm``: ``(n, 3)`` float32 positions (centred) and unit normals;
    ``cosang = |n_i . n_j|``, ``resid = max(|n_i . d|, |n_j . d|)`` with
    ``d = p_j - p_i``.
    """
    n, m = nbr.shape
    for i in prange(n):
        sx, sy, sz = nrm[i, 0], nrm[i, 1], nrm[i, 2]
        px, py, pz = pos[i, 0], pos[i, 1], pos[i, 2]
        for c in range(m):
            j = nbr[i, c]
            tx, ty, tz = nrm[j, 0], nrm[j, 1], nrm[j, 2]
            dx = pos[j, 0] - px
            dy = pos[j, 1] - py
            dz = pos[j, 2] - pz
            cosang[i, c] = abs(sx * tx + sy * ty + sz * tz)
            r1 = abs(sx * dx + sy * dy + sz * dz)
            r2 = abs(tx * dx + ty * dy + tz * dz)
            resid[i, c] = r1 if r1 >= r2 else r2
