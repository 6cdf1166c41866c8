"""Step 2b (issue 13): a wall head strip seen at a grazing angle is still the plate's bearing.

Roof seed 11: the strip of the eaves wall's head between the plate and the room was
seen at a grazing angle over a part of its width that shifts along it (near the
station from the room's face, 3 m on only next to the plate), so its band came out
6.4 degrees off the plate in plan (0.24 m wide, 3.6 m long, its top 2 mm from the
plate's underside).  :func:`pyheracles.beams.frame.bearing` took only boxes within
``roles.horizontal_deg`` (5 degrees) of the plate for its bearing, so the strip
stayed a member: one spurious ``wall`` beam, the draw's only fault.  Horizontal
members laid along one another are parallel and crossing ones square, so a bearing
may be ``FrameParams.bearing_skew_deg`` (10 degrees) off the beam on it.
"""

from __future__ import annotations

import numpy as np
import pytest

from member_points import found_classes
from pyheracles.beams.frame import FrameParams, bearing
from pyheracles.beams.model import BeamCuboid


def _plate_and_strip_of_draw_11() -> tuple[BeamCuboid, BeamCuboid]:
    """The plate and the wall head strip as the step fitted them (both seen on one face)."""
    plate = BeamCuboid(
        centre=np.array([2.17737, -4.8018, 1.1634]),
        axes=np.array(
            [[1.0, 0.00073, -0.00045], [0.00073, -1.0, 0.00029], [-0.00045, -0.00029, -1.0]]
        ),
        length=4.24656,
        width=0.1506,
        height=0.11221,
        rms=0.003,
        n_facets=2,
        faces_seen=1,
    )
    strip = BeamCuboid(
        centre=np.array([2.52201, -4.53081, 1.09219]),
        axes=np.array(
            [
                [0.99381, -0.11108, -0.00003],
                [-0.11108, -0.99381, 0.00032],
                [-0.00007, -0.00031, -1.0],
            ]
        ),
        length=3.58679,
        width=0.23678,
        height=0.03309,
        rms=0.003,
        n_facets=1,
        faces_seen=1,
        height_measured=False,
    )
    return plate, strip


def _turned(b: BeamCuboid, deg: float) -> BeamCuboid:
    """``b`` turned about the vertical through its centre."""
    a = np.radians(deg)
    rot = np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0.0, 0.0, 1.0]])
    return BeamCuboid(
        centre=b.centre, axes=rot @ b.axes, length=b.length, width=b.width, height=b.height,
        rms=b.rms, n_facets=b.n_facets, faces_seen=b.faces_seen,
        height_measured=b.height_measured,
    )  # fmt: skip


def test_the_skewed_wall_head_strip_of_draw_11_is_the_plates_bearing():
    plate, strip = _plate_and_strip_of_draw_11()
    assert bearing([plate, strip], FrameParams()).tolist() == [False, True]


def test_the_strip_turned_either_way_within_the_skew_is_a_bearing():
    plate, strip = _plate_and_strip_of_draw_11()
    for deg in (-3.0, 0.0, 3.0, 6.4, 12.0):  # 9.4 degrees off one way to 5.6 the other
        assert bearing([plate, _turned(strip, deg)], FrameParams()).tolist() == [False, True]


def test_a_timber_crossing_under_the_plate_is_no_bearing():
    """Square to the plate (a tie beam's end under it) or far off: not laid along it."""
    plate, strip = _plate_and_strip_of_draw_11()
    for deg in (30.0, 90.0):
        assert not bearing([plate, _turned(strip, deg)], FrameParams()).any()


@pytest.mark.slow
@pytest.mark.parametrize("noise_draw", range(4))
def test_draw_11_has_no_wall_member_in_any_noise_draw(noise_draw: int):
    """Roof draw 11 and three rescans of it: no found beam is a strip of wall."""
    assert "wall" not in found_classes(11, noise_draw)
