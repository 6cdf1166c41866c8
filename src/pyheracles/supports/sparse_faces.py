"""Wall faces scanned sparsely: whether a face runs on beyond a pier candidate's end
when its scan lines are further apart than the layers and bins the dense test reads."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from pyheracles.supports.core import Array

#: A wall face runs on where its points leave no gap wider than this along it or up it
#: (metres): wider than the scan-line gaps of a face scanned from afar (10-20 cm),
#: narrower than any opening, breach or gap between piers (0.5 m and more).
SPARSE_GAP_M = 0.25
#: A face is scanned sparsely when the cells (a layer by a bin) its points fill hold at
#: most this many points each, median: its scan lines are further apart than a cell.
#: A dense face holds many per cell (9 at 1.6 cm spacing in 5 cm cells) and is judged
#: by its cells alone: a hole in it is a shadow or an opening, not a gap between scan
#: lines (supports draw 30: the architrave over an anta, shadowed next to its end by
#: the anta's capital, ran on beyond both its ends when read from its gaps).
SPARSE_CELL_POINTS = 2


def runs_on_sparse(
    dist: Array,
    layer: NDArray[np.int64],
    n_layers: int,
    cell: float,
    cover_m: float,
    start_m: float,
    gap_m: float = SPARSE_GAP_M,
) -> bool:
    """Whether the points of a flush face line beyond one end of a pier candidate cover
    ``cover_m`` of the line over the band's height, with no gap wider than ``gap_m``.

    The dense test reads the face in bins and layers of ``cell`` (5 cm): a face whose
    scan lines are 10-20 cm apart fills a few of them, and the wall beyond a jamb's end
    did not "run on" (supports draw 34: a ruined wall's piece between the dips of its
    top, walled beyond both ends below them, in no band).  Here the run is read from
    the gaps between its points instead.

    Parameters
    ----------
    dist, layer
        Distance of the points beyond the end along the line (metres, > 0) and their
        height layer (of ``cell``) in the band.
    n_layers
        Height layers in the band.
    cell
        Layer height, metres.
    cover_m
        Length of line the face must cover, metres.
    start_m
        Where the run must start (within ``gap_m``): the end of the points left out as
        the candidate's own (the wall is one with the candidate at its end).
    gap_m
        Widest gap between points along the line or up it, metres.

    Returns
    -------
    bool
        Whether the face is scanned sparsely (:data:`SPARSE_CELL_POINTS`) and a run of
        its points covering ``cover_m`` with no wider gap exists (from
        ``start_m``), whose height layers leave no gap wider than ``gap_m`` from the
        band's foot to its top.
    """
    if len(dist) < 3:
        return False
    _, per_cell = np.unique(
        np.c_[layer, np.floor(dist / cell).astype(np.int64)], axis=0, return_counts=True
    )
    if np.median(per_cell) > SPARSE_CELL_POINTS:
        return False  # a dense face: its cells said whether it runs on
    order = np.argsort(dist)
    a, lay = dist[order], layer[order]
    keep = a <= start_m + cover_m
    a, lay = a[keep], lay[keep]
    if not len(a) or a[0] - start_m > gap_m or start_m + cover_m - a[-1] > gap_m:
        return False
    if np.any(np.diff(a) > gap_m):
        return False
    edges = np.r_[-1, np.unique(lay), n_layers]
    return bool(np.all(np.diff(edges) <= gap_m / cell))
