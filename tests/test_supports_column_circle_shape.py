"""A column's section shape is its circle, even when the section saw an arc of it
(issue 12, mode 5: "square plinths and abaci lose their corners").

Built from draw 22 of the supports family (a nave of 28 columns, r = 1.06-1.2 m, under a
timber ceiling at 15 m): its columns were seen from the nave side only, so the section
island of each was an arc 1.5 m across, not 2.1 m.  The shape took the island's half
extents (0.76 x 0.62 m) for its size; the cookie's buffer, 2.6 times that, stopped
2.0 m off the shaft, short of the corners of the square plinths (2.4 m off it): 37,551
plinth points of 28 columns went to the body, and the capitals lost 45,273 points to
the attic.  The draw's median F1 was 0.921 (main target missed); with the circle's
radius as the shape's size, 0.977 and the draw passes.

Here: columns seen from one side (a quarter of the ring) on square plinths of 2.3 r half
width
(the family draws 1.5-2.5 r), on a floor, under a flat ceiling.
"""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.supports.detect import detect_supports

R = 0.6  # shaft radius, metres
PLINTH = 2.3 * R  # plinth half width
PLINTH_H = 0.35
HEIGHT = 6.0
STEP = 0.02  # point spacing on the surfaces


def _grid(a: float, b: float) -> np.ndarray:
    return np.arange(a, b, STEP)


def _column(x0: float, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Points of one column seen from -y (a quarter of its shaft, its plinth's faces and
    top facing -y, +x and -x); the second array flags the plinth points."""
    ang = np.arange(1.25 * np.pi, 1.75 * np.pi, STEP / R)  # the quarter facing -y
    zz = _grid(PLINTH_H, HEIGHT)
    a, z = np.meshgrid(ang, zz)
    shaft = np.c_[x0 + R * np.cos(a.ravel()), R * np.sin(a.ravel()), z.ravel()]
    s, z = np.meshgrid(_grid(-PLINTH, PLINTH), _grid(0.0, PLINTH_H))
    front = np.c_[x0 + s.ravel(), np.full(s.size, -PLINTH), z.ravel()]
    sides = [np.c_[np.full(s.size, x0 + sgn * PLINTH), s.ravel(), z.ravel()] for sgn in (-1, 1)]
    u, v = np.meshgrid(_grid(-PLINTH, PLINTH), _grid(-PLINTH, 0.0))
    top = np.c_[x0 + u.ravel(), v.ravel(), np.full(u.size, PLINTH_H)]
    top = top[np.hypot(top[:, 0] - x0, top[:, 1]) > R]
    plinth = np.vstack([front, *sides, top])
    pts = np.vstack([shaft, plinth])
    flag = np.r_[np.zeros(len(shaft), bool), np.ones(len(plinth), bool)]
    return pts + rng.normal(0.0, 0.002, pts.shape), flag


def _scene(seed: int) -> tuple[np.ndarray, np.ndarray, list[float]]:
    rng = np.random.default_rng(seed)
    xs = [0.0, 5.0, 10.0, 15.0]
    parts, flags, inst = [], [], []
    for k, x0 in enumerate(xs, start=1):
        p, f = _column(x0, rng)
        parts.append(p)
        flags.append(f)
        inst.append(np.full(len(p), k))
    u, v = np.meshgrid(np.arange(-4.0, 19.0, 0.05), np.arange(-6.0, 4.0, 0.05))
    plane = np.c_[u.ravel(), v.ravel()]
    clear = np.min([np.abs(plane[:, 0] - x) for x in xs], axis=0) > PLINTH + 0.01
    clear |= plane[:, 1] < -PLINTH - 0.01
    clear |= plane[:, 1] > PLINTH + 0.01
    floor = np.c_[plane[clear], np.zeros(clear.sum())]
    ceiling = np.c_[plane, np.full(len(plane), HEIGHT)]
    pts = np.vstack([*parts, floor, ceiling]) + 0.0
    flag = np.r_[np.concatenate(flags), np.zeros(len(floor) + len(ceiling), bool)]
    truth = np.r_[np.concatenate(inst), np.zeros(len(floor) + len(ceiling), int)]
    pts[len(np.concatenate(flags)) :] += rng.normal(0.0, 0.002, (len(floor) + len(ceiling), 3))
    return pts, flag, truth


@pytest.mark.parametrize("seed", range(3))
def test_plinth_corners_of_columns_seen_from_one_side(seed: int) -> None:
    pts, plinth, truth = _scene(seed)
    found = detect_supports(pts, spacing_m=STEP)
    cols = found.objects[found.objects["class"] == "column"]
    assert len(cols) == 4
    for k in range(1, 5):
        mine = truth == k
        ids = found.instance[mine]
        best = np.bincount(ids[ids > 0]).argmax()
        kept = np.mean(ids[plinth[mine]] == best)
        # the corners of the plinth lie 2.3 sqrt(2) r = 2.25 r off the shaft: with the
        # arc's half extents as the shape's size (0.71 x 0.15 r), the buffer was 1.84 r
        assert kept > 0.97, (k, kept)
