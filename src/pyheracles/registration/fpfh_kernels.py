"""Compiled (numba) kernels of the sign-invariant FPFH descriptor (and of the
consensus of its matches: :func:`consistency_kernel`, :func:`inlier_counts_kernel`,
one pass each over what numpy builds as several ``(n, n)`` or ``(batch, n, 3)``
temporaries).

The numpy version of :func:`pyheracles.registration.features.fpfh_descriptors`
materialises about ten ``(pairs, 3)`` temporaries (400 000 pairs for 5 000
points); this kernel walks each neighbour list once.  Its neighbourhoods (the
100 nearest points within 5 voxels) come from :func:`radius_knn_kernel`, a
search on a grid of cells as wide as the radius: a k-d tree keeps a heap of 100
candidates per point and is 2-4 times slower at that.  ``cache=True`` keeps the
compiled code between runs.
"""

from __future__ import annotations

import math
import os

import numba
import numpy as np
from numba import njit, prange

if "NUMBA_THREADING_LAYER" not in os.environ and "NUMBA_THREADING_LAYER_PRIORITY" not in os.environ:
    # as in pyheracles.geometry.knn_kernels: numba tries TBB first and warns when the
    # system's TBB is too old (the tests turn warnings into errors)
    numba.config.THREADING_LAYER_PRIORITY = ["omp", "workqueue", "tbb"]


@njit(cache=True, parallel=True)
def spfh_kernel(xyz, normals, nb, dist, bins):  # pragma: no cover - compiled
    """Simplified point feature histograms (three angle histograms, each summing to 1).

    ``nb``/``dist``: ``(n, k)`` neighbour indices and distances (``index >= n`` or
    ``dist`` not finite: no neighbour; distance 0: the point itself, skipped).

    The third angle ``theta = atan2(y, x)`` has ``x = u . t >= 0`` (``t`` is put on
    ``u``'s side), so it lies in ``[-pi/2, pi/2]`` and its bin is the number of bin
    edges ``theta_q`` with ``y >= x tan(theta_q)``: comparisons instead of an arc
    tangent per pair, the same bins.
    """
    n, k = nb.shape
    out = np.zeros((n, 3 * bins))
    counts = np.zeros(n)
    tan_edge = np.empty(bins - 1)
    for q in range(1, bins):
        tan_edge[q - 1] = math.tan(-0.5 * math.pi + q * math.pi / bins)
    for i in prange(n):
        ux0, ux1, ux2 = normals[i, 0], normals[i, 1], normals[i, 2]
        c = 0.0
        for q in range(k):
            j = nb[i, q]
            dd = dist[i, q]
            if j >= n or not (dd > 1e-12) or not math.isfinite(dd):
                continue
            inv = 1.0 / dd
            d0 = (xyz[j, 0] - xyz[i, 0]) * inv
            d1 = (xyz[j, 1] - xyz[i, 1]) * inv
            d2 = (xyz[j, 2] - xyz[i, 2]) * inv
            u0, u1, u2 = ux0, ux1, ux2
            phi = u0 * d0 + u1 * d1 + u2 * d2
            if phi < 0:
                u0, u1, u2 = -u0, -u1, -u2
                phi = -phi
            t0, t1, t2 = normals[j, 0], normals[j, 1], normals[j, 2]
            x = t0 * u0 + t1 * u1 + t2 * u2
            if x < 0:
                t0, t1, t2 = -t0, -t1, -t2
                x = -x
            v0 = u1 * d2 - u2 * d1
            v1 = u2 * d0 - u0 * d2
            v2 = u0 * d1 - u1 * d0
            vn = math.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
            if vn > 1e-12:
                iv = 1.0 / vn
                v0, v1, v2 = v0 * iv, v1 * iv, v2 * iv
            w0 = u1 * v2 - u2 * v1
            w1 = u2 * v0 - u0 * v2
            w2 = u0 * v1 - u1 * v0
            alpha = v0 * t0 + v1 * t1 + v2 * t2
            y = w0 * t0 + w1 * t1 + w2 * t2
            b1 = min(max(int((alpha + 1.0) * 0.5 * bins), 0), bins - 1)
            b2 = min(max(int(phi * bins), 0), bins - 1)
            if x == 0.0 and y == 0.0:
                b3 = bins // 2  # atan2(0, 0) = 0
            else:
                b3 = 0
                for e in range(bins - 1):
                    if y >= x * tan_edge[e]:
                        b3 += 1
            out[i, b1] += 1.0
            out[i, bins + b2] += 1.0
            out[i, 2 * bins + b3] += 1.0
            c += 1.0
        counts[i] = c
        if c > 0:
            for b in range(3 * bins):
                out[i, b] /= c
    return out, counts


@njit(cache=True, parallel=True)
def fpfh_kernel(spfh, counts, nb, dist, floor):  # pragma: no cover - compiled
    """FPFH = SPFH(p) + neighbours' SPFH weighted by ``1 / max(d, floor)``, L1-normalised."""
    n, k = nb.shape
    m = spfh.shape[1]
    out = np.zeros((n, m))
    for i in prange(n):
        if counts[i] == 0:
            continue
        wsum = 0.0
        for q in range(k):
            j = nb[i, q]
            dd = dist[i, q]
            if j >= n or not (dd > 1e-12) or not math.isfinite(dd):
                continue
            w = 1.0 / max(dd, floor)
            wsum += w
            for b in range(m):
                out[i, b] += w * spfh[j, b]
        total = 0.0
        for b in range(m):
            v = spfh[i, b] + (out[i, b] / wsum if wsum > 0 else 0.0)
            out[i, b] = v
            total += v
        if total > 0:
            for b in range(m):
                out[i, b] /= total
    return out


@njit(cache=True)
def _find_cell(keys, key):  # pragma: no cover - compiled
    """Row of ``key`` in the sorted ``keys``, or -1."""
    lo = 0
    hi = len(keys)
    while lo < hi:
        mid = (lo + hi) // 2
        if keys[mid] < key:
            lo = mid + 1
        else:
            hi = mid
    if lo < len(keys) and keys[lo] == key:
        return lo
    return -1


@njit(cache=True, parallel=True)
def radius_knn_kernel(
    xyz, cell, span, order, cell_keys, cell_start, radius, k, most, nb, dist
):  # pragma: no cover - compiled
    """The (at most) ``k`` nearest points within ``radius`` of every point, itself included.

    ``cell``: ``(n, 3)`` integer cell of every point on a grid of edge ``radius``
    (``span`` cells per axis); ``order``: the points sorted by cell key
    (``(cx * span1 + cy) * span2 + cz``); ``cell_keys``/``cell_start``: the occupied
    keys, ascending, and where each begins in ``order`` (one more start closes the
    last); ``most``: the largest occupancy of a cell.  Writes ``nb``/``dist``
    ``(n, k)`` in no particular order; missing entries are index ``n`` and distance
    ``inf`` (the convention of :meth:`scipy.spatial.cKDTree.query`).
    """
    n = len(xyz)
    r2 = radius * radius
    block = 64  # points per task: the candidate buffers are allocated once per task
    for b in prange((n + block - 1) // block):
        cand = np.empty(27 * most, dtype=np.int64)
        d2 = np.empty(27 * most)
        for i in range(b * block, min(n, (b + 1) * block)):
            m = 0
            px, py, pz = xyz[i, 0], xyz[i, 1], xyz[i, 2]
            for dx in range(-1, 2):
                cx = cell[i, 0] + dx
                if cx < 0 or cx >= span[0]:
                    continue
                for dy in range(-1, 2):
                    cy = cell[i, 1] + dy
                    if cy < 0 or cy >= span[1]:
                        continue
                    for dz in range(-1, 2):
                        cz = cell[i, 2] + dz
                        if cz < 0 or cz >= span[2]:
                            continue
                        c = _find_cell(cell_keys, (cx * span[1] + cy) * span[2] + cz)
                        if c < 0:
                            continue
                        for q in range(cell_start[c], cell_start[c + 1]):
                            j = order[q]
                            ex = xyz[j, 0] - px
                            ey = xyz[j, 1] - py
                            ez = xyz[j, 2] - pz
                            e = ex * ex + ey * ey + ez * ez
                            if e < r2:
                                cand[m] = j
                                d2[m] = e
                                m += 1
            if m <= k:
                for q in range(m):
                    nb[i, q] = cand[q]
                    dist[i, q] = math.sqrt(d2[q])
                for q in range(m, k):
                    nb[i, q] = n
                    dist[i, q] = np.inf
            else:  # the k nearest: those below the k-th distance, then ties at it
                kth = np.partition(d2[:m], k - 1)[k - 1]
                w = 0
                for q in range(m):
                    if d2[q] < kth:
                        nb[i, w] = cand[q]
                        dist[i, w] = math.sqrt(d2[q])
                        w += 1
                for q in range(m):
                    if w < k and d2[q] == kth:
                        nb[i, w] = cand[q]
                        dist[i, w] = math.sqrt(d2[q])
                        w += 1


@njit(cache=True, parallel=True)
def consistency_kernel(a, b, tolerance, min_edge, consistent, usable):  # pragma: no cover
    """Pairwise length consistency of correspondences ``(a_i, b_i)``.

    ``consistent[i, j]``: ``| |a_i - a_j| - |b_i - b_j| | <= tolerance`` (diagonal
    False); ``usable[i, j]``: consistent and both lengths at least ``min_edge``.
    """
    n = len(a)
    for i in prange(n):
        for j in range(n):
            ex = a[i, 0] - a[j, 0]
            ey = a[i, 1] - a[j, 1]
            ez = a[i, 2] - a[j, 2]
            da = math.sqrt(ex * ex + ey * ey + ez * ez)
            ex = b[i, 0] - b[j, 0]
            ey = b[i, 1] - b[j, 1]
            ez = b[i, 2] - b[j, 2]
            db = math.sqrt(ex * ex + ey * ey + ez * ez)
            ok = abs(da - db) <= tolerance and i != j
            consistent[i, j] = ok
            usable[i, j] = ok and min(da, db) >= min_edge


@njit(cache=True, parallel=True)
def inlier_counts_kernel(a, b, R, t, eps2):  # pragma: no cover - compiled
    """Number of correspondences with ``|R_s a_i + t_s - b_i|^2 < eps2`` for every
    motion ``s`` of the batch ``R`` ``(m, 3, 3)``, ``t`` ``(m, 3)``."""
    m = len(R)
    n = len(a)
    counts = np.zeros(m, dtype=np.int64)
    for s in prange(m):
        c = 0
        for i in range(n):
            a0, a1, a2 = a[i, 0], a[i, 1], a[i, 2]
            r0 = a0 * R[s, 0, 0] + a1 * R[s, 0, 1] + a2 * R[s, 0, 2] + (t[s, 0] - b[i, 0])
            r1 = a0 * R[s, 1, 0] + a1 * R[s, 1, 1] + a2 * R[s, 1, 2] + (t[s, 1] - b[i, 1])
            r2 = a0 * R[s, 2, 0] + a1 * R[s, 2, 1] + a2 * R[s, 2, 2] + (t[s, 2] - b[i, 2])
            if r0 * r0 + r1 * r1 + r2 * r2 < eps2:
                c += 1
        counts[s] = c
    return counts
