"""A column's axis from its shaft band only: not its plinth, base or capital.

Why a module of its own: :func:`~pyheracles.supports.primitives.shaft_axis` starts
from the cylinder of the section's points and the line of the slabs' centres, and
refits a cylinder and a cone to the points near them.  On a column seen from one side
whose plinth corners and capital are kept in its cookie (a square plinth and abacus
seen from one side are arcs of no circle), and whose shaft tapers by more than the
band's width, those points are near the cylinder too: the refits lean the axis by a
degree and move it 15 cm off the shaft at its foot (supports draw 22, column 12: radius
1.24 -> 0.95 m over 13 m, found in the low section 0.24 m above the shaft's foot;
radius 3.3 cm too small there).  :func:`shaft_band_axis` fits the axis again to the
points of the shaft band only (between the base band's top and the capital band's
bottom that :func:`~pyheracles.supports.primitives.column_shape` found about the first
axis), the radius a smooth profile of the height (taper and entasis).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pyheracles.geometry.fitting import perpendicular_basis
from pyheracles.geometry.groups import group_medians
from pyheracles.supports.core import Array

__all__ = ["ShaftBandParams", "arc_span_deg", "band_points", "profile_axis", "shaft_band_axis"]


@dataclass(frozen=True)
class ShaftBandParams:
    """Parameters of :func:`shaft_band_axis`.

    Attributes
    ----------
    margin_share : float
        Share of the shaft band's length left out at each end (a base's or a
        capital's moulding the bands did not reach), at least ``margin_m``.
    margin_m : float
        Least length left out at each end of the shaft band (m).
    min_length_m : float
        Shortest shaft band (after the margins) whose axis is fitted again (m).
    layer_m : float
        Height of the layers whose median distance to the axis is the shaft's radius
        there (the surface's points are those within ``max(3 tol, ring_share r)`` of it).
    ring_share : float
        Share of the radius a surface point may lie off its layer's median distance.
    max_points : int
        Points of the band the fit uses (a spread sample).
    min_points : int
        Fewest surface points of the band for a fit.
    refits : int
        Fits, each on the band's surface points about the axis of the one before.
    min_arc_deg : float
        Least azimuth (degrees) the band's points span about the first axis: over a
        shorter arc a lean towards the scanner and a taper fit the points alike.
    max_widening_share : float
        Share of the radius a fitted shaft may widen by from its band's foot to its top
        (a shaft tapers upwards; a fit that widens it leans towards the side the
        scanner saw: held-out supports draw 40, column 24, 0.09 -> 0.28 m over 3 m of
        a 0.14 m shaft seen over 150 degrees, leaning 4 degrees).
    """

    margin_share: float = 0.05
    margin_m: float = 0.1
    min_length_m: float = 1.0
    layer_m: float = 0.25
    ring_share: float = 0.15
    max_points: int = 3000
    min_points: int = 100
    refits: int = 2
    min_arc_deg: float = 120.0
    max_widening_share: float = 0.1


def band_points(
    pts: Array, point: Array, axis: Array, t_lo: float, t_hi: float, tol: float,
    params: ShaftBandParams,
) -> NDArray[np.bool_]:  # fmt: skip
    """Mask of the points of ``pts`` on the shaft's surface between ``t_lo`` and ``t_hi``
    along the axis (through ``point``, unit ``axis``): within ``max(3 tol, ring_share
    r)`` of the shaft's taper line, r the median distance to the axis over the band.

    The taper line is the Theil-Sen line of the median distances of the layers
    (``layer_m``) against their heights: a capital's flare, a moulding or a beam over
    the column in a few of the band's layers moves neither its slope (a median of the
    pairs' slopes) nor its offset, where a layer's own median takes them in.
    """
    rel = pts - point
    t = rel @ axis
    d = np.linalg.norm(rel - np.outer(t, axis), axis=1)
    inside = (t >= t_lo) & (t <= t_hi)
    if inside.sum() < params.min_points:
        return np.zeros(len(pts), dtype=bool)
    n = max(1, math.ceil((t_hi - t_lo) / params.layer_m))
    k = np.clip(((t[inside] - t_lo) / params.layer_m).astype(np.intp), 0, n - 1)
    full = np.bincount(k, minlength=n) >= 5
    if full.sum() < 2:
        return np.zeros(len(pts), dtype=bool)
    hm = group_medians(t[inside], k, n)[full]
    rm = group_medians(d[inside], k, n)[full]
    i, j = np.triu_indices(len(hm), 1)
    dh = hm[j] - hm[i]
    ok = np.abs(dh) > 1e-9
    slope = float(np.median((rm[j] - rm[i])[ok] / dh[ok])) if ok.any() else 0.0
    off = float(np.median(rm - slope * hm))
    width = max(3.0 * tol, params.ring_share * float(np.median(d[inside])))
    return inside & (np.abs(d - (off + slope * t)) <= width)


def arc_span_deg(
    pts: Array, point: Array, axis: Array, *, near_deg: float = 5.0, min_near: int = 3
) -> float:
    """Degrees of azimuth about the axis (through ``point``, unit ``axis``) the points
    of ``pts`` span: 360 less the widest gap between the azimuths of the points that
    have ``min_near`` points (themselves included) within ``near_deg`` of them (a stray
    point is no view of that side; a scan line is many points at one azimuth).  No bins:
    the scan lines of a column far from the stations lie 20-30 degrees apart on it
    (supports draw 27, column 8: 700 points all round 7 m of shaft)."""
    e1 = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    rel = pts - point
    az = np.sort(np.degrees(np.arctan2(rel @ e2, rel @ e1)) % 360.0)
    if len(az) < min_near:
        return 0.0
    ext = np.r_[az - 360.0, az, az + 360.0]
    near = np.searchsorted(ext, az + near_deg, "right") - np.searchsorted(ext, az - near_deg)
    kept = az[near >= min_near]
    if len(kept) == 0:
        return 0.0
    gaps = np.diff(np.r_[kept, kept[0] + 360.0])
    return float(360.0 - gaps.max())


def profile_axis(
    pts: Array, point: Array, axis: Array, radius: float, f_scale: float,
) -> tuple[Array, Array, float, Array, float] | None:  # fmt: skip
    """(point, unit axis z up, radius at the point, residuals, widening: the radius'
    linear change over the points' span along the axis) of the axis about which the
    distances of ``pts`` follow a quadratic of the height along it (taper and entasis),
    robust (soft-L1 of scale ``f_scale``), started from ``point``, ``axis`` and
    ``radius``; the point is at the points' mean height along the axis.  None when the
    fit fails."""
    from scipy.optimize import least_squares

    a0 = np.asarray(axis, dtype=np.float64)
    a0 = a0 / np.linalg.norm(a0)
    if a0[2] < 0:
        a0 = -a0
    e1, e2 = perpendicular_basis(a0)
    c0 = point + float(np.mean((pts - point) @ a0)) * a0
    span = max(float(np.ptp((pts - c0) @ a0)), 1e-6)

    def geom(x: Array) -> tuple[Array, Array]:
        a = a0 + x[0] * e1 + x[1] * e2
        return c0 + x[2] * e1 + x[3] * e2, a / np.linalg.norm(a)

    def res(x: Array) -> Array:
        c, a = geom(x)
        rel = pts - c
        t = rel @ a / span
        d = np.linalg.norm(rel - np.outer(rel @ a, a), axis=1)
        return d - (x[4] + x[5] * t + x[6] * t * t)

    try:
        sol = least_squares(res, np.array([0.0, 0.0, 0.0, 0.0, radius, 0.0, 0.0]),
                            loss="soft_l1", f_scale=f_scale, x_scale=1e-3)  # fmt: skip
    except (ValueError, np.linalg.LinAlgError):
        return None
    if not sol.success or not np.all(np.isfinite(sol.x)) or not sol.x[4] > 0:
        return None
    c, a = geom(sol.x)
    return c, a, float(sol.x[4]), res(sol.x), float(sol.x[5])


def shaft_band_axis(
    pts: Array, point: Array, axis: Array, radius: float, base_top: float,
    capital_bottom: float, tol: float, params: ShaftBandParams | None = None,
) -> tuple[Array, Array, float] | None:  # fmt: skip
    """(point, unit axis z up, radius) of a column's shaft fitted to its shaft band.

    Parameters
    ----------
    pts : (N, 3) ndarray
        The column's points.
    point, axis, radius
        The first axis (a point on it, its direction) and the shaft's radius.
    base_top, capital_bottom : float
        Heights above the points' lowest z of the axis where the base band ends and the
        capital band begins (NaN: no such band; the shaft runs to the points' end).
    tol : float
        The scan's tolerance (m).
    params : ShaftBandParams, optional

    Returns
    -------
    tuple or None
        The axis of :func:`profile_axis` fitted to the shaft band's surface points
        (:func:`band_points`, ``margin`` in from both ends), refitted ``refits`` times
        about the axis before; None when the band is shorter than ``min_length_m`` or
        holds fewer than ``min_points`` surface points, or the fit fails.
    """
    params = params or ShaftBandParams()
    a = np.asarray(axis, dtype=np.float64)
    a = a / np.linalg.norm(a)
    if a[2] < 0:
        a = -a
    if a[2] < 0.5:
        return None
    z_min = float(pts[:, 2].min())
    t = (pts - point) @ a
    lo = (z_min + base_top - point[2]) / a[2] if math.isfinite(base_top) else float(t.min())
    hi = (
        (z_min + capital_bottom - point[2]) / a[2]
        if math.isfinite(capital_bottom)
        else float(t.max())
    )
    margin = max(params.margin_m, params.margin_share * (hi - lo))
    t_lo, t_hi = lo + margin, hi - margin
    if t_hi - t_lo < params.min_length_m:
        return None
    if len(pts) > params.max_points * 4:
        pts = pts[np.linspace(0, len(pts) - 1, params.max_points * 4).astype(np.intp)]
    p0, a0, r0 = np.asarray(point, dtype=np.float64), a, float(radius)
    sel = band_points(pts, p0, a0, t_lo, t_hi, tol, params)
    if sel.sum() < params.min_points or arc_span_deg(pts[sel], p0, a0) < params.min_arc_deg:
        return None
    out = None
    for _ in range(params.refits):
        sel = band_points(pts, p0, a0, t_lo, t_hi, tol, params)
        if sel.sum() < params.min_points:
            break
        q = pts[sel]
        if len(q) > params.max_points:
            q = q[np.linspace(0, len(q) - 1, params.max_points).astype(np.intp)]
        fit = profile_axis(q, p0, a0, r0, max(tol / 4.0, 1e-3))
        if fit is None:
            break
        # again without the points more than 3 robust sigma off the profile (a beam, a
        # moulding, clutter in the band)
        res = fit[3]
        off = np.abs(res - np.median(res))
        close = off <= max(3.0 * 1.4826 * float(np.median(off)), 1e-4)
        if params.min_points <= close.sum() < len(q):
            fit = profile_axis(q[close], fit[0], fit[1], fit[2], max(tol / 4.0, 1e-3)) or fit
        if fit[4] > params.max_widening_share * fit[2]:
            return None  # wider at the top: a lean towards the scanner taken for a taper
        # the band's ends along the new axis: the same heights of the old one
        p1, a1 = fit[0], fit[1]
        half = 0.5 * (t_hi - t_lo)
        s = float((p0 + 0.5 * (t_lo + t_hi) * a0 - p1) @ a1)
        t_lo, t_hi = s - half, s + half
        p0, a0, r0 = fit[0], fit[1], fit[2]
        out = (p0, a0, r0)
    return out
