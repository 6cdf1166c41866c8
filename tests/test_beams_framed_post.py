"""Step 2b (issue 13): a short member seen on one face, framed between two crossing beams.

Small rebuild of ``roof`` draw 22 (queen-post trusses of a 4.7 m span, tie 1.09 m
above the floor): the posts run 0.97 m from the tie up to the beam on their heads,
their 0.25 m wide face seen, their other faces shadowed into patches.  One face
must be twice as elongated as a straight facet (6 times its width) to count as a
member, and 5 of the draw's 8 posts (3.9 times) went to the remainder.  A band
whose two ends abut beams crossing it is as long as its joints let it be.
"""

from __future__ import annotations

import numpy as np

from grid_planes import grid_plane
from pyheracles.beams import BeamCuboid, BeamParams, StraightFacet
from pyheracles.beams.one_face import spans_between
from pyheracles.beams.segment import add_one_face_beams
from pyheracles.geometry.neighbours import build_tree

X, Y, Z = np.eye(3)
POST_W, POST_D, POST_L = 0.25, 0.19, 0.97  # face width, depth behind it, length (m)
NOISE = 0.002


def _post_cloud(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """The post's face (plane x = 0, the room at +x), its sparse sides going back,
    the floor of the room; and the indices of the face's points."""
    face = grid_plane(np.array([0.0, -POST_W / 2, 0.0]), Y, Z, POST_W, POST_L, 0.008, rng)
    sides = []
    for y in (-POST_W / 2, POST_W / 2):
        ab = rng.random((150, 2)) * [POST_D, POST_L]
        p = np.array([0.0, y, 0.0]) - ab[:, :1] * X + ab[:, 1:] * Z
        sides.append(p + rng.normal(scale=NOISE, size=p.shape))
    floor = grid_plane(np.array([0.8, -1.5, -1.1]), X, Y, 3.0, 3.0, 0.05, rng)
    xyz = np.vstack([face, *sides, floor])
    return xyz, np.arange(len(face))


def _crossing(z_centre: float) -> BeamCuboid:
    """A beam along y under or over the post, flush with its face."""
    return BeamCuboid(
        centre=np.array([-POST_D / 2, 0.0, z_centre]),
        axes=np.column_stack([Y, X, Z]),
        length=2.0,
        width=POST_D,
        height=0.2,
        rms=0.0,
        n_facets=2,
        faces_seen=2,
    )


def _face_facet(xyz: np.ndarray, index: np.ndarray) -> StraightFacet:
    pts = xyz[index]
    return StraightFacet(
        index=index,
        normal=X.copy(),
        axis=Z.copy(),
        centre=pts.mean(axis=0),
        width=POST_W,
        length=POST_L,
        plane_rms=NOISE,
        parent=1,
    )


def _one_face(beams: list[BeamCuboid]) -> list[BeamCuboid]:
    rng = np.random.default_rng(22)
    xyz, face = _post_cloud(rng)
    out, _ = add_one_face_beams(
        xyz,
        build_tree(xyz),
        [_face_facet(xyz, face)],
        np.zeros(1, dtype=np.int32),
        beams,
        BeamParams(),
        0.008,
        0.01,
        reach_m=0.07,
    )
    return out


def test_short_post_between_tie_and_head_beam_is_a_member():
    tie, head = _crossing(-0.1), _crossing(POST_L + 0.1)
    out = _one_face([tie, head])
    assert len(out) == 3
    post = out[2]
    assert post.faces_seen == 1
    assert abs(abs(post.axis @ Z) - 1.0) < 1e-3
    assert abs(post.length - POST_L) < 0.03


def test_short_band_abutting_one_beam_only_is_not_a_member():
    # the same band with nothing on its head: 3.9 times its width is no member
    out = _one_face([_crossing(-0.1)])
    assert len(out) == 1


def test_spans_between_needs_both_ends_on_crossing_beams():
    post = BeamCuboid(
        centre=np.array([-POST_D / 2, 0.0, POST_L / 2]),
        axes=np.column_stack([Z, Y, X]),
        length=POST_L,
        width=POST_W,
        height=POST_D,
        rms=0.0,
        n_facets=1,
        faces_seen=1,
    )
    cos_par = np.cos(np.radians(5.0))
    tie, head = _crossing(-0.1), _crossing(POST_L + 0.1)
    assert spans_between(post, [tie, head], 0.07, cos_par)
    assert not spans_between(post, [tie], 0.07, cos_par)
    # a beam going on along the post's line is the same member, not a joint
    above = BeamCuboid(
        centre=np.array([-POST_D / 2, 0.0, POST_L + 0.6]),
        axes=np.column_stack([Z, Y, X]),
        length=1.0,
        width=POST_W,
        height=POST_D,
        rms=0.0,
        n_facets=2,
        faces_seen=2,
    )
    assert not spans_between(post, [tie, above], 0.07, cos_par)
