"""The floor the supports stand on, for the low section of broken columns.

The low section (supports that end below the automatic one: broken columns, the
stumps of a ruin) lies a fixed height above the floor.  The cloud's lowest dense level
is the ground outside when the building stands on a platform (supports draw 24: the
ground at 0.0 m, the platform 0.8 m higher): measured from there the low section cut
the columns 0.35 m above their own floor, where the platform's edge shadows their feet
from stations on the ground, and broken columns of 1.5-2.1 m ended below the main
section.  The supports' own floor is read under the supports found in the main
section: the bottom of the dense levels of the points round each of them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from pyheracles.supports.core import Array
from pyheracles.supports.height import dense_extent


@dataclass(frozen=True)
class SupportsFloorParams:
    """How the floor under the supports of the main section is read.

    Attributes
    ----------
    margin_m
        Points within a shape's reach plus this (metres) show its foot and the floor
        round it.
    max_points
        At most this many points below the section are looked at (an even subsample:
        only the levels' densities matter).
    min_points
        A shape with fewer points round it (of the subsample) gives no floor.
    quantile
        The supports' floor is this quantile of the shapes' floors: a foot shadowed
        by a platform's edge or by clutter ends above its floor, seldom below it.
    """

    margin_m: float = 0.3
    max_points: int = 400_000
    min_points: int = 30
    quantile: float = 0.25


SUPPORTS_FLOOR = SupportsFloorParams()


def shape_floors(
    xyz: Array,
    below: NDArray[np.intp],
    centres: Array,
    reaches: Array,
    params: SupportsFloorParams = SUPPORTS_FLOOR,
) -> Array:
    """Floor under each shape (metres, NaN where too few points): the bottom of the
    dense levels (:func:`~pyheracles.supports.height.dense_extent`) of the points
    ``xyz[below]`` within its reach plus ``margin_m`` of its centre.

    Parameters
    ----------
    xyz
        ``(N, 3)`` coordinates, metres.
    below
        Indices of the points below the section (a subsample is fine).
    centres, reaches
        ``(K, 2)`` plan centres and ``(K,)`` reaches of the shapes, metres.
    params
        See :class:`SupportsFloorParams`.
    """
    out = np.full(len(centres), np.nan)
    if len(centres) == 0 or len(below) == 0:
        return out
    xy = xyz[below, :2]
    dist, k = cKDTree(centres).query(
        xy, distance_upper_bound=float(reaches.max()) + params.margin_m
    )
    hit = np.flatnonzero(np.isfinite(dist))
    hit = hit[dist[hit] <= reaches[k[hit]] + params.margin_m]
    z = xyz[below[hit], 2]
    kk = k[hit]
    srt = np.lexsort((z, kk))
    z, kk = z[srt], kk[srt]
    bounds = np.searchsorted(kk, np.arange(len(centres) + 1))
    for j in range(len(centres)):
        zj = z[bounds[j] : bounds[j + 1]]
        if len(zj) >= params.min_points:
            out[j] = dense_extent(zj)[0]
    return out


def supports_floor(
    xyz: Array,
    order: NDArray[np.intp],
    z_sorted: Array,
    shapes: list[dict],
    reaches: Array,
    z0: float,
    h_sec: float,
    params: SupportsFloorParams = SUPPORTS_FLOOR,
) -> float:
    """The floor the supports of the main section stand on (metres): the ``quantile``
    of their :func:`shape_floors`, no lower than the cloud's floor ``z0`` and below
    the section ``h_sec``; ``z0`` when no shape gives one.

    ``order``, ``z_sorted``: argsort of the heights and the sorted heights; ``shapes``
    (with ``centre``) and their ``reaches`` (metres).
    """
    if not shapes:
        return z0
    b = int(np.searchsorted(z_sorted, h_sec))
    step = max(1, b // params.max_points)
    below = order[:b:step]
    centres = np.array([np.asarray(sh["centre"], dtype=np.float64) for sh in shapes])
    floors = shape_floors(xyz, below, centres, np.asarray(reaches, dtype=np.float64), params)
    floors = floors[np.isfinite(floors)]
    if len(floors) == 0:
        return z0
    return float(min(max(z0, np.quantile(floors, params.quantile)), h_sec))


def low_heights(
    z0: float, z_sup: float, h_sec: float, above_m: float, persistence_m: float
) -> list[float]:
    """Heights of the low sections (metres): ``above_m`` over the cloud's floor ``z0``,
    and ``above_m`` over the supports' floor ``z_sup`` (:func:`supports_floor`) when
    that one lies at least ``persistence_m`` higher (a platform); each at least
    ``persistence_m`` under the main section ``h_sec`` (the second one is lowered to
    that when needed).  None when the main section is that low itself."""
    out = []
    h0 = z0 + above_m
    if h_sec - h0 >= persistence_m:
        out.append(h0)
    h1 = min(z_sup + above_m, h_sec - persistence_m)
    if h1 - h0 >= persistence_m:
        out.append(h1)
    return out
