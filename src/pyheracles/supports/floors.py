"""The floor a support stands on: the level its own outline ends at, not the lowest
ground round it."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pyheracles.supports.core import Array


@dataclass(frozen=True)
class FootFloorParams:
    """How the floor under a support's foot is read from its cookie's ring.

    Attributes
    ----------
    min_cells
        A level is the top of at least this many plan cells of the ring.
    min_cell_share
        ... and of at least this share of the ring's occupied plan cells.
    """

    min_cells: int = 8
    min_cell_share: float = 0.02


FOOT_FLOOR = FootFloorParams()


def ring_levels(
    xy: Array, z: Array, cell: float, params: FootFloorParams = FOOT_FLOOR
) -> list[float]:
    """Horizontal levels of a cookie's ring below its section, highest first (metres).

    ``xy``, ``z``: the ring's points below the section.  Each plan cell of ``cell``
    metres has a top (its highest point): a floor's, a dais's or a seat's cells have
    their top at that surface, a face running down from one (a dais's side) has its
    top at the surface's edge.  A level is a height bin of ``cell`` holding the tops
    of at least ``min_cells`` cells and ``min_cell_share`` of the cells; its height is
    the median of those cells' median heights within ``cell`` of their tops.
    """
    if len(z) == 0:
        return []
    ij = np.floor((xy - xy.min(axis=0)) / cell).astype(np.int64)
    key = ij[:, 0] * (int(ij[:, 1].max()) + 1) + ij[:, 1]
    cells, inv = np.unique(key, return_inverse=True)
    inv = inv.ravel()
    top = np.full(len(cells), -np.inf)
    np.maximum.at(top, inv, z)
    near = z >= top[inv] - cell  # each cell's points near its top
    tb = np.floor((top - top.min()) / cell).astype(np.int64)
    counts = np.bincount(tb)
    need = max(params.min_cells, params.min_cell_share * len(cells))
    levels = []
    for b in np.flatnonzero(counts >= need)[::-1]:
        voting = np.flatnonzero(tb == b)
        sel = near & np.isin(inv, voting)
        sums = np.bincount(inv[sel], weights=z[sel], minlength=len(cells))
        n = np.bincount(inv[sel], minlength=len(cells))
        levels.append(float(np.median(sums[voting] / np.maximum(n[voting], 1))))
    return levels


def foot_floor(
    ring_xy: Array,
    ring_z: Array,
    foot: float,
    low_floor: float,
    cell: float,
    gap: float,
    params: FootFloorParams = FOOT_FLOOR,
) -> float:
    """The floor under a support's foot (metres): the highest horizontal level of its
    cookie's ring below the section (:func:`ring_levels` of ``ring_xy``, ``ring_z``)
    that lies no higher than ``gap`` above the support's own foot ``foot`` (the lowest
    of its points connected to its section) and more than ``cell`` above ``low_floor``
    (a low quantile of the ring, returned when there is no such level).

    A support standing at the edge of a dais has the ground beyond the edge in its
    ring, metres below its foot; a face of the dais flush with its plinth then runs from
    the plinth down to that ground and was joined to the plinth as a piece of it cut off
    by a face the scanners did not see (supports draw 1: 21,000 points, the 0.96 m of a
    kiosk's dais under a column's plinth).  A bench seat or a fence rail in the ring is
    a level too, but above the foot of the shaft standing beside it; the top of the
    support's own plinth lies inside its cookie's buffer, not in the ring.
    """
    for level in ring_levels(ring_xy, ring_z, cell, params):
        if level <= low_floor + cell:
            break
        if level <= foot + gap:
            return level
    return low_floor
