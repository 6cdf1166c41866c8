"""What a step needs before it starts: enough memory for its rasters, enough points.

A raster of too-small cells over a large site, or a neighbour search on a cloud read in
the wrong units, asks for more memory than the machine has; numpy then fails with a
``MemoryError`` (or a C++ ``std::bad_alloc`` that kills the process) long after the
mistake.  :func:`check_grid_memory` estimates the size first and refuses with the
number and a fix.  :func:`check_spread` refuses clouds that define nothing (one point,
thousands of copies of one point, a vertical line) with a message naming the file.

Examples
--------
>>> from pyheracles.resources import check_grid_memory
>>> check_grid_memory((100, 100), 8, "a small raster", available_bytes=10**9)
80000
>>> format_bytes(326 * 2**30)
'326 GiB'
"""

from __future__ import annotations

import functools
import math
import os
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from os import PathLike

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pyheracles.errors import DegenerateGeometryError, InputError

__all__ = [
    "available_memory_bytes",
    "check_grid_memory",
    "check_spread",
    "format_bytes",
    "one_blas_thread",
    "smallest_cell_m",
]

#: Coordinates closer than this (metres, or the file's unit) are the same location.
_SAME_M = 1e-6

#: A grid may use at most this share of the free memory (the step holds other arrays too).
MEMORY_SHARE = 0.8


def available_memory_bytes() -> int | None:
    """Memory the machine can give now, bytes (None when the platform does not say).

    ``MemAvailable`` of ``/proc/meminfo`` on Linux (free memory plus the page cache the
    kernel can drop), else ``os.sysconf('SC_AVPHYS_PAGES') * os.sysconf('SC_PAGE_SIZE')``.
    """
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return int(os.sysconf("SC_AVPHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        return None


@functools.cache
def _blas_controller():  # -> threadpoolctl.ThreadpoolController
    """The BLAS libraries loaded (looked up once: the look-up takes milliseconds)."""
    from threadpoolctl import ThreadpoolController

    return ThreadpoolController()


@contextmanager
def one_blas_thread() -> Iterator[None]:
    """Run the block with the BLAS library (OpenBLAS) on one thread.

    The matrix products of the point-cloud steps are thin (``N x 3`` by ``3 x 3``,
    ``6 x N``): a second BLAS thread only busy-waits, and on a shared machine it
    stalls every product whenever the other core is taken (a ``(300 k, 3) @ (3, 3)``
    product took 151 ms with two threads under load against 4 ms with one).  The
    parallel work of these steps is in the compiled kernels and the tree queries,
    which this does not limit.  The results are the same: OpenBLAS splits the rows
    between its threads, each computed alike.
    """
    with _blas_controller().limit(limits=1, user_api="blas"):
        yield


def format_bytes(n: float) -> str:
    """``326 GiB``, ``1.5 GiB``, ``12 MiB``: the unit people compare with their RAM."""
    for unit, size in (("TiB", 2**40), ("GiB", 2**30), ("MiB", 2**20), ("KiB", 2**10)):
        if n >= size:
            v = n / size
            return f"{v:.0f} {unit}" if v >= 10 else f"{v:.1f} {unit}"
    return f"{int(n)} B"


def check_grid_memory(
    shape: int | Sequence[int],
    bytes_per_cell: float,
    what: str,
    hint: str | None = None,
    *,
    path: str | PathLike[str] | None = None,
    available_bytes: int | None = None,
) -> int:
    """Refuse a grid (raster, cell table, pair list) larger than the free memory.

    Parameters
    ----------
    shape
        Shape of the grid, or its number of cells.
    bytes_per_cell
        Bytes per cell of all the arrays of that shape the step holds at once.
    what
        The grid in words, e.g. ``"a DTM at 0.001 m cells over 1200 x 800 m"``.
    hint
        What to do instead, e.g. ``"--dtm-cell 0.5 or larger"``.
    path
        The input file, named in the message.
    available_bytes
        Free memory, bytes; None = measured (:func:`available_memory_bytes`).

    Returns
    -------
    int
        The estimated size, bytes.

    Raises
    ------
    InputError
        The grid needs more than :data:`MEMORY_SHARE` of the free memory.
    """
    cells = (
        float(shape) if np.ndim(shape) == 0 else float(np.prod([float(s) for s in shape]))  # type: ignore[arg-type]
    )
    need = cells * float(bytes_per_cell)
    free = available_memory_bytes() if available_bytes is None else available_bytes
    if free is not None and need > MEMORY_SHARE * free:
        raise InputError(
            f"{what} needs {format_bytes(need)}; this machine has {format_bytes(free)} free",
            path=path,
            hint=hint,
        )
    return int(min(need, 2**63 - 1))


def smallest_cell_m(
    extent_m: Sequence[float],
    bytes_per_cell: float,
    *,
    available_bytes: int | None = None,
    share: float = 0.25,
) -> float:
    """Smallest round cell size (1, 2, 5 x 10^k m) whose grid over ``extent_m`` fits in
    ``share`` of the free memory: the number a refusal suggests."""
    free = available_memory_bytes() if available_bytes is None else available_bytes
    budget = share * (free if free is not None else 2**30)
    area = float(np.prod([max(float(e), 1e-9) for e in extent_m]))
    dims = len(extent_m)
    cell = (area * float(bytes_per_cell) / max(budget, 1.0)) ** (1.0 / dims)
    k = math.floor(math.log10(cell))
    for m in (1, 2, 5, 10):
        if m * 10.0**k >= cell:
            return float(m * 10.0**k)
    return float(10.0 ** (k + 1))  # pragma: no cover


def check_spread(
    xyz: ArrayLike,
    *,
    step: str,
    min_points: int,
    path: str | PathLike[str] | None = None,
    need_xy: bool = True,
    need_z: bool = False,
) -> NDArray[np.float64]:
    """Refuse a cloud that defines nothing for ``step``; return its extent.

    Parameters
    ----------
    xyz
        ``(N, 3)`` finite coordinates, metres.
    step
        What needs the points, plural, for the message (``"supports"``, ``"ground
        filters"``): "only 1 point; supports need at least 10".
    min_points
        Fewest points the step can work with.
    path
        The input file, named in the message.
    need_xy, need_z
        The points must spread horizontally / vertically.

    Returns
    -------
    numpy.ndarray
        ``(3,)`` extent (max - min) in x, y and z.

    Raises
    ------
    DegenerateGeometryError
        Too few points, all points at one location, no horizontal or vertical extent.

    Examples
    --------
    >>> import numpy as np
    >>> try:
    ...     check_spread(np.zeros((5000, 3)), step="supports", min_points=10)
    ... except InputError as exc:
    ...     print(str(exc)[:40])
    all 5000 points are at the same location
    """
    p = np.asarray(xyz, dtype=np.float64)
    n = len(p)
    hint = "check the file and any crop or filter applied before this step"
    if n < min_points:
        raise DegenerateGeometryError(
            f"only {n} point{'s' if n != 1 else ''}; {step} need at least {min_points}",
            path=path,
            hint=hint,
        )
    span = np.array([float(np.ptp(p[:, k])) for k in range(3)])
    flat = span <= _SAME_M
    if flat.all():
        at = ", ".join(f"{v:g}" for v in p[0])
        raise DegenerateGeometryError(
            f"all {n} points are at the same location ({at}); {step} need points "
            "spread over an area",
            path=path,
            hint=hint,
        )
    if need_xy and flat[:2].all():
        raise DegenerateGeometryError(
            f"all {n} points lie on one vertical line (no extent in x and y); {step} "
            "need points spread over an area",
            path=path,
            hint=hint,
        )
    if need_z and flat[2]:
        raise DegenerateGeometryError(
            f"all {n} points are at the same height (z = {p[0, 2]:g}): a flat cloud has "
            f"no height for {step}",
            path=path,
            hint=hint,
        )
    return span
