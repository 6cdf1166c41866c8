"""Walls: the edges of openings (church family draw 0 failures), the occupancy grid."""

from __future__ import annotations

import numpy as np
import pytest
import shapely

from pyheracles.synthetic.scanner import TLSStation, scan
from pyheracles.synthetic.scene import Scene
from pyheracles.walls import segment_walls
from pyheracles.walls.openings import refine_edges
from pyheracles.walls.outlines import occupancy

QUIET = {"noise_m": 0.002, "noise_per_m": 0.0, "detection": 1e-9, "mixed_pixel_share": 0.0}
L, T = 8.0, 0.3


def _pointed(u0: float, sill: float, w: float, spring: float, rise: float) -> list:
    r = (w**2 / 4 + rise**2) / (2 * rise)  # two arcs meeting at the apex
    t = np.linspace(0, 1, 24)
    ang = np.arcsin(np.clip(rise / r, 0, 1))
    right = [(u0 + w - r + r * np.cos(a), sill + spring + r * np.sin(a)) for a in t * ang]
    left = [(u0 + r - r * np.cos(a), sill + spring + r * np.sin(a)) for a in t * ang]
    ring = [(u0, sill), (u0 + w, sill), *right, *left[::-1]]
    return list(shapely.Polygon(ring).buffer(0).exterior.coords)[:-1]


@pytest.fixture(scope="module")
def pointed_wall() -> np.ndarray:
    """A south wall 8 m x 4 m, 0.3 m thick, with a pointed window 1.6 m wide, sill at
    0.6 m, head at 3.0 m; scanned inside and outside; a wall behind the window."""
    s = Scene()
    frame = np.array([[1.0, 0, 0], [0, 0, 1.0], [0, 1.0, 0]])
    s.add_prism(shapely.Polygon([(0, 0), (L, 0), (L, 4), (0, 4)], [HOLE]), [0, 0, 0], frame,
                T, instance=1, class_name="wall", part="face")  # fmt: skip
    s.add_quad([[0, 4.5, 0], [L, 4.5, 0], [L, 4.5, 5], [0, 4.5, 5]], instance=9,
               class_name="wall", part="face")  # fmt: skip
    stations = [
        TLSStation((4.0, 4.0, 1.6), step_deg=0.2, **QUIET),
        TLSStation((3.8, -4.0, 1.6), step_deg=0.2, azimuth_deg=(20, 160), **QUIET),
    ]
    return scan(s, stations, rng=1).xyz


HOLE = _pointed(3.0, 0.6, 1.6, 1.6, 0.9)
HEIGHT = max(z for _, z in HOLE) - 0.6  # the arcs' top (2.41 m)


def _window(xyz: np.ndarray):
    r = segment_walls(xyz)
    south = min(r.walls, key=lambda x: abs(x.normal[0]) + abs(x.d * x.normal[1]))
    win = [o for o in south.openings if o.kind == "window"]
    assert len(win) == 1, south.openings
    return win[0]


def test_pointed_head_reaches_the_apex(pointed_wall) -> None:
    """Church draw 0: pointed heads came out 6-18 cm short (the lowest point of the
    central band lies on the arch's flanks); the apex is now the highest column."""
    win = _window(pointed_wall)
    assert win.width_m == pytest.approx(1.6, abs=0.05)
    assert win.height_m == pytest.approx(HEIGHT, abs=0.05)


def test_mixed_pixels_on_the_sill_do_not_raise_it(pointed_wall) -> None:
    """Church draw 0 north wall: a scan line of mixed pixels standing on a sill, up to
    2 cm off the face plane, raised the sill by 16 cm; and stray returns inside the
    opening cut its head by 1.2 m.  Both kinds are added to the scan here."""
    rng = np.random.default_rng(3)
    u = rng.uniform(3.7, 3.95, 40)  # a line of mixed pixels over the sill's centre
    line = np.c_[u, rng.uniform(-0.02, 0.02, 40), 0.6 + 0.16 * (u - 3.7) / 0.25]
    strays = np.c_[rng.uniform(3.3, 4.3, 12), rng.uniform(-0.02, 0.02, 12),
                   rng.uniform(1.2, 2.4, 12)]  # fmt: skip
    win = _window(np.vstack([pointed_wall, line, strays]))
    assert win.width_m == pytest.approx(1.6, abs=0.05)
    assert win.z_min == pytest.approx(0.6, abs=0.05)
    assert win.height_m == pytest.approx(HEIGHT, abs=0.05)


def test_refine_edges_takes_the_narrowest_face() -> None:
    """Two faces around one opening: the inner one splayed 0.15 m wider each side and
    higher; the opening through the wall is the outer face's (church draw 0 heads)."""
    rng = np.random.default_rng(0)

    def face(u0, u1, z0, z1, step):  # a scan grid with 2 mm noise
        g = np.mgrid[u0 - 0.6 : u1 + 0.6 : step, z0 - 0.6 : z1 + 0.6 : step].reshape(2, -1).T
        p = g + rng.normal(0, 0.002, g.shape)
        return p[~((p[:, 0] > u0) & (p[:, 0] < u1) & (p[:, 1] > z0) & (p[:, 1] < z1))]

    outer = face(0.0, 1.0, 1.0, 3.0, 0.03)  # from afar
    inner = face(-0.15, 1.15, 0.9, 3.15, 0.01)
    uz = np.r_[outer, inner]
    of = np.r_[np.zeros(len(outer), int), np.ones(len(inner), int)]
    u0, u1, z0, z1 = refine_edges(uz, of, -0.05, 1.05, 0.95, 3.05, 0.05, False, (1.1, 2.9))
    assert (u0, u1, z0, z1) == pytest.approx((0.0, 1.0, 1.0, 3.0), abs=0.02)


def test_sparse_face_gaps_are_closed_dense_holes_stay() -> None:
    """A face scanned in lines two cells apart (the foot of an outer face, church draw
    0) is covered after closing; a 0.3 m hole in a dense face stays open."""
    sparse = np.array([(i, j) for i in range(40) for j in range(0, 20, 2) if (i + j) % 3])
    ij = np.array([(i, j) for i in range(40) for j in range(20, 60)
                   if not (10 <= i < 16 and 30 <= j < 36)] * 3)  # fmt: skip
    occ = occupancy(np.r_[sparse, ij], (40, 60))
    assert occ[2:38, 2:18].all()  # the porous band is wall
    assert not occ[10:16, 30:36].any()  # the hole is open


def test_head_of_a_sharp_pointed_arch_is_its_apex() -> None:
    """An equilateral pointed head 1.8 m wide (church draw 0): near the apex its flanks
    rise at 60 deg, so the lowest point of a central band 0.18 m wide lies 15 cm below
    the apex; the highest column minimum is the apex."""
    from pyheracles.walls.openings import head_sill

    w, spring = 1.8, 2.0
    g = np.mgrid[-1.2:1.2:0.01, 0.5:4.5:0.01].reshape(2, -1).T
    u, z = g[:, 0], g[:, 1]
    arch = spring + np.sqrt(np.clip(w**2 - (np.abs(u) + w / 2) ** 2, 0, None))  # head
    hole = (np.abs(u) < w / 2) & (z > 1.0) & (z < arch)
    apex = spring + np.sqrt(w**2 - (w / 2) ** 2)
    sill, head = head_sill(g[~hole], -w / 2, w / 2, 1.0, apex - 0.04, 0.05, 0.0125, False)
    assert head == pytest.approx(apex, abs=0.02)
    assert sill == pytest.approx(1.0, abs=0.01)


def test_door_over_a_step_starts_at_the_floor() -> None:
    """Church draw 4: the floor inside stands 0.18 m above the ground outside; the doors
    came out 18 cm too tall, from the ground (the outer face's foot, hidden under the
    door by a doorstep).  The opening
    through the wall starts where both faces are open: at the floor."""
    s = Scene()
    frame = np.array([[1.0, 0, 0], [0, 0, 1.0], [0, 1.0, 0]])
    door = [(3.0, 0.0), (4.2, 0.0), (4.2, 2.2), (3.0, 2.2)]
    s.add_prism(shapely.Polygon([(0, -0.18), (L, -0.18), (L, 4), (0, 4)], [door]), [0, 0, 0],
                frame, T, instance=1, class_name="wall", part="face")  # fmt: skip
    s.add_quad([[0, T, 0], [L, T, 0], [L, 4.5, 0], [0, 4.5, 0]], instance=8,
               class_name="floor", part="face")  # fmt: skip
    s.add_quad([[0, -6, -0.18], [L, -6, -0.18], [L, 0, -0.18], [0, 0, -0.18]], instance=7,
               class_name="ground", part="face")  # fmt: skip
    s.add_quad([[0, 4.5, 0], [L, 4.5, 0], [L, 4.5, 5], [0, 4.5, 5]], instance=9,
               class_name="wall", part="face")  # fmt: skip
    for q in (
        [[3, -0.4, 0], [4.2, -0.4, 0], [4.2, 0, 0], [3, 0, 0]],  # a doorstep
        [[3, -0.4, -0.18], [4.2, -0.4, -0.18], [4.2, -0.4, 0], [3, -0.4, 0]],
    ):
        s.add_quad(q, instance=6, class_name="step", part="face")  # fmt: skip
    stations = [
        TLSStation((4.0, 4.0, 1.6), step_deg=0.2, **QUIET),
        TLSStation((3.8, -4.0, 1.6), step_deg=0.2, azimuth_deg=(20, 160), **QUIET),
    ]
    r = segment_walls(scan(s, stations, rng=2).xyz)
    south = min(r.walls, key=lambda x: abs(x.normal[0]) + abs(x.d * x.normal[1]))
    doors = [o for o in south.openings if o.kind == "door"]
    assert len(doors) == 1, south.openings
    assert doors[0].z_min == pytest.approx(0.0, abs=0.05)
    assert doors[0].height_m == pytest.approx(2.2, abs=0.05)
    assert doors[0].width_m == pytest.approx(1.2, abs=0.05)
