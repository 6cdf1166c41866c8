"""Step 2b (issue 13): two one-face pieces showing one face across a shadow are one member.

Roof draw 24 (``python benchmarks/bench_framework.py --sweep 1 --first-seed 24``):
a far common rafter (member 54, 0.139 x 0.162 m) is seen on its side face only,
in two pieces 1.4 m apart (a nearer member's shadow).  Both pieces are one-face
cuboids with the same face (0.171 m wide, one plane, one centre line), but their
depths behind the face are not measured (0.035 and 0.042 m slabs), so
:func:`~pyheracles.beams.cuboids.same_section` refuses them and the gap is past
``max_gap_m``: the far piece was a spurious member.  Two one-face pieces that
show one face (:func:`~pyheracles.beams.piece_joins.same_face`) are joined up
to ``max_shadow_m`` apart.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from pyheracles.beams.cuboids import join_pieces
from pyheracles.beams.model import BeamCuboid
from pyheracles.beams.piece_joins import PieceFace, same_face

COS_PAR = float(np.cos(np.radians(5.0)))
AXIS = np.array([0.0, 0.787, -0.617]) / np.linalg.norm([0.0, 0.787, -0.617])
NORMAL = np.array([1.0, 0.0, 0.0])  # the side face seen


def _piece(start: float, length: float, depth: float, face_w: float = 0.171, shift=0.0):
    """A one-face piece of draw 24's rafter line from ``start`` along it (metres).

    ``shift``: offset of its face across the line, in the face (metres).
    """
    v = np.cross(AXIS, NORMAL)
    base = np.array([8.853, 2.24, 3.66]) + shift * v
    face_centre = base + AXIS * (start + 0.5 * length)
    cub = BeamCuboid(
        centre=face_centre + NORMAL * 0.5 * depth,
        axes=np.column_stack([AXIS, NORMAL, v]),
        length=length,
        width=depth,
        height=face_w,
        rms=0.003,
        n_facets=1,
        faces_seen=1,
        height_measured=False,
    )
    return cub, PieceFace(normal=NORMAL, point=face_centre, width=face_w)


def _join(pieces, with_faces=True):
    cubs = [c for c, _ in pieces]
    faces = [f for _, f in pieces] if with_faces else None
    return join_pieces(cubs, COS_PAR, 1.0, 3.0, faces=faces, plane_tol=0.01)


def test_draw24_pieces_across_shadow_join():
    near = _piece(-1.3, 2.61, 0.035)
    far = _piece(2.71, 1.81, 0.042)  # 1.40 m past the near piece's end
    out, new_id = _join([near, far])
    assert len(out) == 1
    assert list(new_id) == [0, 1, 1]
    assert out[0].length == pytest.approx(2.61 + 1.40 + 1.81, abs=1e-6)
    # without the faces (the sections alone), they stay apart
    assert len(_join([near, far], with_faces=False)[0]) == 2


@pytest.mark.parametrize(
    "far",
    [
        _piece(2.71, 1.81, 0.042, face_w=0.12),  # a narrower face: another member
        _piece(2.71, 1.81, 0.042, shift=0.06),  # off the line by a third of the width
        _piece(4.71, 1.81, 0.042),  # 3.4 m apart: past the shadow length
    ],
)
def test_other_faces_stay_apart(far):
    near = _piece(-1.3, 2.61, 0.035)
    assert len(_join([near, far])[0]) == 2


def test_face_off_the_plane_or_seen_twice_is_no_join():
    near, fn = _piece(-1.3, 2.61, 0.035)
    far, ff = _piece(2.71, 1.81, 0.042)
    off = replace(ff, point=ff.point + 0.03 * NORMAL)  # 3 cm in front of the plane
    assert not same_face(near, far, fn, off, COS_PAR, 0.01)
    assert same_face(near, far, fn, ff, COS_PAR, 0.01)
    # a piece seen on two faces has a located section: same_section's to judge
    assert not same_face(near, replace(far, faces_seen=2), fn, ff, COS_PAR, 0.01)
    assert not same_face(near, far, fn, None, COS_PAR, 0.01)


def test_piece_faces_reads_the_face_of_one_face_pieces_only():
    from pyheracles.beams.model import StraightFacet
    from pyheracles.beams.piece_joins import piece_faces

    rng = np.random.default_rng(24)
    v = np.cross(AXIS, NORMAL)
    # draw 24's side face: 2.6 m x 0.171 m at x = 8.853, 1 cm spacing
    t, s = np.meshgrid(np.arange(0, 2.6, 0.01), np.arange(-0.085, 0.086, 0.01))
    base = np.array([8.853, 2.24, 3.66])
    xyz = base + t.reshape(-1, 1) * AXIS + s.reshape(-1, 1) * v
    xyz[:, 0] += rng.normal(0, 0.002, len(xyz))
    facet = StraightFacet(
        index=np.arange(len(xyz)),
        normal=-NORMAL,
        axis=AXIS,
        centre=xyz.mean(axis=0),
        width=0.171,
        length=2.6,
        plane_rms=0.002,
        parent=1,
    )
    cub, _ = _piece(0.0, 2.6, 0.035)
    faces = piece_faces(xyz, [facet], np.array([1], np.int32), [cub, replace(cub, faces_seen=2)])
    assert faces[1] is None
    assert faces[0] is not None
    assert faces[0].width == pytest.approx(0.171)
    assert abs(faces[0].normal @ NORMAL) == pytest.approx(1.0)
    assert faces[0].point[0] == pytest.approx(8.853, abs=0.002)
