"""Automatic section height: persistent support islands on a cell grid of many slabs."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from pyheracles.forks import map_fork
from pyheracles.segment.euclidean import relabel_by_size
from pyheracles.supports.core import Array, Scales, SupportParams
from pyheracles.supports.kernels import occupied_cells, slab_components, slab_keys
from pyheracles.supports.sections import island_kind

# The 12 "forward" offsets of the 5 x 5 cell neighbourhood: with cells of half the
# clustering distance, only these cells can hold points within that distance.
LINKS = tuple((di, dj) for di in range(3) for dj in range(-2, 3) if (di, dj) > (0, 0))
LINK_STEPS = np.array(LINKS, dtype=np.int64)


DENSE_CELLS = 8_000_000  # larger grids use a sort per slab instead of a dense scatter

#: A height level of the building holds at least this share of the points of its mean
#: level (outliers above the roof, birds, dust spread a few points over many levels).
TOP_LEVEL_SHARE = 0.05
#: The building ends at the first run of sparse levels this tall (metres).
TOP_GAP_M = 0.5


def dense_extent(z_sorted: Array, bin_m: float = 0.05) -> tuple[float, float]:
    """Lowest and highest dense levels of a cloud: the building, not its outliers.

    Levels of ``bin_m`` are counted from the median height up (down); the building ends
    at the top (bottom) of the last level holding at least ``TOP_LEVEL_SHARE`` of the
    points of the mean level (between the median and the 99 % (1 %) quantile) before a
    run of ``TOP_GAP_M`` of sparser levels.  Gross errors, multipath echoes under the
    floor, birds and mixed pixels above a roof spread a few points over many levels;
    the broken top of a column holds its ring, a floor seen only through the
    colonnade (a survey from above, whose fullest level is the roof) holds the feet of
    the supports.  A clean cloud gives its lowest and highest points.

    Parameters
    ----------
    z_sorted
        Heights sorted ascending, metres.
    bin_m
        Height of the levels, metres.

    Returns
    -------
    (float, float)
        Bottom and top, metres (NaN for an empty cloud).
    """
    z = np.asarray(z_sorted, dtype=np.float64)
    if len(z) == 0:
        return float("nan"), float("nan")
    return -_dense_end(-z[::-1], bin_m), _dense_end(z, bin_m)


def _dense_end(z: Array, bin_m: float) -> float:
    """Top of the last dense level above the median of ascending heights ``z``."""
    zm, z1 = float(z[len(z) // 2]), float(z[-1])
    nbins = int((z1 - zm) / bin_m) + 1
    if nbins < 2 or nbins > 1_000_000:  # flat, or not metres: the highest point
        return z1
    edges = zm + bin_m * np.arange(nbins + 1)
    counts = np.diff(np.searchsorted(z, edges, side="left"))
    counts[-1] += len(z) - int(counts.sum())  # the top point falls on the last edge
    # the mean level between the median and the 99 % quantile: outliers stay above it
    z99 = float(z[int(0.99 * (len(z) - 1))])
    mean_level = 0.49 * len(z) * bin_m / max(z99 - zm, bin_m)
    k_dense = np.flatnonzero(counts >= TOP_LEVEL_SHARE * mean_level)
    if len(k_dense) == 0:
        return z1
    # the first dense level followed by a gap of `gap` sparse levels ends the building
    gap = max(1, round(TOP_GAP_M / bin_m))
    nxt = np.r_[k_dense[1:], nbins + gap]
    k = int(k_dense[np.argmax(nxt - k_dense > gap)])
    if k == nbins - 1:
        return z1
    return float(min(z1, z[np.searchsorted(z, edges[k + 1], side="left") - 1]))


class SlabGrid:
    """Occupied square cells of horizontal slabs, for the section height search.

    The raster stand-in for :func:`section_islands` ``(with_shapes=False)`` on many
    slabs: each slab is reduced to its occupied cells of side ``distance / 2`` (as a
    thinning would), each cell is represented by the centroid of its points, cells whose
    centroids are within ``distance`` are linked, and each island is described by the
    principal-axis extents of its cells.  Hand-written because the KD-tree pairs of every
    candidate slab cost most of the height search, while a few thousand occupied cells
    per slab link in milliseconds by cell-key look-ups; the final section is still
    clustered exactly (:func:`section_islands`).
    """

    def __init__(self, xyz: Array, idx: NDArray[np.intp], cell: float) -> None:
        self.x, self.y = np.zeros(0), np.zeros(0)
        self.cell = cell
        self.ny, self.ncells = 1, 0
        self.key = np.zeros(0, dtype=np.int64)
        if len(idx):
            # floor from the lowest x and y (values >= 0), plus a margin of two empty cells
            # on every side: the neighbours of an occupied cell are always inside the
            # grid, never wrapped (one compiled gather and pass: slab_keys)
            self.x, self.y, self.key, self.ny, self.ncells = slab_keys(xyz, idx, cell)
        self.dense = 0 < self.ncells <= DENSE_CELLS
        if self.dense:  # a cell -> occupied-cell-number table, reset after each slab
            self.ids = np.full(self.ncells, -1, dtype=np.int32)

    def _cells(self, k: NDArray[np.int64]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
        """Sorted occupied cell keys of points with keys ``k`` and each point's cell number."""
        if not self.dense:
            cells, inv = np.unique(k, return_inverse=True)
            return cells, inv.ravel()
        return occupied_cells(k, self.ids)

    def support_islands(self, s: int, e: int, params: SupportParams) -> tuple[Array, Array]:
        """Centres ``(K, 2)`` and lengths ``(K,)`` of the support islands of points ``s:e``."""
        none = (np.zeros((0, 2)), np.zeros(0))
        if e - s < params.min_points:
            return none
        cells, inv = self._cells(self.key[s:e])
        # cells linked when their centroids are within the clustering distance
        comp, px, py = slab_components(
            cells, inv, self.x[s:e], self.y[s:e], self.ny, LINK_STEPS, (2 * self.cell) ** 2
        )
        lab = relabel_by_size(comp, params.min_points)
        keep = lab > 0
        if not keep.any():
            return none
        lab, px, py = lab[keep] - 1, px[keep], py[keep]
        cnt = np.bincount(lab).astype(np.float64)
        mx, my = np.bincount(lab, px) / cnt, np.bincount(lab, py) / cnt
        dx, dy = px - mx[lab], py - my[lab]
        sxx, syy = np.bincount(lab, dx * dx), np.bincount(lab, dy * dy)
        sxy = np.bincount(lab, dx * dy)
        theta = 0.5 * np.arctan2(2 * sxy, sxx - syy)  # major principal axis
        cos, sin = np.cos(theta)[lab], np.sin(theta)[lab]
        u, v = dx * cos + dy * sin, dy * cos - dx * sin
        k = len(cnt)
        ext = []
        for w in (u, v):
            hi = np.full(k, -np.inf)
            lo = np.full(k, np.inf)
            np.maximum.at(hi, lab, w)
            np.minimum.at(lo, lab, w)
            ext.append(hi - lo)
        length, width = ext
        sup = island_kind(length, width, params) == "support"
        return np.c_[mx, my][sup], length[sup]


def choose_height(
    xyz: Array,
    order: NDArray[np.intp],
    z_sorted: Array,
    params: SupportParams,
    sc: Scales,
    z_lo: float,
    z_hi: float,
) -> tuple[float, list[tuple[float, int]]]:
    """Automatic section height: middle of the longest run with the most persistent islands.

    An island is persistent at a height when an island of about the same size is found at
    the same place ``persistence_m`` above and below.
    """
    thickness, distance = sc.thickness, sc.distance
    k_off = max(1, round(params.persistence_m / params.candidate_step_m))
    step = params.candidate_step_m
    cands = np.arange(z_lo - k_off * step, z_hi + k_off * step + 1e-9, step)
    if len(cands) == 0:
        return (z_lo + z_hi) / 2, []
    # the points of all candidate slabs, in z order: one gather, then contiguous slices
    s0, e0 = np.searchsorted(z_sorted, [cands[0] - thickness / 2, cands[-1] + thickness / 2])
    grid = SlabGrid(xyz, order[s0:e0], distance / 2)
    ends = np.searchsorted(z_sorted, np.c_[cands - thickness / 2, cands + thickness / 2]) - s0
    ends = np.maximum(ends, 0)
    # the slabs' islands, on two processes (map_fork: Python-heavy, independent slabs)
    found = map_fork(
        lambda se: grid.support_islands(int(se[0]), int(se[1]), params),
        list(ends),
        cost=list(ends[:, 1] - ends[:, 0]),
    )
    centres: list[Array] = [c for c, _ in found]
    sizes: list[Array] = [length for _, length in found]
    trees = [cKDTree(c) if len(c) else None for c in centres]
    score = np.zeros(len(cands), dtype=int)
    for k, c in enumerate(centres):
        if not len(c):
            continue
        ok = np.ones(len(c), dtype=bool)
        for j in (k - k_off, k + k_off):
            if not 0 <= j < len(cands):
                ok[:] = False  # persistence cannot be checked at the ends of the range
            else:
                if trees[j] is None:
                    ok[:] = False
                else:
                    # same place and same size: a vault or a capital widens with height
                    d, nb = trees[j].query(c)
                    same = np.abs(sizes[j][np.minimum(nb, len(sizes[j]) - 1)] - sizes[k])
                    ok &= (d <= 0.15) & (same <= 0.2 * sizes[k] + 2 * distance)
        score[k] = int(ok.sum())
    # The highest island count that holds over a run of at least min_run heights (a
    # single height with one island more is clutter, not a better section); the middle
    # of the longest such run.
    min_run = max(1, min(3, int(np.count_nonzero(score == score.max()) > 0) * 3))
    for level in range(int(score.max()), -1, -1):
        is_best = np.r_[False, score >= level, False]
        edges = np.flatnonzero(np.diff(is_best.astype(int)))
        starts, ends = edges[::2], edges[1::2]
        r = int(np.argmax(ends - starts))
        if ends[r] - starts[r] >= min_run or level == 0:
            break
    mid = (starts[r] + ends[r] - 1) / 2
    height = float(np.interp(mid, np.arange(len(cands)), cands))
    return height, list(zip(cands.tolist(), score.tolist(), strict=True))


def unseen_notes(
    scores: list[tuple[float, int]],
    range_m: tuple[float, float],
    at_m: float,
    lows: list[tuple[float, Array]],
    z0: float,
    params: SupportParams,
) -> list[str]:
    """The note of a support search that finds nothing, when the section height search
    found no persistent support island at any height (none otherwise).

    Parameters
    ----------
    scores
        The height search's ``(height, persistent islands)`` per candidate height (empty:
        the section height was given).
    range_m
        The searched range, metres above the floor.
    at_m
        The section taken (the middle of the range), metres above the floor.
    lows
        The lower sections searched too: ``(height, plan points)``, heights in metres.
    z0
        The floor, metres.
    params
        Detection parameters (``persistence_m``: how far above and below an island had
        to be found again; ``min_free_height_m``: the height a support carrying nothing
        must be seen over).

    Returns
    -------
    list of str
        No note, or one saying what happened and what it means: supports seen only
        below the sections (under low eaves, through doors) or not at all are not found
        (supports draw 2: a colonnade under eaves hanging 1.2 m below its tops, seen
        from outside only up to 1 m, under a roof 9 m high; the section fell into the
        roof, where the wrong note said candidates did not span the body height).
    """
    if max((k for _, k in scores), default=1):
        return []
    low = ", ".join(f"{h - z0:.2f}" for h, _ in lows)
    return [
        f"no height between {range_m[0]:.2f} and {range_m[1]:.2f} m above the floor holds "
        f"a support island found again {params.persistence_m:g} m above and below it: the "
        f"section is the middle of that range ({at_m:.2f} m)"
        + (f", the lower one{'s' if len(lows) > 1 else ''} at {low} m" if lows else "")
        + "; supports seen only lower down (under low eaves, through doors) and over less "
        f"than {params.min_free_height_m:g} m, or not at all, are not found"
    ]
