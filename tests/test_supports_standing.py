"""A support stands as tall as a broken column at least, whatever it carries (issue 12,
mode 8: clutter taken for supports).

Built from draw 10 of the supports family (a ruined nave on a podium): a sign's panel
0.44 m tall "carried" its board, and a pile of debris 0.2 m tall a block lying on it;
the low section, 1.2 m over the ground beside the podium, cut both, and each spanned
more than half the height up to what it carried.
"""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.supports import SupportParams, detect_supports


def _box(lo, hi, step: float) -> np.ndarray:
    """Points on the six faces of the box ``lo``-``hi`` (x, y, z corners)."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    out = []
    for axis in range(3):
        a, b = [k for k in range(3) if k != axis]
        ua = np.arange(lo[a], hi[a] + 1e-9, step)
        ub = np.arange(lo[b], hi[b] + 1e-9, step)
        g1, g2 = np.meshgrid(ua, ub)
        for c in (lo[axis], hi[axis]):
            pts = np.zeros((g1.size, 3))
            pts[:, a], pts[:, b], pts[:, axis] = g1.ravel(), g2.ravel(), c
            out.append(pts)
    return np.vstack(out)


def _plate(x0: float, x1: float, y0: float, y1: float, z: float, step: float) -> np.ndarray:
    gx, gy = np.meshgrid(np.arange(x0, x1, step), np.arange(y0, y1, step))
    return np.c_[gx.ravel(), gy.ravel(), np.full(gx.size, z)]


def _podium_hall(rng: np.random.Generator, low: list[np.ndarray]) -> np.ndarray:
    """Ground at 0 round a podium 1 m high; on it a hall 12 x 8 m whose walls and four
    piers 0.5 m square carry a ceiling at 4 m; ``low`` are the things standing on the
    podium among the piers."""
    ground = _plate(-4.0, 14.0, -4.0, 10.0, 0.0, 0.05)
    ground = ground[~((ground[:, 0] > -1) & (ground[:, 0] < 11) & (ground[:, 1] > -1)
                      & (ground[:, 1] < 7))]  # fmt: skip
    podium = _plate(-1.0, 11.0, -1.0, 7.0, 1.0, 0.04)
    ceiling = _plate(-1.0, 11.0, -1.0, 7.0, 4.0, 0.05)
    sides = _box((-1.0, -1.0, 0.0), (11.0, 7.0, 4.0), 0.03)  # podium and walls
    sides = sides[(sides[:, 2] > 0.0) & (sides[:, 2] < 4.0)]
    piers = [_box((x - 0.25, y - 0.25, 1.0), (x + 0.25, y + 0.25, 4.0), 0.03)
             for x in (1.0, 9.0) for y in (1.0, 5.0)]  # fmt: skip
    xyz = np.vstack([ground, podium, ceiling, sides, *piers, *low])
    return xyz + rng.normal(0.0, 0.002, xyz.shape)


@pytest.mark.parametrize("seed", [10, 11])
def test_low_things_carrying_a_board_are_no_supports(seed: int) -> None:
    """A sign's post 0.2 m square standing 0.45 m on the podium under its board (1.4 m
    square), and a pile 0.3 m square and 0.4 m high under a slab lying on it: both carry
    what lies on them and span all of the height up to it, but stand lower than a
    broken column (1.5 m); the four piers carrying the ceiling stay."""
    rng = np.random.default_rng(seed)
    sign = _box((5.4, 2.4, 1.0), (5.6, 2.6, 1.45), 0.01)
    board = _plate(4.8, 6.2, 1.8, 3.2, 1.46, 0.01)
    pile = _box((3.0, 4.0, 1.0), (3.3, 4.3, 1.4), 0.01)
    slab = _plate(2.4, 3.9, 3.4, 4.9, 1.42, 0.01)
    xyz = _podium_hall(rng, [sign, board, pile, slab])
    found = detect_supports(xyz, SupportParams())
    assert len(found.objects) == 4, found.objects[["class", "x", "y", "z_min", "z_max"]]
    assert (found.objects["class"] == "pier").all()
    assert (found.objects["z_max"] > 3.8).all()
