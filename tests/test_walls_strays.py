"""Walls: a point standing alone on a face's plane is no edge of an opening (church
draw 5)."""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.walls.openings import isolated_out


def test_a_point_alone_is_left_out_the_lattice_is_kept() -> None:
    """A face scanned in columns 3.7 cm apart and lines 2 cm apart, with a hole: its
    points all have neighbours at its spacing and stay, the edge rows of the hole too;
    a point 11 cm above the hole's sill (church draw 5) goes."""
    rng = np.random.default_rng(5)
    u, z = np.meshgrid(np.arange(-1.0, 1.0, 0.037), np.arange(1.0, 3.0, 0.02), indexing="ij")
    face = np.c_[u.ravel(), z.ravel()] + rng.normal(0, 0.002, (u.size, 2))
    face = face[~((np.abs(face[:, 0]) < 0.6) & (face[:, 1] > 1.5) & (face[:, 1] < 2.8))]
    stray = np.array([[0.01, 1.5 + 0.11]])
    kept = isolated_out(np.r_[face, stray], 0.05)
    assert len(kept) == len(face)
    assert not np.any(np.all(np.isclose(kept, stray), axis=1))


@pytest.mark.slow
def test_a_stray_return_above_a_sill_is_no_sill() -> None:
    """Church draw 5, north wall, window 12 (pointed, 1.33 x 3.45 m): one return on
    the inner face's plane 11 cm above the sill, in one of the two columns of the
    face's central band (3.7 cm between points), put the face's sill 7 cm high, and
    the window 8.6 cm short (the highest of the faces' sills is the opening's)."""
    from church_walls import church_walls, nearest_opening

    r, objs = church_walls(5)
    win = next(o for o in objs if o["class"] == "window" and o["instance"] == 12)
    best, dist = nearest_opening(r, win)
    assert best is not None and dist < 0.3
    assert best.width_m == pytest.approx(win["width_m"], abs=0.05)
    assert best.height_m == pytest.approx(win["height_m"], abs=0.05)
