"""Step 2b (issue 13): a ladder apart from the frame, standing on the floor, is no member.

Roof seed 15 (collar roof, tie beams 1.4 m above the floor): the ladder leaning on a
collar came out as two boxes, the whole ladder (0.42 m wide, its rails and rungs)
and one rail, joined to each other and to nothing else (its top touches nothing as
fitted).  A group of fewer than three beams joined to no member of the frame was kept
whenever it rose above the frame's bottom (a couple of rafters apart from the
frame), so both boxes were members: two spurious ``ladder`` beams in the sweep.  A
beam of such a group that is not plumb and whose foot lies more than
``FrameParams.leaning_below_m`` under the frame's bottom stands on the floor beside
the frame (:func:`pyheracles.beams.frame.leaning_apart`).
"""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.beams.frame import FrameParams, frame_members, leaning_apart
from pyheracles.beams.joints import find_joints
from pyheracles.beams.model import BeamCuboid
from test_beams_bearing import box_along

X, Y, Z = np.eye(3)


def _ladder_of_draw_15() -> list[BeamCuboid]:
    """The two boxes of draw 15's ladder as the step fitted them (axes as columns)."""
    whole = BeamCuboid(
        centre=np.array([2.50462, 0.30719, 1.70866]),
        axes=np.array(
            [
                [0.36631, 0.02261, 0.93022],
                [0.00114, -0.99971, 0.02385],
                [0.93049, -0.00768, -0.36623],
            ]
        ),
        length=3.7148,
        width=0.42089,
        height=0.08319,
        rms=0.01,
        n_facets=2,
        faces_seen=2,
    )
    rail = BeamCuboid(
        centre=np.array([2.51645, 0.5403, 1.73335]),
        axes=np.array(
            [
                [-0.36002, -0.03323, -0.93235],
                [-0.00377, -0.99931, 0.03707],
                [-0.93294, 0.01686, 0.35964],
            ]
        ),
        length=3.76268,
        width=0.0563,
        height=0.07344,
        rms=0.01,
        n_facets=2,
        faces_seen=2,
    )
    return [whole, rail]


def _between(foot, head, width: float, height: float) -> BeamCuboid:
    foot, head = np.asarray(foot, float), np.asarray(head, float)
    return box_along(
        0.5 * (foot + head), head - foot, width, height, float(np.linalg.norm(head - foot))
    )


def _collar_roof(tie_z: float = 1.42) -> list[BeamCuboid]:
    """Two collar trusses (x = 0.2 and 4.3 m): a tie beam, two rafters with their feet
    on its ends and their heads under the ridge, a collar between them."""
    out = []
    for x in (0.2, 4.3):
        out.append(box_along([x, 0.0, tie_z], Y, 0.21, 0.2, 6.8))  # tie, underside 0.1 lower
        for s in (-1.0, 1.0):
            out.append(_between([x, 3.2 * s, tie_z + 0.17], [x, 0.0, 5.9], 0.19, 0.26))
        out.append(box_along([x, 0.0, 4.79], Y, 0.17, 0.16, 1.9))  # collar
    out.append(box_along([2.25, 0.0, 6.05], X, 0.19, 0.26, 4.6))  # ridge on the rafters' heads
    return out


def test_a_ladder_apart_from_the_frame_is_no_member():
    frame = _collar_roof()
    beams = frame + _ladder_of_draw_15()
    fp = FrameParams()
    _, member = frame_members(beams, find_joints(beams, fp.joints), fp)
    assert member[: len(frame)].all()
    assert not member[len(frame) :].any()


def test_the_ladder_boxes_stand_below_the_frame_bottom_leaning():
    assert leaning_apart(_ladder_of_draw_15(), 1.32, FrameParams()).tolist() == [True, True]


@pytest.mark.parametrize("foot_below", [-0.1, 0.0, 0.1, 0.25])
def test_a_couple_of_rafters_apart_from_the_frame_stays(foot_below: float):
    """Two rafters joined to each other only (their heads meet under the ridge), their
    feet at the eaves (up to a quarter metre under the frame's bottom: an overhang),
    are members."""
    frame = _collar_roof()
    foot_z = 1.32 - foot_below  # the tie beams' underside is the frame's bottom
    pair = [_between([2.25, 3.2 * s, foot_z], [2.25, 0.0, 5.6], 0.14, 0.14) for s in (-1, 1)]
    beams = frame + pair
    fp = FrameParams()
    joints = find_joints(beams, fp.joints)
    ids = (len(frame) + 1, len(frame) + 2)
    assert [j.members for j in joints if set(j.members) & set(ids)] == [ids]
    _, member = frame_members(beams, joints, fp)
    assert member.all()


def test_a_plumb_prop_apart_is_left_to_idle_standing():
    """A plumb box is not judged here (a post: :func:`idle_standing`)."""
    post = box_along([2.0, 0.0, 0.5], Z, 0.15, 0.15, 1.2)
    assert not leaning_apart([post], 1.32, FrameParams()).any()


@pytest.mark.slow
@pytest.mark.parametrize("noise_draw", range(4))
def test_draw_15_has_no_ladder_member_in_any_noise_draw(noise_draw: int):
    """Roof draw 15 and three rescans of it: no found beam is the ladder."""
    from member_points import found_classes

    assert "ladder" not in found_classes(15, noise_draw)
