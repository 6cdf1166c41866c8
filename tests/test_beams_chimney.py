"""Step 2b (issue 13): a chimney standing apart from the frame is no member.

Roof seed 5: a masonry stack 0.49 m square rises from the floor through the
roof; it comes out as a plumb box seen on four faces.  A stack of planks lies
against its foot and a loose timber against the planks: the three are joined
to one another and to nothing of the frame, a group of three, which counted
as part of the frame (``min_frame_members``).  A post carries what is joined
at its head; the stack carries nothing.  Once it is out, the planks and the
timber lie on the floor far below the frame's tie beams, and a tie beam high
above the floor (cut short, joined to a plate only) is not loose timber.
"""

from __future__ import annotations

import numpy as np

from pyheracles.beams.frame import FrameParams, frame_members, idle_standing, loose
from pyheracles.synthetic.families.roof_frame import member_between
from test_beams_ladder import cuboid_of, joint

X = np.array([1.0, 0.0, 0.0])
Y = np.array([0.0, 1.0, 0.0])
Z = np.array([0.0, 0.0, 1.0])


def _attic(chimney_top_joint: bool = False):
    """Seed 5's attic, simplified: a couple of rafters on a plate, ties 1.1 m up."""
    ms = [
        # 1-2 a couple of rafters from the plates (y = +-4.4) to the ridge
        member_between("r1", "rafter", [2.0, -4.4, 1.4], [2.0, 0.0, 7.4], 0.12, 0.18, X),
        member_between("r2", "rafter", [2.0, 4.4, 1.4], [2.0, 0.0, 7.4], 0.12, 0.18, X),
        # 3 a ridge joining them; 4 a plate under the feet of r2
        member_between("ridge", "ridge", [0.0, 0.0, 7.5], [8.0, 0.0, 7.5], 0.16, 0.2, Z),
        member_between("plate", "plate", [5.4, 4.4, 1.5], [7.4, 4.4, 1.5], 0.16, 0.14, Z),
        # 5 a tie beam 1.24 m up, cut short (6.5 of 8.8 m), joined to the plate only
        member_between("tie", "tie", [6.4, -2.1, 1.24], [6.4, 4.4, 1.24], 0.2, 0.2, Z),
        # 6 the chimney from below the floor through the roof; 7 planks at its foot;
        # 8 a timber against the planks
        member_between("chimney", "x", [3.8, 0.8, -0.9], [3.8, 0.8, 7.1], 0.49, 0.49, X),
        member_between("planks", "x", [2.5, -0.6, 0.15], [6.0, -0.6, 0.15], 0.59, 0.14, Z),
        member_between("timber", "x", [3.7, -2.0, 0.1], [3.7, 0.0, 0.1], 0.19, 0.19, Z),
    ]
    beams = [cuboid_of(m) for m in ms]
    joints = [
        joint(1, 2, 1.0, 1.0),  # apex
        joint(1, 3, 1.0, 0.25),
        joint(2, 3, 1.0, 0.25),
        joint(2, 4, 0.0, 0.0),  # the rafter's foot on the plate
        joint(4, 5, 0.5, 1.0),  # the tie's end at the plate
        joint(6, 7, 0.1, 0.4),  # the chimney's foot against the planks
        joint(7, 8, 0.35, 0.7),
    ]
    if chimney_top_joint:
        joints.append(joint(6, 8, 0.9, 0.5))
    return beams, joints


def test_a_chimney_and_the_timber_at_its_foot_are_no_members():
    beams, joints = _attic()
    _, in_frame = frame_members(beams, joints, FrameParams())
    assert in_frame.tolist() == [True, True, True, True, True, False, False, False]


def test_a_standing_beam_joined_at_its_head_carries_something():
    beams, joints = _attic(chimney_top_joint=True)
    apart = np.array([False] * 5 + [True] * 3)
    assert not idle_standing(beams, joints, apart, 1.1, FrameParams()).any()
    # ... and one of the main frame is never judged so
    beams, joints = _attic()
    assert not idle_standing(beams, joints, np.zeros(8, bool), 1.1, FrameParams()).any()


def test_a_tie_high_above_timber_left_on_the_floor_is_not_loose():
    beams, joints = _attic()
    in_frame = np.array([True] * 5 + [False] * 3)
    assert not loose(beams, joints, in_frame, FrameParams()).any()
    # timber on the floor beside a tie on the floor still is loose
    floor_tie = member_between("tie", "tie", [6.4, -4.4, 0.1], [6.4, 4.4, 0.1], 0.2, 0.2, Z)
    beams[4] = cuboid_of(floor_tie)
    beams[7] = cuboid_of(member_between("t", "x", [3.7, -2.0, 0.1], [3.7, 0.0, 0.1], 0.19, 0.19, Z))
    in_frame = np.array([True] * 5 + [False, False, True])
    assert loose(beams, joints, in_frame, FrameParams()).tolist() == [False] * 7 + [True]
