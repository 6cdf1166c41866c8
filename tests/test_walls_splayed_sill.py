"""Walls: a splayed face's sill, jambs and head are moved in by its splay where the
reveals do not measure them (church draws 14 and 15)."""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.synthetic.scanner import TLSStation
from pyheracles.walls import segment_walls
from pyheracles.walls.outlines import splayed_in
from splayed_windows import QUIET, splayed_window

L, H, T = 8.0, 5.0, 0.9  # wall length, height, thickness (m)
U0, U1, Z0, Z1 = 3.0, 3.8, 2.0, 3.8  # the opening through the wall
SPLAY, PANE = 0.08, 0.55  # the inner reveal widens by SPLAY from depth PANE to the inner face


def _deep_splayed_window() -> np.ndarray:
    """Church draw 14's windows: a wall 0.9 m thick (outer face at y = 0, facing -y),
    an unglazed opening 0.8 x 1.8 m with straight reveals from the outer face to
    0.55 m deep and splayed by 8 cm from there to the inner face.  The inner face is
    scanned from 5 m, the outer face from 30 m at 0.6 deg (31 cm between scan lines):
    the outer face measures no sill, the inner face's sill is its splayed hole's."""
    stations = [
        TLSStation((3.0, 5.0, 1.6), step_deg=0.15, azimuth_deg=(200, 340), **QUIET),
        TLSStation((3.5, -30.0, 1.6), step_deg=0.6, azimuth_deg=(70, 110), **QUIET),
    ]
    return splayed_window(L, H, T, (U0, U1, Z0, Z1), SPLAY, PANE, stations, rng=14)


def test_a_splayed_faces_sill_is_moved_in_by_its_splay() -> None:
    """Church draw 14 (round windows in a 1.09 m wall, splayed by 6 cm; outer face
    15-30 cm between points): the sills were the inner face's, 5-7 cm low, while the
    reveals put the jambs and head back at the opening's edges; draw 15's clerestory
    sills, over an aisle's roof, 8-28 cm low."""
    r = segment_walls(_deep_splayed_window())
    assert len(r.walls) == 1 and len(r.walls[0].faces) == 2
    w = r.walls[0]
    (win,) = [o for o in w.openings if o.kind == "window"]
    u = np.sort([(np.array([U0, 0.0, 0.0]) - w.origin) @ w.u_axis,
                 (np.array([U1, 0.0, 0.0]) - w.origin) @ w.u_axis])  # fmt: skip
    assert win.u_min == pytest.approx(u[0], abs=0.025)
    assert win.u_max == pytest.approx(u[1], abs=0.025)
    assert win.z_min == pytest.approx(Z0, abs=0.025)
    assert win.z_max == pytest.approx(Z1, abs=0.025)


def test_splayed_in_moves_only_the_edges_a_splayed_face_set() -> None:
    """Church draw 14, south wall, window 8: the inner face (row 0) stands 5 cm outside
    the left reveal and sets the right jamb and the sill; the reveals set the left jamb
    and the head.  The sill and the right jamb move in by 5 cm; the edges the reveals
    set and a face standing at the reveals (no splay) move nothing."""
    faces = np.array([[-27.269, -26.424, 7.221, 10.553], [-27.202, -26.346, np.nan, 10.466]])
    reveals = np.array([-27.219, np.nan, np.nan, 10.494])
    took = np.array([True, False, False, True])
    edges = (-27.219, -26.424, 7.221, 10.494)
    spacing = np.array([0.026, 0.177])
    out = splayed_in(edges, np.array([0, 0, 0, 1]), faces, spacing, reveals, took, 0.05)
    assert out[0] == edges[0] and out[3] == edges[3]
    assert out[1] == pytest.approx(-26.474, abs=1e-3)  # true -26.471
    assert out[2] == pytest.approx(7.271, abs=1e-3)  # true 7.295
    flat = faces.copy()
    flat[0, 0] = -27.215  # at the reveal: no splay
    assert splayed_in(edges, np.array([0, 0, 0, 1]), flat, spacing, reveals, took, 0.05) == edges
    sparse = np.array([0.06, 0.177])  # 5 cm out, read between points 6 cm apart
    assert splayed_in(edges, np.array([0, 0, 0, 1]), faces, sparse, reveals, took, 0.05) == edges
