"""A column under a timber ceiling ends where the girder it carries begins (issue 12,
items 5 and 6: keep a support's full height up to what it carries, and no more).

Built from draw 13 of the supports family (a portico with a timber ceiling, scanned
from outside only): each column, 0.26-0.30 m in radius and 3.85 m tall, carries a
girder 0.3 m wide and 0.35 m deep running across its top; joists cross the girder, and
boards lie on them at 4.4 m.  Under the joists found as the surface it carries,
:func:`~pyheracles.supports.profile.head_cut` compared each layer with the outline of
the four layers below it: the girder's faces, a prism of their own, became that outline
four layers above its underside, and its narrowing (2-4 layers) was taken for clutter
that had widened the outline (a scaffold board round a shaft); the girder and the
joists' faces stayed with the columns (50-650 ceiling points each, median F1 0.944).
The narrowing is now also held against the outline under the girder
(:func:`~pyheracles.supports.profile.held_narrow`).

Here a column seen from one side under such a girder, joists and boards, over eight
noise draws.
"""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.supports.cookies import cookies
from pyheracles.supports.core import SupportParams, scales
from pyheracles.supports.profile import head_cut

STEP = 0.022  # point spacing, metres (draw 13's)
R = 0.26  # column radius, metres
TOP = 3.85  # column top = underside of the girder, metres
GIRDER = (0.15, 0.35)  # girder half width and depth, metres
JOIST_TOP = 4.4  # underside of the boards, metres
H_SEC = 2.27  # section height, metres
REACH = 0.8  # the girder in the column's cookie: up to this far from its axis, metres
SEEDS = range(8)  # noise draws


def _grid(a0: float, a1: float, b0: float, b1: float) -> tuple[np.ndarray, np.ndarray]:
    aa, bb = np.meshgrid(np.arange(a0, a1 + 1e-9, STEP), np.arange(b0, b1 + 1e-9, STEP))
    return aa.ravel(), bb.ravel()


def _scene(rng: np.random.Generator) -> np.ndarray:
    """The column (its half facing -y, seen from outside), the floor round it, the
    girder along x over it up to ``REACH`` from its axis (the rest is in the neighbours'
    cookies), two joists along y over the girder and the boards' underside, all seen
    from below."""
    parts = []
    t, z = np.meshgrid(np.arange(np.pi, 2 * np.pi, STEP / R), np.arange(0.0, TOP, STEP))
    parts.append(np.c_[R * np.cos(t.ravel()), R * np.sin(t.ravel()), z.ravel()])
    fx, fy = _grid(-1.2, 1.2, -1.2, 1.2)
    parts.append(np.c_[fx, fy, np.zeros(fx.size)])
    gw, gd = GIRDER
    x, z = _grid(-REACH, REACH, TOP, TOP + gd)  # the girder's faces
    parts += [np.c_[x, np.full(x.size, y), z] for y in (-gw, gw)]
    x, y = _grid(-REACH, REACH, -gw, gw)  # its underside
    parts.append(np.c_[x, y, np.full(x.size, TOP)])
    # the face of a joist resting on the girder, seen over the column's plan only (the
    # girder shadows the rest from the stations outside)
    x, z = _grid(-R, R, TOP + gd, JOIST_TOP)
    parts.append(np.c_[x, np.full(x.size, gw + 0.05), z])
    for x0 in (-0.45, 0.45):  # joists 0.12 m wide across it, out to the whole ring
        y, z = _grid(-1.2, 1.2, TOP + gd, JOIST_TOP)
        parts += [np.c_[np.full(y.size, x0 + s), y, z] for s in (-0.06, 0.06)]
        xj, yj = _grid(x0 - 0.06, x0 + 0.06, -1.2, 1.2)
        parts.append(np.c_[xj, yj, np.full(xj.size, TOP + gd)])
    bx, by = _grid(-1.2, 1.2, -1.2, 1.2)  # the boards' underside
    parts.append(np.c_[bx, by, np.full(bx.size, JOIST_TOP)])
    p = np.vstack(parts)
    p = p[rng.random(len(p)) > 0.2]  # a fifth of the points not seen
    return p + rng.normal(0.0, 0.003, p.shape)


def _column(params: SupportParams) -> dict:
    return {
        "class": "column",
        "centre": np.zeros(2),
        "radius": R,
        "half": np.array([R, R]),
        "angle": 0.0,
        "buffer": max(params.buffer_min_m, params.buffer_fraction * R),
    }


def _head(seed: int) -> float:
    """The head cut of the column under the joists' underside, metres."""
    params = SupportParams()
    sc = scales(STEP, params)
    p = _scene(np.random.default_rng(seed))
    sh = _column(params)
    ((idx, rho, ang),) = cookies(p, [sh], params)
    q = p[idx]
    h_from = H_SEC + sc.thickness / 2
    layer = max(0.05, 3.0 * sc.spacing)
    inner = rho <= sh["buffer"]
    n_sec = min(72, max(8, int(2 * np.pi * R / (3 * sc.spacing))))
    h_to = TOP + GIRDER[1]  # the joists: the surface it carries
    return head_cut(rho[inner], ang[inner], q[inner, 2], h_from + layer, h_to, layer, n_sec, sc.tol)


@pytest.mark.parametrize("seed", SEEDS)
def test_column_ends_where_the_girder_begins(seed: int) -> None:
    assert TOP - 0.15 <= _head(seed) <= TOP + 0.05  # not inf: the girder is cut off
