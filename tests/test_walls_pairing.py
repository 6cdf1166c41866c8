"""Walls: which faces pair into one wall (church family draw 0, north wall)."""

from __future__ import annotations

import numpy as np

from pyheracles.walls.model import WallFace, WallParams
from pyheracles.walls.pairing import pair_faces


def _face(points: np.ndarray, normal=(0.0, 1.0, 0.0)) -> tuple[WallFace, np.ndarray]:
    n = np.asarray(normal)
    return WallFace(n, float(np.mean(points @ n)), np.arange(len(points)), 0.002), points


def test_face_of_panes_near_the_inner_face_is_not_paired() -> None:
    """Church draw 0, north wall (0.41 m): a face fitted through the panes and reveals
    of a row of windows 6 cm from the inner face paired with the outer face (the
    nearer one), giving a 0.36 m wall with a 15 mm RMS face and the true inner face
    as a lone wall.  Faces seen over the same stretch of wall pair now, and a face
    between the two faces of a wall belongs to no wall."""
    rng = np.random.default_rng(0)
    g = np.c_[rng.uniform(0, 20, 40000), rng.uniform(0, 6, 40000)]
    windows = [(u, u + 1.5) for u in (2.0, 6.0, 10.0, 14.0)]
    in_win = np.zeros(len(g), bool)
    for a, b in windows:
        in_win |= (g[:, 0] > a) & (g[:, 0] < b) & (g[:, 1] > 1.5) & (g[:, 1] < 5.0)
    wall = g[~in_win]
    outer = np.c_[wall[:, 0], np.full(len(wall), 4.444), wall[:, 1]]
    inner = np.c_[wall[:, 0], np.full(len(wall), 4.031), wall[:, 1]]
    pane = g[in_win]
    panes = np.c_[pane[:, 0], np.full(len(pane), 4.088), pane[:, 1]]
    xyz = np.vstack([outer, panes, inner])
    faces, start = [], 0
    for pts in (outer, panes, inner):
        f, _ = _face(pts)
        faces.append(WallFace(f.normal, f.d, np.arange(start, start + len(pts)), 0.002))
        start += len(pts)
    groups = pair_faces(xyz, faces, WallParams())
    assert groups == [(0, 2)]  # outer + inner; the panes' face is inside the wall


def test_lone_face_stays_a_wall_of_its_own() -> None:
    """A face with no parallel partner is a group of its own (a wall seen on one face)."""
    rng = np.random.default_rng(1)
    g = rng.uniform(0, 5, (5000, 2))
    a = np.c_[g[:, 0], np.zeros(len(g)), g[:, 1]]
    b = np.c_[np.full(len(g), 7.0), g[:, 0], g[:, 1]]
    faces = [
        WallFace(np.array([0.0, 1.0, 0.0]), 0.0, np.arange(len(g)), 0.002),
        WallFace(np.array([1.0, 0.0, 0.0]), 7.0, np.arange(len(g), 2 * len(g)), 0.002),
    ]
    assert pair_faces(np.vstack([a, b]), faces, WallParams()) == [(0,), (1,)]
