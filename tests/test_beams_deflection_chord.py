"""Step 2b (issue 13): a member's deflection is its bow's sag over the member, not the part seen.

Roof sweep: the faces of a member are located by slices only where they hold
enough points; near its ends a crossing member, the boarding or the wall
hides them, and the first and last located slices stop short of the ends of
the member's cuboid.  The bow (a second-degree curve) was read well, but its
sag was given over the chord of the located slices: a common rafter of 9.1 m
located over 8.9 m showed 25.1 mm of its 28.8 mm (roof seed 4).  The sag over
the member's chord (its cuboid's ends) is ``c L^2 / 4`` with the same ``c``.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from member_points import surface_points
from pyheracles.beams import BeamCuboid
from pyheracles.beams.deflection import member_shape
from pyheracles.synthetic.families.roof_frame import member_between


def _bent_rafter(sag: float):
    up = np.array([0.0, -0.5, 1.0]) / np.linalg.norm([0.0, -0.5, 1.0])
    m = member_between("r", "rafter", [0, 0, 0.0], [0, 4.0, 2.0], 0.12, 0.16, up)
    return replace(m, deflection_m=sag)


@pytest.mark.parametrize("sag", [0.01, 0.025])
def test_the_sag_is_given_over_the_member_when_its_ends_are_too_sparse_to_locate(sag):
    rng = np.random.default_rng(4)
    m = _bent_rafter(sag)
    pts = surface_points(m, 40_000, 0.002, rng)
    t = (pts - m.centre) @ m.axis
    # the last 35 cm at each end are seen by a few points only (under the
    # boarding, in the wall): too few per slice to locate a face
    ends = np.abs(t) > 0.5 * m.length - 0.35
    keep = ~ends | (rng.random(len(pts)) < 0.01)
    pts = pts[keep]
    cub = BeamCuboid(
        m.centre, np.column_stack([m.axis, m.side, m.up]), m.length, m.width, m.height, 0.003, 2
    )
    sh = member_shape(pts, cub, np.abs(cub.signed_distance(pts)) < 0.03)
    assert sh.measured_length_m < m.length - 0.5  # the located slices stop short
    assert sh.chord_m == pytest.approx([-0.5 * m.length, 0.5 * m.length], abs=0.06)
    # over the located slices only: sag (1 - 0.7 / 4.47)^2 = 0.71 of it
    assert sh.deflection_m == pytest.approx(sag, abs=0.0015)
