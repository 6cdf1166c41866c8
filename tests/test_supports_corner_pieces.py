"""The corner of two walls between openings is no pier (issue 12, mode 4: "a jamb is a
wall edge").

Built from draw 3 of the supports family (a ruined portico, noise draws 2 and 3): the
corner block of two walls 0.89 m thick, between a window in one and a door in the
other, was cut off like a pier in the low section (2.4 x 1.7 m, up to the walls' broken
tops at 1.5 m).  Its foot is free (the window's sill is 0.2 m high, the door goes down
to the floor); under its top both walls run on from it over the openings' heads, beyond
one end each, flush with the outer faces it shows: two walls meeting at it.  Draw 0 (an
inner corner between a window and the next wall, seen from inside) likewise.  A pier
under two beams meeting over it, a pier set in the corner of a room against both walls
(its backs, which it does not show, are flush with the walls) and an anta (one wall
beyond one end) stay piers.
"""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.supports.cookies import offset, wall_piece_in_bands
from pyheracles.supports.core import SupportParams, scales
from supports_draws import height_bands

STEP = 0.02  # point spacing of the synthetic faces, metres
T = 0.6  # the walls' thickness, metres
TOP = 1.5  # the walls' broken tops, metres
HEAD = 0.95  # the heads of the window and the door, metres
SILL = 0.2  # the window's sill, metres
H_SEC = 0.8  # the low section, metres
SHADOW = 0.4  # the shadow on wall B next to the corner block, metres
DOOR = T + 1.8  # the door's far jamb (draw 3: a door 2.1 m wide), metres


def _grid(a0: float, a1: float, z0: float, z1: float) -> tuple[np.ndarray, np.ndarray]:
    aa, zz = np.meshgrid(np.arange(a0, a1 + 1e-9, STEP), np.arange(z0, z1 + 1e-9, STEP))
    return aa.ravel(), zz.ravel()


def _x_face(y: float, x0: float, x1: float, z0: float, z1: float) -> np.ndarray:
    """A face at ``y`` running along x from x0 to x1, z0 to z1."""
    x, z = _grid(x0, x1, z0, z1)
    return np.c_[x, np.full(x.size, y), z]


def _y_face(x: float, y0: float, y1: float, z0: float, z1: float) -> np.ndarray:
    """A face at ``x`` running along y from y0 to y1, z0 to z1."""
    y, z = _grid(y0, y1, z0, z1)
    return np.c_[np.full(y.size, x), y, z]


def _floor(x0: float = -3.0, x1: float = 3.0, y0: float = -3.0, y1: float = 4.0) -> np.ndarray:
    fx, fy = np.meshgrid(np.arange(x0, x1, 0.05), np.arange(y0, y1, 0.05))
    return np.c_[fx.ravel(), fy.ravel(), np.zeros(fx.size)]


def _judge(
    p: np.ndarray, half: np.ndarray, top: float, rng: np.random.Generator,
    centre: tuple[float, float] = (0.0, 0.0),
) -> bool:  # fmt: skip
    """The wall-piece test of a pier candidate (rectangle ``centre``, ``half``, angle 0)
    whose own points reach ``top``, among the points ``p`` (with noise)."""
    p = p + rng.normal(0.0, 0.002, p.shape)
    band = height_bands(p)

    sh = {"class": "pier", "centre": np.array(centre), "angle": 0.0, "half": half}
    sc = scales(STEP, SupportParams())
    rho, _ = offset(p[:, :2], sh)
    cookie = np.flatnonzero(rho <= 0.3)
    return wall_piece_in_bands(p, p[cookie], rho[cookie], sh, sc, H_SEC, (0.0,), top, band)


def _corner_block() -> np.ndarray:
    """Two walls T thick meeting at a corner: wall A along x (faces y = 0 and y = -T,
    x <= T), wall B along y (faces x = 0 and x = T, y >= -T).  A window in A (x -1.6 to
    -T, sill SILL, head HEAD) and a door in B (y T to DOOR, head HEAD) cut the corner
    block (x -T..T, y -T..T, an L) off the walls below the heads; the walls stand to
    TOP.  Every face is seen (the stations stand inside and outside) but for a shadow on
    wall B next to the block: wall B does not run on from its end itself."""
    parts = [
        # the corner block's faces
        _x_face(-T, -T, T, 0.0, TOP), _y_face(T, -T, T, 0.0, TOP),  # outer
        _x_face(0.0, -T, 0.0, 0.0, TOP), _y_face(0.0, 0.0, T, 0.0, TOP),  # inner
        # wall A beyond the window, under its sill and over its head
        _x_face(0.0, -3.0, -1.6, 0.0, TOP), _x_face(-T, -3.0, -1.6, 0.0, TOP),
        _x_face(0.0, -1.6, -T, 0.0, SILL), _x_face(-T, -1.6, -T, 0.0, SILL),
        _x_face(0.0, -1.6, -T, HEAD, TOP), _x_face(-T, -1.6, -T, HEAD, TOP),
        # wall B beyond the door and over its head, but for a shadow next to the
        # corner block (SHADOW m wide at every height: a column standing before it)
        _y_face(0.0, DOOR, 4.0, 0.0, TOP), _y_face(T, DOOR, 4.0, 0.0, TOP),
        _y_face(0.0, T + SHADOW, DOOR, HEAD, TOP), _y_face(T, T + SHADOW, DOOR, HEAD, TOP),
        # the reveals at the corner block's ends
        _y_face(-T, -T, 0.0, SILL, HEAD), _x_face(T, 0.0, T, 0.0, HEAD),
    ]  # fmt: skip
    return np.vstack(parts)


@pytest.mark.parametrize("noise", range(4))
def test_corner_block_between_a_window_and_a_door_is_a_wall_piece(noise: int) -> None:
    """Draw 3's corner block: walled under its top beyond one end along each axis (wall
    B beyond a shadow, as the walls of draw 0's inner corner beyond the shadows of the
    columns before them), in no band from its ends themselves."""
    p = np.vstack([_corner_block(), _floor()])
    assert _judge(p, np.array([T, T]), TOP, np.random.default_rng(noise))


@pytest.mark.parametrize("noise", range(4))
def test_pier_under_two_beams_meeting_over_it_stays(noise: int) -> None:
    """A corner pier of a peristyle 0.6 x 0.6 m: two beams as wide as it, flush with its
    outer faces, meet over it and run on over the openings beside it; its top is their
    underside, nothing of a wall stands beside it under its top."""
    h = 0.3
    pier = [
        _x_face(-h, -h, h, 0.0, TOP), _x_face(h, -h, h, 0.0, TOP),
        _y_face(-h, -h, h, 0.0, TOP), _y_face(h, -h, h, 0.0, TOP),
    ]  # fmt: skip
    beams = [
        _x_face(-h, -3.0, h, TOP, TOP + 0.5), _x_face(h, -3.0, -h, TOP, TOP + 0.5),
        _y_face(h, -h, 3.0, TOP, TOP + 0.5), _y_face(-h, h, 3.0, TOP, TOP + 0.5),
    ]  # fmt: skip
    p = np.vstack([*pier, *beams, _floor()])
    assert not _judge(p, np.array([h, h]), TOP - 0.02, np.random.default_rng(noise))


@pytest.mark.parametrize("noise", range(4))
def test_anta_ending_a_wall_stays(noise: int) -> None:
    """An anta 0.8 x 0.8 m ending a wall 0.5 m thick set in from both of its faces: the
    wall runs on beyond one end only."""
    h = 0.4
    pier = [
        _x_face(-h, -h, h, 0.0, TOP), _x_face(h, -h, h, 0.0, TOP),
        _y_face(h, -h, h, 0.0, TOP), _y_face(-h, -h, -0.25, 0.0, TOP),
        _y_face(-h, 0.25, h, 0.0, TOP),
    ]  # fmt: skip
    wall = [_x_face(-0.25, -3.0, -h, 0.0, TOP), _x_face(0.25, -3.0, -h, 0.0, TOP)]
    p = np.vstack([*pier, *wall, _floor()])
    assert not _judge(p, np.array([h, h]), TOP - 0.02, np.random.default_rng(noise))


@pytest.mark.slow
@pytest.mark.parametrize("noise_draw", [2, 3])
def test_draw_3_corner_block_is_no_pier(noise_draw: int) -> None:
    """Draw 3, noise draws 2 and 3: the ruin's corner block (x 22.9..25.4, y -0.9..0.9)
    between a window and a door was a pier found in the low section; its points stay in
    the body."""
    from pyheracles.building import segment_building
    from pyheracles.synthetic.families import simulate

    res = simulate("supports", 3, noise_draw=noise_draw).clouds["cloud"]
    _, found, _, _ = segment_building(res.xyz)
    block = (res.xyz[:, 0] > 22.9) & (res.xyz[:, 0] < 25.45) & (np.abs(res.xyz[:, 1]) < 0.95)
    assert block.sum() > 1000
    assert not found.instance[block].any(), found.objects[["class", "x", "y"]]
