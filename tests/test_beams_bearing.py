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


def box_along(centre, axis, width, height, length) -> BeamCuboid:
    """A cuboid seen on two faces, ``axis`` along its length (any scale), upright."""
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
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
    plate = box_along([4.18, -4.80, 0.111], X, 0.193, 0.125, 8.37)
    strip = box_along([4.20, -4.466, 0.019], X, 0.497, 0.063, 8.43)  # top at 0.05: the plate's bed
    return plate, strip


def test_the_strip_of_wall_head_beside_a_plate_is_its_bearing():
    plate, strip = _plate_on_wall_head()
    assert bearing([plate, strip], FrameParams()).tolist() == [False, True]


def test_the_wall_head_strip_is_no_member_of_the_frame():
    plate, strip = _plate_on_wall_head()
    # two tie beams across the plate and the strip, a couple of rafters on the plate
    ties = [box_along([x, 0.0, 0.03], Y, 0.21, 0.2, 9.4) for x in (1.0, 7.5)]
    rafters = [
        box_along([x, -2.5, 2.2], np.array([0.0, 0.6, 0.8]), 0.1, 0.14, 5.5) for x in (1.0, 7.5)
    ]
    beams = [plate, strip, *ties, *rafters]
    fp = FrameParams()
    _, member = frame_members(beams, find_joints(beams, fp.joints), fp)
    assert not member[1]
    assert member[0] and member[2:].all()


def test_timber_beside_a_plate_or_crossing_it_is_no_bearing():
    plate, _ = _plate_on_wall_head()
    # a timber lying beside the plate, its top above the plate's underside
    beside = box_along([4.2, -4.55, 0.09], X, 0.15, 0.18, 4.0)
    # a tie beam under the plate, across it
    tie = box_along([4.2, -2.0, -0.05], Y, 0.2, 0.2, 9.0)
    # a post under the plate: not laid along it
    post = box_along([4.2, -4.8, -1.0], Z, 0.2, 0.2, 2.1)
    assert not bearing([plate, beside, tie, post], FrameParams()).any()


def _found(centre, axes, length, width, height, measured=True) -> BeamCuboid:
    """A box as the step found it, seen on one face."""
    return BeamCuboid(
        centre=np.asarray(centre, float),
        axes=np.asarray(axes, float),
        length=length,
        width=width,
        height=height,
        rms=0.002,
        n_facets=1,
        faces_seen=1,
        height_measured=measured,
    )


def test_a_strip_seen_at_a_grazing_angle_is_a_bearing_though_short_of_the_plate():
    """Roof seed 11: the wall head's strip (32 cm between the room and the plate) was
    read 19.5 cm wide at half density (its far part, seen at 5 degrees, is sparse),
    and the plate, seen on one face, 15 cm wide (31 cm): the boxes lie 16 cm apart."""
    strip = _found(
        [2.54, -4.4917, 1.0923],
        [[0.9982, -0.0595, 0.0], [-0.0595, -0.9982, 0.0011], [0.0, -0.0011, -1.0]],
        3.611,
        0.195,
        0.033,
        measured=False,
    )
    plate = _found(
        [2.1773, -4.8025, 1.1628],
        [[1.0, 0.0002, -0.0007], [0.0002, -1.0, 0.0011], [-0.0007, -0.0011, -1.0]],
        4.248,
        0.152,
        0.109,
    )
    assert bearing([strip, plate], FrameParams()).tolist() == [True, False]


def test_levels_are_the_sections_not_the_corners_of_tilted_boxes():
    """Roof seed 18: the strip of a wall head at the floor (tie beams sunk 14 cm) and
    its plate, 3.9 m long and tilted by 0.65 degrees: the plate's box reaches 2.2 cm
    below its underside at one end, so the boxes' corners were 4.3 cm apart in height
    where the sections meet within a millimetre."""
    strip = _found(
        [2.4985, 3.3446, 0.0929],
        [[-1.0, 0.0001, -0.0081], [0.0001, 1.0, -0.0023], [0.0081, -0.0023, -1.0]],
        4.993,
        0.443,
        0.205,
    )
    plate = _found(
        [2.5234, 3.67, 0.2655],
        [[-0.9999, -0.0003, -0.0114], [-0.0002, 1.0, -0.0027], [0.0114, -0.0027, -0.9999]],
        3.86,
        0.243,
        0.14,
    )
    assert bearing([strip, plate], FrameParams()).tolist() == [True, False]


def test_level_timber_farther_than_a_wall_head_is_no_bearing():
    plate, strip = _plate_on_wall_head()
    # the same strip 1.5 m into the room from the plate: the plate does not rest on it
    far = box_along(strip.centre + [0.0, 1.5, 0.0], X, 0.2, 0.063, 8.43)
    # timber on the wall head 30 cm from the plate, its top above the plate's underside
    beside = box_along([4.2, -4.3, 0.12], X, 0.15, 0.14, 4.0)
    assert not bearing([plate, far, beside], FrameParams()).any()
