"""Whether a support ending short of what it carries goes on above its own points.

A support's points may end below the surface found over it for two reasons: the
cookie-cutter lost its upper part (a scaffold's deck or ledgers round the shaft cut it
off, the shaft above stayed a piece of its own: supports held-out draw 46, a 0.24 m
column cut at 6.2 m under a vault carried at 8.7 m, its shaft seen in every layer
above; draw 33, a tapered column of 1.2 m seen sparsely from 9.9 m up to the attic at
15 m), or it ends there and carries something else, not the surface (the post of a
pulpit under its tub, a fence's bars under its top rail: draws 8, 12, 16 and 25, the
plan of their own top holding no point from there up to the ceiling).  So the plan of
the candidate's own top is followed upwards: a support goes on where its plan holds
points in a good share of the layers up to what it carries; one that does not, ends at
its own top and is judged by it (:func:`~pyheracles.supports.carriers.low_carriers`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import ConvexHull, QhullError, cKDTree

from pyheracles.geometry.fitting import fit_circle
from pyheracles.supports.core import Array

__all__ = ["GOES_ON_SHARE", "AboveParams", "ends_short", "goes_on_share", "in_plan"]


@dataclass(frozen=True)
class AboveParams:
    """How the plan of a support's top is followed upwards.

    Attributes
    ----------
    top_band_m : float
        The plan is that of the candidate's own points this far under its top (metres).
    cell_m : float
        Smallest margin round the plan of the top (metres); ``max(cell_m, 2 x tol)``
        (a shaft leaning a degree moves 2 cm per metre).
    layers : int
        Most layers between its top and what it carries.
    min_layer_m : float
        Thinnest layer (metres).
    min_points : int
        A layer holds the plan with at least this many points in it (a stray
        mixed pixel or outlier does not).
    """

    top_band_m: float = 1.0
    cell_m: float = 0.05
    layers: int = 20
    min_layer_m: float = 0.1
    min_points: int = 3


def in_plan(own_xy: Array, xy: Array, cell: float, radius: float = math.nan) -> NDArray[np.bool_]:
    """Whether each point of ``xy`` lies in the plan of ``own_xy``: within ``cell`` of
    its convex hull, or, when the hull is flat, within ``cell`` of its points; for a
    column (``radius`` given) also within ``cell`` of the disc of the circle fitted to
    ``own_xy`` (when that circle's radius lies within half and twice ``radius``): a
    shaft narrowing upwards stays inside its lower outline, and the arc seen of its top
    may be short (draw 33: a column of 1.2 m seen over a quarter of its ring at its top,
    its shaft above 2-10 cm further in).

    Parameters
    ----------
    own_xy : (N, 2) ndarray
        Plan coordinates of a candidate's top (metres).
    xy : (M, 2) ndarray
        Plan coordinates to test (metres).
    cell : float
        Margin (metres).
    radius : float, optional
        A column's radius (metres); ``nan`` for a pier.

    Returns
    -------
    (M,) bool ndarray
    """
    own_xy = np.asarray(own_xy, dtype=np.float64)
    xy = np.asarray(xy, dtype=np.float64)
    if not len(own_xy) or not len(xy):
        return np.zeros(len(xy), dtype=bool)
    try:
        eq = ConvexHull(own_xy).equations
        out = np.max(xy @ eq[:, :2].T + eq[:, 2], axis=1) <= cell
    except QhullError:  # fewer than three points or all on one line
        out = np.isfinite(cKDTree(own_xy).query(xy, distance_upper_bound=cell)[0])
    if math.isfinite(radius) and len(own_xy) >= 3:
        fit = fit_circle(own_xy)
        if fit and 0.5 * radius <= fit.radius <= 2.0 * radius:
            out |= np.hypot(*(xy - fit.center).T) <= fit.radius + cell
    return out


def goes_on_share(
    own: Array,
    above: Array,
    carried_z: float,
    tol: float,
    params: AboveParams | None = None,
    radius: float = math.nan,
) -> float:
    """Share of the layers between a candidate's top and what it carries in which the
    plan of its top holds points (0..1).

    Parameters
    ----------
    own : (N, 3) ndarray
        The candidate's own points (metres).
    above : (M, 3) ndarray
        The cloud's points between its top and ``carried_z`` (any plan position).
    carried_z : float
        The underside of what it carries (metres).
    tol : float
        Surface tolerance (metres): the layers start and end that far from the
        candidate's top and from ``carried_z``.
    params : AboveParams, optional

    Returns
    -------
    float
        Share of the layers (each ``max(min_layer_m, gap / layers)`` thick) whose points
        within the plan of the candidate's top (:func:`in_plan` of its points within
        ``top_band_m`` of its highest) number at least ``min_points``; ``nan`` when there is no
        such layer (the candidate's top within ``2 tol`` of ``carried_z``).
    """
    prm = params or AboveParams()
    own = np.asarray(own, dtype=np.float64)
    above = np.asarray(above, dtype=np.float64)
    if not len(own) or not math.isfinite(carried_z):
        return math.nan
    top = float(own[:, 2].max())
    lo, hi = top + tol, carried_z - tol
    if hi - lo < prm.min_layer_m:
        return math.nan
    cell = max(prm.cell_m, 2.0 * tol)
    step = max(prm.min_layer_m, (hi - lo) / prm.layers)
    n_layers = max(1, int((hi - lo) // step))
    step = (hi - lo) / n_layers
    sel = above[(above[:, 2] > lo) & (above[:, 2] < hi)]
    if not len(sel):
        return 0.0
    inside = in_plan(own[own[:, 2] >= top - prm.top_band_m, :2], sel[:, :2], cell, radius)
    layer = np.minimum(((sel[inside, 2] - lo) / step).astype(np.int64), n_layers - 1)
    counts = np.bincount(layer, minlength=n_layers)
    return float(np.count_nonzero(counts >= prm.min_points)) / n_layers


#: A support goes on above its points when the plan of its top holds points in at least
#: this share of the layers up to what it carries (supports family, seeds 0-49: 0.8-1.0
#: over the columns cut by a scaffold's deck (held-out draw 46) or seen sparsely above
#: (draw 33), 0.5-0.9 over the piers of an arcade under its arches (draw 32); 0 over the
#: posts of pulpits and the bars of fences, draws 8, 12, 16 and 25).
GOES_ON_SHARE = 0.25


def ends_short(
    p: Array,
    rows: list[dict],
    members: list[tuple],
    band: Callable[[float, float], NDArray[np.intp]],
    tol: float,
    params: AboveParams | None = None,
) -> list[bool]:
    """Per candidate, whether it carries something it does not reach and the plan of its
    top stays empty up to it (:func:`goes_on_share` below :data:`GOES_ON_SHARE`): it
    ends at its own top.

    Parameters
    ----------
    p : (N, 3) ndarray
        The cloud (metres).
    rows : list of dict
        The candidates' objects-table rows (``class``, ``radius_m``).
    members : list of tuple
        Per candidate ``(indices, carries, carried_z, overhead, reaches, ...)`` as in
        :func:`~pyheracles.supports.detect.detect_supports`.
    band : callable
        ``band(z_lo, z_hi)``: indices of the points of ``p`` between two heights.
    tol : float
        Surface tolerance (metres).
    params : AboveParams, optional

    Returns
    -------
    list of bool
    """
    prm = params or AboveParams()
    cell = max(prm.cell_m, 2.0 * tol)
    out = []
    for row, (cidx, carries, carried_z, _, reaches, *_) in zip(rows, members, strict=True):
        if not carries or reaches or not math.isfinite(carried_z) or not len(cidx):
            out.append(False)
            continue
        own = np.take(p, cidx, axis=0)
        top = float(own[:, 2].max())
        idx = band(top, carried_z)
        lo, hi = own[:, :2].min(axis=0) - 2 * cell, own[:, :2].max(axis=0) + 2 * cell
        near = idx[np.all((p[idx, :2] >= lo) & (p[idx, :2] <= hi), axis=1)]
        radius = float(row["radius_m"]) if row["class"] != "pier" else math.nan
        share = goes_on_share(own, np.take(p, near, axis=0), carried_z, tol, prm, radius)
        out.append(bool(math.isfinite(share) and share < GOES_ON_SHARE))
    return out
