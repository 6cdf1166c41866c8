"""Step 2b (issue 13): two pieces of a member overlapping along its axis are one member.

Roof seed 18: the eaves plate (33 x 13 cm, 5 m) was seen on its room-side face only and
came out as two one-face pieces on that face, overlapping by 0.34 m along it, their depths
read from a few side points (0.128 and 0.085 m): sizes too far apart for one section, and
79 % of the smaller section inside the larger, short of the 80 % asked of pieces apart.
Two members cannot fill one stretch of space, so pieces overlapping along their axis need
only half the smaller section inside the larger (``cuboids.OVERLAP_INSIDE_SHARE``).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from pyheracles.beams.cuboids import collinear, join_pieces
from pyheracles.beams.model import BeamCuboid

COS_PAR = float(np.cos(np.radians(5.0)))


def _plate_pieces_of_draw_18() -> tuple[BeamCuboid, BeamCuboid]:
    """The two pieces as the step fitted them (axes as columns)."""
    a = BeamCuboid(
        centre=np.array([1.52279, 3.61159, 0.27481]),
        axes=np.array(
            [
                [-0.99995, -0.00131, -0.00988],
                [0.00119, -0.99993, 0.01158],
                [-0.00989, 0.01157, 0.99988],
            ]
        ),
        length=1.96883,
        width=0.12761,
        height=0.12758,
        rms=0.005,
        n_facets=1,
        faces_seen=1,
    )
    b = BeamCuboid(
        centre=np.array([3.31358, 3.59166, 0.26765]),
        axes=np.array(
            [[-0.99999, 0.00027, 0.00541], [-0.00029, -1.0, -0.00256], [0.00541, -0.00256, 0.99998]]
        ),
        length=2.2792,
        width=0.085,
        height=0.13014,
        rms=0.005,
        n_facets=1,
        faces_seen=1,
    )
    return a, b


def test_the_overlapping_plate_pieces_of_draw_18_are_one_member():
    a, b = _plate_pieces_of_draw_18()
    assert collinear(a, b, COS_PAR, 1.0, 3.0)
    joined, new_id = join_pieces([a, b], COS_PAR, 1.0, 3.0)
    assert len(joined) == 1 and new_id.tolist() == [0, 1, 1]
    assert joined[0].length > 3.9  # 0.54 to 4.45 m along the plate


def test_the_same_pieces_apart_stay_two():
    """Moved 0.5 m apart along the axis, the rule for pieces apart holds (80 %)."""
    a, b = _plate_pieces_of_draw_18()
    b = replace(
        b, centre=b.centre + 0.84 * (b.centre - a.centre) / np.linalg.norm(b.centre - a.centre)
    )
    assert not collinear(a, b, COS_PAR, 1.0, 3.0)


def test_parallel_members_side_by_side_overlapping_along_are_two():
    """A plate and a timber beside it (their sections apart) are no pieces of one member."""
    a, b = _plate_pieces_of_draw_18()
    beside = replace(b, centre=b.centre + 0.12 * b.axes[:, 1])  # 12 cm across: 30 % inside
    assert not collinear(a, beside, COS_PAR, 1.0, 3.0)
