"""Piers seen from their two long sides on draws of the supports scene family (issue 12,
step 2a): the two dense faces were two short walls, the grazed short sides a few
points each, and the pier was missed (draw 34)."""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.supports import SupportParams, section_islands
from pyheracles.synthetic.families import simulate

PARAMS = SupportParams()


def _pier_faces(w: float, d: float, end_points: int, seed: int) -> np.ndarray:
    """Section points of a ``w`` x ``d`` pier centred at (21, 12.55): its long faces
    every 1.5 cm, ``end_points`` points on each short side, 3 mm noise."""
    rng = np.random.default_rng(seed)
    x = np.arange(-w / 2, w / 2 + 1e-9, 0.015)
    faces = [np.c_[x, np.full(len(x), -d / 2)], np.c_[x, np.full(len(x), d / 2)]]
    if end_points:
        y = np.linspace(-d / 2 + 0.1, d / 2 - 0.1, end_points)
        faces += [np.c_[np.full(end_points, -w / 2), y], np.c_[np.full(end_points, w / 2), y]]
    xy = np.vstack(faces) + [21.0, 12.55]
    return xy + rng.normal(0, 0.003, xy.shape)


def test_pier_seen_from_its_long_sides_is_one_pier() -> None:
    """Draw 34 (a ruined portico, its 2.0 x 0.86 m piers 12 m tall): the section held
    each long face as a 2 m "wall" and 6-8 points on each short side; two parallel
    straight faces ending at the same places, their short sides closed by points, are
    one pier."""
    xy = _pier_faces(2.0, 0.86, 6, 34)
    islands = section_islands(xy, PARAMS, 0.066)
    piers = [i for i in islands if i.kind == "pier"]
    assert len(piers) == 1, [(i.kind, i.size) for i in islands]
    np.testing.assert_allclose(np.sort(piers[0].size), [0.86, 2.0], atol=0.03)
    np.testing.assert_allclose(piers[0].center, [21.0, 12.55], atol=0.02)
    assert not [i for i in islands if i.kind == "wall"]


def test_open_faces_stay_walls() -> None:
    """Two parallel faces with nothing on their short sides (two walls of a passage, the
    backs of two benches) are not a pier."""
    islands = section_islands(_pier_faces(2.0, 0.86, 0, 34), PARAMS, 0.066)
    assert not [i for i in islands if i.kind in ("pier", "column")]


def test_wall_between_two_doors_is_no_face_pair() -> None:
    """Draw 31 (a 1.2 m thick wall, two doors 0.3 m apart; here 0.45 m): the reveals of the
    piece of wall between the doors are two parallel 1.2 m "walls" ending at the same
    places, closed by the wall's faces, like the faces of a pier; but those short
    sides lie on the wall's faces, which run on beyond the doors."""
    rng = np.random.default_rng(31)

    def line(a, b, step=0.015):
        n = int(np.hypot(*np.subtract(b, a)) / step) + 1
        return np.linspace(a, b, n)

    xy = np.vstack(
        [
            line([-0.6, -0.225], [0.6, -0.225]),  # the reveals
            line([-0.6, 0.225], [0.6, 0.225]),
            line([-0.6, -0.1], [-0.6, 0.1], 0.1),  # the wall's faces between them,
            line([0.6, -0.1], [0.6, 0.1], 0.1),  # grazed: three points each
        ]
        + [line([x, y0], [x, y1]) for x in (-0.6, 0.6) for y0, y1 in ((2.15, 3.5), (-3.5, -2.15))]
        + [line([-0.6, y], [0.6, y]) for y in (2.15, -2.15)]  # the far reveals of the doors
    )
    xy = xy + rng.normal(0, 0.003, xy.shape)
    islands = section_islands(xy, PARAMS, 0.066)
    near = [i for i in islands if i.kind == "pier" and np.hypot(*i.center) < 0.5]
    assert not near, [(i.kind, i.center, i.size) for i in near]


@pytest.mark.slow
def test_draw_34_finds_the_pier_seen_from_its_long_sides() -> None:
    """Draw 34 itself: pier 4 (2.0 x 0.86 m) is found, as a pier."""
    from pyheracles.building import segment_building

    sim = simulate("supports", 34)
    res = sim.clouds["cloud"]
    _, found, _, _ = segment_building(res.xyz)
    mine = found.instance[(res.instance == 4) & ~res.outlier]
    ids, counts = np.unique(mine[mine > 0], return_counts=True)
    assert len(ids) and counts.max() > 0.5 * len(mine)
    row = found.objects.set_index("instance").loc[int(ids[np.argmax(counts)])]
    assert row["class"] == "pier"


def _one_dense_face(wall_run_m: float, seed: int) -> np.ndarray:
    """Section points of a 1.39 x 0.68 m pier centred at (0, 0.34): its face at y = 0
    every 1 cm (running on ``wall_run_m`` beyond its right end), its other three faces
    crossed by scan lines 6 cm apart (regrouped as a sparse pier island), 3 mm noise."""
    rng = np.random.default_rng(seed)
    x = np.arange(-0.695, 0.695 + wall_run_m + 1e-9, 0.01)
    dense = np.c_[x, np.zeros(len(x))]
    y = np.arange(0.08, 0.68 + 1e-9, 0.06)
    xs = np.arange(-0.695, 0.695 + 1e-9, 0.06)
    sparse = np.vstack(
        [np.c_[np.full(len(y), -0.695), y], np.c_[np.full(len(y), 0.695), y],
         np.c_[xs, np.full(len(xs), 0.68)]]
    )  # fmt: skip
    xy = np.vstack([dense, sparse])
    return xy + rng.normal(0, 0.003, xy.shape)


def test_pier_with_one_dense_face_is_one_pier() -> None:
    """Draw 19 (an open kiosk, 1.39 x 0.68 m piers 15 m tall): the face seen square on
    was a 1.39 x 0.07 m "wall", the other faces a sparse pier island beside it, which
    that wall alongside made a piece of a wall; both missed.  A short straight wall on
    the outline of a pier island, as long as its side, is its face."""
    islands = section_islands(_one_dense_face(0.0, 19), PARAMS, 0.03)
    piers = [i for i in islands if i.kind == "pier"]
    assert len(piers) == 1, [(i.kind, i.size) for i in islands]
    np.testing.assert_allclose(np.sort(piers[0].size), [0.68, 1.39], atol=0.03)
    assert not [i for i in islands if i.kind == "wall"]


def test_wall_running_past_a_pier_is_no_face() -> None:
    """A wall running 0.8 m on past the side of a pier-like island is no face of it (the
    wall's end and its return): it stays a wall."""
    islands = section_islands(_one_dense_face(0.8, 19), PARAMS, 0.03)
    assert [i for i in islands if i.kind == "wall"], [(i.kind, i.size) for i in islands]
