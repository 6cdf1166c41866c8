"""Compiled loops of the supports step's passes over millions of points (issue 12, speed).

Why compiled (numba, ``nogil``): on a 10 M point hall three pieces of step 2a are
gathers and per-point cell arithmetic that numpy does in several passes with a
temporary array each (the fancy-indexed copies, the cell indices, the sort of the
candidates' cell keys), and cost about 2.5 s of CPU together:

* the cell keys of the points of every candidate slab of the section height search
  (:class:`~pyheracles.supports.height.SlabGrid`): one gather of x and y and the keys in
  one pass (numpy gathered each coordinate separately, each a cache miss per point);
* the occupied cells of one slab, their centroids and the links between cells whose
  centroids are within the clustering distance, as connected components
  (numpy: a scan of the whole cell table, 12 vectorised look-ups, a sparse matrix);
* the cookie-cutter's candidates (:func:`~pyheracles.supports.cookies.cookies`): the
  points in the cell box of a shape and near its outline, in input order, so that no
  sort of the candidates is needed.

Each gives exactly what the numpy code it replaces gives (the same float operations in
the same order where a value is kept; the cookie-cutter's offsets are still computed by
numpy on the candidates, the kernel only leaves out points clearly too far): the labels
of the 10 M hall and the supports family's rows are unchanged (tests/
test_supports_kernels.py compares each kernel with a plain numpy reference).  They
release the interpreter lock, so :func:`pyheracles.threads.map_threads` runs blocks of
points on the machine's cores.  ``cache=True`` stores the compiled code next to this
module: only the first run on a machine pays the compilation (about 2 s).
"""

from __future__ import annotations

from itertools import pairwise

import numpy as np
from numba import njit
from numpy.typing import NDArray

from pyheracles.threads import map_threads, n_workers

__all__ = [
    "cookie_candidates",
    "occupied_cells",
    "slab_components",
    "slab_keys",
]

#: Points per thread below which the passes run in the calling thread.
MIN_BLOCK = 200_000
#: Metres added to a cookie's reach in the candidate test: the kernel's offset may differ
#: from numpy's (which may use fused multiply-adds in its matrix product) by a few units
#: in the last place; numpy's exact test follows on the candidates.
REACH_MARGIN_M = 1e-6


def _blocks(n: int) -> list[tuple[int, int]]:
    """``(start, stop)`` of contiguous blocks of ``n`` items, one per thread."""
    k = max(1, min(n_workers(), n // MIN_BLOCK))
    edges = np.linspace(0, n, k + 1).astype(np.int64)
    return [(int(a), int(b)) for a, b in pairwise(edges)]


# ------------------------------------------------------------------ slab grid (height.py)
@njit(nogil=True, cache=True)
def _gather_xy(xyz, idx, x, y, s, e):  # pragma: no cover - compiled
    for i in range(s, e):
        r = idx[i]
        x[i] = xyz[r, 0]
        y[i] = xyz[r, 1]


@njit(nogil=True, cache=True)
def _cell_keys(x, y, x0, y0, inv):  # pragma: no cover - compiled
    n = len(x)
    ci = np.empty(n, dtype=np.int64)
    key = np.empty(n, dtype=np.int64)
    ci_max = 0
    cj_max = 0
    for i in range(n):
        a = np.int64((x[i] - x0) * inv) + 2  # floor: values are >= 0
        b = np.int64((y[i] - y0) * inv) + 2
        ci[i] = a
        key[i] = b
        ci_max = max(ci_max, a)
        cj_max = max(cj_max, b)
    ny = cj_max + 3
    for i in range(n):
        key[i] += ci[i] * ny
    return key, ny, (ci_max + 3) * ny


def slab_keys(
    xyz: NDArray[np.float64], idx: NDArray[np.intp], cell: float
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64], int, int]:
    """x and y of the points ``idx`` of ``xyz`` and their cell keys ``ci * ny + cj``.

    The cells have side ``cell`` from the lowest x and y of those points, with a margin
    of two empty cells on every side (``ci, cj >= 2``); ``ny`` is the number of rows
    along y, ``ncells`` the size of the grid.  ``idx`` must not be empty.

    Returns
    -------
    x, y, key, ny, ncells
    """
    n = len(idx)
    x, y = np.empty(n), np.empty(n)
    map_threads(lambda se: _gather_xy(xyz, idx, x, y, se[0], se[1]), _blocks(n))
    key, ny, ncells = _cell_keys(x, y, float(x.min()), float(y.min()), 1.0 / cell)
    return x, y, key, int(ny), int(ncells)


@njit(nogil=True, cache=True)
def occupied_cells(key, ids):  # pragma: no cover - compiled
    """Sorted distinct cell keys of ``key`` and each point's number among them.

    ``ids`` is a table of all cells holding -1, left as it was found; the result is
    that of ``np.unique(key, return_inverse=True)`` without a sort of the points."""
    cells = np.empty(len(key), dtype=np.int64)
    m = 0
    for k in key:
        if ids[k] == -1:
            ids[k] = 0
            cells[m] = k
            m += 1
    cells = np.sort(cells[:m])
    for j in range(m):
        ids[cells[j]] = j
    inv = np.empty(len(key), dtype=np.int64)
    for i in range(len(key)):
        inv[i] = ids[key[i]]
    for j in range(m):
        ids[cells[j]] = -1
    return cells, inv


@njit(nogil=True, cache=True)
def _root(parent, a):  # pragma: no cover - compiled
    while parent[a] != a:  # path halving
        parent[a] = parent[parent[a]]
        a = parent[a]
    return a


@njit(nogil=True, cache=True)
def slab_components(cells, inv, x, y, ny, links, limit_sq):  # pragma: no cover - compiled
    """Connected components of the occupied cells of one slab, linked when their
    centroids are within the clustering distance.

    Parameters
    ----------
    cells, inv
        Sorted occupied cell keys and each point's cell number (:func:`occupied_cells`).
    x, y
        The points' coordinates, metres.
    ny
        Rows of the grid along y (a key is ``ci * ny + cj``).
    links
        ``(L, 2)`` cell offsets ``(di, dj)`` to look at from each cell.
    limit_sq
        Squared linking distance of two centroids, square metres.

    Returns
    -------
    comp, px, py
        Each cell's component, numbered as :func:`scipy.sparse.csgraph.connected_components`
        numbers them (in the order of each component's first cell), and the cell
        centroids (sums in point order, as ``np.bincount``).
    """
    m = len(cells)
    cnt = np.zeros(m)
    px = np.zeros(m)
    py = np.zeros(m)
    for i in range(len(inv)):
        c = inv[i]
        cnt[c] += 1.0
        px[c] += x[i]
        py[c] += y[i]
    for c in range(m):
        px[c] /= cnt[c]
        py[c] /= cnt[c]
    parent = np.arange(m)
    for a in range(m):
        for r in range(len(links)):
            nb = cells[a] + links[r, 0] * ny + links[r, 1]
            b = np.searchsorted(cells, nb)
            if b >= m or cells[b] != nb:
                continue
            dx = px[a] - px[b]
            dy = py[a] - py[b]
            if dx * dx + dy * dy <= limit_sq:
                ra, rb = _root(parent, a), _root(parent, b)
                if ra < rb:  # the smaller index becomes the root
                    parent[rb] = ra
                elif rb < ra:
                    parent[ra] = rb
    comp = np.empty(m, dtype=np.int64)
    n_comp = 0
    for a in range(m):
        ra = _root(parent, a)
        if ra == a:
            comp[a] = n_comp
            n_comp += 1
        else:
            comp[a] = comp[ra]  # ra < a: numbered already
    return comp, px, py


# --------------------------------------------------------------- cookie-cutter (cookies.py)
@njit(nogil=True, cache=True)
def _near(px, py, s, shape_f, shape_round):  # pragma: no cover - compiled
    """Whether a point is within the reach (plus the margin) of shape ``s``'s outline."""
    qx = px - shape_f[s, 0]
    qy = py - shape_f[s, 1]
    if shape_round[s]:  # within radius + reach of the centre (no square root)
        return qx * qx + qy * qy <= shape_f[s, 2]
    c, sn = shape_f[s, 3], shape_f[s, 4]
    u = qx * c + qy * sn
    v = qy * c - qx * sn
    return max(abs(u) - shape_f[s, 5], abs(v) - shape_f[s, 6]) <= shape_f[s, 7]


@njit(nogil=True, cache=True)
def _cookie_scan(
    p, s0, e0, x0, y0, inv, width, cell_ptr, cell_sid, shape_f, shape_round, counts, out, pos
):  # pragma: no cover - compiled
    """Count the points of ``s0:e0`` in each shape's cell box (``out`` empty: an upper
    bound of its candidates), or store its candidates (``pos``: the next free slot of
    each shape in ``out``)."""
    fill = len(out) > 0
    for i in range(s0, e0):
        ci = np.int64((p[i, 0] - x0) * inv)  # floor: values are >= 0
        cj = np.int64((p[i, 1] - y0) * inv)
        cell = cj * width + ci
        for t in range(cell_ptr[cell], cell_ptr[cell + 1]):
            s = cell_sid[t]
            if not fill:
                counts[s] += 1
            elif _near(p[i, 0], p[i, 1], s, shape_f, shape_round):
                out[pos[s]] = i
                pos[s] += 1


@njit(nogil=True, cache=True)
def _cookie_block(
    p, s0, e0, x0, y0, inv, width, cell_ptr, cell_sid, shape_f, shape_round
):  # pragma: no cover - compiled
    """Candidates of points ``s0:e0`` grouped by shape: shape ``s`` has
    ``out[starts[s]:ends[s]]``."""
    n_sh = len(shape_f)
    counts = np.zeros(n_sh, dtype=np.int64)
    none = np.zeros(0, dtype=np.int64)
    args = (x0, y0, inv, width, cell_ptr, cell_sid, shape_f, shape_round)
    _cookie_scan(p, s0, e0, *args, counts, none, none)
    starts = np.zeros(n_sh + 1, dtype=np.int64)
    starts[1:] = np.cumsum(counts)
    out = np.empty(starts[n_sh], dtype=np.int64)
    ends = starts[:n_sh].copy()
    if len(out):
        _cookie_scan(p, s0, e0, *args, counts, out, ends)
    return out, starts, ends


def cookie_candidates(
    p: NDArray[np.float64],
    xy0: tuple[float, float],
    cell: float,
    grid_shape: tuple[int, int],
    boxes: NDArray[np.int64],
    shape_f: NDArray[np.float64],
    shape_round: NDArray[np.bool_],
) -> list[NDArray[np.intp]]:
    """Indices (ascending) of the points of ``p`` that may belong to each cookie.

    A point is a candidate of shape ``s`` when its cell (side ``cell`` from ``xy0``,
    ``grid_shape`` = rows along y, columns along x) is in the shape's cell box
    ``boxes[s] = (lo_x, lo_y, hi_x, hi_y)`` and its offset from the shape's outline is at
    most its reach: ``shape_f[s] = (cx, cy, (radius + reach)**2, cos, sin, half_u,
    half_v, reach)``, round shapes (``shape_round``) by the distance to the centre minus
    the radius, the others by the largest excess over the half sizes along the turned
    axes.
    """
    height, width = grid_shape
    n_sh = len(boxes)
    # cell -> the shapes whose box holds it (CSR)
    cell_l, sid_l = [], []
    for s, (lx, ly, hx, hy) in enumerate(boxes):
        cj, ci = np.mgrid[ly : hy + 1, lx : hx + 1]
        cell_l.append((cj * width + ci).ravel())
        sid_l.append(np.full(cj.size, s, dtype=np.int64))
    cells = np.concatenate(cell_l) if cell_l else np.zeros(0, dtype=np.int64)
    sids = np.concatenate(sid_l) if sid_l else np.zeros(0, dtype=np.int64)
    srt = np.argsort(cells, kind="stable")
    cell_ptr = np.zeros(height * width + 1, dtype=np.int64)
    np.cumsum(np.bincount(cells, minlength=height * width), out=cell_ptr[1:])
    args = (float(xy0[0]), float(xy0[1]), 1.0 / cell, int(width), cell_ptr, sids[srt])
    args += (shape_f, shape_round)
    parts = map_threads(lambda se: _cookie_block(p, se[0], se[1], *args), _blocks(len(p)))
    return [
        np.concatenate([out[st[s] : en[s]] for out, st, en in parts]).astype(np.intp, copy=False)
        for s in range(n_sh)
    ]
