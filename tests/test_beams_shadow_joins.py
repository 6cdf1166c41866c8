"""Step 2b (issue 13): one face's pieces across a shadow longer than either piece.

Roof draw 19 (``python benchmarks/bench_framework.py --sweep 1 --first-seed 19``):
a far common rafter (member 20, 0.092 x 0.132 m) is seen on its underside only,
in a 1.45 m and a 1.04 m piece 1.93 m apart (a purlin's shadow; 22 of its points
in the gap).  Both are one-face cuboids showing one face 0.095-0.100 m wide on
one line, but two rules kept them apart and the far piece was a spurious member:
the gap was past the longer piece's length, and each piece's normal, a degree
off over 3 m, put the other's face 2.7 and 2.2 cm off its plane (0.2 cm on
their mean normal).  Now the faces' planes are compared on their mean normal
(:func:`~pyheracles.beams.piece_joins.same_face`) and pieces farther apart than
the longer one's length join when the line between them runs through no other
cuboid (:func:`~pyheracles.beams.piece_joins.gap_clear`).  Noise draws 1 and 3
of draw 19 show the same two pieces (noise draw 2: one piece, no split).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from pyheracles.beams.cuboids import join_pieces
from pyheracles.beams.model import BeamCuboid
from pyheracles.beams.piece_joins import PieceFace, gap_clear, same_face

COS_PAR = float(np.cos(np.radians(5.0)))


def _unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


def _piece(centre, axis, across, length, width, height, normal, point):
    """A one-face piece (its cuboid and face) from draw 19's values (metres)."""
    axis, across = _unit(axis), _unit(across)
    across = _unit(across - (across @ axis) * axis)
    cub = BeamCuboid(
        centre=np.asarray(centre, dtype=float),
        axes=np.column_stack([axis, across, np.cross(axis, across)]),
        length=length,
        width=width,
        height=height,
        rms=0.0025,
        n_facets=1,
        faces_seen=1,
        height_measured=True,
    )
    return cub, PieceFace(normal=_unit(normal), point=np.asarray(point, float), width=width)


# member 20's two pieces as join_pieces gets them (draw 19, noise draws 0, 1, 3):
# centre, axis, across the face, length, size across, depth, face normal, face point
PIECES = {
    0: (
        ([0.4276, -1.0663, 4.8336], [-0.0010, 0.6560, 0.7547], [-0.9998, 0.0130, -0.0126],
         1.4493, 0.0948, 0.0954, [-0.0181, -0.7546, 0.6559], [0.4190, -1.0559, 4.7718]),
        ([0.4315, -3.1883, 2.4793], [0.0141, 0.6683, 0.7438], [-0.9999, 0.0071, 0.0126],
         1.0380, 0.0999, 0.1539, [0.0031, -0.7439, 0.6683], [0.4084, -3.0284, 2.5428]),
    ),
    1: (
        ([0.4281, -1.0649, 4.8392], [-0.0009, 0.6568, 0.7541], [-1.0, -0.0011, -0.0002],
         1.4396, 0.0948, 0.1008, [0.0007, -0.7541, 0.6568], [0.4181, -1.0517, 4.7773]),
        ([0.4303, -3.1890, 2.4796], [0.0100, 0.6679, 0.7442], [0.9998, 0.0041, -0.0171],
         1.0385, 0.0992, 0.1556, [-0.0145, 0.7442, -0.6678], [0.4083, -3.0288, 2.5425]),
    ),
    3: (
        ([0.4256, -1.0914, 4.8091], [0.0038, 0.6571, 0.7538], [1.0, -0.0086, 0.0024],
         1.3945, 0.0932, 0.1008, [0.0081, 0.7537, -0.6571], [0.4193, -1.0600, 4.7686]),
        ([0.4296, -3.2384, 2.4229], [-0.0016, 0.6677, 0.7445], [-0.9999, -0.0106, 0.0074],
         1.1898, 0.0930, 0.1528, [0.0128, -0.7444, 0.6676], [0.4095, -3.0428, 2.5270]),
    ),
}  # fmt: skip
NEAR, FAR = (_piece(*v) for v in PIECES[0])


def _join(pieces, others=()):
    cubs = [c for c, _ in pieces] + list(others)
    faces = [f for _, f in pieces] + [None] * len(others)
    return join_pieces(cubs, COS_PAR, 1.0, 3.0, faces=faces, plane_tol=0.01)


def _gap(a: BeamCuboid, b: BeamCuboid) -> float:
    return abs((b.centre - a.centre) @ a.axis) - 0.5 * (a.length + b.length)


def test_draw19_pieces_show_one_face():
    (a, fa), (b, fb) = NEAR, FAR
    assert _gap(a, b) == pytest.approx(1.93, abs=0.01)  # past the longer piece (1.45 m)
    # each face is 2-3 cm off the other's own plane, 0.2 cm off their mean plane
    d = fb.point - fa.point
    assert abs(d @ fa.normal) > 0.02 and abs(d @ fb.normal) > 0.02
    assert same_face(a, b, fa, fb, COS_PAR, 0.01)


@pytest.mark.parametrize("noise_draw", sorted(PIECES))
def test_draw19_pieces_join_across_the_shadow(noise_draw):
    near, far = (_piece(*v) for v in PIECES[noise_draw])
    (a, fa), (b, fb) = near, far
    assert _gap(a, b) > max(a.length, b.length)  # a shadow longer than either piece
    assert same_face(a, b, fa, fb, COS_PAR, 0.01)
    out, new_id = _join([near, far])
    assert len(out) == 1
    assert list(new_id) == [0, 1, 1]
    assert out[0].length == pytest.approx(a.length + _gap(a, b) + b.length, abs=0.02)


def test_a_face_off_the_plane_is_another_member():
    b, fb = FAR
    moved = replace(fb, point=fb.point + 0.03 * fb.normal)  # 3 cm behind or in front
    assert not same_face(NEAR[0], replace(b, centre=b.centre + 0.03 * fb.normal), NEAR[1], moved,
                         COS_PAR, 0.01)  # fmt: skip


def test_a_member_on_the_line_between_keeps_them_apart():
    a, b = NEAR[0], FAR[0]
    mid = 0.5 * (a.centre + b.centre)
    # a post through the gap: the two pieces are two members meeting it
    post = BeamCuboid(
        centre=mid,
        axes=np.eye(3)[:, [2, 0, 1]],
        length=2.0,
        width=0.2,
        height=0.2,
        rms=0.002,
        n_facets=2,
        faces_seen=2,
        height_measured=True,
    )
    assert not gap_clear(a, b, [post])
    out, _ = _join([NEAR, FAR], others=[post])
    assert len(out) == 3
    # beside the line (a purlin under the rafter, as in the draw), the gap is clear
    purlin = replace(post, axes=np.eye(3), length=4.7, width=0.15, height=0.17)
    assert not gap_clear(a, b, [purlin])  # across the line: two rafters meeting it
    below = replace(purlin, centre=mid - 0.2 * NEAR[1].normal)
    assert gap_clear(a, b, [below])
    assert len(_join([NEAR, FAR], others=[below])[0]) == 2


def test_past_the_shadow_length_stay_apart():
    b, fb = FAR
    shift = -1.2 * NEAR[0].axis  # 3.1 m apart
    far = (replace(b, centre=b.centre + shift), replace(fb, point=fb.point + shift))
    assert len(_join([NEAR, far])[0]) == 2
