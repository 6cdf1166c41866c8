"""Short arcs of small rings confirmed by the same circle at several heights.

A small column far from the scanners (or shadowed by its twin) shows only 40-80 degrees
of its ring, in a few scan-line bunches, at every height.  Its arc does not bulge
enough out of its chord to be told from the corner of a pier in one section
(:func:`~pyheracles.supports.rings.ring_covered` asks a quarter ring of rings up to
0.2 m).  What tells it from noise and clutter is that the circle is tight (its
residual far below the ring test's tolerance) and that the same circle, fitted again
on its own, comes back in the slabs above and below the section.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pyheracles.supports.core import Array, Island, SupportParams
from pyheracles.supports.rings import (
    ARC_GAP_M,
    ARC_MIN_SECTORS,
    ARC_SPREAD_RMS_SHARE,
    gap_clusters,
    ring_covered,
    ring_fit,
    ring_tolerance,
)


@dataclass(frozen=True)
class HeightRingParams:
    """Settings of :func:`rings_over_heights`.

    Attributes
    ----------
    slab_m
        Thickness of each slab the circle is fitted again in, metres.
    slabs_each_way
        Slabs looked at above and below the section (each ``slab_m`` thick, next to
        each other).
    confirmations
        Slabs other than the section's in which the circle must come back.
    radius_share
        The circle comes back when its radius is within this share of the arc's ...
    centre_share
        ... and its centre within this share of the arc's radius (plus ``lean``
        times the height between the slabs) of the arc's centre.
    lean
        Allowed horizontal shift of the centre per metre of height (a leaning column,
        up to 6 degrees).
    """

    slab_m: float = 0.3
    slabs_each_way: int = 4
    confirmations: int = 2
    radius_share: float = 0.2
    centre_share: float = 0.25
    lean: float = 0.1


def ring_candidates(
    xy: Array, params: SupportParams
) -> list[tuple[NDArray[np.intp], tuple[Array, float, float, float, int]]]:
    """Groups of the plan points ``xy`` (left over by the section's islands) that are a
    short tight arc of a ring: :func:`~pyheracles.supports.rings.ring_fit` passes over
    at least ``ARC_MIN_SECTORS`` sectors, within ``ARC_SPREAD_RMS_SHARE`` of the ring
    tolerance, and :func:`~pyheracles.supports.rings.ring_covered` does not (a ring it
    covers is an island already).  Returns ``(indices into xy, fit)`` per group."""
    if len(xy) < params.min_points:
        return []
    lab = gap_clusters(xy, ARC_GAP_M, params.min_points)
    out = []
    for g in range(1, int(lab.max(initial=0)) + 1):
        idx = np.flatnonzero(lab == g)
        if np.hypot(*np.ptp(xy[idx], axis=0)) < params.min_support_size_m:
            continue
        fit = ring_fit(xy[idx])
        if fit is None or fit[4] < ARC_MIN_SECTORS or ring_covered(fit):
            continue
        if fit[2] > ARC_SPREAD_RMS_SHARE * ring_tolerance(fit[1]):
            continue
        out.append((idx, fit))
    return out


def same_circle(q: Array, centre: Array, radius: float, dz: float, hp: HeightRingParams) -> bool:
    """Whether the points ``q`` (plan, one slab ``dz`` metres from the section) are the
    ring of the circle ``centre``, ``radius`` again: their own ring fit passes with a
    radius and centre close to it (``hp``)."""
    fit = ring_fit(q) if len(q) >= 5 else None
    if fit is None or fit[4] < ARC_MIN_SECTORS:
        return False
    c, r = fit[0], fit[1]
    if abs(r - radius) > hp.radius_share * radius:
        return False
    return bool(np.hypot(*(c - centre)) <= hp.centre_share * radius + hp.lean * abs(dz))


def rings_over_heights(
    p: Array,
    order: NDArray[np.intp],
    z_sorted: Array,
    h: float,
    left: NDArray[np.intp],
    params: SupportParams,
    hp: HeightRingParams | None = None,
) -> list[Island]:
    """Column islands from the short tight arcs among the section points ``left``
    (:func:`ring_candidates`) whose circle comes back, fitted on its own, in at least
    ``hp.confirmations`` of the slabs above and below the section (``hp``).

    Parameters
    ----------
    p
        ``(N, 3)`` levelled points, metres.
    order, z_sorted
        ``argsort`` of ``p[:, 2]`` and the sorted heights.
    h
        Height of the section, metres.
    left
        Indices into ``p`` of the section slab's left-over points (no island took
        them: noise islands and unclustered points).
    params
        Detection parameters (``min_points``, ``min_support_size_m``).
    hp
        Settings (defaults of :class:`HeightRingParams`).

    Returns
    -------
    list of Island
        One column island per confirmed arc (``index`` into ``p``).
    """
    hp = hp or HeightRingParams()
    cands = ring_candidates(p[left, :2], params)
    if not cands:
        return []
    reach = hp.slab_m * (hp.slabs_each_way + 0.5)
    a, b = np.searchsorted(z_sorted, [h - reach, h + reach])
    tall = order[a:b]
    txy, tz = p[tall, :2], p[tall, 2]
    others = hp.slab_m * np.r_[-hp.slabs_each_way : 0, 1 : hp.slabs_each_way + 1]
    out = []
    for idx, fit in cands:
        centre, radius, c_rms, line_rms, _ = fit
        box = np.max(np.abs(txy - centre), axis=1) <= radius + 2.0 * ring_tolerance(radius)
        bxy, bz = txy[box], tz[box]
        seen = sum(
            same_circle(bxy[np.abs(bz - (h + dz)) <= hp.slab_m / 2], centre, radius, dz, hp)
            for dz in others
        )
        if seen < hp.confirmations:
            continue
        sub = left[idx]
        ext = np.ptp(p[sub, :2], axis=0)
        nan = float("nan")
        out.append(Island("column", sub, centre, radius, 0.0, ext, nan, c_rms, line_rms))
    return out


def arc_columns(
    p: Array,
    order: NDArray[np.intp],
    z_sorted: Array,
    h: float,
    slab_idx: NDArray[np.intp],
    islands: list[Island],
    params: SupportParams,
) -> list[dict]:
    """Column section shapes (as :func:`~pyheracles.supports.detect.support_shapes`
    gives them, marked ``sparse``) of the confirmed arcs (:func:`rings_over_heights`)
    among the points of the slab ``slab_idx`` at height ``h`` that none of its
    ``islands`` took but the noise islands."""
    taken = np.zeros(len(slab_idx), dtype=bool)
    for isl in islands:
        if isl.kind != "noise":
            taken[isl.index] = True
    return [
        {
            "class": "column",
            "centre": isl.center,
            "radius": isl.radius,
            "half": np.array([isl.radius, isl.radius]),
            "angle": 0.0,
            "circularity": float("nan"),
            "sparse": True,
            "buffer": max(params.buffer_min_m, params.buffer_fraction * isl.radius),
        }
        for isl in rings_over_heights(p, order, z_sorted, h, slab_idx[~taken], params)
    ]
