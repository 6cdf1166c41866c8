"""Walls: a front cut where the nave's arcade walls abut it (T junctions), not at a tower.

Church draws 10, 12, 15 and 16 (aisled): the west and east fronts are one plane from
one aisle's outer corner to the other's, but three true walls (the aisles' end walls
and the nave's gable).  Their inner face, interrupted by the arcades' ends only 0.5-0.7
m wide, was one face with the outer face, and the aisles' end walls were never found
(held-out draws: 4-8 walls a draw).
"""

from __future__ import annotations

import numpy as np

from pyheracles.walls import segment_walls

SPACING = 0.05
T = 0.6  # thickness of every wall


def _face(rng, x0, y0, x1, y1, z1, gaps=()) -> np.ndarray:
    """Points on the vertical rectangle from ``(x0, y0)`` to ``(x1, y1)``, 0 to ``z1``
    high, jittered on a grid; ``gaps``: ``(a, b)`` stretches along it left out."""
    length = float(np.hypot(x1 - x0, y1 - y0))
    s, z = np.meshgrid(np.arange(0, length, SPACING), np.arange(0, z1, SPACING))
    s = s.ravel() + rng.uniform(0, SPACING, s.size)
    z = z.ravel() + rng.uniform(0, SPACING, z.size)
    keep = np.ones(s.size, dtype=bool)
    for a, b in gaps:
        keep &= (s < a) | (s > b)
    s, z = s[keep], z[keep]
    t = s / length
    xyz = np.c_[x0 + t * (x1 - x0), y0 + t * (y1 - y0), z]
    xyz[:, :2] += rng.normal(0, 0.002, (len(xyz), 2))
    return xyz


def _aisled_front(tower: bool, aisle_end_hidden: bool = False) -> np.ndarray:
    """A front on x = 0 (outer face) and x = T (inner), y from -7 to 7, 6 m high, and
    the nave's two arcade walls abutting it inside at y = +-4 (outer lines), 12 m long;
    with ``tower``, a tower's two side walls against its outer face at y = +-2, the
    front's outer face between them unseen (inside the tower); with
    ``aisle_end_hidden``, the front's inner face in the aisle at y < -4 unseen."""
    rng = np.random.default_rng(0)
    arcades = [(-4.0, -4.0 + T), (4.0 - T, 4.0)]
    inner_gaps = [(a + 7.0, b + 7.0) for a, b in arcades]
    if aisle_end_hidden:
        inner_gaps.append((-1.0, 3.0 + T))
    outer_gaps = [(5.0, 9.0)] if tower else []
    parts = [_face(rng, 0.0, -7.0, 0.0, 7.0, 6.0, outer_gaps),
             _face(rng, T, -7.0, T, 7.0, 6.0, inner_gaps)]  # fmt: skip
    for a, b in arcades:
        parts += [_face(rng, T, a, 12.0, a, 8.0), _face(rng, T, b, 12.0, b, 8.0)]
    if tower:
        for y in (-2.0, 2.0):
            parts.append(_face(rng, 0.0, y, -4.0, y, 10.0))
        parts.append(_face(rng, -4.0, -2.0, -4.0, 2.0, 10.0))
    return np.vstack(parts)


def _front_walls(xyz: np.ndarray):
    r = segment_walls(xyz)
    front = [w for w in r.walls if abs(w.normal[0]) > 0.99 and abs(w.d) < 1.0]
    return sorted(front, key=lambda w: float(np.mean(xyz[w.faces[0].indices, 1])))


def test_front_is_cut_where_the_arcades_abut_it() -> None:
    """Three walls on the front's plane, each with both faces: the aisles' end walls
    (y -7 to -4 and 4 to 7) and the nave's (-4 to 4); one wall before the cut."""
    xyz = _aisled_front(tower=False)
    front = _front_walls(xyz)
    assert len(front) == 3
    for w, (lo, hi) in zip(front, [(-7.0, -4.0), (-4.0, 4.0), (4.0, 7.0)], strict=True):
        assert len(w.faces) == 2
        y = xyz[np.concatenate([f.indices for f in w.faces]), 1]
        assert np.mean((y > lo - T) & (y < hi + T)) > 0.99
        assert abs(w.thickness_m - T) < 0.01


def test_a_tower_against_the_front_does_not_cut_it() -> None:
    """A tower's side walls meet the front's outer face where that face stops (it is
    not seen inside the tower): the front is cut at the arcades only, the nave's inner
    face one face from arcade to arcade.  (The outer face's two pieces beside the
    tower face one inner face: one pairs with it, the other stays a lone face.)"""
    xyz = _aisled_front(tower=True)
    front = [w for w in _front_walls(xyz) if len(w.faces) == 2]
    assert len(front) == 3
    for w, (lo, hi) in zip(front, [(-7.0, -4.0), (-4.0, 4.0), (4.0, 7.0)], strict=True):
        y = xyz[np.concatenate([f.indices for f in w.faces]), 1]
        assert np.mean((y > lo - T) & (y < hi + T)) > 0.99
    inner = max(front[1].faces, key=lambda f: abs(f.d))
    y = xyz[inner.indices, 1]
    assert y.min() < -4.0 + T + 0.05 and y.max() > 4.0 - T - 0.05


def test_front_is_cut_where_its_inner_face_stops_at_an_arcade() -> None:
    """The front's inner face stops at an arcade, its outer face runs on (church draws
    15 and 25: a south tower built into the aisle's west end hides the aisle's end
    wall inside): the aisle's end wall (y -7 to -4) is a wall of its own, seen on its
    outer face, and the nave's wall ends at the arcade.  Before: the nave's outer face
    ran on to the aisle's corner, and the aisle's end wall was part of the nave's."""
    xyz = _aisled_front(tower=False, aisle_end_hidden=True)
    front = _front_walls(xyz)
    assert len(front) == 3
    aisle, nave = front[0], front[1]
    assert len(aisle.faces) == 1 and len(nave.faces) == 2
    y = xyz[aisle.faces[0].indices, 1]
    assert y.max() < -4.0 + T and y.min() < -6.9
    y = xyz[np.concatenate([f.indices for f in nave.faces]), 1]
    assert y.min() > -4.0 - 0.05
