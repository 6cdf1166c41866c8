"""Following a support's shaft through the sparse stretches of its height.

The final clustering of a support (:func:`~pyheracles.supports.cookies.extract_support`)
keeps what is connected to its section island at the point spacing about that section.
A shaft found in a low section, in the dense band of the scans, goes on above it where
the scanners saw it only on a few lines: the points of that stretch lie several times
that gap apart, the clustering cut the shaft where the band ends, and the support,
ending far below what the others carry, was dropped as a post under nothing (supports
draw 33: columns of 1.1 m radius, 500-3400 points per 0.5 m up to 6-9 m, 8-37 above,
kept only up to 7.2 and 9.8 m of 15 m).  Here the kept part is followed beyond each of
its ends, stretch by stretch, at the spacing of that stretch's own points, through the
points lying on the shaft's surface (about the section shape's outline).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from pyheracles.segment.euclidean import voxel_clusters
from pyheracles.supports.core import Array


@dataclass(frozen=True)
class FollowParams:
    """Parameters of :func:`follow_shaft`.

    Attributes
    ----------
    window_m
        Height of the stretch beyond a kept end whose own spacing sets the gap, metres.
    min_points
        Fewest points of that stretch measured for its spacing (fewer: no shaft there).
    spacing_factor
        The stretch is clustered at this many times its spacing (the 4th nearest
        neighbour's median distance), as the final clustering is at the section's.
    max_gap_m
        Largest clustering gap, metres (sparser, a stretch is no surface).
    max_slope
        Slope (horizontal over vertical) a shaft's surface drifts off its section shape
        by (a taper of 0.75 over a 15 m column of 1.2 m radius: 0.02): a stretch's
        points lie within the tolerance and that drift over their height from the kept
        end of the offset the kept end has (the other twin of a plinth, a wall, a
        ceiling's middle lie further off it).
    max_steps
        Stretches followed beyond each end.
    """

    window_m: float = 1.0
    min_points: int = 8
    spacing_factor: float = 3.0
    max_gap_m: float = 1.5
    max_slope: float = 0.03
    max_steps: int = 8


def stretch_spacing(pts: Array) -> float:
    """Median distance to the 4th nearest neighbour of a stretch's points (metres)."""
    if len(pts) < 5:
        return float("inf")
    d, _ = cKDTree(pts).query(pts, k=5)
    return float(np.median(d[:, 4]))


def follow_shaft(
    pts: Array,
    rho: Array,
    kept: NDArray[np.bool_],
    gap: float,
    tol: float,
    params: FollowParams | None = None,
) -> NDArray[np.bool_]:
    """``kept`` grown by the sparse stretches of the shaft beyond its ends.

    Parameters
    ----------
    pts
        ``(N, 3)`` points of the support's cookie left by the clutter test, metres.
    rho
        Their offsets from the section shape (metres, > 0 outside).
    kept
        The points connected to the section island by the final clustering.
    gap
        The final clustering's voxel edge, metres: a stretch clustered at no larger a
        gap is no sparser than the section, and was cut for a reason.
    tol
        Offset tolerance of the shaft's surface, metres.
    params
        :class:`FollowParams`.

    Returns
    -------
    ndarray of bool, shape (N,)
        ``kept`` with the followed stretches.
    """
    params = params or FollowParams()
    out = kept.copy()
    if not out.any():
        return out
    z = pts[:, 2]
    for up in (True, False):
        for _ in range(params.max_steps):
            grown = follow_step(pts, z, rho, out, up, gap, tol, params)
            if not grown.any():
                break
            out |= grown
    return out


def follow_step(
    pts: Array,
    z: Array,
    rho: Array,
    out: NDArray[np.bool_],
    up: bool,
    gap: float,
    tol: float,
    params: FollowParams,
) -> NDArray[np.bool_]:
    """The points of the next stretch beyond the kept end (up or down) joined to it at
    the stretch's own spacing (none if it is not sparser than ``gap`` or not on the
    shaft)."""
    none = np.zeros(len(z), dtype=bool)
    sign = 1.0 if up else -1.0
    end = float(z[out].max()) if up else float(z[out].min())
    rise = sign * (z - end)
    # the surface goes on from the kept end's offset (a taper has moved it inward)
    ref = float(np.median(rho[out & (-rise <= params.window_m)]))
    beyond = ~out & (rise > 0) & (np.abs(rho - ref) <= tol + params.max_slope * rise)
    window = beyond & (rise <= params.window_m)
    if np.count_nonzero(window) < params.min_points:
        return none
    g = params.spacing_factor * stretch_spacing(pts[window])
    if not gap < g <= params.max_gap_m:
        return none  # no sparser than the section (cut for a reason), or no surface
    head = out & (sign * (end - z) <= g)
    sel = np.flatnonzero(head | beyond)
    lab = voxel_clusters(pts[sel], g, 1)
    joined = np.isin(lab, np.unique(lab[head[sel]]))
    new = sel[joined & ~head[sel]]
    if not len(new):
        return none
    grown = none.copy()
    grown[new] = True
    return grown
