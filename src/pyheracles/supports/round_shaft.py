"""A support taken for a pier at its section whose shaft is round over its height.

The section's shape test (:func:`~pyheracles.supports.sections.classify_island`)
judges one slab a few centimetres thick.  A column far from the scanners holds a few
dozen points there, and a sign or a lamp fixed to it at that height turns its ring's
best fit into a rectangle (supports draw 0's column 20: 0.18 m radius, 25-35 points per
25 cm of its shaft, a sign's 34 points beside it at the section's level only).  Over
its height the shaft says more: cut into ``bands`` bands between its foot and head
mouldings (which may be square: a plinth, an abacus), its points lie on one circle in
nearly every band, the clutter fills one or two; a pier's shaft is a rectangle in each.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pyheracles.supports.cookies import RING_M, offset
from pyheracles.supports.core import Array, SupportParams
from pyheracles.supports.sections import classify_island


@dataclass(frozen=True)
class RoundShaftParams:
    """Parameters of :func:`round_shaft`.

    Attributes
    ----------
    lo_share, hi_share
        The middle of the shaft tested: between these shares of the support's height
        above its lowest point (the plinth, the base, the capital and the abacus, which
        may be square, are left out).
    bands
        Bands of equal height the middle is cut into.
    round_share
        A round shaft is round (the section's shape test calls the band's points a
        column) in at least this share of its bands...
    radius_spread
        ... with radii within this share of their median (a taper or an entasis of a
        few per cent; clutter fitted as a circle is off).
    min_band_points
        A band with fewer points counts as not round.
    max_points
        Points of a band used at most (a spread sample: the shape test is as good).
    """

    lo_share: float = 0.15
    hi_share: float = 0.85
    bands: int = 6
    round_share: float = 2.0 / 3.0
    radius_spread: float = 0.2
    min_band_points: int = 15
    max_points: int = 2000


def band_circles(
    pts: Array, params: SupportParams, rp: RoundShaftParams = RoundShaftParams()
) -> tuple[Array, Array]:
    """The circles of the bands of a support's shaft that the section's shape test
    calls round.

    Parameters
    ----------
    pts
        ``(N, 3)`` points of one support (floor to top), metres.
    params
        The step's parameters (the section's shape test uses them).
    rp
        :class:`RoundShaftParams`.

    Returns
    -------
    (centres, radii)
        ``(K, 2)`` and ``(K,)``, one row per round band (K <= ``rp.bands``), metres.
    """
    z = pts[:, 2]
    if len(z) == 0:
        return np.zeros((0, 2)), np.zeros(0)
    z0, h = float(z.min()), float(np.ptp(z))
    edges = z0 + h * np.linspace(rp.lo_share, rp.hi_share, rp.bands + 1)
    band = np.searchsorted(edges, z, side="right") - 1
    order = np.argsort(band, kind="stable")
    bounds = np.searchsorted(band[order], np.arange(rp.bands + 1))
    centres, radii = [], []
    for k in range(rp.bands):  # loop over a few bands, not points
        idx = order[bounds[k] : bounds[k + 1]]
        if len(idx) < rp.min_band_points:
            continue
        if len(idx) > rp.max_points:
            idx = idx[np.linspace(0, len(idx) - 1, rp.max_points).astype(np.intp)]
        isl = classify_island(pts[idx, :2], idx, params)
        if isl.kind == "column":
            centres.append(isl.center)
            radii.append(isl.radius)
    return np.reshape(np.asarray(centres, dtype=np.float64), (-1, 2)), np.asarray(radii)


def round_shaft(
    pts: Array, params: SupportParams, rp: RoundShaftParams = RoundShaftParams()
) -> tuple[Array, float] | None:
    """The circle of a support's shaft when its shaft is round over its height.

    Parameters
    ----------
    pts
        ``(N, 3)`` points of one support (floor to top), metres.
    params
        The step's parameters (the section's shape test uses them).
    rp
        :class:`RoundShaftParams`.

    Returns
    -------
    (centre, radius) or None
        The median centre and radius of the round bands (:func:`band_circles`) when at
        least ``rp.round_share`` of the bands are round with radii within
        ``rp.radius_spread`` of their median; None otherwise (a pier, or too few
        points to tell).
    """
    centres, radii = band_circles(pts, params, rp)
    if len(radii) < rp.round_share * rp.bands:
        return None
    r = float(np.median(radii))
    if np.any(np.abs(radii - r) > rp.radius_spread * r):
        return None
    return np.median(centres, axis=0), r


def column_again(
    p: Array, idx: NDArray[np.intp], kept: Array, sh: dict, params: SupportParams
) -> tuple[dict, NDArray[np.intp], Array, Array] | None:
    """A pier shape ``sh`` whose extracted points ``kept`` are round over the shaft
    (:func:`round_shaft`) as a column shape, with its cookie's points ``idx`` (of the
    cloud ``p``) offset from the circle: ``(shape, indices, rho, angle)`` to extract it
    again; None for a pier."""
    rnd = round_shaft(kept, params)
    if rnd is None:
        return None
    c, r = rnd
    col = {**sh, "class": "column", "centre": c, "radius": r, "angle": 0.0}
    col["half"] = np.array([r, r])
    col["buffer"] = max(params.buffer_min_m, params.buffer_fraction * r)
    rho, ang = offset(np.take(p, idx, axis=0)[:, :2], col)
    keep = rho <= col["buffer"] + RING_M
    return col, idx[keep], rho[keep], ang[keep]
