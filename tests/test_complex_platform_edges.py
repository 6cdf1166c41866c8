"""A sparse platform's edge beside its one released point (issue 17, complex draw 9).

:func:`pyheracles.complex.platforms.platform_tops` releases the ground points inside a
polygon that continue a released platform top beside them.  On a sparse survey (draw 9,
0.16 points/m^2) a pavilion's platform has six points; one point of its edge had a single
released point within the linking distance (3.7 m) and stayed ground when two were
required.
"""

from __future__ import annotations

import numpy as np
import shapely

from pyheracles.complex.platforms import platform_tops
from test_complex_foliage import run_complex_draw


def _sparse_platform() -> tuple[np.ndarray, np.ndarray, np.ndarray, shapely.Polygon]:
    """Flat terrain every 2 m round a 12 x 10 m polygon; inside it a platform top 0.6 m
    high with one released point and, 3.7 m from it, a ground point of the same top 0.05 m
    lower; a ground point at the terrain's height in the polygon's other half.  Returns
    the points, the ground mask, the released mask and the polygon."""
    gx, gy = np.meshgrid(np.arange(-10.0, 22.1, 2.0), np.arange(-10.0, 20.1, 2.0))
    g = np.column_stack([gx.ravel(), gy.ravel()])
    g = g[~((g[:, 0] > -1.5) & (g[:, 0] < 13.5) & (g[:, 1] > -1.5) & (g[:, 1] < 11.5))]
    terrain = np.column_stack([g, np.zeros(len(g))])
    inside = np.array([[2.0, 2.0, 0.6], [5.7, 2.0, 0.55], [10.0, 8.0, 0.03]])
    xyz = np.vstack([terrain, inside])
    n = len(terrain)
    released = np.zeros(len(xyz), dtype=bool)
    released[n] = True
    ground = np.zeros(len(xyz), dtype=bool)
    ground[:n] = True
    ground[n + 1 :] = True
    return xyz, ground, released, shapely.box(0, 0, 12, 10)


def test_one_released_point_beside_gives_the_level() -> None:
    xyz, ground, released, poly = _sparse_platform()
    out = platform_tops(xyz, ground, released, np.array([poly]), 0.5, 5.3)
    n = len(xyz) - 3
    assert out[n + 1]  # the platform's edge
    assert not out[n + 2]  # terrain height inside the polygon, no released point near
    assert not out[:n].any()


def test_draw_9_pavilion_keeps_its_platform_edge() -> None:
    """Draw 9, B19: with the roof point under the crown (test_complex_crown_under.py) and
    the platform's edge it scores 0.95 (0.89 with either alone, 0.82 with neither)."""
    _, f1 = run_complex_draw(9)
    assert f1["building/B19"] >= 0.94
