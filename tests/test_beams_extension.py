"""Step 2b (issue 13): a beam is lengthened over its own faces, not over what crosses them.

Roof seed 2: a king post standing on a tie beam 1.3 m above the floor was
lengthened down through the tie, across a metre of air and through the floor to
0.5 m under it: a few mixed pixels along its faces' planes (one or two per
slice) bridged the gaps one by one, and the ring where the floor crosses the
faces' planes looked like faces going on.  The post's box set the frame's
bottom under the floor, so that the ladder standing on the floor no longer
reached below it and stayed a member.  Roof seed 1: a straining beam between
two queen posts was lengthened through each post to the boarding behind the
rafters, 0.9 m past each end.  A slice holding a single point does not go on
with a beam's faces (unless they are that sparse at its end), and the wide
surfaces (floor, walls, boarding) are no beam's faces.
"""

from __future__ import annotations

import numpy as np

from grid_planes import grid_plane
from pyheracles.beams import BeamCuboid, segment_beams
from pyheracles.beams.segment import extend_along_axis

X, Y, Z = np.eye(3)
POST_W, POST_FOOT, POST_TOP = 0.18, 1.3, 3.5


def _post_faces(rng, foot: float, top: float, step: float) -> np.ndarray:
    """Two adjacent faces of a post standing along z (18 x 18 cm) from ``foot`` to ``top``."""
    lo = np.array([-POST_W / 2, -POST_W / 2, foot])
    return np.vstack(
        [
            grid_plane(lo, Y, Z, POST_W, top - foot, step, rng),
            grid_plane(lo, X, Z, POST_W, top - foot, step, rng),
        ]
    )


def _post_cuboid() -> BeamCuboid:
    return BeamCuboid(
        centre=np.array([0.0, 0.0, 0.5 * (POST_FOOT + POST_TOP)]),
        axes=np.column_stack([Z, X, Y]),
        length=POST_TOP - POST_FOOT,
        width=POST_W,
        height=POST_W,
        rms=0.001,
        n_facets=2,
        faces_seen=2,
    )


def test_scattered_points_on_a_post_s_face_planes_do_not_lengthen_it_to_the_floor():
    rng = np.random.default_rng(2)
    post = _post_faces(rng, POST_FOOT, POST_TOP, 0.008)
    # mixed pixels on the faces' planes under the post: one every 12 cm down to the floor
    z = np.arange(POST_FOOT - 0.12, 0.0, -0.12)
    stray = np.column_stack([np.full(len(z), -POST_W / 2), rng.uniform(-0.08, 0.08, len(z)), z])
    # the floor, where it crosses the faces' planes (a ring round the foot)
    ring = grid_plane(np.array([-0.2, -0.2, 0.0]), X, Y, 0.4, 0.4, 0.008, rng, noise=0.001)
    xyz = np.vstack([post, stray, ring])
    free = np.ones(len(xyz), bool)
    out = extend_along_axis(xyz, free, _post_cuboid(), 0.01, 1.0, 0.008)
    foot = float(out.centre[2] - 0.5 * out.length)
    assert foot > POST_FOOT - 0.1  # was at the floor, 1.3 m lower


def test_a_sparse_far_stretch_of_a_face_still_lengthens_a_post():
    rng = np.random.default_rng(3)
    dense = _post_faces(rng, POST_FOOT, POST_TOP, 0.008)
    # the faces go on 0.8 m lower at a fifth of the density (farther from the station)
    sparse = _post_faces(rng, POST_FOOT - 0.8, POST_FOOT, 0.018)
    xyz = np.vstack([dense, sparse])
    out = extend_along_axis(xyz, np.ones(len(xyz), bool), _post_cuboid(), 0.01, 1.0, 0.008)
    foot = float(out.centre[2] - 0.5 * out.length)
    assert foot < POST_FOOT - 0.7


def _collar_and_boarding(rng):
    """A horizontal beam along y seen on its underside and a side, and boarding past its end.

    The beam (18 x 15 cm) runs from y = -1.1 to 1.1 at z 2.0-2.15; past its
    far end a gap of 0.3 m (a member passed through, its points in its own
    facets) and then roof boarding sloping at 40 degrees across the beam's
    line, wider than any beam.  Labels: 1 the beam, 0 the boarding.
    """
    lo = np.array([-0.09, -1.1, 2.0])
    beam = np.vstack(
        [
            grid_plane(lo, X, Y, 0.18, 2.2, 0.008, rng),
            grid_plane(lo, Y, Z, 2.2, 0.15, 0.008, rng),
        ]
    )
    # the boarding's underside: through (y 1.4, z 2.0), rising to +y at 40 degrees
    slope = np.array([0.0, np.cos(np.radians(40)), np.sin(np.radians(40))])
    start = np.array([-1.5, 1.4, 2.0]) - 1.5 * slope
    board = grid_plane(start, X, slope, 3.0, 3.0, 0.01, rng)
    xyz = np.vstack([beam, board])
    return xyz, np.concatenate([np.ones(len(beam), int), np.zeros(len(board), int)])


def test_boarding_crossing_a_beam_s_line_past_its_end_does_not_lengthen_it():
    xyz, truth = _collar_and_boarding(np.random.default_rng(1))
    res = segment_beams(xyz)
    assert len(res.beams) == 1
    b = res.beams[0]
    ends = b.centre[1] + 0.5 * b.length * np.array([-abs(b.axis[1]), abs(b.axis[1])])
    assert ends[1] < 1.1 + 0.1  # reached the boarding at y 1.4-1.6 before
    assert ends[0] > -1.1 - 0.1
    assert np.mean(res.labels[truth == 0] == 1) < 0.01  # the boarding is not the beam's
