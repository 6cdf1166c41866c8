"""Walls: the foot of a wall under stray returns below it (church draws 8 and 9)."""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.walls import segment_walls


def _face(rng: np.random.Generator, x: float, door: tuple[float, float, float],
          spacing: float = 0.04) -> np.ndarray:  # fmt: skip
    """A face ``x`` = const, 12 m long and 6 m high, scanned on a jittered grid, with a
    door ``(u0, u1, head)`` from the floor."""
    u, z = np.meshgrid(np.arange(0, 12, spacing), np.arange(0, 6, spacing), indexing="ij")
    uz = np.c_[u.ravel(), z.ravel()] + rng.uniform(0, spacing, (u.size, 2))
    keep = ~((uz[:, 0] > door[0]) & (uz[:, 0] < door[1]) & (uz[:, 1] < door[2]))
    uz = uz[keep]
    return np.c_[np.full(len(uz), x) + rng.normal(0, 0.002, len(uz)), uz]


def _wall_with_ghosts(n_ghosts: int) -> tuple[np.ndarray, tuple[float, float, float]]:
    rng = np.random.default_rng(9)
    door = (5.0, 6.6, 3.0)
    faces = [_face(rng, 0.0, door), _face(rng, 1.0, door)]
    # the floor inside and the ground outside, 1.5 m each side, and the doorway's floor
    g = rng.uniform([-1.5, 0.0], [2.5, 12.0], (40000, 2))
    g = g[(g[:, 0] < 0) | (g[:, 0] > 1.0) | ((g[:, 1] > door[0]) & (g[:, 1] < door[1]))]
    ground = np.c_[g, rng.normal(0, 0.003, len(g))]
    # a leaf standing open inside the doorway (points through the door, in the wall)
    lf = rng.uniform([door[0], 0.0], [door[0] + 0.05, door[2]], (3000, 2))
    leaf = np.c_[rng.uniform(0.1, 0.9, len(lf)), lf]
    # multipath returns of the faces' points dropped 0.2-1.5 m straight down, on the
    # faces' planes below the floor, here and there along the wall
    src = np.vstack(faces)
    pick = src[rng.integers(0, len(src), n_ghosts)]
    pick = pick[pick[:, 2] < 1.5]
    pick[:, 2] -= rng.uniform(0.2, 1.5, len(pick)) + pick[:, 2]
    return np.vstack([*faces, ground, leaf, pick]), door


@pytest.mark.parametrize("n_ghosts", [0, 1000, 3000])
def test_door_through_a_wall_with_returns_below_its_foot(n_ghosts: int) -> None:
    """Church draw 9, north wall: a few points on the faces' planes below their foot
    (multipath) lowered the envelope's foot by up to a metre along 2.5 m of wall each,
    and the door's hole ran on along the empty band above them: a door 13.7 m wide
    (draw 8: the band reached the wall's end and the door was lost).  The foot is now
    the lowest within 2.5 m but for half a metre of columns, and bands of empty cells
    lower than an opening are no part of one."""
    xyz, door = _wall_with_ghosts(n_ghosts)
    r = segment_walls(xyz)
    w = max(r.walls, key=lambda x: x.n_points)
    assert len(w.faces) == 2
    doors = [o for o in w.openings if o.kind == "door"]
    assert len(doors) == 1 and len(w.openings) == 1
    assert doors[0].width_m == pytest.approx(door[1] - door[0], abs=0.05)
    assert doors[0].height_m == pytest.approx(door[2], abs=0.05)


def test_slim_runs_drops_runs_at_the_foot_lower_than_an_opening() -> None:
    from pyheracles.walls.outlines import slim_runs

    h = np.zeros((4, 10), dtype=bool)
    h[0, 2:4] = True  # 2 cells from the foot: dropped
    h[1, 1:9] = True  # 8: kept
    h[2, [0, 1, 2, 5, 6, 7, 8, 9]] = True  # 3 from the foot, 5: kept
    h[3, 5:7] = True  # 2 cells above the foot: kept (within an opening)
    foot = np.array([2, 1, 0, 0])
    out = slim_runs(h, 3, foot)
    assert not out[0].any() and out[1].sum() == 8 and out[2].sum() == 8 and out[3].sum() == 2
    assert slim_runs(h, 4, foot)[2].sum() == 5


def test_arch_wider_than_the_feet_window_is_one_opening() -> None:
    """Church draw 2, east wall: the arch into the apse, 5 m wide and 12 m high, was two
    openings either side of a 0.7 m pillar of wall that is not there.  Over its middle
    every column's lowest covered cell is the head, and the foot (the lowest within
    2.5 m) rose to it.  Where that foot stands more than 1.5 m above the lowest within
    10 m, the wall stands over an opening, not on a slope."""
    rng = np.random.default_rng(2)
    arch = (3.5, 8.5, 4.5)
    faces = [_face(rng, 0.0, arch), _face(rng, 1.0, arch)]
    g = rng.uniform([-1.5, 0.0], [2.5, 12.0], (40000, 2))
    g = g[(g[:, 0] < 0) | (g[:, 0] > 1.0) | ((g[:, 1] > arch[0]) & (g[:, 1] < arch[1]))]
    ground = np.c_[g, rng.normal(0, 0.003, len(g))]
    # the reveals: jambs and soffit across the wall's thickness
    jamb = rng.uniform([0.0, 0.0], [1.0, arch[2]], (8000, 2))
    reveals = [np.c_[jamb[:, 0], np.full(len(jamb), u), jamb[:, 1]] for u in arch[:2]]
    head = rng.uniform([0.0, arch[0]], [1.0, arch[1]], (8000, 2))
    reveals.append(np.c_[head, np.full(len(head), arch[2])])
    r = segment_walls(np.vstack([*faces, ground, *reveals]))
    w = max(r.walls, key=lambda x: x.n_points)
    assert len(w.faces) == 2
    assert len(w.openings) == 1
    o = w.openings[0]
    assert o.width_m == pytest.approx(arch[1] - arch[0], abs=0.05)
    assert o.height_m == pytest.approx(arch[2], abs=0.05)
