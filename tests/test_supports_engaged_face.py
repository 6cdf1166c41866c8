"""Engaged columns told by their wall's face, not by the points next to the shaft.

Draw 39 of the supports family (a nave of 0.6 m engaged columns, 17 m tall, their
centres 0.34 m in front of the wall face, the section 9.6 m above the floor): 8 of the
15 engaged columns found were classed free-standing.  In the section's 10 cm slab the
wall beside them held 0-31 points within 1.7 m (sparse high up and shadowed by the
shaft), so no wall island stood next to them; and the 3-D check of the face counted
cells of 3 cm over the face's 17 m, of which a wall seen at 5-15 cm spacing fills
5-45 %, although its points were in 64-68 of about 70 layers of 25 cm.
"""

from __future__ import annotations

import numpy as np

from pyheracles.supports.cookies import face_cover
from pyheracles.supports.core import Scales
from pyheracles.supports.rings import wall_face_beside

SC = Scales(spacing=0.01, distance=0.04, thickness=0.1, tol=0.03)
R = 0.58  # draw 39's columns
FACE_Y = -0.34  # the wall's face, 0.34 m behind the column's axis


def _shape() -> dict:
    return {"class": "engaged_column", "centre": np.zeros(2), "radius": R,
            "normal": np.array([0.0, 1.0]), "d": FACE_Y, "face_gap": 0.01,
            "buffer": 0.8}  # fmt: skip


def _face(z_top: float, x_range: tuple[float, float], step: tuple[float, float]) -> np.ndarray:
    """Points of the face y = FACE_Y on both sides of the column, spaced ``step`` (along,
    up): a wall seen high up and far from the stations."""
    xs = np.arange(x_range[0], x_range[1], step[0])
    xs = np.r_[-xs, xs]
    zs = np.arange(0.05, z_top, step[1])
    x, z = np.meshgrid(xs, zs)
    return np.c_[x.ravel(), np.full(x.size, FACE_Y), z.ravel()]


def _cover(pts: np.ndarray) -> float:
    sh = _shape()
    front = pts[:, :2] @ sh["normal"] - sh["d"]
    rho = np.hypot(pts[:, 0], pts[:, 1]) - R
    return face_cover(pts, pts[:, 2], front, rho, sh, SC, 0.0, 17.0)


def test_a_sparse_wall_face_covers_the_column_height() -> None:
    # 12 cm along and 15 cm up: every layer of the face holds it, few 3 cm cells do
    assert _cover(_face(17.0, (0.75, 1.6), (0.12, 0.15))) >= 0.9


def test_a_fence_or_a_post_beside_a_column_is_no_wall() -> None:
    assert _cover(_face(1.0, (0.75, 1.6), (0.03, 0.03))) < 0.5  # a dense fence, 1 m high
    post = _face(17.0, (1.0, 1.1), (0.02, 0.02))  # a 10 cm post each side, full height
    assert _cover(post[post[:, 0] > 0]) < 0.5


def _ring(arc_deg: float, n: int = 60) -> np.ndarray:
    """Section points on the ring, the arc centred on the room side (+y)."""
    half = np.radians(arc_deg) / 2
    a = np.pi / 2 + np.linspace(-half, half, n)
    return np.c_[R * np.cos(a), R * np.sin(a)]


def _wall_beside(rng: np.random.Generator, y: float = FACE_Y) -> np.ndarray:
    """A slab's wall points beside the column: its face beyond the shaft's shadow,
    sparse (draw 39: 30-350 points within 1.6 m of the axis)."""
    x = rng.uniform(0.9, 1.6, 120) * rng.choice([-1.0, 1.0], 120)
    return np.c_[x, y + rng.normal(0.0, 0.003, 120)]


def test_a_ring_stopping_at_a_wall_face_is_engaged() -> None:
    rng = np.random.default_rng(39)
    ring = _ring(249.0)  # the part of the ring in front of the face
    face = wall_face_beside(np.vstack([ring, _wall_beside(rng)]), ring, np.zeros(2), R, 0.03, rng)
    assert face is not None
    normal, d, rms = face
    assert normal[1] > 0.99  # into the room
    assert abs(d - FACE_Y) < 0.01 and rms < 0.01


def test_a_free_ring_is_not_engaged() -> None:
    rng = np.random.default_rng(40)
    # a column standing 0.4 m clear of a wall: its face is too far from the axis
    ring = _ring(360.0)
    far = _wall_beside(rng, y=-(R + 0.4))
    assert wall_face_beside(np.vstack([ring, far]), ring, np.zeros(2), R, 0.03, rng) is None
    # a ring seen all round does not stop at the line of the wall points beside it
    # (a column standing in line with a wall's face, as at the end of a portico)
    near = _wall_beside(rng)
    assert wall_face_beside(np.vstack([ring, near]), ring, np.zeros(2), R, 0.03, rng) is None


def test_a_scaffold_through_a_column_is_no_wall_face() -> None:
    """Draw 46 (held out): scaffold standards and ledgers on a line through free columns
    seen from one side passed for the wall they stand in.  A wall's face is a surface:
    its points fill the slab's height wherever it is seen along it; tubes do not."""
    rng = np.random.default_rng(46)
    ring = _ring(180.0)
    # a wall's face beside the column, with heights over the 0.6 m slab
    wall = _wall_beside(rng)
    wall_z = rng.uniform(0.0, 0.6, len(wall))
    ring_z = rng.uniform(0.0, 0.6, len(ring))
    around, up = np.vstack([ring, wall]), np.r_[ring_z, wall_z]
    assert wall_face_beside(around, ring, np.zeros(2), R, 0.03, rng, up) is not None
    # standards (vertical tubes) every 0.5 m and one ledger 0.4 m up on the same line
    xs = np.r_[-1.5, -1.0, 1.0, 1.5]
    std = np.c_[np.repeat(xs, 40), np.full(160, FACE_Y)] + rng.normal(0, 0.003, (160, 2))
    std_z = np.tile(np.linspace(0.0, 0.6, 40), len(xs))
    x = rng.uniform(0.9, 1.6, 80) * rng.choice([-1.0, 1.0], 80)
    ledger = np.c_[x, np.full(80, FACE_Y)]
    tubes = np.vstack([std, ledger])
    tubes_z = np.r_[std_z, np.full(80, 0.4)]
    around, up = np.vstack([ring, tubes]), np.r_[ring_z, tubes_z]
    assert wall_face_beside(around, ring, np.zeros(2), R, 0.03, rng, up) is None
