"""Piers that stand proud of a wall: the step between a pier's face and the wall's.

An anta (the end of a wall thickened into a pier) or a respond (a pier built against a
wall face) is joined to its wall, yet its faces stand out of the wall's faces by a
step of a few centimetres or more: in the section, the pier's side and the wall's
face beyond it lie on two parallel lines.  A piece of a wall (between two openings, a
door reveal) has its faces flush with the wall's.  The functions here tell a side's
own line from a wall face stepped back from it.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from pyheracles.supports.core import Array

#: A face or a side lies on its line within this (metres) or three times its RMS: the
#: alignment of a wall piece's face with the wall's (draw 8 of the supports family: an
#: anta's side stands 10 cm out of its wall's face; a reveal's side runs on in line).
LINE_TOL_M = 0.03


def line_tolerance(rms: float) -> float:
    """Half-width of a face's line, metres: ``LINE_TOL_M`` or three times its RMS."""
    return max(LINE_TOL_M, 3.0 * rms)


def side_on_line(
    t: Array, candidates: NDArray[np.bool_], end: float, off: float
) -> tuple[NDArray[np.bool_], float]:
    """The points of a side that runs back from a face's end, on their own line.

    Parameters
    ----------
    t
        Coordinates of section points along the face, metres.
    candidates
        The points that may be the side's (near the face's end, on the side of the face
        the side runs back to).
    end
        The face's end along it, metres.
    off
        Half-width of the side's line (:func:`line_tolerance`), metres.

    Returns
    -------
    mask, position
        The candidates within ``off`` of the line through the candidate closest to the
        face's end (a wall face stepped back from the side, farther than ``off``, is no
        part of it), and that line's position along the face (the median of its points).
        An empty mask and ``end`` when there is no candidate.
    """
    idx = np.flatnonzero(candidates)
    if len(idx) == 0:
        return np.zeros(len(t), dtype=bool), float(end)
    x0 = float(t[idx[np.argmin(np.abs(t[idx] - end))]])
    mask = candidates & (np.abs(t - x0) <= off)
    return mask, float(np.median(t[mask]))


#: The back of a pier outline lies on a wall face when that face runs on past one of
#: the outline's ends over at least this length (metres), within ``BACK_REACH_M``.
BACK_COVER_M = 0.3
BACK_REACH_M = 1.0
BACK_BIN_M = 0.1


def back_on_wall_face(xy: Array, back: Array, u: Array, ext: Array, off: float, tol: float) -> bool:
    """Whether the back of a pier outline (the line through ``back`` along ``u``,
    parallel to the face it was seen from, whose ends are at ``ext`` along it) lies on a
    wall face that runs on past one of its ends.

    Draw 30 of the supports family: in the inner corner of two walls, a short piece of
    the rear wall's inner face (occluded beyond 1.85 m) and two points of its outer face,
    0.7 m behind, at the piece's two ends made the "face and sides" of a pier.  Those
    points were no sides: the outer face they lie on runs on past the outline.  The back
    of a pier seen from its front holds no points, or its own side's corner; that of an
    anta is crossed by the faces of its wall, not run along.

    Parameters
    ----------
    xy
        Section points, metres.
    back, u
        A point on the back line and its unit direction.
    ext
        The outline's extent along ``u`` from ``back``, metres.
    off
        Half-width of the line (:func:`line_tolerance`), metres.
    tol
        Gap allowed past an end before the run is counted, metres.

    Returns
    -------
    bool
        Points within ``off`` of the line, from ``tol`` to ``BACK_REACH_M`` beyond an
        end, span ``BACK_COVER_M`` of it and fall in three bins of ``BACK_BIN_M`` (a
        face crossed by scan lines 10-15 cm apart; a post or a chair leg is one bin).
    """
    q = xy - back
    t, s = q @ u, q @ np.array([-u[1], u[0]])
    on = np.abs(s) <= off
    for dist in (t - ext[1], ext[0] - t):
        d = dist[on & (dist > tol) & (dist <= BACK_REACH_M)]
        if len(np.unique(np.floor(d / BACK_BIN_M))) >= 3 and np.ptp(d) >= BACK_COVER_M:
            return True
    return False
