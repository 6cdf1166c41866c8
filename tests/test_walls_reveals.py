"""Walls: the jambs and head of an opening from its reveals (church draws 4 and 17)."""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.synthetic.scanner import TLSStation
from pyheracles.walls import segment_walls
from pyheracles.walls.reveals import RevealParams, reveal_peak
from splayed_windows import QUIET
from splayed_windows import splayed_window as scene_of_splayed_window

L, H, T = 8.0, 4.5, 0.5  # wall length, height, thickness (m)
U0, U1, Z0, Z1 = 3.0, 4.2, 1.2, 3.0  # the opening through the wall
SPLAY, PANE = 0.2, 0.25  # the inner reveal widens by SPLAY from depth PANE to the inner face


@pytest.fixture(scope="module")
def splayed_window() -> np.ndarray:
    """A wall 0.5 m thick (outer face at y = 0, facing -y) with an unglazed opening
    1.2 x 1.8 m: straight reveals from the outer face to 0.25 m deep, splayed by 0.2 m
    from there to the inner face.  The inner face is scanned from 4 m, the outer face
    from 25 m at 0.5 deg (22 cm between scan lines, as a high window's outer face seen
    from the ground): the faces' holes are the inner face's, 0.2 m wider all round, and
    the outer face's, read between points 22 cm apart."""
    stations = [
        TLSStation((3.6, 4.0, 1.6), step_deg=0.2, azimuth_deg=(200, 340), **QUIET),
        TLSStation((5.0, -25.0, 1.6), step_deg=0.5, azimuth_deg=(60, 120), **QUIET),
    ]
    return scene_of_splayed_window(L, H, T, (U0, U1, Z0, Z1), SPLAY, PANE, stations, rng=1)


def test_splayed_window_is_the_straight_reveals_section(splayed_window) -> None:
    """Church draws 4 and 17: where the outer face is sparse, the faces put the jambs
    and head 5-17 cm off (the inner face's splayed hole, or the outer face read between
    its scan lines); the straight reveals, seen edge on, stand at the opening's edges."""
    r = segment_walls(splayed_window)
    assert len(r.walls) == 1 and len(r.walls[0].faces) == 2
    w = r.walls[0]
    (win,) = [o for o in w.openings if o.kind == "window"]
    u = np.sort([(np.array([U0, 0.0, 0.0]) - w.origin) @ w.u_axis,
                 (np.array([U1, 0.0, 0.0]) - w.origin) @ w.u_axis])  # fmt: skip
    assert win.u_min == pytest.approx(u[0], abs=0.02)
    assert win.u_max == pytest.approx(u[1], abs=0.02)
    assert win.z_max == pytest.approx(Z1, abs=0.02)


def test_reveal_peak_takes_the_innermost_straight_reveal() -> None:
    """Across a mullion the next light's jamb is a reveal too, farther out: the
    narrowest section is the innermost peak; scattered points are no peak."""
    rng = np.random.default_rng(0)
    jamb = rng.normal(0.30, 0.002, 60)  # this light's straight jamb
    other = rng.normal(0.12, 0.002, 80)  # the next light's, across a mullion
    splay = rng.uniform(0.05, 0.30, 30)  # a splayed reveal's spread
    mixed = rng.uniform(0.3, 0.7, 10)  # mixed pixels inside the opening
    v = np.r_[jamb, other, splay, mixed]
    assert reveal_peak(v, 0.0, 0.7, RevealParams()) == pytest.approx(0.30, abs=0.005)
    assert np.isnan(reveal_peak(np.r_[splay, mixed], 0.0, 0.7, RevealParams()))


def test_stray_returns_in_one_bin_are_no_reveal() -> None:
    """Church draw 8: in a sparse band, 11 stray returns of a leaded light gathered in
    three bins 0.37 m inside the jamb passed the contrast; a reveal lines the opening
    along its height, and they reach a few of its rows only."""
    rng = np.random.default_rng(1)
    jamb_v, jamb_z = rng.normal(0.10, 0.002, 40), rng.uniform(1.0, 3.0, 40)
    stray_v, stray_z = rng.normal(0.47, 0.004, 12), rng.uniform(2.0, 2.3, 12)
    v, z = np.r_[jamb_v, stray_v], np.r_[jamb_z, stray_z]
    p = RevealParams()
    assert reveal_peak(v, 0.0, 0.6, p, z, (1.0, 3.0)) == pytest.approx(0.10, abs=0.005)


def test_a_scan_column_on_a_splayed_reveal_is_no_jamb() -> None:
    """Church draw 7: a scanner's column of fixed azimuth meets a splayed reveal along
    one vertical line, at one ``u`` and one depth, as sharp in ``u`` as a straight
    reveal; it put heads and jambs of splayed windows 5-11 cm outside the opening.  A
    straight reveal runs across the wall's depth from a face to the glass."""
    rng = np.random.default_rng(2)
    z = rng.uniform(1.0, 3.0, 50)
    v = rng.normal(0.10, 0.002, 50)
    column = rng.normal(-0.25, 0.003, 50)  # one depth: a line on the splay
    straight = rng.uniform(-0.45, -0.25, 50)  # from the face to the glass
    p = RevealParams()
    assert np.isnan(reveal_peak(v, 0.0, 0.6, p, z, (1.0, 3.0), column))
    assert reveal_peak(v, 0.0, 0.6, p, z, (1.0, 3.0), straight) == pytest.approx(0.10, abs=0.005)


@pytest.mark.slow  # a church draw: about 35 s
def test_a_sparse_face_narrows_the_reveals_jamb_by_more_than_its_spacing_only() -> None:
    """Church draw 3, north wall, window 13 (outer face 9-15 cm between points): the
    faces put its jambs 2.4 and 2.7 cm inside the straight reveals, and the innermost
    jambs made it 5.1 cm narrow; a face's jamb is its innermost points and part of the
    gap to the next, as uncertain as its spacing."""
    from church_walls import church_walls

    r, objs = church_walls(3)
    (o,) = [o for o in objs if o.get("instance") == 13 and o["class"] == "window"]
    tw = next(t for t in objs if t["class"] == "wall" and t["name"] == o["wall"])
    n = np.asarray(tw["outer_plane"]["normal"])
    bc = np.asarray(o["box_corners_m"])
    w = max((w for w in r.walls if any(abs(f.normal @ n) > 0.999 for f in w.faces)
             and abs((bc.mean(axis=0) - w.origin) @ w.normal) < 1.0),
            key=lambda w: w.n_points)  # fmt: skip
    uc = float((bc.mean(axis=0) - w.origin) @ w.u_axis)
    b = min(w.openings, key=lambda q: abs(0.5 * (q.u_min + q.u_max) - uc)
            + abs(0.5 * (q.z_min + q.z_max) - bc[:, 2].mean()))  # fmt: skip
    assert b.width_m == pytest.approx(o["width_m"], abs=0.03)
