"""Planes of walls: least-squares fits, plane frames, plane intersections, thinning."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pyheracles.errors import InputError
from pyheracles.walls.model import Array

__all__ = [
    "bridge_mullions",
    "bridge_runs",
    "fit_vertical",
    "grid_components",
    "intersect_planes",
    "plane_frame",
    "run_on_ends",
    "voxel_sample",
]


def intersect_planes(normals: ArrayLike, ds: ArrayLike) -> Array:
    """Least-squares intersection point of planes ``n_i . x = d_i`` (``intersectMultPlanes``).

    Minimum-norm solution when the planes do not fix a point (two planes: the point of
    their line nearest the origin; vertical planes only: z = 0).
    """
    n = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    d = np.asarray(ds, dtype=np.float64).reshape(-1)
    if len(n) != len(d) or len(n) < 1:
        raise InputError("intersect_planes needs as many offsets as normals (at least one)")
    x, *_ = np.linalg.lstsq(n, d, rcond=None)
    return x


def voxel_sample(xyz: Array, size: float) -> NDArray[np.int64]:
    """Index of one point per occupied cube (the first in input order)."""
    cells = np.floor((xyz - xyz.min(axis=0)) / size).astype(np.int64)
    dims = cells.max(axis=0) + 1
    if float(np.prod(dims.astype(np.float64))) >= 2.0**62:  # no single integer key
        _, first = np.unique(cells, axis=0, return_index=True)
    else:  # one integer per cube: a 1D sort, far faster than unique rows
        key = (cells[:, 0] * dims[1] + cells[:, 1]) * dims[2] + cells[:, 2]
        _, first = np.unique(key, return_index=True)
    return np.sort(first)


def fit_vertical(p: Array) -> tuple[Array, float, float]:
    """Plane of points by least squares (3D PCA); normal with a deterministic sign."""
    c = p.mean(axis=0)
    _, _, vt = np.linalg.svd(p - c, full_matrices=False)
    n = vt[-1]
    big = int(np.argmax(np.abs(n[:2])))
    if n[big] < 0:
        n = -n
    res = (p - c) @ n
    return n, float(n @ c), float(np.sqrt(np.mean(res**2)))


def plane_frame(n: Array, d: float) -> tuple[Array, Array]:
    """Origin on the plane (above the local origin) and the horizontal in-plane axis."""
    h = np.array([n[0], n[1], 0.0])
    h /= np.linalg.norm(h)
    u = np.array([-h[1], h[0], 0.0])
    origin = h * d / max(float(n @ h), 1e-9)
    return origin, u


def run_on_ends(u: Array, lo: float, hi: float, reach: float,
                gap: float) -> tuple[float, float]:  # fmt: skip
    """A face's stretch ``[lo, hi]`` (m along the wall) run on past its ends over the
    positions ``u`` of its plane's points, up to ``reach`` beyond each end, across gaps
    of at most ``gap``.

    A face's points are found by their normals, and the normal of a point within the
    normals' neighbourhood of a corner mixes in the other face's: a face ends short of
    its corners by about that neighbourhood's radius.  Its plane's points run on to the
    corner; at a free edge there are none beyond it, and the stretch stays.

    Examples
    --------
    >>> import numpy as np
    >>> run_on_ends(np.array([-0.3, -0.08, -0.02, 1.05, 1.12, 1.4]), 0.0, 1.0, 0.2, 0.1)
    (-0.08, 1.12)
    """
    ends = []
    for s, end in ((-1.0, lo), (1.0, hi)):
        v = np.sort(s * (u - end))
        v = v[(v > 0) & (v <= reach)]
        steps = np.diff(np.r_[0.0, v])
        k = int(np.argmax(steps > gap)) if np.any(steps > gap) else len(v)
        ends.append(end + s * float(v[k - 1]) if k else end)
    return ends[0], ends[1]


def bridge_runs(occ: NDArray[np.bool_], n: int) -> NDArray[np.bool_]:
    """Empty cells of a grid ``occ`` (axis 0 along the wall, axis 1 up) that bridge a
    gap of up to ``n`` cells in a column of covered cells: a mullion's run broken where
    a few of its points are missing.

    A cell is such a bridge when covered cells stand below and above it within ``n``
    cells (a closing with a vertical line of ``n + 1`` cells), and the bridged cells
    across it are at most ``n`` and open (not covered) on both sides: the gap is a
    passage between two holes.  A hole shorter than ``n`` between covered cells all
    across it (a small window between its sill and head) is bounded across too, and
    stays open.  Rows are not bridged: across a light, the reveals' returns along
    both jambs joined into a transom (church draw 10: a window split, 1.28 m short).
    """
    from scipy import ndimage

    if n < 1 or not occ.any():
        return np.zeros(occ.shape, dtype=bool)
    line = np.ones((1, n + 1), dtype=bool)
    closed = ndimage.binary_closing(np.pad(occ, [(0, 0), (n + 1, n + 1)]), structure=line)
    gap = closed[:, n + 1 : -(n + 1)] & ~occ  # no closing against the grid's border
    return _short_runs(gap, occ, 0, n, 1)


def bridge_mullions(occ: NDArray[np.bool_], n: int, w: int) -> NDArray[np.bool_]:
    """Empty cells of a grid ``occ`` (axis 0 along the wall, axis 1 up) that bridge a
    gap of up to ``n`` cells in a mullion's column of covered cells.

    A cell is such a bridge when covered cells stand below and above it within ``n``
    cells, one of them in a mullion: cells covered over at most ``n`` across, with
    ``w`` open cells or more on both sides (holes at least an opening's least width,
    not gaps between a sparse face's scan columns), running up for longer than they
    are wide; and the bridged cells across it are at most ``n``, open on both sides.
    A hole shorter than ``n`` between its sill and head is bounded by covered cells
    all across, and stays open.  Only columns are bridged: a sparse face's scan rows,
    0.2-0.3 m apart, look like transoms between its jamb and a mullion.

    A mullion seen by a few scan columns of a sparse face is a column of points a
    spacing apart; where a mixed pixel at its edge or a lost return leaves a gap of
    two or three spacings in every column at once, the lights on either side joined
    (church draw 4's three-light window: its first mullion lost in 5 of 10 noise
    realisations).
    """
    if n < 1 or not occ.any():
        return np.zeros(occ.shape, dtype=bool)
    thin = _short_runs(occ, occ, 0, n, w)
    a0, a1 = _runs(thin, 1)
    b0, b1 = _runs(occ, 0)
    thin &= a1 - a0 > b1 - b0  # a mullion: thin over more than its width
    m = occ.shape[1]
    idx = np.arange(m)[None, :]
    below = np.maximum.accumulate(np.where(occ, idx, -1), axis=1)
    above = np.minimum.accumulate(np.where(occ, idx, m)[:, ::-1], axis=1)[:, ::-1]
    rows = np.arange(occ.shape[0])[:, None]
    gap = ~occ & (below >= 0) & (above < m) & (above - below - 1 <= n)
    gap &= thin[rows, np.clip(below, 0, m - 1)] | thin[rows, np.clip(above, 0, m - 1)]
    return _short_runs(gap, occ, 0, n, 1)


def _runs(mask: NDArray[np.bool_], axis: int) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """First and last index along ``axis`` of the run of ``mask`` cells each cell is in
    (meaningless outside ``mask``)."""
    g = np.moveaxis(mask, axis, 0)
    m = g.shape[0]
    idx = np.arange(m)[:, None]
    prev = np.zeros_like(g)
    prev[1:] = g[:-1]
    nxt = np.zeros_like(g)
    nxt[:-1] = g[1:]
    start = np.maximum.accumulate(np.where(g & ~prev, idx, -1), axis=0)
    stop = np.minimum.accumulate(np.where(g & ~nxt, idx, m)[::-1], axis=0)[::-1]
    return np.moveaxis(start, 0, axis), np.moveaxis(stop, 0, axis)


def _short_runs(mask: NDArray[np.bool_], occ: NDArray[np.bool_], axis: int, n: int,
                w: int) -> NDArray[np.bool_]:  # fmt: skip
    """Cells of ``mask`` whose run of ``mask`` cells along ``axis`` is at most ``n``
    long, with ``w`` cells or more open (not in ``occ``, inside the grid) past both
    of its ends."""
    start, stop = (np.moveaxis(x, axis, 0) for x in _runs(mask, axis))
    g = np.moveaxis(mask, axis, 0)
    o = np.moveaxis(occ, axis, 0)
    m = g.shape[0]
    cols = np.arange(g.shape[1])[None, :]
    cum = np.r_[np.zeros((1, o.shape[1]), dtype=np.int64), np.cumsum(o, axis=0)]

    def empty(a: NDArray[np.int64], b: NDArray[np.int64]) -> NDArray[np.bool_]:
        """Cells ``a`` to ``b`` (exclusive) inside the grid and none covered."""
        inside = (a >= 0) & (b <= m)
        a, b = np.clip(a, 0, m), np.clip(b, 0, m)
        return inside & (cum[b, cols] - cum[a, cols] == 0)

    keep = g & (stop - start + 1 <= n) & empty(start - w, start) & empty(stop + 1, stop + 1 + w)
    return np.moveaxis(keep, 0, axis)


def grid_components(mask: NDArray[np.bool_], grow: int) -> tuple[NDArray[np.int32], int]:
    from scipy import ndimage

    m = ndimage.binary_dilation(mask, iterations=grow) if grow else mask
    lab, k = ndimage.label(m)
    lab[~mask] = 0
    return lab, k
