"""The ground surface as a raster: rasterising points, inpainting holes, sampling heights.

A :class:`DTM` is a north-up grid in the LOCAL frame of the cloud (the frame of
``PointCloud.xyz``); :meth:`DTM.transform` gives the world affine transform for a
GeoTIFF once the cloud's offset is added.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

import numpy as np
from numpy.typing import NDArray
from scipy import sparse
from scipy.sparse.linalg import spsolve

from pyheracles.errors import InputError
from pyheracles.groundfilters.pyramid import band_and_fill, halve

if TYPE_CHECKING:  # pragma: no cover
    from affine import Affine

__all__ = [
    "DTM",
    "Grid",
    "RasterSampler",
    "dtm_from_ground",
    "gradient",
    "height_above_ground",
    "inpaint",
    "inpaint_update",
    "mean_surface",
    "mean_surface_cells",
    "positions_of_cells",
    "rasterise",
    "rasterise_cells",
    "sample_raster",
]


@dataclass(frozen=True)
class Grid:
    """A north-up raster geometry in the local frame.

    Attributes
    ----------
    x0_m, y0_m
        Local x of the west edge of column 0 and local y of the north edge of row 0, metres.
    cell_m
        Cell size, metres.
    shape
        ``(rows, cols)``.
    """

    x0_m: float
    y0_m: float
    cell_m: float
    shape: tuple[int, int]

    @classmethod
    def covering(cls, xy: NDArray[np.float64], cell_m: float) -> Grid:
        """Smallest grid of ``cell_m`` cells that holds every point of ``xy`` (N, 2)."""
        if not np.isfinite(cell_m) or cell_m <= 0:
            raise InputError(f"cell size must be a positive number of metres, got {cell_m!r}")
        # per column: a reduction over axis 0 of a strided (N, 3)[:, :2] view is slow
        lo = np.array([xy[:, 0].min(), xy[:, 1].min()])
        hi = np.array([xy[:, 0].max(), xy[:, 1].max()])
        return cls.from_bounds(lo, hi, cell_m)

    @classmethod
    def from_bounds(cls, lo: NDArray[np.float64], hi: NDArray[np.float64], cell_m: float) -> Grid:
        """:meth:`covering` from the points' (min x, min y) ``lo`` and (max x, max y) ``hi``."""
        if not np.isfinite(cell_m) or cell_m <= 0:
            raise InputError(f"cell size must be a positive number of metres, got {cell_m!r}")
        cols = int(np.floor((hi[0] - lo[0]) / cell_m)) + 1
        rows = int(np.floor((hi[1] - lo[1]) / cell_m)) + 1
        return cls(float(lo[0]), float(hi[1]), float(cell_m), (rows, cols))

    def index(self, xy: NDArray[np.float64]) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
        """Row and column of the cell holding each point (clipped to the grid)."""
        col = np.floor((xy[:, 0] - self.x0_m) / self.cell_m).astype(np.intp)
        row = np.floor((self.y0_m - xy[:, 1]) / self.cell_m).astype(np.intp)
        np.clip(col, 0, self.shape[1] - 1, out=col)
        np.clip(row, 0, self.shape[0] - 1, out=row)
        return row, col

    def flat_index(self, xy: NDArray[np.float64]) -> NDArray[np.intp]:
        """Row-major flat index ``row * cols + col`` of the cell holding each point.

        The same cells as :meth:`index`; clipped in floating point and cast once (two
        integer clips and a multiply-add over N points cost more than the whole cast).
        """
        rows, cols = self.shape
        col = np.subtract(xy[:, 0], self.x0_m)
        col /= self.cell_m
        # no floor: clipped at 0 the column is >= 0, and the final cast truncates it
        np.clip(col, 0, cols - 1, out=col)
        row = np.subtract(self.y0_m, xy[:, 1])
        row /= self.cell_m
        np.floor(row, out=row)
        np.clip(row, 0, rows - 1, out=row)
        row *= cols
        row += col
        return row.astype(np.intp)

    def fractional_index(self, xy: NDArray[np.float64]) -> NDArray[np.float64]:
        """(2, N) fractional (row, col) of each point relative to cell centres."""
        col = (xy[:, 0] - self.x0_m) / self.cell_m - 0.5
        row = (self.y0_m - xy[:, 1]) / self.cell_m - 0.5
        return np.vstack([row, col])


def rasterise(
    grid: Grid,
    xy: NDArray[np.float64],
    z: NDArray[np.float64],
    statistic: Literal["min", "max", "mean"] = "min",
) -> NDArray[np.float64]:
    """Per-cell statistic of ``z`` over the points falling in each cell; NaN where empty."""
    if statistic not in ("min", "max", "mean"):
        raise ValueError(f"statistic must be one of 'min', 'max', 'mean', got {statistic!r}")
    return rasterise_cells(grid, grid.flat_index(xy), z, statistic)


def rasterise_cells(
    grid: Grid,
    flat: NDArray[np.intp],
    z: NDArray[np.float64],
    statistic: Literal["min", "max", "mean"] = "min",
) -> NDArray[np.float64]:
    """:func:`rasterise` with the points' flat cell indices already known (``Grid.flat_index``).

    ``np.minimum.at`` is kept: in numpy >= 2 it runs at ~3 ns a point, an order of
    magnitude faster than sorting the points by cell for ``np.minimum.reduceat``.
    """
    if statistic not in ("min", "max", "mean"):
        raise ValueError(f"statistic must be one of 'min', 'max', 'mean', got {statistic!r}")
    size = grid.shape[0] * grid.shape[1]
    if statistic == "mean":
        count = np.bincount(flat, minlength=size).astype(np.float64)
        total = np.bincount(flat, weights=z, minlength=size)
        with np.errstate(invalid="ignore", divide="ignore"):
            out = total / count
    else:
        out = np.full(size, np.inf if statistic == "min" else -np.inf)
        (np.minimum if statistic == "min" else np.maximum).at(out, flat, z)
        out[~np.isfinite(out)] = np.nan
    return out.reshape(grid.shape)


def _pad_linear(values: NDArray[np.float64]) -> NDArray[np.float64]:
    """Pad a raster by one cell on each side, extrapolating linearly from the edge cells."""
    padded = np.pad(values, 1, mode="edge")
    if values.shape[0] > 1:
        padded[0, :] = 2 * padded[1, :] - padded[2, :]
        padded[-1, :] = 2 * padded[-2, :] - padded[-3, :]
    if values.shape[1] > 1:
        padded[:, 0] = 2 * padded[:, 1] - padded[:, 2]
        padded[:, -1] = 2 * padded[:, -2] - padded[:, -3]
    return padded


def _pad_linear_as(values: NDArray[np.float64], dtype: np.dtype) -> NDArray:
    """``_pad_linear(values).astype(dtype)`` without the float64 copy of the raster: the
    interior is cast once into the padded raster and only the border is computed in
    float64 (the same values to the bit). The refinement samples rasters of a whole
    mosaic's bounding box several times; two full copies per call added up."""
    rows, cols = values.shape
    if rows < 3 or cols < 3 or np.dtype(dtype) == np.float64:
        return _pad_linear(values).astype(dtype, copy=False)
    out = np.empty((rows + 2, cols + 2), dtype=dtype)
    out[1:-1, 1:-1] = values
    top = np.pad(values[:2], ((0, 0), (1, 1)), mode="edge")
    bottom = np.pad(values[-2:], ((0, 0), (1, 1)), mode="edge")
    first = 2 * top[0] - top[1]
    last = 2 * bottom[1] - bottom[0]
    out[0] = first
    out[-1] = last
    left1 = np.concatenate([[first[1]], values[:, 0], [last[1]]])
    left2 = np.concatenate([[first[2]], values[:, 1], [last[2]]])
    right1 = np.concatenate([[first[-2]], values[:, -1], [last[-2]]])
    right2 = np.concatenate([[first[-3]], values[:, -2], [last[-3]]])
    out[:, 0] = 2 * left1 - left2
    out[:, -1] = 2 * right1 - right2
    return out


class RasterSampler:
    """Bilinear sampling of rasters of one :class:`Grid` at fixed points, weights computed once.

    Between cell centres a raster is interpolated bilinearly; in the outer half cell (and
    beyond) it is extrapolated linearly from the two outermost cells, so a plane is
    reproduced exactly everywhere. Hand-written instead of ``ndimage.map_coordinates``
    because the refinement samples several rasters at the same points: the indices and
    weights are shared, and a gather is ~10x faster than the general spline machinery.

    ``dtype=np.float32`` halves the memory traffic of the per-point arithmetic (about twice
    as fast on millions of points); the filters use it on heights taken relative to a
    reference level (float32 resolves 8 µm at 100 m, thresholds are >= 5 cm), the public
    :func:`sample_raster` / :meth:`DTM.sample` stay in float64.

    It also keeps the cell of each point (:attr:`flat`, as :meth:`Grid.flat_index`), so one
    sampler built per cloud serves the rasterising, the sampling and the checks of a run.
    """

    def __init__(
        self, grid: Grid, xy: NDArray[np.float64], *, dtype: type[np.floating] = np.float64
    ) -> None:
        rows, cols = grid.shape
        # fractional column / row in cell units from the west / north edge, computed once
        u = np.subtract(xy[:, 0], grid.x0_m)
        u /= grid.cell_m
        v = np.subtract(grid.y0_m, xy[:, 1])
        v /= grid.cell_m
        # np.intp, not int32: numpy converts other index types to intp on every gather and
        # bincount (int32 made each gather ~1.6x slower)
        index_type = np.intp
        c0 = np.floor(u)
        r0 = np.floor(v)
        np.clip(c0, 0, cols - 1, out=c0)
        np.clip(r0, 0, rows - 1, out=r0)
        r0 *= cols
        r0 += c0
        self.flat: NDArray[np.integer] = r0.astype(index_type)
        """(N,) row-major index of the cell holding each point (as :meth:`Grid.flat_index`)."""
        # bilinear corner in the padded raster: fractional index relative to cell centres + 1
        u += 0.5
        v += 0.5
        np.clip(u, 0.0, cols + 1.0, out=u)
        np.clip(v, 0.0, rows + 1.0, out=v)
        np.floor(u, out=c0)
        np.minimum(c0, cols, out=c0)
        r0 = np.floor(v)
        np.minimum(r0, rows, out=r0)
        u -= c0
        v -= r0
        self.dtype = np.dtype(dtype)
        self._wc = u.astype(self.dtype, copy=False)
        self._wr = v.astype(self.dtype, copy=False)
        r0 *= cols + 2
        r0 += c0
        self._k00 = r0.astype(index_type)
        self._cols = cols + 2
        self.grid = grid

    def __call__(
        self, values: NDArray[np.float64], at: NDArray[np.intp] | None = None
    ) -> NDArray[np.float64]:
        """Values of the raster (shaped like the grid) at the points, in :attr:`dtype`.

        ``at``: indices of the points wanted (None = all); each value is the one of the
        whole call, bit for bit.
        """
        flat = _pad_linear_as(values, self.dtype).ravel()
        k, w = self._k00, self._cols
        wc, wr = self._wc, self._wr
        if at is not None:
            k, wc, wr = k[at], wc[at], wr[at]
        # the four corners gathered through shifted views: no index arithmetic per point
        f00 = flat[k]
        top = flat[1:][k]
        top -= f00
        top *= wc
        top += f00
        f10 = flat[w:][k]
        bottom = flat[w + 1 :][k]
        bottom -= f10
        bottom *= wc
        bottom += f10
        bottom -= top
        bottom *= wr
        bottom += top
        return bottom

    def value_range(self, values: NDArray[np.float64]) -> tuple[float, float]:
        """Bounds of every value :meth:`__call__` returns for the raster ``values``.

        The samples are convex combinations (weights in [0, 1]) of the raster padded by its
        linear extrapolation, so they lie in the padded raster's range; the bounds are
        widened by 0.1 % of its magnitude (plus 1 mm) for the rounding of the arithmetic.
        NaN when the raster has NaN cells.
        """
        padded = _pad_linear(values).astype(self.dtype, copy=False)
        lo, hi = float(padded.min()), float(padded.max())
        margin = 1e-3 * (max(abs(lo), abs(hi)) + 1.0)
        return lo - margin, hi + margin


def sample_raster(
    grid: Grid, values: NDArray[np.float64], xy: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Bilinear value of a raster at points ``xy`` (N, 2), see :class:`RasterSampler`."""
    return RasterSampler(grid, xy)(values)


def gradient(values: NDArray[np.float64], cell_m: float) -> tuple[NDArray, NDArray]:
    """(d/dy, d/dx) of a raster, with y growing northwards (rows grow southwards)."""
    rows, cols = values.shape
    gx = np.gradient(values, cell_m, axis=1) if cols > 1 else np.zeros_like(values)
    gy = -np.gradient(values, cell_m, axis=0) if rows > 1 else np.zeros_like(values)
    return gy, gx


def mean_surface(
    grid: Grid,
    xy: NDArray[np.float64],
    z: NDArray[np.float64],
    *,
    flat: NDArray[np.integer] | None = None,
) -> NDArray[np.float64]:
    """Height of the points' surface at each cell centre; NaN where no point falls.

    The mean height of a cell's points is the surface at their centroid, not at the cell
    centre: on a 45° slope with points bunched on one side the two differ by up to half a
    cell. The mean is moved to the centre with the raster's own gradient (one linear
    correction step: exact on planes). ``flat``: the points' cells when already known
    (:attr:`RasterSampler.flat` of the points); computed from ``xy`` otherwise.
    """
    if flat is None:
        flat = grid.flat_index(xy)
    return mean_surface_cells(grid, flat, xy[:, 0], xy[:, 1], z)


def mean_surface_cells(
    grid: Grid,
    flat: NDArray[np.integer],
    x: NDArray[np.float64],
    y: NDArray[np.float64],
    z: NDArray[np.float64],
) -> NDArray[np.float64]:
    """:func:`mean_surface` from the points' cells and separate coordinate arrays.

    The centroid correction and the gradient are computed at the occupied cells only
    (the same central and one-sided differences as :func:`numpy.gradient`): a mosaic of
    tiles on a diagonal has a raster eight times its data, and the cost must follow the
    data (issue 17).
    """
    rows, cols = grid.shape
    size = rows * cols
    count = np.bincount(flat, minlength=size).astype(np.float64)
    at = np.flatnonzero(count)
    n_at = count[at]
    with np.errstate(invalid="ignore", divide="ignore"):
        mz = np.bincount(flat, weights=z, minlength=size) / count
    mx = np.bincount(flat, weights=x, minlength=size)[at] / n_at
    my = np.bincount(flat, weights=y, minlength=size)[at] / n_at
    rr, cc = np.divmod(at, cols)
    dx = grid.x0_m + (cc + 0.5) * grid.cell_m - mx
    dy = grid.y0_m - (rr + 0.5) * grid.cell_m - my
    gx = _difference(mz, at, cc, cols, 1, grid.cell_m)
    gy = -_difference(mz, at, rr, rows, cols, grid.cell_m)
    with np.errstate(invalid="ignore"):
        shift = np.nan_to_num(gx * dx + gy * dy, nan=0.0, posinf=0.0, neginf=0.0)
    mz[at] += shift
    return mz.reshape(grid.shape)


def _difference(
    flat_values: NDArray[np.float64],
    at: NDArray[np.intp],
    pos: NDArray[np.intp],
    n: int,
    stride: int,
    cell_m: float,
) -> NDArray[np.float64]:
    """:func:`numpy.gradient` (first order at the ends) of a raster along one axis, at the
    flat cells ``at`` only (``pos``: their index along the axis of ``n`` cells, ``stride``
    apart in the flat raster)."""
    if n < 2:
        return np.zeros(len(at))
    lo = np.where(pos > 0, at - stride, at)
    hi = np.where(pos < n - 1, at + stride, at)
    inner = (pos > 0) & (pos < n - 1)
    diff = flat_values[hi] - flat_values[lo]
    out = np.empty(len(at))
    out[inner] = diff[inner] / (2.0 * cell_m)
    out[~inner] = diff[~inner] / cell_m
    return out


#: Largest number of unknown cells solved exactly by one sparse LU (:func:`_solve_red_black`);
#: larger holes go through the coarse-to-fine path of :func:`inpaint`. SuperLU's fill-in
#: grows faster than the cells: 70 k unknowns cost ~4 s, 2.5 M unknowns 90 s and 3.3 GB.
EXACT_MAX_UNKNOWN = 20_000
#: Width of the band of unknown cells around the data solved at full resolution, cells;
#: farther cells take the (bilinearly refined) value of the coarser level.
INPAINT_BAND_CELLS = 6


def inpaint(values: NDArray[np.float64]) -> NDArray[np.float64]:
    """Fill the NaN cells of a raster with a harmonic (membrane) surface.

    Every unknown cell takes the mean of its four neighbours, known cells are fixed:
    the discrete Laplace equation. This is the "springs" inpainting Pingel et al. (2013)
    use for SMRF (D'Errico's ``inpaint_nans``); hand-written because scikit-image's
    biharmonic inpainting is an order of magnitude slower on rasters with large holes.

    The cost follows the filled area near the data, not the bounding box:

    - up to :data:`EXACT_MAX_UNKNOWN` unknown cells: one exact sparse solve over the
      unknown cells (reduced to its black cells, :func:`_solve_red_black`);
    - more: coarse to fine. The raster is halved (2 x 2 blocks, mean of their known
      cells) and inpainted recursively; unknown cells farther than
      :data:`INPAINT_BAND_CELLS` from any known cell take the value of that coarse
      surface (bilinear), and the band of unknown cells near the data is solved at full
      resolution (conjugate gradients, started from the coarse surface) with the far
      cells as its boundary. Far inside a large empty area (between tiles on a
      diagonal, open water) the surface is thus the coarse membrane, within centimetres
      of the exact one on smooth terrain; near the data it is the exact membrane to the
      solver's tolerance.

    Raises
    ------
    InputError
        If no cell is known.
    """
    out = np.array(values, dtype=np.float64, copy=True)
    unknown = np.isnan(out)
    n_unknown = int(unknown.sum())
    if n_unknown == 0:
        return out
    if n_unknown == out.size:
        raise InputError("cannot build a surface: no cell of the raster holds a point")
    if n_unknown <= EXACT_MAX_UNKNOWN or min(out.shape) < 4:
        out[unknown] = _solve_red_black(np.where(unknown, 0.0, out), unknown)
        return out
    return _inpaint_coarse_to_fine(out, unknown)


def inpaint_update(
    surface: NDArray[np.float64], unknown: NDArray[np.bool_], changed: NDArray[np.bool_]
) -> NDArray[np.float64]:
    """:func:`inpaint` of ``surface`` again after the ``changed`` cells became unknown.

    ``surface`` is an inpainted raster; ``unknown`` the cells to fill now, ``changed``
    those among them that were known.  Only the connected regions of unknown cells
    (4-neighbours) that hold a changed cell move: each is solved exactly (its neighbours
    are known cells, fixed), in its own box, the rest of ``surface`` is kept.  Used for
    the pits SMRF takes out of its terrain: a few cells, where the whole inpainting of a
    mosaic's raster costs a quarter of a second.  Regions of more than
    :data:`EXACT_MAX_UNKNOWN` cells in all go through :func:`inpaint`.
    """
    from scipy import ndimage

    labels, _ = ndimage.label(unknown)
    hit = np.unique(labels[changed & unknown])
    hit = hit[hit > 0]
    if len(hit) == 0:
        return np.array(surface, dtype=np.float64, copy=True)
    sizes = np.bincount(labels.ravel(), minlength=int(labels.max()) + 1)
    if int(sizes[hit].sum()) > EXACT_MAX_UNKNOWN:
        return inpaint(np.where(unknown, np.nan, surface))
    out = np.array(surface, dtype=np.float64, copy=True)
    rows, cols = unknown.shape
    boxes = ndimage.find_objects(labels)
    for k in hit:
        r, c = boxes[k - 1]
        win = (slice(max(0, r.start - 1), min(rows, r.stop + 1)),
               slice(max(0, c.start - 1), min(cols, c.stop + 1)))  # fmt: skip
        region = labels[win] == k
        sub = out[win]
        sub[region] = _solve_red_black(np.where(region, 0.0, sub), region)
    return out


def _inpaint_coarse_to_fine(
    out: NDArray[np.float64], unknown: NDArray[np.bool_]
) -> NDArray[np.float64]:
    """:func:`inpaint` of a raster with many unknown cells (see there); ``out`` holds NaN
    at the ``unknown`` cells."""
    coarse = inpaint(halve(out))
    # the unknown cells take the coarse surface's bilinear value at their centres (the
    # far cells keep it; it bounds the band and starts its solve); the band: unknown
    # cells with a known cell within INPAINT_BAND_CELLS (chessboard)
    band = band_and_fill(out, coarse, INPAINT_BAND_CELLS)
    if band.size:
        out.ravel()[band] = _solve_band_cells(out, band)
    return out


def positions_of_cells(
    at: NDArray[np.int64], flat: NDArray[np.int64]
) -> tuple[NDArray[np.bool_], NDArray[np.intp]]:
    """Which of the flat cell indices ``flat`` are among the sorted cells ``at``, and
    their positions there (by binary search: no raster-sized id map, as a mosaic's
    mostly empty raster would need).

    Returns
    -------
    found
        ``(len(flat),)`` bool.
    positions
        ``(len(flat),)`` index into ``at`` (meaningful where ``found``).
    """
    if len(at) == 0:
        return np.zeros(len(flat), dtype=bool), np.zeros(len(flat), dtype=np.intp)
    pos = np.minimum(np.searchsorted(at, flat), len(at) - 1)
    return at[pos] == flat, pos


def _solve_band_cells(values: NDArray[np.float64], at: NDArray[np.int64]) -> NDArray[np.float64]:
    """Harmonic values of the cells ``at`` (flat, sorted), every other cell fixed.

    Conjugate gradients on the 5-point Laplacian (symmetric positive definite), started
    from the values the band cells already hold (the coarse surface). The system is
    gathered at the band cells and their neighbours only (no raster-sized temporaries:
    around tiles on a diagonal the band is a small part of a mostly empty raster).
    """
    rows, cols = values.shape
    ur, uc = np.divmod(at, cols)
    n = ur.size
    deg = np.zeros(n)
    rhs = np.zeros(n)
    row_parts, col_parts = [], []
    for dr, dc in _FOUR:
        nr, nc = ur + dr, uc + dc
        inside = (nr >= 0) & (nr < rows) & (nc >= 0) & (nc < cols)
        deg += inside
        idx = np.flatnonzero(inside)
        in_band, pos = positions_of_cells(at, nr[idx] * cols + nc[idx])
        fixed = idx[~in_band]
        rhs[fixed] += values[nr[fixed], nc[fixed]]
        row_parts.append(idx[in_band])
        col_parts.append(pos[in_band])
    r = np.concatenate([np.arange(n), *row_parts])
    c = np.concatenate([np.arange(n), *col_parts])
    d = np.concatenate([deg, -np.ones(r.size - n)])
    matrix = sparse.csr_matrix((d, (r, c)), shape=(n, n))
    return _jacobi_cg(matrix, rhs, values[ur, uc], 1.0 / deg)


def _dot(a: NDArray[np.float64], b: NDArray[np.float64]) -> float:
    # einsum, not np.dot: BLAS threads contend on a shared machine (20 ms for an 80 k dot)
    return float(np.einsum("i,i->", a, b))


def _jacobi_cg(
    matrix: sparse.csr_matrix,
    rhs: NDArray[np.float64],
    x: NDArray[np.float64],
    inv_diag: NDArray[np.float64],
    *,
    tol_m: float = 1e-6,
    max_iterations: int = 5000,
) -> NDArray[np.float64]:
    """Jacobi-preconditioned conjugate gradients for a symmetric positive definite system.

    Stops when the largest preconditioned residual (the change a Jacobi step would make
    to a cell, metres) is below ``tol_m``.
    """
    x = np.array(x, dtype=np.float64)
    r = rhs - matrix @ x
    z = r * inv_diag
    p = z.copy()
    rz = _dot(r, z)
    for _ in range(max_iterations):
        if np.abs(z).max() <= tol_m:
            break
        q = matrix @ p
        alpha = rz / _dot(p, q)
        x += alpha * p
        r -= alpha * q
        np.multiply(r, inv_diag, out=z)
        rz_new = _dot(r, z)
        p *= rz_new / rz
        p += z
        rz = rz_new
    return x


# Offsets between black cells coupled by the Schur complement, each with the red cells
# adjacent to both (the cells through which the coupling runs).
_BLACK_COUPLINGS = (
    ((0, 2), ((0, 1),)),
    ((0, -2), ((0, -1),)),
    ((2, 0), ((1, 0),)),
    ((-2, 0), ((-1, 0),)),
    ((1, 1), ((1, 0), (0, 1))),
    ((1, -1), ((1, 0), (0, -1))),
    ((-1, 1), ((-1, 0), (0, 1))),
    ((-1, -1), ((-1, 0), (0, -1))),
)
_FOUR = ((-1, 0), (1, 0), (0, -1), (0, 1))
_PAD = 2


def _solve_red_black(known: NDArray[np.float64], unknown: NDArray[np.bool_]) -> NDArray[np.float64]:
    """Harmonic values of the ``unknown`` cells (row-major order) given the ``known`` ones.

    Every unknown cell equals the mean of its in-grid 4-neighbours (``known`` holds 0 at
    the unknown cells). The 5-point stencil only couples cells of opposite checkerboard
    colour, so the red cells are eliminated exactly (their block is diagonal) and the
    sparse LU runs on the Schur complement over the black cells only: half the columns
    (SuperLU costs about 1 µs per column here, whatever the ordering). The complement's
    9-point stencil is gathered from rasters padded by two cells; the red cells follow by
    back-substitution.
    """
    rows, cols = unknown.shape
    width = cols + 2 * _PAD

    def padded(values: NDArray, fill: float = 0.0) -> NDArray:
        return np.pad(values, _PAD, constant_values=fill).ravel()

    def gather(raster: NDArray, at: NDArray[np.intp], offsets) -> NDArray:
        total = raster[at + (offsets[0][0] * width + offsets[0][1])]
        for dr, dc in offsets[1:]:
            total = total + raster[at + (dr * width + dc)]
        return total

    ur, uc = np.nonzero(unknown)
    at = (ur + _PAD) * width + (uc + _PAD)  # flat index in the padded rasters
    rhs = gather(padded(known), at, _FOUR)  # sum of the known neighbours
    deg = gather(padded(np.ones(unknown.shape)), at, _FOUR)  # in-grid neighbours
    red = (ur + uc) % 2 == 0
    black = ~red
    at_r, at_b = at[red], at[black]
    inv_r = 1.0 / deg[red]
    inv_red = np.zeros((rows + 2 * _PAD) * width)
    inv_red[at_r] = inv_r
    rhs_red = np.zeros_like(inv_red)
    rhs_red[at_r] = rhs[red] * inv_r
    x = np.zeros_like(inv_red)
    n_black = at_b.size
    if n_black:
        ids = np.arange(n_black)
        black_id = np.full(inv_red.size, -1, dtype=np.intp)
        black_id[at_b] = ids
        row_parts = [ids]
        col_parts = [ids]
        data_parts = [deg[black] - gather(inv_red, at_b, _FOUR)]
        for offset, through in _BLACK_COUPLINGS:
            weight = gather(inv_red, at_b, through)
            other = black_id[at_b + (offset[0] * width + offset[1])]
            ok = (other >= 0) & (weight != 0.0)
            row_parts.append(ids[ok])
            col_parts.append(other[ok])
            data_parts.append(-weight[ok])
        schur = sparse.csc_matrix(
            (np.concatenate(data_parts), (np.concatenate(row_parts), np.concatenate(col_parts))),
            shape=(n_black, n_black),
        )
        x[at_b] = spsolve(schur, rhs[black] + gather(rhs_red, at_b, _FOUR))
    result = np.empty(ur.size)
    result[black] = x[at_b]
    result[red] = (rhs[red] + gather(x, at_r, _FOUR)) * inv_r
    return result


@dataclass(frozen=True, eq=False)
class DTM:
    """Digital terrain model: a gap-free north-up raster of ground height (local frame).

    Attributes
    ----------
    z_m
        (rows, cols) float64 ground height, metres; holes are inpainted (see
        :func:`inpaint`), so every cell is finite.
    grid
        Geometry of the raster (:class:`Grid`, local frame, metres).
    observed
        (rows, cols) bool: True where the cell held at least one ground point.
    """

    z_m: NDArray[np.float64]
    grid: Grid
    observed: NDArray[np.bool_]

    @property
    def cell_m(self) -> float:
        """Cell size in metres."""
        return self.grid.cell_m

    @property
    def shape(self) -> tuple[int, int]:
        """``(rows, cols)``."""
        return self.grid.shape

    def sample(self, xy: NDArray[np.float64]) -> NDArray[np.float64]:
        """Ground height under each point of ``xy`` (N, 2), bilinear (:func:`sample_raster`)."""
        return sample_raster(self.grid, self.z_m, np.asarray(xy, dtype=np.float64))

    def slope(self) -> NDArray[np.float64]:
        """Terrain slope per cell as rise over run (dimensionless, 1.0 = 45°)."""
        gy, gx = gradient(self.z_m, self.grid.cell_m)
        return np.hypot(gx, gy)

    def transform(self, offset: NDArray[np.float64] | None = None) -> Affine:
        """Affine transform (rasterio convention) of the raster in the world frame.

        Parameters
        ----------
        offset
            The cloud's offset (``PointCloud.offset``) added to the local frame; None = local.
        """
        from affine import Affine

        ox, oy = (0.0, 0.0) if offset is None else (float(offset[0]), float(offset[1]))
        g = self.grid
        return Affine(g.cell_m, 0.0, g.x0_m + ox, 0.0, -g.cell_m, g.y0_m + oy)


def dtm_from_ground(
    xyz: NDArray[np.float64],
    mask: NDArray[np.bool_],
    cell_m: float,
    *,
    sampler: RasterSampler | None = None,
) -> DTM:
    """Raster the ground points of a cloud into a gap-free :class:`DTM`.

    Parameters
    ----------
    xyz
        (N, 3) float64 points in the local frame, metres.
    mask
        (N,) bool, True for ground points.
    cell_m
        Cell size in metres.
    sampler
        ``RasterSampler(Grid.covering(xyz[:, :2], cell_m), xyz[:, :2])`` when the caller
        already built it (its cells are reused); None = computed here.

    Returns
    -------
    DTM
        Covering the extent of ALL points (so every point has a ground height); each
        cell holds the height of its ground points' surface at the cell centre
        (:func:`mean_surface`), empty cells are inpainted.

    Raises
    ------
    InputError
        If the mask selects no point or does not match ``xyz``.
    """
    xyz = np.asarray(xyz, dtype=np.float64)
    mask = np.asarray(mask, dtype=bool)
    if xyz.ndim != 2 or xyz.shape[1] != 3 or mask.shape != (xyz.shape[0],):
        raise InputError(
            f"xyz must be (N, 3) and mask (N,), got {xyz.shape} and {mask.shape}",
        )
    if not mask.any():
        raise InputError(
            "no ground point: a terrain model needs ground",
            hint="use --ground none (heracles complex) for clouds without ground (building "
            "interiors) or check the ground filter parameters",
        )
    if sampler is not None and sampler.grid.cell_m == cell_m:
        grid, flat = sampler.grid, sampler.flat[mask]
    else:
        grid, flat = Grid.covering(xyz[:, :2], cell_m), None
    z = mean_surface(grid, xyz[mask, :2], xyz[mask, 2], flat=flat)
    observed = np.isfinite(z)
    return DTM(inpaint(z), grid, observed)


def height_above_ground(xyz: NDArray[np.float64], dtm: DTM) -> NDArray[np.float64]:
    """Height of each point above the terrain model (negative below it), metres."""
    xyz = np.asarray(xyz, dtype=np.float64)
    return xyz[:, 2] - dtm.sample(xyz[:, :2])
