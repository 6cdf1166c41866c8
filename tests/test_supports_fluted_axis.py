"""A fluted, tapered column seen from one side keeps its axis (issue 12; issue 18's IFC).

Supports draw 1: twin columns with 17 flutes 3 cm deep, radius 0.72 -> 0.55 m over
13.8 m, seen from one side. The cone of their shaft was fitted to the points within the
surface tolerance of a cylinder, which on a tapered shaft are those of the heights
where the cylinder meets the cone, and on a fluted one its arrises or its flutes'
bottoms only: the axes leaned 2.3-3.1 cm at 12 m and the IFC surfaces of the columns
were 1.7-2.5 cm RMS from their points (draw 1's only IFC failure). The cone is now
refitted to the points near itself.
"""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.geometry.fitting import fit_cylinder
from pyheracles.supports.primitives import cone_residuals, fit_cone, shaft_axis


def _shaft(seed: int, *, flutes: int, depth: float, r_top: float) -> np.ndarray:
    """A vertical shaft 13.8 m tall about the z axis, radius 0.72 m at its foot and
    ``r_top`` at its top, with ``flutes`` flutes ``depth`` deep, seen over 200 degrees."""
    rng = np.random.default_rng(seed)
    n, h = 30000, 13.8
    z = rng.uniform(0.0, h, n)
    th = rng.uniform(-0.55 * np.pi, 0.55 * np.pi, n)
    r = 0.72 - (0.72 - r_top) * z / h - depth * np.abs(np.sin(0.5 * flutes * th))
    return np.c_[r * np.cos(th), r * np.sin(th), z] + rng.normal(0.0, 0.002, (n, 3))


def _offsets(pts: np.ndarray) -> list[float]:
    """Horizontal distance (m) of the fitted axis from the true one at 0.5, 6 and 12 m."""
    band = pts[np.abs(pts[:, 2] - 6.9) < 0.25]
    cyl = fit_cylinder(band, axis_hint=[0, 0, 1], f_scale=0.01)
    p, a, _ = shaft_axis(pts, cyl, 0.03)
    return [float(np.hypot(*(p + a * (z - p[2]) / a[2])[:2])) for z in (0.5, 6.0, 12.0)]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_fluted_tapered_shaft_seen_from_one_side_keeps_its_axis(seed: int) -> None:
    off = _offsets(_shaft(seed, flutes=17, depth=0.03, r_top=0.55))
    assert max(off) < 0.008, off  # 1.0-2.4 cm at the foot or the top before the refits


def test_a_plain_cylinder_keeps_its_axis() -> None:
    off = _offsets(_shaft(3, flutes=0, depth=0.0, r_top=0.72))
    assert max(off) < 0.002, off


def test_cone_residuals_are_the_distances_to_the_cone() -> None:
    pts = _shaft(4, flutes=0, depth=0.0, r_top=0.55)
    cone = fit_cone(pts[::30], np.array([0.0, 0.0, 6.9]), np.array([0.0, 0.0, 1.0]), 0.63)
    assert cone is not None
    point, axis, radius, _, slope = cone
    res = cone_residuals(pts, point, axis, radius, slope)
    assert abs(slope + (0.72 - 0.55) / 13.8) < 1e-3
    assert float(np.sqrt(np.mean(res**2))) < 0.003


@pytest.mark.slow
def test_supports_draw_16_column_with_big_mouldings_keeps_its_radius() -> None:
    """Supports draw 16, column 7: a 0.28 m shaft (2,300 points) seen from one side
    between a square plinth of 1.3 m and an abacus of 1.1 m (2,488 and 933 points). A
    cone refitted to a band centred on the median offset (the mouldings') went through
    the plinth's top face and the abacus' underside: radius 0.45 m, leaning 1.5 degrees
    (radius 15 cm off). The band is centred on the cone and judged on its own points."""
    from pyheracles.building import segment_building
    from pyheracles.synthetic.families import simulate
    from pyheracles.synthetic.families.supports_score import score_supports

    sim = simulate("supports", 16)
    res = sim.clouds["cloud"]
    _, found, _, _ = segment_building(res.xyz)
    m = score_supports(sim, found.instance, found.objects, section_height=found.section_height)
    assert m["radius_err_m"], "no column matched"
    assert max(abs(v) for v in m["radius_err_m"].values()) < 0.01, m["radius_err_m"]
