"""Supports too sparse for the thin section (issue 12, step 2a): piers are taken from the
thick section too, where they stand free of every wall and the thin section holds few
points, and judged by the level the building carries like columns."""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.supports import SupportParams, detect_supports


def _wall_and_floor() -> tuple[np.ndarray, np.ndarray]:
    """A dense wall (1 cm, 12 m long, 3.5 m tall at y = -2) and a floor grid (5 cm)."""
    wx, wz = np.meshgrid(np.arange(0.0, 12.0, 0.01), np.arange(0.0, 3.5, 0.01))
    wall = np.c_[wx.ravel(), np.full(wx.size, -2.0), wz.ravel()]
    fx, fy = np.meshgrid(np.arange(-1.0, 12.0, 0.05), np.arange(-2.0, 4.0, 0.05))
    return wall, np.c_[fx.ravel(), fy.ravel(), np.zeros(fx.size)]


def _sparse_pier(cx: float, cy: float, w: float, d: float, n: int, rng) -> np.ndarray:
    """``n`` random points on the four faces of a ``w`` x ``d`` pier 3.5 m tall."""
    s = rng.uniform(0.0, 2 * (w + d), n)
    x = np.where(s < w, s, np.where(s < w + d, w, np.where(s < 2 * w + d, 2 * w + d - s, 0)))
    y = np.where(s < w, 0, np.where(s < w + d, s - w, np.where(s < 2 * w + d, d, 2 * (w + d) - s)))
    return np.c_[cx - w / 2 + x, cy - d / 2 + y, rng.uniform(0.0, 3.5, n)]


@pytest.mark.parametrize("seed", [8, 14])
def test_sparse_piers_found_on_the_thick_section(seed: int) -> None:
    """Draw 8 (a peristyle scanned from inside, a 0.3 m pier with 7 points in the thin
    section) and draw 14 (two antae with 19 and 24): the thick section found the sparse
    columns only, its piers were not trusted.  Four piers of 0.5 x 0.4 m hold 500
    points each (~7 in a 5 cm slab, ~40 in 30 cm) beside a dense wall that sets the
    spacing; a fifth stands against the wall and stays out."""
    rng = np.random.default_rng(seed)
    wall, floor = _wall_and_floor()
    centres = [(1.0 + 2.5 * k, 1.5) for k in range(4)]
    piers = [_sparse_pier(cx, cy, 0.5, 0.4, 500, rng) for cx, cy in centres]
    against = _sparse_pier(11.0, -1.8, 0.5, 0.4, 500, rng)  # touching the wall's face
    xyz = np.vstack([wall, floor, *piers, against]) + rng.normal(0, 0.002, (1, 3))
    found = detect_supports(xyz, SupportParams(section_height_m=None))
    got = found.objects[found.objects["class"] == "pier"]
    assert len(got) == 4, found.objects
    for cx, cy in centres:
        assert np.min(np.hypot(got["x"] - cx, got["y"] - cy)) < 0.05


def _box_sides(lo, hi, step: float) -> np.ndarray:
    """Points on the four vertical faces of the box ``lo``-``hi`` (x, y, z corners)."""
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    out = []
    for u0, u1, fixed, axis in ((y0, y1, (x0, x1), 0), (x0, x1, (y0, y1), 1)):
        uu, zz = np.meshgrid(np.arange(u0, u1 + 1e-9, step), np.arange(z0, z1 + 1e-9, step))
        for c in fixed:
            pts = np.c_[np.full(uu.size, c), uu.ravel(), zz.ravel()]
            out.append(pts if axis == 0 else pts[:, [1, 0, 2]])
    return np.vstack(out)


@pytest.mark.parametrize("seed", [1, 2])
def test_a_sparse_post_ending_low_in_a_standing_hall_is_no_pier(seed: int) -> None:
    """Draw 1 (a kiosk whose columns carry the roof at 14.7 m): the standard of a
    scaffold, 8 m tall and sparse, gave a pier in the thick section.  A pier found
    there only, carrying nothing and ending far below the level the other supports
    carry, is judged like a column (a sparse pier reaching that level stays).  Three
    dense piers carry a ceiling at 3.5 m; two sparse piers stand beside them, one up to
    the ceiling and one 1.8 m tall beyond its edge."""
    rng = np.random.default_rng(seed)
    wall, floor = _wall_and_floor()
    under = floor[:, 0] < 9.5  # the low post stands beyond the ceiling: it carries nothing
    ceiling = (floor + [0.0, 0.0, 3.5])[under]
    dense = [
        _box_sides((cx - 0.25, 1.3, 0.0), (cx + 0.25, 1.7, 3.47), 0.03) for cx in (1.0, 3.5, 6.0)
    ]
    tall = _sparse_pier(8.5, 1.5, 0.4, 0.4, 500, rng)
    tall = tall[tall[:, 2] < 3.47]
    low = _sparse_pier(11.0, 1.5, 0.4, 0.4, 500, rng)
    low = low[low[:, 2] < 1.8]
    xyz = np.vstack([wall, floor, ceiling, *dense, tall, low]) + rng.normal(0, 0.002, (1, 3))
    found = detect_supports(xyz, SupportParams(section_height_m=1.2))
    got = found.objects[found.objects["class"] == "pier"]
    assert np.min(np.hypot(got["x"] - 8.5, got["y"] - 1.5)) < 0.05  # the tall one
    assert np.min(np.hypot(got["x"] - 11.0, got["y"] - 1.5)) > 0.5, found.objects
    assert len(got) == 4
