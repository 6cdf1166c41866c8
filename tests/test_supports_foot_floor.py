"""The floor under a support's foot (issue 12, step 2a): at the edge of a dais the ring
round a support holds the ground beyond the edge, metres below the support's foot; the
floor is the level its foot stands on (`supports.floors.foot_floor`), not the ring's
lowest ground, so a face of the dais flush with its plinth is not the support."""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.supports import SupportParams, detect_supports
from pyheracles.supports.floors import foot_floor, ring_levels
from test_supports_clutter import grid, tube
from test_supports_heads import square_sides


def _dais_edge_ring(step: float = 0.03) -> tuple[np.ndarray, np.ndarray]:
    """Ring points round a support at x = 0 standing on a 0.96 m dais whose edge runs
    along x = 1: the dais top for x < 1, its face at x = 1, the ground beyond."""
    top = grid(-2.0, 1.0, -2.0, 2.0, step)
    face = grid(-2.0, 2.0, 0.0, 0.96, step)
    ground = grid(1.0, 2.0, -2.0, 2.0, step)
    xyz = np.vstack(
        [
            np.c_[top, np.full(len(top), 0.96)],
            np.c_[np.full(len(face), 1.0), face],
            np.c_[ground, np.zeros(len(ground))],
        ]
    )
    ring = np.hypot(xyz[:, 0], xyz[:, 1]) > 1.6
    return xyz[ring, :2], xyz[ring, 2]


def test_ring_levels_are_the_dais_top_and_the_ground() -> None:
    xy, z = _dais_edge_ring()
    levels = ring_levels(xy, z, 0.05)
    assert len(levels) == 2
    assert levels[0] == pytest.approx(0.96, abs=0.03)
    assert levels[1] == pytest.approx(0.0, abs=0.03)


def test_floor_is_the_level_the_foot_stands_on() -> None:
    """A support whose own points end at the dais top stands on it; one whose shaft goes
    down past it (a seat in its ring at that height) stands on the ground."""
    xy, z = _dais_edge_ring()
    low = float(np.quantile(z, 0.05))
    assert foot_floor(xy, z, 0.97, low, 0.05, 0.02) == pytest.approx(0.96, abs=0.03)
    assert foot_floor(xy, z, 0.02, low, 0.05, 0.02) == low


def test_dais_face_flush_with_an_unseen_plinth_is_not_its_piece() -> None:
    """Draw 1 rebuilt: two columns (r 0.7 m) on square plinths 1.7 m half wide whose top
    faces were not seen (so a plinth is a piece of its own, joined back to its shaft at
    the foot), standing on a 0.96 m dais; the first plinth's side is flush with the
    dais's edge, whose face runs from it down to the ground beyond.  Plinth and face are
    one piece cut off the shaft: joined to the column whole (draw 1) or, as here, left
    out whole (half of the first plinth lost).  The face is no piece of the plinth: its
    points lie below the level the column stands on."""
    rng = np.random.default_rng(1)
    step, r, top, dais, edge = 0.04, 0.7, 6.0, 0.96, 5.7
    cols = [(4.0, 4.0), (-1.0, 4.0)]
    top_xy = grid(-4.0, edge, -1.0, 9.0, step)
    top_xy = top_xy[~np.any([np.max(np.abs(top_xy - c), axis=1) < 1.7 for c in cols], axis=0)]
    ground = grid(edge, 10.0, -1.0, 9.0, step)
    face = grid(-1.0, 9.0, 0.0, dais, step)
    ceiling = grid(-4.0, 10.0, -1.0, 9.0, step)
    room = [
        np.c_[top_xy, np.full(len(top_xy), dais)],
        np.c_[ground, np.zeros(len(ground))],
        np.c_[np.full(len(face), edge), face],
        np.c_[ceiling, np.full(len(ceiling), top)],
    ]
    for c in cols:
        room += [square_sides(c, 1.7, dais, dais + 0.2, step), tube(c, r, dais + 0.2, top, step)]
    xyz = np.vstack(room)
    xyz += rng.normal(0, 0.003, xyz.shape)
    found = detect_supports(xyz, SupportParams(section_height_m=3.0))
    assert list(found.objects["class"]) == ["column"] * 2, found.objects
    dais_face = (np.abs(xyz[:, 0] - edge) < 0.02) & (xyz[:, 2] < dais - 0.05)
    assert np.count_nonzero(found.instance[dais_face]) < 50
    plinth = (np.max(np.abs(xyz[:, :2] - cols[0]), axis=1) > 1.68) & (xyz[:, 2] > dais + 0.05)
    plinth &= xyz[:, 2] < dais + 0.15
    assert np.mean(found.instance[plinth] > 0) > 0.9  # and the plinth stays (0.50 before)
