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


def test_lights_of_one_window_are_one_opening() -> None:
    """Three lights with 0.18 m mullions (church family) are one 1.90 m window; a window
    1.2 m away and a door stay apart; lights at different heights do not merge."""
    from pyheracles.walls import Opening, merge_lights

    def box(kind, u0, u1, z0, z1):
        return Opening(kind, u0, u1, z0, z1, np.array([[u0, z0], [u1, z0], [u1, z1], [u0, z1]]))

    lights = [box("window", 1.0 + k * 0.64, 1.46 + k * 0.64, 2.0, 4.5) for k in range(3)]
    other = box("window", 4.10, 4.90, 2.0, 4.5)
    door = box("door", 6.0, 7.2, 0.0, 2.4)
    high = box("window", 8.2, 8.6, 5.5, 6.0)  # a clerestory light beside...
    low = box("window", 8.8, 9.2, 2.0, 3.0)  # ...and a low one: no common height
    out = merge_lights([*lights, other, door, high, low], 0.3)
    assert len(out) == 5
    w = out[0]
    assert w.n_lights == 3 and abs(w.width_m - 1.74) < 1e-9 and abs(w.height_m - 2.5) < 1e-9
    import shapely

    assert abs(shapely.Polygon(w.polygon).area - 1.74 * 2.5) < 1e-6  # mullions included
    assert [o.n_lights for o in out[1:]] == [1, 1, 1, 1]
    assert merge_lights([*lights], 0.1) == sorted(lights, key=lambda o: o.u_min)  # 0.18 > 0.1


def test_pointed_window_keeps_its_width() -> None:
    """A pointed window 1.6 m wide (church family seed 0): its sides were refined in the
    head, where the arch narrows, and it came out 1.0-1.5 m wide; the jambs now set it."""
    s = Scene()
    u0, sill, w, spring, rise = 3.0, 0.6, 1.6, 1.6, 0.9
    r = (w**2 / 4 + rise**2) / (2 * rise)  # two arcs meeting at the apex
    t = np.linspace(0, 1, 24)
    left_c, right_c = u0 + w - r, u0 + r
    ang_r = np.arcsin(np.clip(rise / r, 0, 1))
    right_arc = [(left_c + r * np.cos(a), sill + spring + r * np.sin(a)) for a in t * ang_r]
    left_arc = [(right_c - r * np.cos(a), sill + spring + r * np.sin(a)) for a in t * ang_r]
    ring = [(u0, sill), (u0 + w, sill), *right_arc, *left_arc[::-1]]
    hole = shapely.Polygon(ring).buffer(0)
    _wall_h(s, (0, 0), (L, 0), 1, [list(hole.exterior.coords)[:-1]])
    stations = [
        TLSStation((4.0, 4.0, 1.6), step_deg=0.2, **QUIET),
        TLSStation((3.8, -4.0, 1.6), step_deg=0.2, azimuth_deg=(20, 160), **QUIET),
    ]
    s.add_quad(
        [[0, 4.5, 0], [L, 4.5, 0], [L, 4.5, 5], [0, 4.5, 5]],
        instance=9,
        class_name="wall",
        part="face",
    )  # something seen through the window
    res = scan(s, stations, rng=1)
    walls = segment_walls(res.xyz)
    south = min(walls.walls, key=lambda x: abs(x.normal[0]) + abs(x.d * x.normal[1]))
    win = [o for o in south.openings if o.kind == "window"]
    assert len(win) == 1
    assert win[0].width_m == pytest.approx(w, abs=0.05)
    # these arcs top out before they meet (rise > radius): the hole's own top
    top = max(z for _, z in hole.exterior.coords) - sill
    assert win[0].height_m == pytest.approx(top, abs=0.05)


def _wall_h(s: Scene, p0, p1, inst: int, holes=(), height: float = 4.0) -> None:
    p0, p1 = np.asarray(p0, float), np.asarray(p1, float)
    length = float(np.linalg.norm(p1 - p0))
    u = (p1 - p0) / length
    frame = np.array([[u[0], u[1], 0.0], [0.0, 0.0, 1.0], [-u[1], u[0], 0.0]])
    poly = shapely.Polygon([(0, 0), (length, 0), (length, height), (0, height)], holes)
    s.add_prism(poly, [p0[0], p0[1], 0.0], frame, T, instance=inst, class_name="wall",
                part="face")  # fmt: skip


def test_cli_walls_door_step_and_mullion_options(room, tmp_path) -> None:
    """``--door-step`` and ``--max-mullion`` reach WallParams (run.json says so); a negative
    value is one line and exit code 2."""
    import json

    from pyheracles.cli import main
    from pyheracles.cloud import PointCloud
    from pyheracles.io import write_cloud

    xyz, _ = room
    src = tmp_path / "room.laz"
    write_cloud(PointCloud.from_world(xyz[::3] + [500000.0, 5400000.0, 100.0]), src)
    out = tmp_path / "w"
    assert main(["walls", str(src), "-o", str(out), "--door-step", "0.35",
                 "--max-mullion", "0.15"]) == 0  # fmt: skip
    used = json.loads((out / "run.json").read_text())["parameters"]["walls"]
    assert used["door_step_m"] == 0.35 and used["max_mullion_m"] == 0.15
    doc = json.loads((out / "walls.json").read_text())
    assert doc["walls"], "the room's walls are found"
    assert main(["walls", str(src), "-o", str(tmp_path / "bad"), "--door-step", "-1"]) == 2
