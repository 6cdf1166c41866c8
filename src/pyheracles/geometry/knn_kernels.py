"""Compiled exact k-nearest-neighbour covariances on an implicit octree.

Why hand-written (numba) rather than a library: normals and curvature only need
the 3x3 covariance of each point's ``k`` nearest neighbours, never the
``(N, k)`` neighbour table.  scipy's ``cKDTree`` and ``pykdtree`` return that
table (their query alone costs as much as Open3D's whole ``estimate_normals``
on 2 cores), Open3D returns neither the curvature nor the eigenvalues, and no
well-kept Python library fuses an exact k-NN search with the covariance.  The
kernel below does, in one pass, with a few arrays of ``N`` numbers:

1. Every point gets a 60-bit Morton (Z-order) key of its cell in a fine grid
   (``2**20`` cells along the longest side of the bounding box).  After one
   radix sort, *every* cell of every coarser level ``L`` (size ``h0 * 2**L``) is
   a contiguous run of the sorted keys: an octree without pointers.
2. The octree is cut into *work cells*: the coarsest cells holding at most
   ``max_leaf`` points.  Dense parts of a scan get small cells, sparse parts
   large ones, so the number of candidates per point stays small although
   the point density of a terrestrial scan varies a hundredfold.
3. For each point of a work cell of size ``h``, the candidates are the points
   of the 3 x 3 x 3 block of cells around it.  The search is exact: any point
   outside the block is farther than ``h`` plus the distance from the point to
   its cell's walls (infinite on a side where the block already reaches the
   end of the data), so the ``k`` best candidates are the true ``k`` nearest
   neighbours if the ``k``-th distance is within that bound.  Otherwise the
   search is repeated one level up where the cell size is at least the
   current ``k``-th distance, which then always satisfies the bound (the root
   cell holds everything), so isolated points and big gaps are handled
   without a fallback.
   The ``k`` nearest are selected as a set (the covariance needs no order):
   a distance threshold is bracketed by branch-free counts over the
   candidates, starting from the previous point's ``k``-th distance.
4. The covariance of the ``k`` neighbours is accumulated about their mean
   (two passes, no cancellation) and decomposed in closed form (trigonometric
   solution of the characteristic cubic, eigenvectors from cross products of
   ``C - lambda I``), with a Jacobi iteration for the rare ill-conditioned
   matrices (two nearly equal eigenvalues), in :mod:`pyheracles.geometry.eigen3`.

Work cells are processed in parallel (``prange``) in Morton order, which keeps
the candidate points in cache.  ``cache=True`` stores the compiled code next to
this module, so only the first process ever compiles it.
"""

from __future__ import annotations

import os

import numba
import numpy as np
from numba import njit, prange
from numpy.typing import NDArray

from pyheracles.geometry.eigen3 import eigen_one

if "NUMBA_THREADING_LAYER" not in os.environ and "NUMBA_THREADING_LAYER_PRIORITY" not in os.environ:
    # Numba tries TBB first and warns when the system's TBB is too old (the tests
    # turn warnings into errors); OpenMP, or numba's own work queue, is enough here.
    numba.config.THREADING_LAYER_PRIORITY = ["omp", "workqueue", "tbb"]

#: Bits per axis of the finest grid (3 x 20 = 60-bit keys fit in int64).
BITS = 20


@njit(cache=True, inline="always")
def _part1by2(v: np.int64) -> np.int64:
    x = v & 0x1FFFFF
    x = (x | (x << 32)) & 0x1F00000000FFFF
    x = (x | (x << 16)) & 0x1F0000FF0000FF
    x = (x | (x << 8)) & 0x100F00F00F00F00F
    x = (x | (x << 4)) & 0x10C30C30C30C30C3
    x = (x | (x << 2)) & 0x1249249249249249
    return x


@njit(cache=True, inline="always")
def _compact1by2(v: np.int64) -> np.int64:
    x = v & 0x1249249249249249
    x = (x | (x >> 2)) & 0x10C30C30C30C30C3
    x = (x | (x >> 4)) & 0x100F00F00F00F00F
    x = (x | (x >> 8)) & 0x1F0000FF0000FF
    x = (x | (x >> 16)) & 0x1F00000000FFFF
    x = (x | (x >> 32)) & 0x1FFFFF
    return x


@njit(cache=True, inline="always")
def _morton(x: np.int64, y: np.int64, z: np.int64) -> np.int64:
    return _part1by2(x) | (_part1by2(y) << 1) | (_part1by2(z) << 2)


@njit(cache=True, parallel=True)
def morton_keys(
    xyz: NDArray[np.float64], lo: NDArray[np.float64], inv_h0: float
) -> NDArray[np.int64]:
    """Morton keys of the fine cells ``floor((xyz - lo) * inv_h0)`` (clipped to the grid)."""
    n = xyz.shape[0]
    keys = np.empty(n, np.int64)
    top = (1 << BITS) - 1
    for i in prange(n):
        cx = min(max(np.int64((xyz[i, 0] - lo[0]) * inv_h0), 0), top)
        cy = min(max(np.int64((xyz[i, 1] - lo[1]) * inv_h0), 0), top)
        cz = min(max(np.int64((xyz[i, 2] - lo[2]) * inv_h0), 0), top)
        keys[i] = _morton(cx, cy, cz)
    return keys


@njit(cache=True)
def bounding_box(xyz: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Lower and upper corners of the points (one pass; numpy's axis-0 min and
    max on an ``(N, 3)`` array take two strided passes each)."""
    lo = xyz[0].copy()
    hi = xyz[0].copy()
    for i in range(1, xyz.shape[0]):
        for a in range(3):
            v = xyz[i, a]
            if v < lo[a]:
                lo[a] = v
            if v > hi[a]:
                hi[a] = v
    return lo, hi


@njit(cache=True, parallel=True)
def gather_sorted(
    xyz: NDArray[np.float64], keys: NDArray[np.int64], order: NDArray[np.int64]
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """``xyz[order]`` and ``keys[order]``, in parallel."""
    n = order.shape[0]
    pts = np.empty((n, 3))
    skeys = np.empty(n, np.int64)
    for i in prange(n):
        o = order[i]
        pts[i, 0] = xyz[o, 0]
        pts[i, 1] = xyz[o, 1]
        pts[i, 2] = xyz[o, 2]
        skeys[i] = keys[o]
    return pts, skeys


@njit(cache=True)
def radix_argsort(keys: NDArray[np.int64], n_bits: int) -> NDArray[np.int64]:
    """Stable LSD radix argsort of non-negative keys below ``2**n_bits``.

    About 5x faster than ``numpy.argsort`` on a million 60-bit keys; passes
    whose digit is the same for every key are skipped.
    """
    n = keys.shape[0]
    digit_bits = 11
    n_buckets = 1 << digit_bits
    mask = n_buckets - 1
    order = np.arange(n)
    cur = keys.copy()
    tmp_keys = np.empty_like(cur)
    tmp_order = np.empty_like(order)
    counts = np.empty(n_buckets, np.int64)
    shift = 0
    while shift < n_bits:
        counts[:] = 0
        for i in range(n):
            counts[(cur[i] >> shift) & mask] += 1
        if counts.max() < n:
            total = 0
            for b in range(n_buckets):
                c = counts[b]
                counts[b] = total
                total += c
            for i in range(n):
                b = (cur[i] >> shift) & mask
                j = counts[b]
                counts[b] = j + 1
                tmp_keys[j] = cur[i]
                tmp_order[j] = order[i]
            cur, tmp_keys = tmp_keys, cur
            order, tmp_order = tmp_order, order
        shift += digit_bits
    return order


@njit(cache=True)
def _lower_bound(keys: NDArray[np.int64], value: np.int64, lo: int, hi: int) -> int:
    while lo < hi:
        mid = (lo + hi) >> 1
        if keys[mid] < value:
            lo = mid + 1
        else:
            hi = mid
    return lo


@njit(cache=True)
def work_cells(keys: NDArray[np.int64], max_leaf: int) -> tuple[NDArray[np.int64], ...]:
    """Cut the sorted keys into the coarsest octree cells of at most ``max_leaf`` points.

    Returns ``starts`` (``len + 1``), the level of each work cell and its Morton
    code at that level.  Cells of duplicated points that stay too full down to
    level 0 are kept whole.
    """
    n = keys.shape[0]
    cap = n + 1
    starts = np.empty(cap, np.int64)
    levels = np.empty(cap, np.int64)
    codes = np.empty(cap, np.int64)
    stack_s = np.empty(8 * (BITS + 1) + 8, np.int64)
    stack_e = np.empty_like(stack_s)
    stack_l = np.empty_like(stack_s)
    bounds = np.empty(9, np.int64)
    top = 0
    stack_s[0], stack_e[0], stack_l[0] = 0, n, BITS
    count = 0
    while top >= 0:
        s, e, lev = stack_s[top], stack_e[top], stack_l[top]
        top -= 1
        if e - s <= max_leaf or lev == 0:
            starts[count] = s
            levels[count] = lev
            codes[count] = keys[s] >> (3 * lev)
            count += 1
            continue
        # children at level lev - 1, pushed in reverse so they pop in key order
        child = lev - 1
        parent = keys[s] >> (3 * lev)
        bounds[0] = s
        for c in range(1, 8):
            bounds[c] = _lower_bound(keys, ((parent << 3) | c) << (3 * child), s, e)
        bounds[8] = e
        for c in range(7, -1, -1):
            if bounds[c + 1] > bounds[c]:
                top += 1
                stack_s[top], stack_e[top], stack_l[top] = bounds[c], bounds[c + 1], child
    starts[count] = n
    return starts[: count + 1].copy(), levels[:count].copy(), codes[:count].copy()


@njit(cache=True, inline="always")
def _insert(bd: NDArray[np.float64], bi: NDArray[np.int64], filled: int, k: int, d: float, q: int):
    if filled < k:
        j = filled
        filled += 1
    elif d < bd[k - 1]:
        j = k - 1
    else:
        return filled
    while j > 0 and bd[j - 1] > d:
        bd[j] = bd[j - 1]
        bi[j] = bi[j - 1]
        j -= 1
    bd[j] = d
    bi[j] = q
    return filled


@njit(cache=True)
def _block_ranges(
    keys: NDArray[np.int64],
    cx: int,
    cy: int,
    cz: int,
    lev: int,
    cmax: NDArray[np.int64],
    ranges: NDArray[np.int64],
) -> int:
    """Runs of sorted points in the 3 x 3 x 3 cells around ``(cx, cy, cz)`` at ``lev``.

    Row ``m`` of ``ranges`` is ``(first, end, dx, dy, dz)``: the run and the offset
    of its cell from the centre cell."""
    n = keys.shape[0]
    m = 0
    span = np.int64(1) << (3 * lev)
    for oo in range(27):
        dx = oo % 3 - 1
        dy = (oo // 3) % 3 - 1
        dz = oo // 9 - 1
        x, y, z = cx + dx, cy + dy, cz + dz
        if x < 0 or y < 0 or z < 0 or x > cmax[0] or y > cmax[1] or z > cmax[2]:
            continue
        first = _morton(x, y, z) << (3 * lev)
        a = _lower_bound(keys, first, 0, n)
        # end of the run: gallop from its start (runs are usually short)
        last = first + span
        step = 1
        b = a
        while b + step < n and keys[b + step] < last:
            b += step
            step <<= 1
        b = _lower_bound(keys, last, b, min(b + step, n))
        if b > a:
            ranges[m, 0] = a
            ranges[m, 1] = b
            ranges[m, 2] = dx
            ranges[m, 3] = dy
            ranges[m, 4] = dz
            m += 1
    return m


@njit(cache=True)
def _block_search(
    pts: NDArray[np.float64],
    p: int,
    lo: NDArray[np.float64],
    h: float,
    cx: int,
    cy: int,
    cz: int,
    k: int,
    bd: NDArray[np.float64],
    bi: NDArray[np.int64],
    ranges: NDArray[np.int64],
    n_ranges: int,
    cell_d2: NDArray[np.float64],
    visit: NDArray[np.int64],
) -> int:
    """k best of the point ``p`` among the candidate runs ``ranges[:n_ranges]``.

    The cells are visited nearest first (distance from ``p`` to the cell box), and
    the visit stops at the first cell farther than the current k-th distance."""
    px, py, pz = pts[p, 0], pts[p, 1], pts[p, 2]
    # offsets of p inside its cell, in metres, from the lower and to the upper walls
    tx = px - (lo[0] + cx * h)
    ty = py - (lo[1] + cy * h)
    tz = pz - (lo[2] + cz * h)
    for t in range(n_ranges):
        d2 = 0.0
        for a in range(3):
            off = ranges[t, 2 + a]
            if off != 0:
                w = tx if a == 0 else (ty if a == 1 else tz)
                g = w if off < 0 else h - w
                g = max(g, 0.0)
                d2 += g * g
        # insertion into the visit order
        j = t
        while j > 0 and cell_d2[j - 1] > d2:
            cell_d2[j] = cell_d2[j - 1]
            visit[j] = visit[j - 1]
            j -= 1
        cell_d2[j] = d2
        visit[j] = t
    filled = 0
    for u in range(n_ranges):
        if filled == k and cell_d2[u] >= bd[k - 1]:
            break
        t = visit[u]
        for q in range(ranges[t, 0], ranges[t, 1]):
            dx = pts[q, 0] - px
            dy = pts[q, 1] - py
            dz = pts[q, 2] - pz
            filled = _insert(bd, bi, filled, k, dx * dx + dy * dy + dz * dz, q)
    return filled


@njit(cache=True, inline="always")
def _bound2(
    pts: NDArray[np.float64],
    p: int,
    lo: NDArray[np.float64],
    h: float,
    cx: int,
    cy: int,
    cz: int,
    cmax: NDArray[np.int64],
) -> float:
    """Squared distance from point ``p`` to the outside of its 3x3x3 block."""
    best = np.inf
    c = (cx, cy, cz)
    for a in range(3):
        t = (pts[p, a] - lo[a]) / h - c[a]
        t = min(max(t, 0.0), 1.0)
        if c[a] - 1 > 0:
            best = min(best, (t + 1.0) * h)
        if c[a] + 1 < cmax[a]:
            best = min(best, (2.0 - t) * h)
    return best * best


@njit(cache=True, parallel=True)
def knn_covariance_pca(
    pts: NDArray[np.float64],
    keys: NDArray[np.int64],
    order: NDArray[np.int64],
    starts: NDArray[np.int64],
    levels: NDArray[np.int64],
    codes: NDArray[np.int64],
    fine_max: NDArray[np.int64],
    lo: NDArray[np.float64],
    h0: float,
    k: int,
    directions: bool,
    vals: NDArray[np.float64],
    vmin: NDArray[np.float64],
    vmax: NDArray[np.float64],
    table_d2: NDArray[np.float64],
    table_idx: NDArray[np.int64],
) -> int:
    """Exact k-NN PCA of every point; results written at ``order[p]`` (input order).

    ``pts`` and ``keys`` are sorted by key; returns how many points needed a
    search at a coarser level than their work cell (for diagnostics).  With
    ``table_idx`` of ``N`` rows, the neighbour table is written instead of the
    PCA: ``table_idx[i]`` the input indices of the ``k`` nearest neighbours of
    point ``i`` by increasing squared distance ``table_d2[i]`` (ties by index)."""
    n_cells = levels.shape[0]
    # Scratch arrays are allocated once per chunk of work cells, not per cell:
    # allocations inside a parallel loop cost more than the search itself.
    n_chunks = min(n_cells, 1024)
    promoted = np.zeros(n_chunks, np.int64)
    for chunk in prange(n_chunks):
        cmax = np.empty(3, np.int64)
        ranges = np.empty((27, 5), np.int64)
        bd = np.empty(k)
        bi = np.empty(k, np.int64)
        cmax2 = np.empty(3, np.int64)
        ranges2 = np.empty((27, 5), np.int64)
        cell_d2 = np.empty(27)
        visit = np.empty(27, np.int64)
        cov6 = np.empty(6)
        mat = np.empty((3, 3))
        jv = np.empty((3, 3))
        jw = np.empty(3)
        v3 = np.empty(3)
        n1 = np.empty(3)
        d1 = np.empty(3)
        cap = 256
        bx = np.empty(cap)
        by = np.empty(cap)
        bz = np.empty(cap)
        bidx = np.empty(cap, np.int64)
        dbuf = np.empty(cap)
        cidx = np.empty(cap + 1, np.int64)
        w_first = chunk * n_cells // n_chunks
        w_end = (chunk + 1) * n_cells // n_chunks
        for w in range(w_first, w_end):
            lev0 = levels[w]
            code = codes[w]
            cx0 = _compact1by2(code)
            cy0 = _compact1by2(code >> 1)
            cz0 = _compact1by2(code >> 2)
            for a in range(3):
                cmax[a] = fine_max[a] >> lev0
            n_r = _block_ranges(keys, cx0, cy0, cz0, lev0, cmax, ranges)
            n_cand = 0
            for t in range(n_r):
                n_cand += ranges[t, 1] - ranges[t, 0]
            if n_cand > cap:
                cap = 2 * n_cand
                bx = np.empty(cap)
                by = np.empty(cap)
                bz = np.empty(cap)
                bidx = np.empty(cap, np.int64)
                dbuf = np.empty(cap)
                cidx = np.empty(cap + 1, np.int64)
            _gather(pts, ranges, n_r, bx, by, bz, bidx)
            promoted[chunk] += _work_cell(
                pts, keys, order, starts, fine_max, lo, h0, k, directions,
                vals, vmin, vmax, w, lev0, cx0, cy0, cz0, cmax, n_cand, bx, by, bz, bidx,
                dbuf, cidx, bd, bi, cmax2, ranges2, cell_d2, visit, cov6, mat, jv, jw, v3, n1, d1,
                table_d2, table_idx,
            )  # fmt: skip
    return promoted.sum()


@njit(cache=True)
def _gather(pts, ranges, n_r, bx, by, bz, bidx):
    """Copy the candidate runs into contiguous buffers, nearest cells first
    (centre, faces, edges, corners), so the k-th distance settles early."""
    m = 0
    for rank in range(4):
        for t in range(n_r):
            if abs(ranges[t, 2]) + abs(ranges[t, 3]) + abs(ranges[t, 4]) != rank:
                continue
            for q in range(ranges[t, 0], ranges[t, 1]):
                bx[m] = pts[q, 0]
                by[m] = pts[q, 1]
                bz[m] = pts[q, 2]
                bidx[m] = q
                m += 1
    return m


@njit(cache=True, inline="always")
def _select(dbuf, bidx, cidx, n_cand, k, bd, bi, limit):
    """The k smallest of ``dbuf[:n_cand]`` not above ``limit``, sorted in ``bd, bi``."""
    m = 0
    for j in range(n_cand):  # branch-free compaction of the candidates under the limit
        cidx[m] = j
        m += dbuf[j] <= limit
    filled = 0
    for t in range(m):
        j = cidx[t]
        d = dbuf[j]
        if filled < k or d < bd[k - 1]:
            filled = _insert(bd, bi, filled, k, d, bidx[j])
    return filled


@njit(cache=True, inline="always")
def _count_le(dbuf, n, t):
    c = 0
    for j in range(n):
        c += dbuf[j] <= t
    return c


@njit(cache=True)
def _select_set(dbuf, bidx, cidx, n_cand, k, bd, bi, guess, bound):
    """The k smallest of ``dbuf[:n_cand]`` not above ``bound``, as a set.

    Returns k with ``bi[:k]`` the chosen indices and ``bd[k - 1]`` the largest
    chosen distance (the rest of ``bd`` is scratch), or a number below k when
    fewer than k candidates are within ``bound``.
    """
    slack = 8
    hi_t = min(guess, bound)
    c_hi = _count_le(dbuf, n_cand, hi_t)
    if c_hi < k:
        if hi_t >= bound:
            return c_hi
        hi_t = bound
        c_hi = _count_le(dbuf, n_cand, hi_t)
        if c_hi < k:
            return c_hi
    lo_t = 0.0
    it = 0
    # Bisect until at most k + slack candidates remain under the threshold.  Twelve
    # halvings were not always enough: a sparse work cell beside a dense one starts
    # from its block's bound, 100x the k-th distance there, and the hundreds of
    # candidates left were then dropped one maximum at a time (quadratic: a 100 k
    # point part of roof draw 1 took 12 s).  Sixty-four halvings reach any spacing.
    while c_hi > k + slack and it < 64:
        mid = 0.5 * (lo_t + hi_t)
        if mid <= lo_t or mid >= hi_t:
            break  # no threshold between them: ties at the k-th distance
        c = _count_le(dbuf, n_cand, mid)
        if c >= k:
            hi_t, c_hi = mid, c
        else:
            lo_t = mid
        it += 1
    if c_hi > 2 * k + slack:  # many ties (exact duplicates): ranked by insertion
        return _select(dbuf, bidx, cidx, n_cand, k, bd, bi, hi_t)
    m = 0
    for j in range(n_cand):  # branch-free compaction
        cidx[m] = j
        m += dbuf[j] <= hi_t
    # drop the m - k largest (ties at the k-th distance: any of them)
    while m > k:
        best = 0
        for t in range(1, m):
            if dbuf[cidx[t]] > dbuf[cidx[best]]:
                best = t
        m -= 1
        cidx[best] = cidx[m]
    kth = 0.0
    for t in range(k):
        j = cidx[t]
        d = dbuf[j]
        bd[t] = d
        bi[t] = bidx[j]
        kth = max(kth, d)
    bd[k - 1] = kth  # only the k-th distance is used after a set selection
    return k


@njit(cache=True, inline="always")
def _nearest(
    pts, keys, fine_max, lo, h0, k, p, lev0, cx0, cy0, cz0, cmax, h_w, guess, n_cand,
    bx, by, bz, bidx, dbuf, cidx, bd, bi, cmax2, ranges2, cell_d2, visit,
):  # fmt: skip
    """The ``k`` nearest neighbours of point ``p`` of a work cell of level ``lev0``.

    Returns ``(filled, promoted, guess)``: ``bi[:filled]`` (sorted positions) are the
    neighbours, as a set when the cell's block held them (``bd[filled - 1]`` is the
    k-th squared distance, the rest of ``bd`` scratch) and sorted by distance when
    the search went up a level (``promoted`` levels); ``guess`` is the k-th
    distance expected for the next point of the cell.
    """
    promoted = 0
    px, py, pz = pts[p, 0], pts[p, 1], pts[p, 2]
    for j in range(n_cand):  # vectorised by the compiler
        ex = bx[j] - px
        ey = by[j] - py
        ez = bz[j] - pz
        dbuf[j] = ex * ex + ey * ey + ez * ez
    # The k nearest as a set (the covariance needs no order): a distance
    # threshold is bracketed by branch-free counts, starting from the
    # previous point's k-th distance (a neighbour in the same cell), then
    # the few extra candidates under it are dropped.  Beyond the block's
    # exactness bound nothing can be accepted; if fewer than k candidates
    # are within it, all of them are ranked and the search goes up a level.
    bound = _bound2(pts, p, lo, h_w, cx0, cy0, cz0, cmax)
    filled = _select_set(dbuf, bidx, cidx, n_cand, k, bd, bi, guess, bound)
    if filled < k:
        filled = _select(dbuf, bidx, cidx, n_cand, k, bd, bi, np.inf)
    next_guess = 2.25 * bd[k - 1] if filled == k else np.inf
    lev = lev0
    while not (filled == k and bd[k - 1] <= bound):
        # go up to the level whose cells are at least the k-th distance
        lev += 1
        if filled == k:
            kth = np.sqrt(bd[k - 1])
            while h0 * (1 << lev) < kth and lev < BITS:
                lev += 1
        lev = min(lev, BITS)
        h = h0 * (1 << lev)
        cx = cx0 >> (lev - lev0)
        cy = cy0 >> (lev - lev0)
        cz = cz0 >> (lev - lev0)
        for a in range(3):
            cmax2[a] = fine_max[a] >> lev
        n_r2 = _block_ranges(keys, cx, cy, cz, lev, cmax2, ranges2)
        filled = _block_search(pts, p, lo, h, cx, cy, cz, k, bd, bi, ranges2, n_r2, cell_d2, visit)
        bound = _bound2(pts, p, lo, h, cx, cy, cz, cmax2)
        if lev == BITS:
            break
        promoted += 1
    return filled, promoted, next_guess


@njit(cache=True, inline="always")
def _table_row(pts, order, p, filled, bi, table_d2, table_idx):
    """Row ``order[p]`` of the neighbour table: the ``filled`` neighbours ``bi`` (sorted
    positions) by increasing squared distance, ties by input index."""
    o = order[p]
    px, py, pz = pts[p, 0], pts[p, 1], pts[p, 2]
    for j in range(filled):
        q = bi[j]
        dx = pts[q, 0] - px
        dy = pts[q, 1] - py
        dz = pts[q, 2] - pz
        d = dx * dx + dy * dy + dz * dz
        i = order[q]
        t = j
        while t > 0 and (
            table_d2[o, t - 1] > d or (table_d2[o, t - 1] == d and table_idx[o, t - 1] > i)
        ):
            table_d2[o, t] = table_d2[o, t - 1]
            table_idx[o, t] = table_idx[o, t - 1]
            t -= 1
        table_d2[o, t] = d
        table_idx[o, t] = i


@njit(cache=True)
def _work_cell(
    pts, keys, order, starts, fine_max, lo, h0, k, directions,
    vals, vmin, vmax, w, lev0, cx0, cy0, cz0, cmax, n_cand, bx, by, bz, bidx,
    dbuf, cidx, bd, bi, cmax2, ranges2, cell_d2, visit, cov6, mat, jv, jw, v3, n1, d1,
    table_d2, table_idx,
):  # fmt: skip
    """All points of work cell ``w`` (see :func:`knn_covariance_pca`); the
    candidates of its 3 x 3 x 3 block are in the buffers ``bx, by, bz, bidx``."""
    table = table_idx.shape[0] > 0
    promoted = 0
    h_w = h0 * (1 << lev0)
    guess = np.inf  # k-th squared distance expected from the previous point
    for p in range(starts[w], starts[w + 1]):
        filled, up, guess = _nearest(
            pts, keys, fine_max, lo, h0, k, p, lev0, cx0, cy0, cz0, cmax, h_w, guess, n_cand,
            bx, by, bz, bidx, dbuf, cidx, bd, bi, cmax2, ranges2, cell_d2, visit,
        )  # fmt: skip
        promoted += up
        if table:
            _table_row(pts, order, p, filled, bi, table_d2, table_idx)
            continue
        # covariance about the neighbours' mean
        mx = my = mz = 0.0
        for j in range(filled):
            q = bi[j]
            mx += pts[q, 0]
            my += pts[q, 1]
            mz += pts[q, 2]
        inv = 1.0 / filled
        mx *= inv
        my *= inv
        mz *= inv
        sxx = syy = szz = sxy = sxz = syz = 0.0
        for j in range(filled):
            q = bi[j]
            x = pts[q, 0] - mx
            y = pts[q, 1] - my
            z = pts[q, 2] - mz
            sxx += x * x
            syy += y * y
            szz += z * z
            sxy += x * y
            sxz += x * z
            syz += y * z
        cov6[0], cov6[1], cov6[2] = sxx * inv, syy * inv, szz * inv
        cov6[3], cov6[4], cov6[5] = sxy * inv, sxz * inv, syz * inv
        eigen_one(cov6, v3, n1, d1, directions, mat, jv, jw)
        o = order[p]
        for a in range(3):
            vals[o, a] = v3[a]
            vmin[o, a] = n1[a]
            if directions:
                vmax[o, a] = d1[a]
    return promoted
