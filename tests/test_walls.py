"""Walls: planes, thickness where both faces are seen, openings, joins, bad input."""

from __future__ import annotations

import numpy as np
import pytest
import shapely

from pyheracles.synthetic.scanner import TLSStation, scan
from pyheracles.synthetic.scene import Scene
from pyheracles.walls import WallParams, intersect_planes, segment_walls

QUIET = {"noise_m": 0.002, "noise_per_m": 0.0, "detection": 1e-9, "mixed_pixel_share": 0.0}
L, W, H, T = 8.0, 6.0, 3.0, 0.3  # outer size, height, wall thickness
WINDOW = (3.0, 1.0, 1.0, 1.2)  # u, sill, width, height on the south wall
DOOR = (2.0, 0.9, 2.1)  # u, width, height on the west wall


def _wall(s: Scene, p0, p1, inst: int, holes=()) -> None:
    p0, p1 = np.asarray(p0, float), np.asarray(p1, float)
    length = float(np.linalg.norm(p1 - p0))
    u = (p1 - p0) / length
    frame = np.array([[u[0], u[1], 0.0], [0.0, 0.0, 1.0], [-u[1], u[0], 0.0]])
    poly = shapely.Polygon([(0, 0), (length, 0), (length, H), (0, H)], holes)
    s.add_prism(poly, [p0[0], p0[1], 0.0], frame, T, instance=inst, class_name="wall",
                part="face")  # fmt: skip


@pytest.fixture(scope="module")
def room() -> tuple[np.ndarray, np.ndarray]:
    s = Scene()
    u, z, w, h = WINDOW
    win = [[(u, z), (u + w, z), (u + w, z + h), (u, z + h)]]
    du, dw, dh = DOOR
    door = [[(du, 0.0), (du + dw, 0.0), (du + dw, dh), (du, dh)]]
    # outer faces on the rectangle [0, L] x [0, W]; the inside to the left of p0 -> p1
    _wall(s, (0, 0), (L, 0), 1, win)
    _wall(s, (L, 0), (L, W), 2)
    _wall(s, (L, W), (0, W), 3)
    _wall(s, (0, W), (0, 0), 4, door)
    s.add_quad([[0, 0, 0], [L, 0, 0], [L, W, 0], [0, W, 0]], instance=9,
               class_name="floor", part="floor")  # fmt: skip
    stations = [
        TLSStation((L / 2, W / 2, 1.5), step_deg=0.25, **QUIET),
        TLSStation((3.5, -4.0, 1.6), step_deg=0.25, azimuth_deg=(20, 160), **QUIET),
    ]
    res = scan(s, stations, rng=0)
    return res.xyz, res.instance


def test_intersect_planes_least_squares() -> None:
    x = intersect_planes([[1, 0, 0], [0, 1, 0], [0.7071, 0.7071, 0]], [2.0, 3.0, 3.5355])
    assert np.allclose(x[:2], [2.0, 3.0], atol=1e-3)


def test_room_walls_planes_thickness_openings(room) -> None:
    xyz, inst = room
    r = segment_walls(xyz)
    tab = r.objects_table()
    assert len(r.walls) == 4, tab
    # south wall: both faces seen, thickness measured; the others one face (explicit)
    south = min(r.walls, key=lambda w: abs(w.d * w.normal[1]) + abs(w.normal[0]) * 10)
    assert len(south.faces) == 2
    assert south.thickness_m == pytest.approx(T, abs=0.01)
    for w in r.walls:
        assert w.rms_m < 0.01
        if len(w.faces) == 1:
            assert np.isnan(w.thickness_m)
    assert sum("one face" in n for n in r.notes) == 3
    windows = [o for o in south.openings if o.kind == "window"]
    assert len(windows) == 1
    assert windows[0].width_m == pytest.approx(WINDOW[2], abs=0.05)
    assert windows[0].height_m == pytest.approx(WINDOW[3], abs=0.05)
    doors = [o for w in r.walls for o in w.openings if o.kind == "door"]
    assert len(doors) == 1
    assert doors[0].width_m == pytest.approx(DOOR[1], abs=0.05)
    assert doors[0].height_m == pytest.approx(DOOR[2], abs=0.05)
    # labels: wall points carry their wall, mostly the true one
    for w in r.walls:
        truth = np.bincount(inst[r.labels == w.instance]).argmax()
        assert truth in (1, 2, 3, 4)
    # joins: the walls' lengths end at the plane intersections (inner faces: L - 2T ...)
    lengths = sorted(round(w.length_m, 2) for w in r.walls if len(w.faces) == 1)
    assert lengths[-1] == pytest.approx(L - 2 * T, abs=0.06)


def test_no_vertical_planes_gives_a_note() -> None:
    rng = np.random.default_rng(0)
    xyz = np.c_[rng.uniform(0, 10, 5000), rng.uniform(0, 10, 5000), rng.normal(0, 0.002, 5000)]
    r = segment_walls(xyz)
    assert r.walls == ()
    assert not r.labels.any()
    assert r.notes and "no walls" in r.notes[0]
    assert len(r.objects_table()) == 0
    r.to_segmentation().check_balance()


def test_bad_parameters_are_refused() -> None:
    with pytest.raises(ValueError, match="distance_m"):
        WallParams(distance_m=-1)
