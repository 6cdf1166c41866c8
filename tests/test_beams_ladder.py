"""Step 2b (issue 13): a ladder leaning on the frame is no member, whatever it touches.

Roof seed 16: a ladder (stiles and rungs: a box 5 x 7 cm, 3 m long) leans on
a rafter and passes a collar 0.7 m lower down; two joints, both in its upper
half, its foot on the floor half a metre below the frame's bottom.  The rule
asked for one joint only, and it stayed in the frame as a spurious member.
"""

from __future__ import annotations

import numpy as np

from pyheracles.beams import BeamCuboid
from pyheracles.beams.frame import FrameParams, leaning
from pyheracles.beams.joints import Joint
from pyheracles.synthetic.families.roof_frame import member_between

Z = np.array([0.0, 0.0, 1.0])


def cuboid_of(m) -> BeamCuboid:
    return BeamCuboid(
        centre=np.asarray(m.centre, float),
        axes=np.column_stack([m.axis, m.side, m.up]),
        length=m.length,
        width=m.width,
        height=m.height,
        rms=0.0,
        n_facets=2,
        faces_seen=2,
    )


def _frame_and_ladder():
    tie = member_between("tie", "tie", [0, -2.5, 0.9], [0, 2.5, 0.9], 0.2, 0.22, Z)
    post = member_between("post", "post", [0, 0, 1.0], [0, 0, 3.0], 0.16, 0.16,
                          np.array([1.0, 0, 0]))  # fmt: skip
    rafter = member_between("r", "rafter", [0, -2.5, 1.0], [0, 0, 3.0], 0.14, 0.18,
                            np.array([1.0, 0, 0]))  # fmt: skip
    # from the floor (z 0.2) up to the post's side, 0.7 m below its top past a rafter
    ladder = member_between("ladder", "x", [0.6, 1.2, 0.2], [0.12, 0.0, 2.4], 0.06, 0.05, Z)
    return [cuboid_of(m) for m in (tie, post, rafter, ladder)]


def joint(a: int, b: int, at_a: float, at_b: float) -> Joint:
    return Joint(members=(a, b), point=np.zeros(3), type="T", distance_m=0.0, at=(at_a, at_b))


def test_a_ladder_touching_two_members_at_its_upper_half_leans():
    beams = _frame_and_ladder()
    # the ladder's axis rises from its foot: its foot is at 0, its top at 1
    assert beams[3].axis[2] > 0
    joints = [
        joint(1, 2, 0.5, 0.0),  # post on the tie
        joint(1, 3, 0.0, 0.0),  # rafter's foot on the tie
        joint(2, 3, 1.0, 1.0),  # rafter at the post's head
        joint(2, 4, 0.7, 1.0),  # the ladder's top against the post
        joint(3, 4, 0.6, 0.75),  # ... and its side past the rafter
    ]
    out = leaning(beams, joints, np.ones(4, bool), FrameParams())
    assert out.tolist() == [False, False, False, True]


def test_a_strut_joined_at_its_foot_does_not_lean():
    beams = _frame_and_ladder()
    joints = [
        joint(1, 2, 0.5, 0.0),
        joint(1, 3, 0.0, 0.0),
        joint(2, 3, 1.0, 1.0),
        joint(2, 4, 0.7, 1.0),
        joint(1, 4, 0.6, 0.05),  # its foot on the tie: a strut, not a ladder
    ]
    out = leaning(beams, joints, np.ones(4, bool), FrameParams())
    assert not out[3]
