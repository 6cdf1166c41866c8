"""Two walls meeting at a pier candidate: a corner piece of a wall, not a pier.

A wall face flush with a face of a pier candidate is that face continued: it runs
parallel to it, within the surface tolerance over the whole length of the side.  A
curved surface near the candidate (the echinus of a column in antis beside an anta) is
read by the line search as a line tilted across the candidate's side, flush with it at
one corner only; two such "walls" at 45 degrees or more apart made an anta a corner.
"""

from __future__ import annotations

import numpy as np

from pyheracles.supports.core import Array
from pyheracles.supports.piers import WallLine, walled_piece


def along_side(lines: list[WallLine], axis: Array, half: Array, tol: float) -> list[WallLine]:
    """The flush wall faces (:data:`~pyheracles.supports.piers.WallLine`) that run
    parallel to a side of a pier candidate: across the side they run with, they stray
    less than ``tol`` from it over its whole length.

    Parameters
    ----------
    lines
        Flush wall faces of one or more height bands
        (:func:`~pyheracles.supports.piers.flush_wall_ends`).
    axis
        Unit direction of the candidate's first side (its section rectangle's angle).
    half
        Half sizes of the candidate along ``axis`` and across it, metres.
    tol
        Surface tolerance, metres.

    Returns
    -------
    list of WallLine
        The lines kept, in order.
    """
    ax = np.asarray(axis, dtype=np.float64)
    sides = (ax, np.array([-ax[1], ax[0]]))
    out = []
    for line in lines:
        d = np.asarray(line[0], dtype=np.float64)
        k = 0 if abs(float(d @ sides[0])) >= abs(float(d @ sides[1])) else 1
        stray = abs(float(d @ sides[1 - k])) * 2.0 * float(half[k])
        if stray <= tol:
            out.append(line)
    return out


def shown_corner(lines: list[WallLine], axis: Array, half: Array, tol: float) -> bool:
    """Whether two flush wall faces on faces a pier candidate shows, parallel to its
    sides (:func:`along_side`) and at least 45 degrees apart, run on beyond one of its
    ends each (:func:`~pyheracles.supports.piers.walled_piece` of those lines: two walls
    meeting at it, a corner)."""
    shown = [line for line in lines if line[2]]
    return walled_piece(along_side(shown, axis, half, tol))
