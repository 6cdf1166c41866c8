"""Step 2b (issue 13): two pieces of a member past a shadow, each size read at an edge.

Roof draw 3 (``python benchmarks/bench_framework.py --sweep 1 --first-seed 3``):
a common rafter (member 54, 0.122 x 0.141 m) is seen on two faces in a 1.42 m
and a 1.68 m piece, 1.51 m apart past a shadow.  Their depths, each read at the
half-density edge of a face, came out 0.131 and 0.149 m: each within 1 cm of
the truth, 1.8 cm from each other, past the 10 % or 1 cm of
:func:`~pyheracles.beams.cuboids.same_section`, so the two stayed apart (a
spurious member and a rafter matched over 18 % of its length).  Two readings
each off by up to ``EDGE_SIZE_UNCERTAINTY_M`` may differ by twice that.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from member_points import oriented_cuboid
from pyheracles.beams.cuboids import EDGE_SIZE_UNCERTAINTY_M, join_pieces, same_section
from pyheracles.beams.model import BeamCuboid

COS_PAR = float(np.cos(np.radians(5.0)))


def _piece(centre, axis, across, length, width, height) -> BeamCuboid:
    return oriented_cuboid(centre, axis, across, length, width, height, faces_seen=2, rms=0.004)


NEAR = _piece([10.6513, 0.705, 4.1821], [-0.0002, -0.7977, 0.603], [-1.0, -0.0052, -0.0071],
              1.4161, 0.1204, 0.1306)  # fmt: skip
FAR = _piece([10.6516, 3.1522, 2.3415], [-0.0002, 0.7974, -0.6035], [0.9997, 0.0157, 0.0204],
             1.6822, 0.1211, 0.1488)  # fmt: skip


def test_draw3_rafter_pieces_have_one_section():
    assert abs(FAR.height - NEAR.height) > 0.1 * FAR.height  # past 10 % and 1 cm
    assert abs(FAR.height - NEAR.height) <= 2 * EDGE_SIZE_UNCERTAINTY_M
    assert same_section(NEAR, FAR)


def test_draw3_rafter_pieces_join_across_the_shadow():
    out, new_id = join_pieces([NEAR, FAR], COS_PAR, 1.0, 3.0)
    assert len(out) == 1
    assert list(new_id) == [0, 1, 1]
    assert out[0].length > NEAR.length + FAR.length + 1.4  # the 1.51 m gap spanned


def test_a_section_off_by_more_than_two_readings_is_another_member():
    deeper = replace(FAR, height=NEAR.height + 2 * EDGE_SIZE_UNCERTAINTY_M + 0.005)
    assert not same_section(NEAR, deeper)
    assert len(join_pieces([NEAR, deeper], COS_PAR, 1.0, 3.0)[0]) == 2
