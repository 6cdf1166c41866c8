"""Clutter taken for supports on draws of the supports scene family (issue 12, step 2a,
failure mode 8): each mechanism rebuilt on a small synthetic room with the dimensions
of the draw that showed it."""

from __future__ import annotations

import numpy as np

from pyheracles.supports import SupportParams, detect_supports


def grid(u0: float, u1: float, v0: float, v1: float, step: float) -> np.ndarray:
    """``(M, 2)`` points every ``step`` metres over a rectangle."""
    u, v = np.meshgrid(np.arange(u0, u1 + 1e-9, step), np.arange(v0, v1 + 1e-9, step))
    return np.c_[u.ravel(), v.ravel()]


def box_sides(lo, hi, step: float) -> np.ndarray:
    """Points on the four vertical faces of the box ``lo``-``hi`` (x, y, z corners)."""
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    out = []
    for x in (x0, x1):
        yz = grid(y0, y1, z0, z1, step)
        out.append(np.c_[np.full(len(yz), x), yz])
    for y in (y0, y1):
        xz = grid(x0, x1, z0, z1, step)
        out.append(np.c_[xz[:, 0], np.full(len(xz), y), xz[:, 1]])
    return np.vstack(out)


def horizontal(x0, x1, y0, y1, z: float, step: float) -> np.ndarray:
    xy = grid(x0, x1, y0, y1, step)
    return np.c_[xy, np.full(len(xy), z)]


def tube(centre, radius: float, z0: float, z1: float, step: float) -> np.ndarray:
    n = max(8, int(2 * np.pi * radius / step))
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    z = np.arange(z0, z1 + 1e-9, step)
    tt, zz = np.meshgrid(t, z)
    return np.c_[
        centre[0] + radius * np.cos(tt.ravel()), centre[1] + radius * np.sin(tt.ravel()), zz.ravel()
    ]


def _pulpit(centre, floor_m: float, step: float) -> np.ndarray:
    """A pulpit as the family draws it: a post of 0.12 m radius up to ``floor_m``, a
    1.2 x 1.0 m tub 1.05 m high on it (open at the top, an inner lining 5 cm in), its
    underside."""
    cx, cy = centre
    return np.vstack(
        [
            tube(centre, 0.12, 0.0, floor_m, step),
            box_sides((cx - 0.6, cy - 0.5, floor_m), (cx + 0.6, cy + 0.5, floor_m + 1.05), step),
            box_sides((cx - 0.55, cy - 0.45, floor_m), (cx + 0.55, cy + 0.45, floor_m + 1.0), step),
            horizontal(cx - 0.6, cx + 0.6, cy - 0.5, cy + 0.5, floor_m, step),
        ]
    )


def test_pulpit_tub_under_a_ceiling_is_no_pier() -> None:
    """Draw 4 (a kiosk under a flat ceiling at 4.84 m, the section at 3.18 m): the section
    cut three pulpits through their tubs, 1.2 x 1.0 m rectangles, which were piers
    "carrying" the ceiling 0.7-1.5 m above their rims; only a pier carrying nothing had
    to be a prism, and the narrow post under the tub made 61-69 % of the layers
    narrower than the section.  A pier, carrying or not, is a prism."""
    rng = np.random.default_rng(4)
    step = 0.03
    room = np.vstack(
        [
            horizontal(0.0, 8.0, 0.0, 5.0, 0.0, step),  # floor
            horizontal(0.0, 8.0, 0.0, 5.0, 4.84, step),  # flat ceiling
            box_sides((1.7, 2.25, 0.0), (2.3, 2.75, 4.84), step),  # a 0.6 x 0.5 m pier
            _pulpit((5.5, 2.5), 2.0, step),  # the tub from 2.0 to 3.05 m
        ]
    )
    xyz = room + rng.normal(0, 0.003, room.shape)
    found = detect_supports(xyz, SupportParams(section_height_m=2.5))
    objects = found.objects
    assert list(objects["class"]) == ["pier"], objects
    pulpit = found.instance[np.hypot(xyz[:, 0] - 5.5, xyz[:, 1] - 2.5) < 0.8]
    assert not pulpit.any()  # the pulpit stays in the body
    pier = (np.hypot(xyz[:, 0] - 2.0, xyz[:, 1] - 2.5) < 0.32) & (np.abs(xyz[:, 2] - 2.4) < 2.2)
    assert np.mean(found.instance[pier] == 1) > 0.9
