"""Walls: an arch wider than half of the foot's wide window plus 2.5 m is one opening
from the wall's foot (``pyheracles.walls.outlines``: the foot under it is the low foot
on both sides, within the wide window's reach of one; a chancel arch 8.9 m wide was
three openings, the head's columns near each jamb taken for pillars of wall)."""

from __future__ import annotations

import numpy as np
import pytest


def _arched_wall(width: float, pier: float = 1.5, height: float = 10.0, top: float = 7.85,
                 thickness: float = 0.45, s: float = 0.05) -> np.ndarray:  # fmt: skip
    """A wall on the plane y = 0 (faces at y = 0 and y = ``thickness``), ``width`` m of
    rectangular arch from the floor to ``top`` between two piers ``pier`` m wide, its
    jambs and soffit lined by reveals, and the floor on both sides, every ``s`` m."""
    length = width + 2 * pier
    x, z = np.meshgrid(np.arange(0.0, length, s), np.arange(0.0, height, s), indexing="ij")
    solid = (np.abs(x - length / 2) > width / 2) | (z > top)
    faces = [np.c_[x[solid], np.full(solid.sum(), y), z[solid]] for y in (0.0, thickness)]
    d, zr = np.meshgrid(np.arange(s, thickness, s), np.arange(0.0, top, s), indexing="ij")
    jambs = [np.c_[np.full(d.size, length / 2 + g * width / 2), d.ravel(), zr.ravel()]
             for g in (-1, 1)]  # fmt: skip
    xs, ds = np.meshgrid(np.arange(pier, pier + width, s), np.arange(s, thickness, s),
                         indexing="ij")  # fmt: skip
    soffit = np.c_[xs.ravel(), ds.ravel(), np.full(xs.size, top)]
    fx, fy = np.meshgrid(np.arange(0.0, length, s), np.r_[np.arange(-2.0, 0.0, s),
                         np.arange(thickness + s, thickness + 2.0, s)], indexing="ij")  # fmt: skip
    floor = np.c_[fx.ravel(), fy.ravel(), np.zeros(fx.size)]
    rng = np.random.default_rng(3)
    xyz = np.vstack([*faces, *jambs, soffit, floor])
    return xyz + rng.normal(0.0, 0.002, xyz.shape)


@pytest.mark.parametrize("width", [4.0, 8.9])
def test_wide_arch_is_one_opening_from_the_foot(width: float) -> None:
    """An arch 4 m or 8.9 m wide between 1.5 m piers is one opening, its width and height
    within 5 cm (8.9 m: three openings, a 2.45 m one in its middle and two 0.6-0.8 m
    ones at its jambs, before the foot under it was the low foot on both sides)."""
    from pyheracles.walls import segment_walls

    r = segment_walls(_arched_wall(width))
    w = max(r.walls, key=lambda w: w.n_points)
    assert len(w.openings) == 1
    o = w.openings[0]
    assert abs(o.width_m - width) <= 0.05
    assert abs(o.height_m - 7.85) <= 0.05


@pytest.mark.slow  # simulates a church draw: about 20 s each
@pytest.mark.parametrize("noise_draw", [0, 1, 2])
def test_church15_chancel_arch_is_one_opening(noise_draw: int) -> None:
    """Church draw 15's east wall (both faces seen): its chancel arch, 8.9 m wide and
    7.8 m high, is one opening from the floor, on the draw's own scan and on noise draws
    1 and 2 (three before: 0.8, 2.45 and 0.6 m wide)."""
    from church_walls import wall_crop
    from pyheracles.walls import segment_walls

    xyz, tw, _ = wall_crop(15, "east", noise_draw)
    n = np.asarray(tw["outer_plane"]["normal"])
    r = segment_walls(xyz)
    w = max(r.walls, key=lambda w: w.n_points if abs(w.normal @ n) > 0.999 else 0)
    assert len(w.faces) == 2
    wide = [o for o in w.openings if o.width_m > 4.0]
    assert len(wide) == 1
    assert len(w.openings) == 1
    assert 8.5 < wide[0].width_m < 9.2
