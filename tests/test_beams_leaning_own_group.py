"""Step 2b (issue 13): a ladder leans on the frame it is joined to, not on a pile apart.

Roof draw 2 (with the one-face depths of ``one_face.side_run``): a ladder's
rail (1.84 m, 5 x 8 cm, 69 degrees, its foot on the floor) touches two common
rafters and a plate 1.0 m up, all in its upper half.  Four pieces of timber
stored on the floor touch one another: a group of four, apart from the frame,
and counted in the frame's core until :func:`~pyheracles.beams.frame.loose`
drops them.  The frame's bottom that :func:`~pyheracles.beams.frame.leaning`
compared the ladder's foot with was taken over every core beam, the pile too:
0.26 m for the frame's 1.03 m, the foot (-0.01 m) was not 0.3 m below it and
the rail stayed a member.  The bottom is now the one of the beam's own group.
"""

from __future__ import annotations

import numpy as np

from member_points import oriented_cuboid
from pyheracles.beams import BeamCuboid
from pyheracles.beams.frame import FrameParams, frame_members, leaning
from pyheracles.beams.joints import Joint

# draw 2's cuboids as frame_members gets them: centre, axis, side, length, width, height
CUBOIDS = {
    "rafter_a": ([0.7, -1.285, 2.443], [0.0, -0.849, 0.529], [1.0, 0.0, 0.0], 3.38, 0.104, 0.187),
    "rafter_b": (
        [0.701, 1.28, 2.441],
        [-0.0, 0.848, 0.529],
        [1.0, -0.001, 0.001],
        3.382,
        0.104,
        0.19,
    ),
    "plate": ([0.822, -0.012, 1.174], [0.0, -1.0, -0.0], [-1.0, -0.0, -0.0], 10.502, 0.036, 0.296),
    "pile_1": ([2.09, 3.529, 0.237], [-0.8, -0.6, -0.0], [0.6, -0.8, 0.0], 3.022, 0.35, 0.07),
    "pile_2": (
        [3.219, 2.36, 0.229],
        [-0.076, 0.997, 0.005],
        [-0.987, -0.075, -0.144],
        3.491,
        0.045,
        0.13,
    ),
    "pile_3": (
        [3.446, 2.251, 0.289],
        [-0.04, 0.999, -0.0],
        [-0.999, -0.04, 0.001],
        3.222,
        0.38,
        0.054,
    ),
    "pile_4": (
        [3.266, 2.225, 0.148],
        [-0.074, 0.997, 0.014],
        [0.98, 0.075, -0.183],
        3.212,
        0.043,
        0.148,
    ),
    "ladder": (
        [1.054, 0.252, 0.841],
        [-0.36, -0.001, 0.933],
        [-0.037, -0.999, -0.015],
        1.835,
        0.054,
        0.075,
    ),
}
NAMES = list(CUBOIDS)
LADDER = NAMES.index("ladder")


def cuboid(centre, axis, side, length, width, height) -> BeamCuboid:
    return oriented_cuboid(centre, axis, side, length, width, height)


def joint(a: str, b: str, kind: str, at_a: float, at_b: float) -> Joint:
    i, j = NAMES.index(a) + 1, NAMES.index(b) + 1
    return Joint(members=(i, j), point=np.zeros(3), type=kind, distance_m=0.0, at=(at_a, at_b))


def draw_2(with_pile: bool = True) -> tuple[list[BeamCuboid], list[Joint]]:
    beams = [cuboid(*CUBOIDS[n]) for n in NAMES]
    joints = [
        joint("rafter_a", "plate", "X", 0.1, 0.85),  # the frame holds together
        joint("rafter_b", "plate", "X", 0.1, 0.15),
        joint("rafter_a", "ladder", "lap", 0.0, 0.93),  # the rail's top half only
        joint("rafter_b", "ladder", "T", 0.13, 1.0),
        joint("plate", "ladder", "X", 0.47, 0.71),
    ]
    if with_pile:  # the timber stored on the floor, touching one another
        joints += [
            joint("pile_1", "pile_2", "T", 0.12, 1.0),
            joint("pile_2", "pile_3", "lap", 0.0, 0.0),
            joint("pile_2", "pile_4", "T", 0.92, 1.0),
            joint("pile_3", "pile_4", "lap", 0.0, 0.0),
        ]
    return beams, joints


def test_the_ladder_rail_leans_with_a_pile_of_timber_on_the_floor():
    beams, joints = draw_2()
    out = leaning(beams, joints, np.ones(len(beams), bool), FrameParams())
    assert out.tolist() == [n == "ladder" for n in NAMES]


def test_the_ladder_rail_is_no_member_beside_the_pile():
    beams, joints = draw_2()
    _, member = frame_members(beams, joints, FrameParams())
    assert not member[LADDER]
    assert member[: NAMES.index("pile_1")].all()  # the rafters and the plate stay


def test_with_the_pile_out_of_the_core_the_ladder_rail_leans_as_before():
    beams, joints = draw_2(with_pile=False)
    frame = np.array([not n.startswith("pile") for n in NAMES])
    out = leaning(beams, joints, frame, FrameParams())
    assert out.tolist() == [n == "ladder" for n in NAMES]
