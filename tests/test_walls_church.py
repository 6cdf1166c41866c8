"""Walls on the church family, draw 0 (interior + exterior TLS): the failures it showed."""

from __future__ import annotations

import numpy as np
import pytest

from church_walls import church_walls

pytestmark = pytest.mark.slow  # a 3.4 M point draw: about 35 s


@pytest.fixture(scope="module")
def church0():
    return church_walls(0)


def _match(r, tw):
    n, d = np.asarray(tw["outer_plane"]["normal"]), tw["outer_plane"]["d"]
    for w in r.walls:
        for f in w.faces:
            if abs(f.normal @ n) > 0.999 and abs(np.sign(f.normal @ n) * f.d - d) < 0.05:
                return w
    return None


def test_every_wall_on_both_faces_with_planar_faces(church0) -> None:
    """The north wall was paired with a face through its panes (0.36 m thick, a 15 mm
    RMS face, its inner face a lone wall): now four walls, both faces, 0.41 m."""
    r, objs = church0
    truth = [o for o in objs if o["class"] == "wall"]
    assert len(r.walls) == len(truth) == 4
    for tw in truth:
        w = _match(r, tw)
        assert w is not None and len(w.faces) == 2, tw["name"]
        assert w.thickness_m == pytest.approx(tw["thickness_m"], abs=0.01)
        assert max(f.rms_m for f in w.faces) <= 0.01
    assert not r.notes


def test_openings_in_count_and_size(church0) -> None:
    """The south door (its foot on the sparse outer plinth) was missed, pointed heads
    were 6-18 cm short and sills raised by mixed pixels: counts match on every wall,
    the door is a door, and at least 19 of the 21 openings are within 5 cm."""
    r, objs = church0
    ops = [o for o in objs if o["class"] in ("window", "door")]
    ok = 0
    for tw in (o for o in objs if o["class"] == "wall"):
        w = _match(r, tw)
        mine = [o for o in ops if o["wall"] == tw["name"]]
        assert len(w.openings) == len(mine), tw["name"]
        for o in mine:
            uc = float((np.asarray(o["box_corners_m"]).mean(axis=0) - w.origin) @ w.u_axis)
            b = min(w.openings, key=lambda q: abs(0.5 * (q.u_min + q.u_max) - uc))
            ok += abs(b.width_m - o["width_m"]) <= 0.05 and abs(b.height_m - o["height_m"]) <= 0.05
            if o["class"] == "door" and tw["name"] == "south":
                assert b.kind == "door"
                assert b.width_m == pytest.approx(o["width_m"], abs=0.05)
                assert b.height_m == pytest.approx(o["height_m"], abs=0.05)
    assert ok >= 19
