"""Horizontal beams that tie a couple of rafters: members even when joined to nothing.

A couple is two inclined members rising from opposite sides of the roof to
meet at its top (principal or common rafters); its tie beam (or collar) lies
across between them, in their vertical plane.  A tie beam's ends are often
hidden (sunk in the wall heads, shadowed by a plate or a strut) and a tie seen
on one face only may be found in pieces, so the box of such a tie can be
joined to nothing and shorter than the frame is wide; it still lies in the
plane of the couple it ties, between the couple's feet, which timber lying on
the floor does only by chance (roof seed 5: a tie seen on its side face, a
3.6 m piece of a 9.4 m tie in the plane of the couple at its truss).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from pyheracles.beams.model import BeamCuboid

__all__ = ["ties_couple"]


def _plan_unit(v: NDArray[np.float64]) -> NDArray[np.float64] | None:
    """The horizontal direction of ``v`` as a unit vector (``None`` for a plumb one)."""
    h = np.array([v[0], v[1], 0.0])
    n = float(np.linalg.norm(h))
    return h / n if n > 1e-9 else None


def _section(b: BeamCuboid) -> float:
    return float(max(b.width, b.height))


def ties_couple(
    beams: list[BeamCuboid],
    i: int,
    others: NDArray[np.bool_],
    *,
    inclined_deg: float,
    vertical_deg: float,
    skew_deg: float,
) -> bool:
    """Whether beam ``i`` lies across the plane of a couple of inclined beams, between their feet.

    Parameters
    ----------
    beams
        Fitted cuboids.
    i
        The (horizontal) beam judged.
    others
        ``(B,)`` the beams that may make the couple (the frame's members).
    inclined_deg, vertical_deg
        A beam of the couple is inclined at least ``inclined_deg`` and less than
        ``vertical_deg``, degrees.
    skew_deg
        Largest angle in plan between beam ``i`` and each beam of the couple,
        degrees.

    Returns
    -------
    bool
        True when two such beams, each running in plan along beam ``i`` and
        with its plan line within one section (the larger of the two beams'
        largest section sides) of beam ``i``'s centre, have their lower ends
        on opposite sides of beam ``i``'s centre along its axis, each rising
        towards it, and beam ``i``'s centre is lower than both beams' upper
        ends: beam ``i`` ties (or is a collar of) that couple.
    """
    b = beams[i]
    u = _plan_unit(b.axis)
    if u is None:
        return False
    cos_skew = math.cos(math.radians(skew_deg))
    sides: set[int] = set()
    for k in np.flatnonzero(others):
        if k == i:
            continue
        r = beams[int(k)]
        if not inclined_deg <= r.inclination_deg < vertical_deg:
            continue
        v = _plan_unit(r.axis)
        if v is None or abs(float(v @ u)) < cos_skew:
            continue
        up = r.axis if r.axis[2] >= 0 else -r.axis
        foot = r.centre - 0.5 * r.length * up
        head = r.centre + 0.5 * r.length * up
        # the plan line of the rafter: how far beam i's centre lies from it
        d = b.centre - r.centre
        lateral = abs(float(d[0] * v[1] - d[1] * v[0]))
        if lateral > max(_section(b), _section(r)):
            continue
        if float(b.centre[2]) >= float(head[2]):
            continue
        side = float((foot - b.centre) @ u)
        rises_inward = float(up @ u) * side < 0  # from its foot towards beam i's centre
        if rises_inward:
            sides.add(1 if side > 0 else -1)
        if len(sides) == 2:
            return True
    return False
