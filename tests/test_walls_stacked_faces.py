"""Walls: a wall's face crossed by a roof, seen in two pieces one above the other (a
nave arcade's aisle side under the aisle's lean-to roof and its clerestory over it), is
one face of that wall (``pyheracles.walls.pairing.join_coplanar``), and a face cut at a
junction keeps a piece as long as half ``min_length_m`` (``walls.junctions.cut_faces``:
an aisled front's outer face beside a tower)."""

from __future__ import annotations

import numpy as np
import pytest

from church_walls import faces_along_x
from pyheracles.walls.model import WallParams


def _face(rng: np.random.Generator, x: float, y: tuple[float, float], z: tuple[float, float],
          n: int) -> np.ndarray:  # fmt: skip
    """``n`` points on the plane x = ``x`` over ``y`` by ``z`` (m), 2 mm noise."""
    return np.c_[np.full(n, x) + rng.normal(0.0, 0.002, n), rng.uniform(*y, n),
                 rng.uniform(*z, n)]  # fmt: skip


def _arcade(seed: int) -> tuple[np.ndarray, list]:
    """Church draw 29's north arcade (0.61 m): the nave side 15.3 m long up to 11.2 m,
    the aisle side below the aisle's roof (up to 4.4 m) and the clerestory above it
    (from 5.6 m), on one plane."""
    rng = np.random.default_rng(seed)
    nave = _face(rng, 0.0, (0.6, 15.9), (0.0, 11.2), 60000)
    clerestory = _face(rng, 0.61, (0.0, 16.4), (5.6, 11.2), 20000)
    aisle = _face(rng, 0.61, (0.6, 15.4), (0.0, 4.4), 20000)
    return faces_along_x(nave, clerestory, aisle)


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_aisle_side_under_a_roof_joins_the_arcade(seed: int) -> None:
    """The clerestory pairs with the nave side; the aisle side, alone, was a wall of its
    own (two walls on the arcade's outer plane): it is the same wall's face."""
    from pyheracles.walls.pairing import join_coplanar, pair_faces

    xyz, faces = _arcade(seed)
    p = WallParams()
    groups = pair_faces(xyz, faces, p)
    assert sorted(map(len, groups)) == [1, 2]
    out, joined = join_coplanar(xyz, faces, groups, p)
    assert joined == [(0, 1)] and len(out) == 2
    outer = xyz[out[1].indices]
    assert outer[:, 2].min() < 0.1 and outer[:, 2].max() > 11.0
    assert abs(out[1].d - 0.61) < 0.005 and out[1].rms_m < 0.005


def test_roof_crossed_face_is_one_wall() -> None:
    """The whole chain: one wall on both faces (it was two, the aisle side a lone face)."""
    from pyheracles.walls import segment_walls

    xyz, _ = _arcade(29)
    r = segment_walls(xyz)
    assert len(r.walls) == 1
    assert len(r.walls[0].faces) == 2 and abs(r.walls[0].thickness_m - 0.61) < 0.01


def test_face_past_the_other_face_stays_apart() -> None:
    """A face on the outer plane above the nave side's top (a tower's face flush with a
    front) or wholly past its end is no piece of that wall: it stays alone."""
    from pyheracles.walls.pairing import join_coplanar, pair_faces

    rng = np.random.default_rng(4)
    nave = _face(rng, 0.0, (0.6, 15.9), (0.0, 11.2), 60000)
    outer = _face(rng, 0.61, (0.0, 16.4), (0.0, 11.2), 40000)
    tower = _face(rng, 0.61, (4.0, 12.0), (12.5, 24.0), 20000)
    beyond = _face(rng, 0.61, (17.5, 21.0), (0.0, 9.0), 20000)
    xyz, faces = faces_along_x(nave, outer, tower, beyond)
    p = WallParams()
    groups = pair_faces(xyz, faces, p)
    out, joined = join_coplanar(xyz, faces, groups, p)
    assert sorted(joined) == [(0, 1), (2,), (3,)] and len(out) == 4


def _front() -> tuple[list, np.ndarray, list]:
    """Church draw 29's west front (x = 0 outer, 0.61 m): its outer face beside the
    tower, y 3.97-5.08, 11 m high, and the front's wall cut at the arcade's mid-plane."""
    from pyheracles.walls.model import WallFace
    from pyheracles.walls.planes import plane_frame

    rng = np.random.default_rng(29)
    pts = _face(rng, 0.0, (3.97, 5.08), (-0.4, 11.7), 12000)
    n = np.array([1.0, 0.0, 0.0])
    face = WallFace(n, 0.0, np.arange(len(pts)), 0.002)
    origin, u = plane_frame(n, 0.0)
    wall = {"normal": n, "d": 0.0, "origin": origin, "u_axis": u, "faces": [face]}
    return [face], pts, [wall]


def test_piece_beside_a_tower_cut_at_a_junction_is_a_face() -> None:
    """Cut at the arcade's mid-plane (y = 4.966), the nave's piece is 1.0 m long (it fell
    under ``min_length_m``, and the nave's west wall was its inner face alone); the
    aisle's piece, 0.11 m, is a sliver and no face."""
    from pyheracles.walls.junctions import cut_faces
    from pyheracles.walls.planes import plane_frame

    faces, xyz, walls = _front()
    origin, u = plane_frame(np.array([1.0, 0.0, 0.0]), 0.0)
    cut = float((np.array([0.0, 4.966, 0.0]) - origin) @ u)
    out = cut_faces(xyz, faces, walls, [[cut]], WallParams())
    assert len(out) == 1
    y = xyz[out[0].indices, 1]
    assert y.min() < 4.0 and 4.9 < y.max() < 4.966


@pytest.mark.slow  # simulates a church draw and crops its arcade: about 30-60 s each
@pytest.mark.parametrize("noise_draw", [0, 1, 2, 3])
def test_church29_arcade_aisle_side_in_the_arcade(noise_draw: int) -> None:
    """Church draw 29's north arcade: its aisle side under the aisle's roof is a face of
    the arcade wall, no wall of its own, on the draw's scan and noise draws 1-3."""
    from church_walls import wall_crop
    from pyheracles.walls import segment_walls

    xyz, tw, _ = wall_crop(29, "north", noise_draw)
    n = np.asarray(tw["outer_plane"]["normal"])
    d_out = tw["outer_plane"]["d"]
    r = segment_walls(xyz)
    on_outer = [w for w in r.walls if abs(w.normal @ n) > 0.999 and any(
        abs(abs(f.d) - abs(d_out)) < 0.03 for f in w.faces)]  # fmt: skip
    assert len(on_outer) == 1
    wall = on_outer[0]
    assert len(wall.faces) == 2
    outer = next(f for f in wall.faces if abs(abs(f.d) - abs(d_out)) < 0.03)
    z = xyz[outer.indices, 2]
    assert np.mean(z < 4.5) > 0.2 and np.mean(z > 5.5) > 0.2
