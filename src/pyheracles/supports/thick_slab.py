"""The thick section: a slab ``THICK_SECTION_M`` thick about a section height.

The supports too sparse for the thin section (a few hundred points on a column far from
every station, a pier with a handful of points in the thin slab) are searched again in
a thicker slab about the same height (:func:`pyheracles.supports.detect.detect_supports_checked`,
steps 2c and 2e).  Its islands draw no random numbers, so they may be computed anywhere
(a forked child computes them while the parent searches the thin sections:
:class:`pyheracles.forks.ForkedCall`) with the same result.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from pyheracles.supports.core import Array, Island, SupportParams
from pyheracles.supports.sections import section_islands

__all__ = ["THICK_SECTION_M", "shape_reach", "slab_indices", "thick_islands", "thick_pier"]

#: Thickness of the section that finds the supports too sparse for the thin one, metres
#: (a column leaning 6 degrees moves 3 cm over it; its outline stays one ring).
THICK_SECTION_M = 0.3


def slab_indices(
    order: NDArray[np.intp], z_sorted: Array, h: float, thickness: float
) -> NDArray[np.intp]:
    """Indices of the points within ``thickness / 2`` of the height ``h`` (``order``
    sorts the cloud by z, ``z_sorted`` its heights in that order)."""
    s, e = np.searchsorted(z_sorted, [h - thickness / 2, h + thickness / 2])
    return order[s:e]


def thick_islands(
    p: Array,
    order: NDArray[np.intp],
    z_sorted: Array,
    heights: list[float],
    params: SupportParams,
    distance_m: float,
) -> list[list[Island]]:
    """Islands (:func:`~pyheracles.supports.sections.section_islands`) of the thick
    slab about each of ``heights``, in the slab's order of :func:`slab_indices`."""
    return [
        section_islands(p[slab_indices(order, z_sorted, h, THICK_SECTION_M), :2], params,
                        distance_m)
        for h in heights
    ]  # fmt: skip


def shape_reach(sh: dict) -> float:
    """How far a section shape reaches from its centre: a column's radius, a pier's
    half diagonal (metres)."""
    if sh["class"] == "pier":
        return float(np.hypot(*sh["half"]))
    return float(sh["radius"])


def thick_pier(sh: dict, params: SupportParams, thin_xy: Array) -> bool:
    """Whether a pier shape of the thick section may be a support: at least
    ``min_support_size_m`` across both ways (the thick slab holds window frames,
    mullions and slivers of wall faces seen through openings), and too sparse for the
    thin section ``thin_xy`` (fewer than ``2 x min_points`` of its points within the
    shape's reach): where the thin slab holds the place densely, its islands said what
    stands there (draw 19: a part of a 2 x 1 m pier split off as a second one)."""
    if sh["class"] != "pier" or 2.0 * float(np.min(sh["half"])) < params.min_support_size_m:
        return False
    near = np.max(np.abs(thin_xy - sh["centre"]), axis=1) <= shape_reach(sh)
    return int(np.count_nonzero(near)) < 2 * params.min_points
