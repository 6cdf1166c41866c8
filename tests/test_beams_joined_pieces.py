"""Step 2b (issue 13): a piece of a member seen on one face joins the member's box.

Roof seed 4: a common rafter's box (two faces, 9.27 m) and a 1.8 m piece of
the same rafter seen on its side alone, lying along it; the piece's axis is
0.8 degrees off, so measured in the piece's own frame the rafter's centre,
3.4 m along, lies 4.4 cm aside (more than 30 % of the 11.8 cm width) and
the two stayed two beams.  In the rafter's frame the piece is 7 mm aside.

Roof seed 29: a common rafter cut by a 1.6 m shadow; the piece beyond it is
seen on one face with its depth measured, its section within 5 mm of the
other piece's, yet :func:`same_section` asked for two located sections.
"""

from __future__ import annotations

import numpy as np

from pyheracles.beams import BeamCuboid
from pyheracles.beams.cuboids import collinear, join_pieces, same_section

COS_PAR = float(np.cos(np.radians(5.0)))


def box(centre, axes, length, width, height, faces, measured=True) -> BeamCuboid:
    return BeamCuboid(
        centre=np.asarray(centre, float),
        axes=np.asarray(axes, float),
        length=length,
        width=width,
        height=height,
        rms=0.0,
        n_facets=faces,
        faces_seen=faces,
        height_measured=measured,
    )


def rafter_frame(tilt_deg: float = 0.0) -> np.ndarray:
    """Axis down the slope, width along x, height normal to the slope; ``tilt`` about the height."""
    a = np.array([0.0, -1.0, 1.0]) / np.sqrt(2.0)
    w = np.array([1.0, 0.0, 0.0])
    h = np.cross(a, w)
    t = np.radians(tilt_deg)
    a2 = np.cos(t) * a + np.sin(t) * w
    w2 = np.cross(h, a2)
    return np.column_stack([a2, w2, h])


def test_a_short_one_face_piece_along_a_rafter_is_measured_in_the_rafter_frame():
    ax = rafter_frame()
    rafter = box([0.94, 3.40, 5.02], ax, 9.27, 0.113, 0.174, faces=2)
    centre = rafter.centre + 3.4 * ax[:, 0] + 0.007 * ax[:, 1] + 0.014 * ax[:, 2]
    piece = box(centre, rafter_frame(0.79), 1.8, 0.118, 0.172, faces=1)
    # in the piece's own frame the rafter's centre lies 4 cm aside
    d = rafter.centre - piece.centre
    assert abs(d @ piece.axes[:, 1]) > 0.3 * piece.width
    assert collinear(rafter, piece, COS_PAR, 1.0)
    assert collinear(piece, rafter, COS_PAR, 1.0)
    joined, new_id = join_pieces([rafter, piece], COS_PAR, 1.0, 3.0)
    assert len(joined) == 1 and new_id.tolist() == [0, 1, 1]
    assert joined[0].faces_seen == 2 and abs(joined[0].length - 9.27) < 1e-9


def test_a_piece_past_a_shadow_seen_on_one_face_has_the_same_section():
    ax = rafter_frame()
    near = box([2.0, 1.0, 4.0], ax, 1.21, 0.098, 0.188, faces=2)
    # 1.6 m of shadow between the pieces' ends
    gap = 1.62
    centre = near.centre + (0.5 * (1.21 + 3.08) + gap) * ax[:, 0] + 0.018 * ax[:, 1]
    far = box(centre, ax, 3.08, 0.102, 0.183, faces=1)
    assert same_section(near, far)
    assert collinear(near, far, COS_PAR, 1.0, 3.0)
    joined, _ = join_pieces([near, far], COS_PAR, 1.0, 3.0)
    assert len(joined) == 1


def test_a_one_face_piece_without_a_measured_depth_or_another_section_stays_apart():
    ax = rafter_frame()
    near = box([2.0, 1.0, 4.0], ax, 1.21, 0.098, 0.188, faces=2)
    centre = near.centre + (0.5 * (1.21 + 3.08) + 1.62) * ax[:, 0]
    unmeasured = box(centre, ax, 3.08, 0.102, 0.02, faces=1, measured=False)
    assert not same_section(near, unmeasured)
    other = box(centre, ax, 3.08, 0.14, 0.183, faces=1)  # 4 cm wider: another member
    assert not same_section(near, other)
    # two pieces seen on one face each: no located section to compare with
    one = box(near.centre, ax, 1.21, 0.098, 0.188, faces=1)
    assert not same_section(one, box(centre, ax, 3.08, 0.102, 0.183, faces=1))
