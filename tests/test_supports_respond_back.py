"""Responds on wall islands (issue 12, step 2a): a respond's back is one with its wall,
in no scanner's view, so the wall face it stands out of does not run on behind it; the
piece of a wall between two windows, its far face the wall island's long face and its
near face and reveal a cluster off that face, stands out of it as deep as the wall but
has that face behind it (supports draw 13: a jamb found as a respond)."""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.supports import SupportParams
from pyheracles.supports.responds import responds_on_wall
from pyheracles.supports.rings import wall_face_lines
from supports_draws import section_line, wall_face

STEP = 0.02
TOL = 0.03
DISTANCE = 0.04
BIN = 0.05


def _wall_piece(thick: float, length: float, dense: float) -> np.ndarray:
    """The section of the piece of a ``thick`` wall between two windows, ``length`` long
    from x = 0, as draw 13 saw it: its far face (y = -thick) and its reveal at x = 0
    dense, its near face (y = 0) dense over ``dense`` from the reveal and crossed by a
    few scan lines beyond, its other reveal by a few."""
    x_sparse = np.arange(dense + 0.2, length, 0.3)
    sparse_near = np.c_[x_sparse, np.zeros(len(x_sparse))]
    sparse_reveal = np.c_[np.full(3, length), [-0.4, -0.25, -0.1]]
    return np.vstack(
        [
            section_line((0.0, -thick), (length, -thick)),
            section_line((0.0, -thick), (0.0, 0.0)),
            section_line((0.0, 0.0), (dense, 0.0)),
            sparse_near,
            sparse_reveal,
        ]
    )


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_wall_piece_between_windows_is_no_respond(seed: int) -> None:
    """Draw 13's piece of a 0.53 m wall between two windows (2.2 m long, its near face
    seen densely over 0.66 m from one reveal): the cluster of its near face and reveal
    stands 0.53 m out of its far face, whose line runs on beyond both windows, but that
    face runs on behind the cluster too: no respond (one was, a jamb found as a pier)."""
    rng = np.random.default_rng(seed)
    piece = _wall_piece(0.53, 2.2, 0.66)
    piece = piece + rng.normal(0.0, 0.003, piece.shape)
    beyond = np.vstack(
        [
            wall_face(-0.53, [(-3.0, -0.76), (2.76, 5.0)]),
            wall_face(0.0, [(-3.0, -0.76), (2.76, 5.0)]),
        ]
    )
    section = np.vstack([piece, beyond + rng.normal(0.0, 0.003, beyond.shape)])
    faces = wall_face_lines(piece, TOL, DISTANCE, rng)
    assert responds_on_wall(piece, faces, SupportParams(), TOL, DISTANCE, BIN, section) == []


def test_respond_with_its_back_in_the_wall_stays() -> None:
    """A 0.6 x 0.5 m respond on the face of a 0.53 m wall: the face runs on beyond both
    of its sides, not behind it (its back is in the wall): one respond."""
    rng = np.random.default_rng(0)
    xy = np.vstack(
        [
            wall_face(0.0, [(-3.0, -0.3), (0.3, 3.0)]),
            wall_face(-0.53, [(-3.0, 3.0)]),
            section_line((-0.3, 0.5), (0.3, 0.5)),
            section_line((-0.3, 0.0), (-0.3, 0.5)),
            section_line((0.3, 0.0), (0.3, 0.5)),
        ]
    )
    xy = xy + rng.normal(0.0, 0.003, xy.shape)
    found = responds_on_wall(
        xy, wall_face_lines(xy, TOL, DISTANCE, rng), SupportParams(), TOL, DISTANCE, BIN
    )
    assert len(found) == 1
    assert np.allclose(found[0]["centre"], [0.0, 0.25], atol=0.03)


@pytest.mark.slow
@pytest.mark.parametrize("noise_draw", [0, 1, 3])
def test_draw_13_wall_piece_between_windows_is_no_support(noise_draw: int) -> None:
    """Draw 13 of the supports family (a portico, 0.53 m walls with windows 0.76 m wide):
    the piece of wall between the windows at x 17.9-20.1 m was a respond 0.66 x 0.53 m
    at (18.2, -0.26) on noise draws 0, 1 and 3 (a jamb found as a pier, 0.9-1.0 of its
    points wall); no support stands there."""
    from pyheracles.building import segment_building
    from pyheracles.synthetic.families import simulate

    sim = simulate("supports", 13, noise_draw=noise_draw)
    _, found, _, _ = segment_building(sim.clouds["cloud"].xyz)
    obj = found.objects
    near = np.hypot(obj["x"].to_numpy() - 18.2, obj["y"].to_numpy() + 0.26) < 0.5
    assert not near.any(), obj[near]
