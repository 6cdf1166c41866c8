"""Clutter touching a column, told from its mouldings by the shaft's own surface.

A bench seat, a chair or a fence rail touching a column is cut out with it: the
cookie-cutter's reach per height band (:func:`pyheracles.supports.profile.band_reach`)
follows the median of the innermost offsets of a layer's sectors, and a flat board
tangent to a round shaft covers half of them (supports draw 4: a bench seat 3-21 cm
beyond the shaft, 533 points, kept in its column).  A plinth, a base moulding or a
capital is wider than the shaft all round and hides the shaft's surface in its layers;
beside a bench or a chair the shaft's surface shows in most of the layer's sectors.
So: in a layer where the fitted shaft's surface holds points in at least half the
sectors that hold any, the points well outside that surface are not the column.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from pyheracles.supports.core import Array

__all__ = ["SURFACE_SECTOR_SHARE", "off_shaft", "plan_reach", "thin_pier"]

#: Height of the layers in which a candidate's plan reach is measured (metres).
WIDTH_LAYER_M = 0.1


#: A layer is the shaft's (not a moulding's) when its points on the shaft's surface fill
#: at least this share of the sectors its points fill.
SURFACE_SECTOR_SHARE = 0.5


def off_shaft(
    pts: Array,
    point: Array,
    axis: Array,
    row: dict,
    tol: float,
    *,
    layer_m: float = 0.05,
    sectors: int = 36,
) -> NDArray[np.bool_]:
    """Points of a column that lie well outside its shaft in a layer where the shaft shows.

    Parameters
    ----------
    pts : (N, 3) ndarray
        The column's points (metres).
    point, axis : (3,) ndarray
        A point of the shaft's axis and its direction.
    row : dict
        The column's objects-table row: ``z_min``, ``height_m``, ``radius_bottom_m``,
        ``radius_top_m`` (or ``radius_m``), ``base_top_m``, ``capital_bottom_m``.
    tol : float
        Surface tolerance (metres): a point within ``max(2 tol, 1 cm, 2 sigma)`` of the
        shaft's surface is on it, one more than ``max(3 tol, 3 cm, 4 sigma, radius / 10)``
        outside it is off it (sigma: the robust standard deviation of the offsets from the
        surface between the bands: the flutes' depth, the noise).
    layer_m, sectors
        Height layers (metres) and angular sectors about the axis.

    Returns
    -------
    (N,) bool ndarray
        True for the points off the shaft: between the base and capital bands (a layer
        in from each), more than the threshold outside the surface, in a layer whose
        surface points fill at least :data:`SURFACE_SECTOR_SHARE` of its occupied sectors,
        as they do in the layers above and below it.
    """
    n = len(pts)
    out = np.zeros(n, dtype=bool)
    a = np.asarray(axis, dtype=np.float64)
    norm = float(np.linalg.norm(a))
    if n == 0 or not norm > 0:
        return out
    a = a / norm
    r_bottom = float(row.get("radius_bottom_m", math.nan))
    r_top = float(row.get("radius_top_m", math.nan))
    if not (math.isfinite(r_bottom) and math.isfinite(r_top)):
        r_bottom = r_top = float(row.get("radius_m", math.nan))
    if not math.isfinite(r_bottom):
        return out
    z = pts[:, 2] - float(row["z_min"])
    base, cap = float(row.get("base_top_m", math.nan)), float(row.get("capital_bottom_m", math.nan))
    z_lo = base if math.isfinite(base) else 0.0
    z_hi = cap if math.isfinite(cap) else float(row["height_m"])
    if z_hi - z_lo <= 3 * layer_m:
        return out
    rel = pts - np.asarray(point, dtype=np.float64)
    t = rel @ a
    radial = rel - np.outer(t, a)
    d = np.linalg.norm(radial, axis=1)
    r = r_bottom + (r_top - r_bottom) * np.clip((z - z_lo) / (z_hi - z_lo), 0.0, 1.0)
    off = d - r
    zone = (z > z_lo + layer_m) & (z < z_hi - layer_m)
    if zone.sum() < 20:
        return out
    # the shaft's own scatter about its surface: flutes (an arris of a 6 cm flute stands
    # 3 cm proud of the mean radius), noise; robust, so that the clutter does not set it
    sigma = 1.4826 * float(np.median(np.abs(off[zone] - np.median(off[zone]))))
    surface = np.abs(off) <= max(2.0 * tol, 0.01, 2.0 * sigma)
    # and a tenth of the radius: a large shaft's axis a few centimetres off, or its base
    # swelling above the band found, puts one side that far out (draw 22, 1.2 m columns)
    outer = off > max(3.0 * tol, 0.03, 4.0 * sigma, 0.1 * min(r_bottom, r_top))
    if not (outer & zone).any():
        return out
    e1 = np.cross(a, [1.0, 0.0, 0.0] if abs(a[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(a, e1)
    sector = ((np.arctan2(radial @ e2, radial @ e1) + np.pi) / (2 * np.pi) * sectors).astype(
        np.intp
    ) % sectors
    layer = np.floor(z / layer_m).astype(np.intp)
    layer -= layer.min()
    n_layers = int(layer.max()) + 1
    occupied = np.zeros((n_layers, sectors), dtype=bool)
    on_surface = np.zeros((n_layers, sectors), dtype=bool)
    occupied[layer, sector] = True
    on_surface[layer[surface], sector[surface]] = True
    shaft_layer = on_surface.sum(axis=1) >= SURFACE_SECTOR_SHARE * occupied.sum(axis=1)
    # and so are both neighbours: a plinth's top face lies in the layer of the shaft's foot
    below = np.r_[False, shaft_layer[:-1]]
    above = np.r_[shaft_layer[1:], False]
    return outer & zone & (shaft_layer & below & above)[layer]


def plan_reach(pts: Array, layer_m: float = WIDTH_LAYER_M) -> float:
    """How far points reach in plan, layer by layer (metres).

    Per height layer ``layer_m`` thick holding at least three points, the larger of the
    points' spreads along the two plan axes of the whole set (its covariance's principal
    axes); the median over the layers.  A ledger or a board crossing in a few layers
    does not lengthen it; a pier seen on one face only reaches the face's width.
    ``nan`` without such a layer.
    """
    xyz = np.asarray(pts, dtype=np.float64)
    if len(xyz) < 3:
        return math.nan
    rel = xyz[:, :2] - xyz[:, :2].mean(axis=0)
    _, vec = np.linalg.eigh(np.cov(rel.T))
    uv = rel @ vec
    layer = np.floor((xyz[:, 2] - xyz[:, 2].min()) / layer_m).astype(np.intp)
    order = np.argsort(layer, kind="stable")
    cuts = np.flatnonzero(np.diff(layer[order])) + 1
    spans = [float(np.max(np.ptp(uv[g], axis=0))) for g in np.split(order, cuts) if len(g) >= 3]
    return float(np.median(spans)) if spans else math.nan


def thin_pier(pts: Array, min_support_size_m: float) -> bool:
    """Whether a pier candidate's points are a tube's over its height, not a pier's.

    A section island shorter than ``min_support_size_m`` every way is noise (a fence
    bar, a chair leg); one cut where a scaffold's ledger or deck joins its standard is
    long enough, but the candidate's points over its height are the standard's, a
    0.024 m tube (supports draws 1 and 35: standards 3.8-9.8 m tall, boxes 0.125 x 0.039
    and 0.150 x 0.027 m, reaching 0.02-0.06 m in their layers, were piers).  So the same
    bound holds for the points kept, layer by layer over the height
    (:func:`plan_reach`); a pier seen on one face only reaches that face's width
    (draws 27 and 32: 0.16-0.28 m).

    Parameters
    ----------
    pts : (N, 3) ndarray
        The pier candidate's points (metres).
    min_support_size_m : float
        The smallest support across (metres), :class:`~pyheracles.supports.core.SupportParams`.

    Returns
    -------
    bool
        True when the points reach less than ``min_support_size_m`` in the median layer.
    """
    reach = plan_reach(pts)
    return bool(np.isfinite(reach) and reach < min_support_size_m)
