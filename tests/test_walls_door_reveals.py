"""Walls: a door's jambs from its reveals, its leaf left out (church draws 3 and 9)."""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.synthetic.families.church import draw_params
from pyheracles.synthetic.families.church_geometry import add_wall
from pyheracles.synthetic.families.church_layout import build_church
from pyheracles.synthetic.scanner import TLSStation, scan
from pyheracles.synthetic.scene import GROUND, Scene
from pyheracles.walls import segment_walls
from pyheracles.walls.reveals import RevealParams, pane_mask


def _door_scan(seed: int, name: str, inside: list, outside: list, step: float,
               box: tuple[float, float, float]) -> tuple[np.ndarray, dict]:  # fmt: skip
    """The wall ``name`` of church draw ``seed``, scanned from the draw's stations at
    ``step`` (deg), its points with ``box[0]`` < x < ``box[1]`` and z < ``box[2]``; the
    record of its door there."""
    p = draw_params(seed, exterior_kind="tls")
    plan, _ = build_church(p, np.random.default_rng([seed, 1]))
    wall = next(w for w in plan.walls if w.name == name)
    scene = Scene()
    objs = add_wall(scene, wall)
    # the ground outside and the floor inside at z = 0, as in the draw: the outer
    # face runs on down to the wall's z_bottom_m, 4 m lower, and without them the
    # stations saw it there (from inside, under the inner face's foot)
    a, b = np.asarray(wall.p0, dtype=float), np.asarray(wall.p1, dtype=float)
    along = (b - a) / np.linalg.norm(b - a)
    out = np.array([along[1], -along[0]])  # the inside is to the left of p0 -> p1
    e0, e1 = a - 20 * along, b + 20 * along
    for near, far, part in ((0.0, 30.0, "ground"), (-wall.thickness_m, -30.0, "floor")):
        quad = [e0 + near * out, e1 + near * out, e1 + far * out, e0 + far * out]
        scene.add_quad([[x, y, 0.0] for x, y in quad], part=part, material=GROUND)
    st = [TLSStation(tuple(x), step_deg=step, elevation_deg=(-60, 75)) for x in inside + outside]
    xyz = scan(scene, st, rng=0).xyz
    keep = (xyz[:, 0] > box[0]) & (xyz[:, 0] < box[1]) & (xyz[:, 2] < box[2])
    door = next(o for o in objs if o["class"] == "door"
                and box[0] < np.mean(np.asarray(o["box_corners_m"])[:, 0]) < box[1])  # fmt: skip
    return xyz[keep], door


def _door_found(xyz: np.ndarray, door: dict):
    r = segment_walls(xyz)
    w = max(r.walls, key=lambda x: x.n_points)
    assert len(w.faces) == 2
    bc = np.asarray(door["box_corners_m"])
    uc = float((bc.mean(axis=0) - w.origin) @ w.u_axis)
    return min(w.openings, key=lambda q: abs(0.5 * (q.u_min + q.u_max) - uc))


def test_stray_returns_on_a_sparse_face_do_not_narrow_a_door() -> None:
    """Church draw 3, south door (open, in a wall 0.87 m thick): multipath returns of
    the outer face above the door, dropped 0.2-1.5 m straight down onto its plane,
    stood 4-14 cm inside the left jamb in four of the sparse face's rows, and the
    face's jamb took them (the door 5.1 cm narrow).  The door's straight reveals,
    across the wall's depth, stand at its jambs."""
    xyz, door = _door_scan(3, "south", [[3.69, 0.13, 1.73]], [[-2.39, -10.16, 1.46]],
                           0.3, (0.5, 7.0, 5.0))  # fmt: skip
    left = float(np.asarray(door["box_corners_m"])[:, 0].min())
    y = float(np.asarray(door["box_corners_m"])[0, 1]) - door["depth_from_outer_face_m"]
    ghosts = np.c_[left + np.array([0.044, 0.040, 0.136, 0.137]), np.full(4, y),
                   [1.46, 2.10, 1.07, 1.43]]  # fmt: skip
    got = _door_found(np.vstack([xyz, ghosts]), door)
    assert got.kind == "door"
    assert got.width_m == pytest.approx(door["width_m"], abs=0.03)


def test_a_door_leaf_seen_on_both_faces_is_no_reveal() -> None:
    """Church draw 9, north door (a leaf 6.4 cm thick, 0.43 m deep in a wall 1.02 m
    thick): in the doorway's middle 450 points lay on the leaf's outer face and 81
    (15 %) on its inner face 6.4 cm deeper; with the median depth alone left out, the
    inner face's columns beside the jamb made a reveal 0.35 m inside the door.  Both
    faces of a door's leaf are left out; a few stray returns at another depth do not
    hide a reveal."""
    rng = np.random.default_rng(3)
    mid_u, mid_z = rng.uniform(0.5, 1.2, 560), rng.uniform(1.0, 2.0, 560)
    leaf = np.r_[rng.normal(0.051, 0.003, 450), rng.normal(0.115, 0.003, 81)]
    stray = rng.uniform(-0.45, 0.45, 29)  # mixed pixels across the doorway
    reveal_u, reveal_z = np.zeros(200), rng.uniform(0.0, 3.0, 200)
    reveal_d = rng.uniform(-0.5, 0.5, 200)  # the jamb, across the wall's depth
    uz = np.r_[np.c_[mid_u, mid_z], np.c_[reveal_u, reveal_z]]
    depth = np.r_[leaf, stray, reveal_d]
    keep = pane_mask(uz, depth, 0.0, 1.7, 0.0, 3.0, RevealParams(), leaf=True)
    assert not keep[:531].any()  # both faces of the leaf
    assert keep[531:560].mean() > 0.6  # stray returns far from the leaf are no leaf
    off_leaf = (np.abs(reveal_d - 0.051) > 0.05) & (np.abs(reveal_d - 0.115) > 0.05)
    assert keep[560:][off_leaf].all()  # the reveal, but near the leaf's depths
