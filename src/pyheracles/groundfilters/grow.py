"""Recovery of rejected ground that continues the accepted terrain smoothly (issue 17).

A morphological opening lowers the top of a crest of curvature ``k`` by ``k r^2 / 2`` at
radius ``r``; SMRF's allowed drop grows like ``slope * r``, so every crest sharper than
about ``2 slope / r_max`` loses its top at the largest windows, whatever its height above
the surrounding terrain. What tells a crest from an object is continuity, not height: the
lowest point of a crest cell lies on the plane of the ground beside it, the roof of a
building or a shrub stands on a step above it.

:func:`grow_smooth` grows the accepted ground cell ring by cell ring into rejected cells
whose lowest point lies within a tolerance of the plane fitted to the ground (accepted or
already grown) around it, where that ground fits its own plane within the tolerance too:
the window of a cell beside a wall mixes two levels and its plane fits neither.
:func:`smooth_components` tells the terrain (one large component of cells linked without
steps) from the few cells of a roof the openings keep, which must not seed the growth.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from pyheracles.groundfilters.surface import positions_of_cells

__all__ = ["grow_smooth", "smooth_components", "window_any", "window_cells", "window_planes"]

_EIGHT = np.ones((3, 3), dtype=bool)


def window_planes(
    values: NDArray[np.float64],
    support: NDArray[np.bool_],
    at: NDArray[np.intp],
    radius: int,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Least-squares planes through the ``support`` cells of square windows.

    Parameters
    ----------
    values
        (rows, cols) heights, metres (only read where ``support``).
    support
        (rows, cols) bool, the cells the planes are fitted to.
    at
        (C,) flat indices of the window centres.
    radius
        Half width of the windows, cells (the window is ``2 radius + 1`` cells wide).

    Returns
    -------
    height
        (C,) the plane's height at each centre, NaN where the window holds fewer than
        three support cells or they are collinear.
    gradient
        (C,) the plane's gradient norm, metres per cell (NaN where ``height`` is).
    rms
        (C,) root mean square residual of the support cells about their plane, metres
        (NaN where ``height`` is): large where the window mixes two levels (the ground
        and a roof beside it).
    """
    rows, cols = values.shape
    r0, c0 = np.divmod(at, cols)
    offsets = np.arange(-radius, radius + 1)
    dr = np.repeat(offsets, offsets.size)
    dc = np.tile(offsets, offsets.size)
    rr = r0[:, None] + dr[None, :]
    cc = c0[:, None] + dc[None, :]
    inside = (rr >= 0) & (rr < rows) & (cc >= 0) & (cc < cols)
    flat = np.where(inside, rr * cols + cc, 0)
    w = (inside & support.ravel()[flat]).astype(np.float64)
    z = values.ravel()[flat]
    wz = np.where(w > 0, z, 0.0)  # w * z without NaN from empty cells
    x, y = dc.astype(np.float64), dr.astype(np.float64)
    # moments of z = a + b x + c y about each window's centre, by two small products
    design = np.stack([np.ones_like(x), x, y, x * x, y * y, x * y], axis=1)
    n, sx, sy, sxx, syy, sxy = (w @ design).T
    sz, szx, szy = (wz @ design[:, :3]).T
    szz = np.einsum("ij,ij->i", wz, wz)
    m = np.empty((at.size, 3, 3))
    m[:, 0] = np.stack([n, sx, sy], 1)
    m[:, 1] = np.stack([sx, sxx, sxy], 1)
    m[:, 2] = np.stack([sy, sxy, syy], 1)
    rhs = np.stack([sz, szx, szy], 1)
    det = np.linalg.det(m) if at.size else np.zeros(0)
    good = (n >= 3) & (np.abs(det) > 1e-6 * np.maximum(n, 1.0) ** 3)
    height = np.full(at.size, np.nan)
    grad = np.full(at.size, np.nan)
    rms = np.full(at.size, np.nan)
    if good.any():
        coef = np.linalg.solve(m[good], rhs[good][:, :, None])[:, :, 0]
        height[good] = coef[:, 0]
        grad[good] = np.hypot(coef[:, 1], coef[:, 2])
        # residual sum of squares of the least-squares plane: sum w z^2 - coef . rhs
        sse = szz[good] - np.einsum("ij,ij->i", coef, rhs[good])
        rms[good] = np.sqrt(np.maximum(sse, 0.0) / n[good])
    return height, grad, rms


def smooth_components(
    zmin: NDArray[np.float64],
    cells: NDArray[np.bool_],
    step_m: float,
    *,
    reach: int = 1,
    rise_m: float = 0.0,
) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """Components of ``cells`` linked through cells close in plan and in height.

    Two cells are linked when they lie within ``reach`` cells of each other (Chebyshev
    distance: 1 = the 8 neighbours; more bridges empty cells on sparse clouds) and their
    heights differ by less than ``step_m + rise_m * d``, ``d`` being their distance in
    cells.

    Returns
    -------
    labels
        (rows, cols) component of every cell (-1 outside ``cells``).
    sizes
        (K,) cells per component.
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    rows, cols = cells.shape
    at = np.flatnonzero(cells)  # row-major, sorted: a neighbour's id by binary search
    r, c = np.divmod(at, cols)
    z = zmin.ravel()[at]
    heads, tails = [], []
    reach = max(1, int(reach))
    # each unordered pair once: offsets in the half plane (dr > 0, or dr == 0 and dc > 0);
    # gathered at the cells only (a mosaic's raster is mostly empty)
    offsets = [(0, dc) for dc in range(1, reach + 1)]
    offsets += [(dr, dc) for dr in range(1, reach + 1) for dc in range(-reach, reach + 1)]
    for dr, dc in offsets:
        if dr >= rows or abs(dc) >= cols:
            continue
        ok = np.flatnonzero((r + dr < rows) & (c + dc >= 0) & (c + dc < cols))
        hit, pos = positions_of_cells(at, at[ok] + dr * cols + dc)
        ok, pos = ok[hit], pos[hit]
        limit = step_m + rise_m * float(np.hypot(dr, dc))
        link = np.abs(z[ok] - z[pos]) < limit
        heads.append(ok[link])
        tails.append(pos[link])
    head = np.concatenate(heads) if heads else np.zeros(0, dtype=np.intp)
    tail = np.concatenate(tails) if tails else np.zeros(0, dtype=np.intp)
    graph = coo_matrix((np.ones(head.size, dtype=np.int8), (head, tail)), shape=(at.size, at.size))
    _, comp = connected_components(graph, directed=False)
    labels = np.full(cells.shape, -1, dtype=np.intp)
    labels.ravel()[at] = comp
    return labels, np.bincount(comp, minlength=1)


def _window_offsets(
    cells: NDArray[np.intp], shape: tuple[int, int], radius: int
):
    """Per offset of the (2 radius + 1)^2 window: the positions of ``cells`` (flat) whose
    shifted cell lies in the raster, and those shifted flat cells."""
    rows, cols = shape
    rr, cc = np.divmod(cells, cols)
    for dr in range(-radius, radius + 1):  # a few rows and columns of offsets
        r = rr + dr
        in_r = (r >= 0) & (r < rows)
        for dc in range(-radius, radius + 1):
            c = cc + dc
            ok = np.flatnonzero(in_r & (c >= 0) & (c < cols))
            yield ok, r[ok] * cols + c[ok]


def window_any(
    mask: NDArray[np.bool_], cells: NDArray[np.intp], radius: int
) -> NDArray[np.bool_]:
    """Per flat cell of ``cells``: whether ``mask`` holds a cell within its square window
    of half width ``radius`` (a binary dilation looked up at those cells only)."""
    flat = mask.ravel()
    out = np.zeros(len(cells), dtype=bool)
    for ok, shifted in _window_offsets(cells, mask.shape, radius):
        out[ok] |= flat[shifted]
    return out


def window_cells(
    cells: NDArray[np.intp], shape: tuple[int, int], radius: int
) -> NDArray[np.intp]:
    """Flat cells within the square window of half width ``radius`` of any of ``cells``,
    sorted, each once (the binary dilation of a few cells, at their cost)."""
    parts = [shifted for _, shifted in _window_offsets(cells, shape, radius)]
    return np.unique(np.concatenate(parts)) if parts else np.zeros(0, dtype=np.intp)


def grow_smooth(
    zmin: NDArray[np.float64],
    kept: NDArray[np.bool_],
    candidates: NDArray[np.bool_],
    *,
    radius: int,
    tolerance_m: float,
    slope_scalar: float,
    max_rise: float,
    max_steps: int,
) -> NDArray[np.bool_]:
    """Candidate cells reached from the kept ground through smooth continuations of it.

    Parameters
    ----------
    zmin
        (rows, cols) lowest point per cell, metres (NaN where empty).
    kept
        (rows, cols) bool, the accepted ground cells.
    candidates
        (rows, cols) bool, rejected cells that may be recovered (holding points).
    radius
        Half width of the window of the plane fits, cells (at least 1); a candidate is
        tested once ground lies within this window of it.
    tolerance_m
        Largest distance of a cell's lowest point from the plane of the ground around it,
        metres, on flat ground.
    slope_scalar
        The tolerance grows by ``slope_scalar`` times the plane's rise over one cell (the
        lowest point of a cell on a slope lies anywhere in the cell).
    max_rise
        Largest rise over one cell counted in the tolerance, metres (the steepest
        terrain expected times the cell).
    max_steps
        Largest number of rings grown.

    Returns
    -------
    numpy.ndarray
        (rows, cols) bool, the grown cells (a subset of ``candidates``).
    """
    cand = candidates & ~kept & np.isfinite(zmin)
    grown = np.zeros(kept.shape, dtype=bool)
    if not cand.any() or not kept.any():
        return grown
    ground = kept.copy()
    radius = max(1, int(radius))
    cand_flat, grown_flat, ground_flat = cand.ravel(), grown.ravel(), ground.ravel()
    # the front: candidates within the window of the ground, so that it crosses empty
    # cells (sparse clouds: a cell of 1-2 m holds less than one point on average).
    # Windows are looked up cell by cell, not dilated over the raster: the cost follows
    # the candidates and each ring, not the raster (tiles on a diagonal, issue 17)
    front = np.flatnonzero(cand)
    front = front[window_any(ground, front, radius)]
    for _ in range(int(max_steps)):
        at = front
        if at.size == 0:
            break
        height, grad, rms = window_planes(zmin, ground, at, radius)
        misfit = np.abs(zmin.ravel()[at] - height)
        tolerance = tolerance_m + slope_scalar * np.minimum(grad, max_rise)
        # the cell continues the plane, and the ground around it is a plane: a window
        # mixing the ground and a roof beside it has a steep plane that fits neither
        ok = np.isfinite(misfit) & (misfit <= tolerance) & (rms <= tolerance)
        if not ok.any():
            break
        grown_flat[at[ok]] = True
        ground_flat[at[ok]] = True
        # the next ring: the candidates whose window gained support (the others would
        # fail the same test again)
        near = window_cells(at[ok], kept.shape, radius)
        front = near[cand_flat[near] & ~grown_flat[near]]
    return grown
