"""A pier seen square on from one side: a dense face and two sparse side faces.

Draw 11 of the supports family: piers of 2.0 x 1.2 m in a portico's front row, seen
from stations outside; the front face, crossed square on by close scan lines, was a
"wall" island 2 m long and 1 cm thin, while the scan lines grazing the two side faces
left a point every 10 cm there, too sparse for any island: the pier was missed
(``sections.face_and_sides``).  The faces of a wall -- a sparse face broken into pieces
at the gaps between its scan lines, or a door reveal with the wall's two faces running
on behind it -- stay walls.
"""

from __future__ import annotations

import numpy as np

from pyheracles.supports.core import SupportParams
from pyheracles.supports.sections import section_islands

DIST = 0.04  # clustering distance of the section, metres


def _line(a: tuple[float, float], b: tuple[float, float], step: float) -> np.ndarray:
    n = max(2, round(float(np.hypot(b[0] - a[0], b[1] - a[1])) / step) + 1)
    t = np.linspace(0.0, 1.0, n)[:, None]
    return np.asarray(a) + t * (np.asarray(b) - np.asarray(a))


def _noisy(p: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    return p + rng.normal(0.0, 0.002, p.shape)


def one_face_pier(rng: np.random.Generator) -> np.ndarray:
    """A 2.0 x 1.2 m pier: its front face (y = 0) every 1 cm, its sides every 10 cm."""
    return _noisy(
        np.vstack(
            [
                _line((0.0, 0.0), (2.0, 0.0), 0.01),
                _line((0.0, 0.1), (0.0, 1.2), 0.1),
                _line((2.0, 0.1), (2.0, 1.2), 0.1),
            ]
        ),
        rng,
    )


def test_pier_from_one_dense_face_and_sparse_sides() -> None:
    for seed in range(3):
        xy = one_face_pier(np.random.default_rng(seed))
        islands = section_islands(xy, SupportParams(), DIST)
        piers = [i for i in islands if i.kind == "pier"]
        assert len(piers) == 1, [i.kind for i in islands]
        assert np.allclose(piers[0].center, [1.0, 0.6], atol=0.05)
        assert np.allclose(sorted(piers[0].size), [1.2, 2.0], atol=0.1)


def test_piece_of_a_sparse_wall_face_is_no_pier() -> None:
    """The face runs on in line past its ends (a far wall face broken at the gaps of its
    scan lines): the points beside it make no pier."""
    rng = np.random.default_rng(0)
    xy = np.vstack(
        [
            one_face_pier(rng),
            _noisy(_line((-3.0, 0.0), (-0.12, 0.0), 0.1), rng),  # the face goes on
        ]
    )
    islands = section_islands(xy, SupportParams(), DIST)
    assert not [i for i in islands if i.kind == "pier"]


def test_reveal_with_wall_faces_behind_is_no_pier() -> None:
    """A door reveal (dense, 1.2 m across a thick wall) with the wall's two faces running
    back from its ends for 4 m, a point every 13 cm (within ``max_support_size_m`` of the
    reveal they and the reveal make a 2.44 x 1.2 m rectangle): a piece of a wall beside
    an opening, not a pier."""
    rng = np.random.default_rng(1)
    xy = _noisy(
        np.vstack(
            [
                _line((0.0, 0.0), (1.2, 0.0), 0.01),
                _line((0.0, 0.1), (0.0, 4.0), 0.13),
                _line((1.2, 0.1), (1.2, 4.0), 0.13),
            ]
        ),
        rng,
    )
    islands = section_islands(xy, SupportParams(), DIST)
    assert not [i for i in islands if i.kind == "pier"]


def test_face_on_the_line_of_a_long_wall_is_no_pier() -> None:
    """The face lies on the line of a wall face 6 m long, a metre past its end (a piece
    of the wall between two doors, seen from inside with its two reveals: draw 34)."""
    rng = np.random.default_rng(2)
    xy = np.vstack(
        [
            one_face_pier(rng),
            _noisy(_line((3.0, 0.0), (9.0, 0.0), 0.01), rng),  # the wall beyond the door
        ]
    )
    islands = section_islands(xy, SupportParams(), DIST)
    assert [i.kind for i in islands if i.kind == "pier"] == []
    assert any(i.kind == "wall" and max(i.size) > 5.0 for i in islands)


def test_inner_corner_of_two_walls_is_no_pier() -> None:
    """A wall face ending 1.85 m from the inner corner where it meets a long wall (draw
    30): the face, the few points at the foot of the long wall and a few more at the
    face's other end make a rectangle, but a side of it runs on the long wall's line."""
    rng = np.random.default_rng(3)
    xy = _noisy(
        np.vstack(
            [
                _line((0.0, 0.0), (1.85, 0.0), 0.01),
                _line((0.0, 0.1), (0.0, 0.8), 0.1),
                _line((1.85, 0.1), (1.85, 0.8), 0.1),
                _line((0.0, 1.4), (0.0, 7.0), 0.01),  # the long wall, 0.6 m on
            ]
        ),
        rng,
    )
    islands = section_islands(xy, SupportParams(), DIST)
    assert [i.kind for i in islands if i.kind == "pier"] == []
