"""Step 2b (issue 13): the wall head a plate rests on is masonry, not a member.

Roof seed 17: each wall plate (19 x 12 cm) lies on the head of an eaves wall
70 cm thick, inset from the room.  The strip of the wall head between the
plate and the room, 50 cm wide, with the wall's face under it down to the
floor (6 cm), came out as a beam 8.4 m long on each side, joined to the
frame through the plate and the tie beams: two spurious members per draw
(seeds 8, 12, 17, 18, 25, 29 alike, ``spurious: wall`` in the sweep).
"""

from __future__ import annotations

import numpy as np

from pyheracles.beams.frame import FrameParams, bearing, frame_members
from pyheracles.beams.joints import find_joints
from pyheracles.beams.model import BeamCuboid

X, Y, Z = np.eye(3)


def _box(centre, axis, width, height, length) -> BeamCuboid:
    axis = np.asarray(axis, float)
    side = np.cross(Z, axis) if abs(axis[2]) < 0.9 else np.cross(axis, X)
    side /= np.linalg.norm(side)
    up = np.cross(axis, side)
    return BeamCuboid(
        centre=np.asarray(centre, float),
        axes=np.column_stack([axis, side, up]),
        length=length,
        width=width,
        height=height,
        rms=0.002,
        n_facets=2,
        faces_seen=2,
    )


def _plate_on_wall_head():
    plate = _box([4.18, -4.80, 0.111], X, 0.193, 0.125, 8.37)
    strip = _box([4.20, -4.466, 0.019], X, 0.497, 0.063, 8.43)  # top at 0.05: the plate's bed
    return plate, strip


def test_the_strip_of_wall_head_beside_a_plate_is_its_bearing():
    plate, strip = _plate_on_wall_head()
    assert bearing([plate, strip], FrameParams()).tolist() == [False, True]


def test_the_wall_head_strip_is_no_member_of_the_frame():
    plate, strip = _plate_on_wall_head()
    # two tie beams across the plate and the strip, a couple of rafters on the plate
    ties = [_box([x, 0.0, 0.03], Y, 0.21, 0.2, 9.4) for x in (1.0, 7.5)]
    rafters = [_box([x, -2.5, 2.2], np.array([0.0, 0.6, 0.8]), 0.1, 0.14, 5.5) for x in (1.0, 7.5)]
    beams = [plate, strip, *ties, *rafters]
    fp = FrameParams()
    _, member = frame_members(beams, find_joints(beams, fp.joints), fp)
    assert not member[1]
    assert member[0] and member[2:].all()


def test_timber_beside_a_plate_or_crossing_it_is_no_bearing():
    plate, _ = _plate_on_wall_head()
    # a timber lying beside the plate, its top above the plate's underside
    beside = _box([4.2, -4.55, 0.09], X, 0.15, 0.18, 4.0)
    # a tie beam under the plate, across it
    tie = _box([4.2, -2.0, -0.05], Y, 0.2, 0.2, 9.0)
    # a post under the plate: not laid along it
    post = _box([4.2, -4.8, -1.0], Z, 0.2, 0.2, 2.1)
    assert not bearing([plate, beside, tie, post], FrameParams()).any()
