"""Wall pieces between openings that stand free up to the lintels (issue 12, mode 4: "a
jamb is a wall edge").

Built from draw 29 of the supports family (a portico whose side wall has a door beside a
door-high opening): the piece of wall between them, 0.46 x 0.32 m, was cut off like a
pier in the low section from the floor up to the lintels; its foot stands free on both
sides, and only above the lintels does the wall run on beyond its ends, flush with its
faces, up to the ceiling it reaches.  A pier of an arcade, whose arches spring from its
top, and a pier under a beam flush with its faces stand free up to their tops.
"""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.supports.cookies import offset, wall_piece_in_bands
from pyheracles.supports.core import SupportParams, scales
from pyheracles.supports.piers import walled_at_both_ends
from supports_draws import height_bands

STEP = 0.02  # point spacing of the synthetic faces, metres
HALF = np.array([0.25, 0.15])  # the candidate: 0.5 m along the wall, 0.3 m thick
H_SEC = 1.2  # its section (the low section of a portico), metres


def _grid(u0: float, u1: float, z0: float, z1: float) -> tuple[np.ndarray, np.ndarray]:
    uu, zz = np.meshgrid(np.arange(u0, u1 + 1e-9, STEP), np.arange(z0, z1 + 1e-9, STEP))
    return uu.ravel(), zz.ravel()


def _x_faces(x0: float, x1: float, z0: float, z1: float) -> np.ndarray:
    """The two faces (y = -0.15 and 0.15) of a wall run from x0 to x1, z0 to z1."""
    u, z = _grid(x0, x1, z0, z1)
    return np.vstack([np.c_[u, np.full(u.size, y), z] for y in (-HALF[1], HALF[1])])


def _candidate(top: float, back: bool = True) -> np.ndarray:
    """The candidate's faces from the floor up to ``top``: all four, or without its back
    (y = 0.15) when it stands against a wall there."""
    ends = []
    for x in (-HALF[0], HALF[0]):
        v, z = _grid(-HALF[1], HALF[1], 0.0, top)
        ends.append(np.c_[np.full(v.size, x), v, z])
    faces = _x_faces(-HALF[0], HALF[0], 0.0, top)
    if not back:
        faces = faces[faces[:, 1] < 0.0]
    return np.vstack([faces, *ends])


def _floor() -> np.ndarray:
    fx, fy = np.meshgrid(np.arange(-2.0, 2.0, 0.05), np.arange(-2.0, 2.0, 0.05))
    return np.c_[fx.ravel(), fy.ravel(), np.zeros(fx.size)]


def _judge(
    above: np.ndarray, top: float, rng: np.random.Generator, carries: bool = True,
    back: bool = True,
) -> bool:  # fmt: skip
    """Run the wall-piece test on the candidate standing to ``top`` with ``above`` (the
    wall, arches or beam beside and over it) and a floor; ``carries``: whether it
    carries something (its top is looked at only then), ``back``: whether its back face
    is seen."""
    own = _candidate(top, back)
    p = np.vstack([own, above, _floor()])
    p = p + rng.normal(0.0, 0.002, p.shape)
    band = height_bands(p)

    sh = {"class": "pier", "centre": np.zeros(2), "angle": 0.0, "half": HALF.copy()}
    sc = scales(STEP, SupportParams())
    rho, _ = offset(p[:, :2], sh)
    cookie = np.flatnonzero(rho <= 0.3)
    pts, rho = p[cookie], rho[cookie]
    feet = (0.0,)
    own_top = top - 0.02 if carries else None
    return wall_piece_in_bands(p, pts, rho, sh, sc, H_SEC, feet, own_top, band)


def test_wall_piece_between_two_doors_is_walled_above_the_lintels() -> None:
    """Draw 29's piece: doors 1.5 m wide on both sides up to lintels at 2.8 m, the wall
    above them up to the ceiling at 3.3 m; the piece reaches 3.28 m.  Its foot is free
    on both sides, so the foot test alone (no top given) keeps it."""
    rng = np.random.default_rng(29)
    above = np.vstack([_x_faces(-1.75, -0.25, 2.8, 3.3), _x_faces(0.25, 1.75, 2.8, 3.3)])
    soffits = np.c_[rng.uniform(-1.75, 1.75, 4000), rng.uniform(-0.15, 0.15, 4000),
                    np.full(4000, 2.8)]  # fmt: skip
    soffits = soffits[np.abs(soffits[:, 0]) > HALF[0]]
    assert _judge(np.vstack([above, soffits]), 3.3, rng)
    assert not _judge(np.vstack([above, soffits]), 3.3, rng, carries=False)  # foot only


def test_wall_piece_between_a_window_and_a_door() -> None:
    """Walled at the foot beyond one end only (the wall under a window's sill at 1.2 m)
    and above the lintel beyond the other (a door up to 2.6 m): neither band alone runs
    on beyond both ends, together they do."""
    rng = np.random.default_rng(30)
    under_sill = _x_faces(-1.75, -0.25, 0.0, 1.2)
    over_window = _x_faces(-1.75, -0.25, 2.6, 3.3)
    over_door = _x_faces(0.25, 1.75, 2.6, 3.3)
    walls = np.vstack([under_sill, over_window, over_door])
    assert _judge(walls, 3.3, rng)
    assert not _judge(walls, 3.3, rng, carries=False)  # the foot: beyond one end only
    # the same lines one band at a time: beyond one end each, on faces it shows
    d = np.array([1.0, 0.0])
    room, out = (d, (True, False), True), (-d, (True, False), True)
    assert not walled_at_both_ends([room], d)
    assert walled_at_both_ends([room, out], d)
    # a pier standing against a wall (a respond): the wall runs on along its back,
    # which it does not show
    back = (-d, (True, False), False)
    assert not walled_at_both_ends([room, back], d)


@pytest.mark.parametrize("kind", ["arcade", "beam"])
def test_piers_of_an_arcade_and_under_a_beam_stand_free_to_their_tops(kind: str) -> None:
    """A pier of an arcade ends where its arches spring (2.6 m): the arches and the wall
    over them rise beside its ends only above its top.  A pier under a beam as wide as
    it is ends at the beam's underside; the beam runs on over the openings."""
    rng = np.random.default_rng(31)
    top = 2.6
    if kind == "arcade":
        radius = 1.0  # semicircular arches springing from the pier's ends
        parts = []
        for sign in (-1.0, 1.0):
            cx = sign * (HALF[0] + radius)
            u, z = _grid(0.0, radius, top, top + radius + 0.5)
            x = sign * (HALF[0] + u)
            solid = (z - top) ** 2 + (x - cx) ** 2 >= radius**2  # spandrel over the arch
            for y in (-HALF[1], HALF[1]):
                parts.append(np.c_[x[solid], np.full(solid.sum(), y), z[solid]])
        above = np.vstack(parts)
    else:
        above = _x_faces(-1.75, 1.75, top, top + 0.5)
    assert not _judge(above, top, rng)


def test_respond_against_a_wall_with_a_door_beside_it_stays() -> None:
    """Draw 37: a pier 0.46 x 0.34 m standing against the aisle wall, a door beside it;
    its cookie reached 0.57 m above its top into the vault it carries.  The wall's room
    face is flush with its back face, beyond one end at its foot and beyond both above
    the door's lintel, along the back it does not show (its sides end there); its front
    face stands out in the room with no wall on its line."""
    rng = np.random.default_rng(37)
    y_room, y_out = HALF[1], HALF[1] + 0.3  # the wall behind it, 0.3 m thick
    parts = []
    for y in (y_room, y_out):
        for x0, x1, z0, z1 in ((-1.75, -0.25, 0.0, 3.3), (0.25, 1.75, 2.6, 3.3)):
            u, z = _grid(x0, x1, z0, z1)
            parts.append(np.c_[u, np.full(u.size, y), z])
    assert not _judge(np.vstack(parts), 3.3, rng, back=False)


@pytest.mark.slow
def test_draw_29_wall_piece_between_two_doors_is_no_pier() -> None:
    """Draw 29: the wall piece between a door and a door-high opening of the side wall
    (x -0.3..0, y 3.75..4.25 m) was a pier found in the low section, from the floor up
    to 3.23 m under the ceiling; above the lintels (2.8 m) the wall runs on beyond both
    its ends, flush with its room face.  Its points stay in the body."""
    from pyheracles.building import segment_building
    from pyheracles.synthetic.families import simulate

    res = simulate("supports", 29).clouds["cloud"]
    _, found, _, _ = segment_building(res.xyz)
    piece = (np.abs(res.xyz[:, 0] + 0.16) < 0.25) & (np.abs(res.xyz[:, 1] - 3.99) < 0.25)
    assert piece.sum() > 1000
    assert not found.instance[piece].any(), found.objects[["class", "x", "y"]]
