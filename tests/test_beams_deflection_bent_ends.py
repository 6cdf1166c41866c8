"""Step 2b (issue 13): the deflection's chord reaches the ends a tight straight box leaves out.

Roof draw 29 (``python benchmarks/bench_framework.py --sweep 1 --first-seed 29``):
a common rafter sagging 27 mm was fitted a box of its true height once the
boarding's points no longer widened it; the straight box stands where the bow
is on average, and the rafter's ends, bent 18 mm out of it, were labelled to no
beam (the labels take the points within 1 cm of a box).  The chord of the
deflection ran between the ends of the labelled points, 28 cm short, and the
sag over it came out 3.5 mm too small (1.5 mm before).  The points near the
bent surface within the box's length are the member's: the chord reaches them.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from member_points import surface_points
from pyheracles.beams import BeamCuboid
from pyheracles.beams.deflection import ShapeParams, member_shape, reach_ends, scanned_ends
from pyheracles.synthetic.families.roof_frame import member_between

#: Labelling tolerance of the step about a box, metres.
LABEL_TOL = 0.01


def _bent_rafter(sag: float):
    up = np.array([0.0, -0.5, 1.0]) / np.linalg.norm([0.0, -0.5, 1.0])
    m = member_between("r", "rafter", [0, 0, 0.0], [0, 5.0, 2.5], 0.10, 0.18, up)
    return replace(m, deflection_m=sag)


def _box_on_the_mean_bow(m) -> BeamCuboid:
    """The straight box of the member's true size where its sag is on average (2/3 of it)."""
    centre = m.centre - (2.0 / 3.0) * m.deflection_m * m.up
    axes = np.column_stack([m.axis, m.side, m.up])
    return BeamCuboid(centre, axes, m.length, m.width, m.height, 0.003, 2)


def _seen_on_top(m, rng: np.random.Generator) -> np.ndarray:
    """The member's upper face, and one side away from its ends (the wall and the
    ridge hide its last 60 cm): the upper face at the ends lies 2/3 of the sag
    outside the box (the underside lies inside it, its edges within the labels'
    tolerance of the sides)."""
    pts = surface_points(m, 30_000, 0.0025, rng)
    rel = pts - m.centre
    t = np.clip(rel @ m.axis / m.length + 0.5, 0.0, 1.0)
    rel = rel + (4.0 * m.deflection_m * t * (1.0 - t))[:, None] * m.up  # about the bent line
    u, v = rel @ m.side, rel @ m.up
    upper = v > 0.5 * m.height - 0.005
    side = (u < -0.5 * m.width + 0.005) & (np.abs(rel @ m.axis) < 0.5 * m.length - 0.6)
    return pts[upper | (side & (rng.random(len(pts)) < 0.3))]


@pytest.mark.parametrize("seed", range(3))
@pytest.mark.parametrize("sag", [0.025, 0.03])
def test_the_chord_reaches_the_bent_ends_out_of_the_box(seed, sag):
    m = _bent_rafter(sag)
    pts = _seen_on_top(m, np.random.default_rng(seed))
    cub = _box_on_the_mean_bow(m)
    own = np.abs(cub.signed_distance(pts)) < LABEL_TOL
    t = (pts - cub.centre) @ m.axis
    # the labels stop short of the ends
    assert np.ptp(scanned_ends(t[own], 0.1, ShapeParams().min_face_points)) < m.length - 0.2
    sh = member_shape(pts, cub, own)
    assert sh.chord_m == pytest.approx([-0.5 * m.length, 0.5 * m.length], abs=0.06)
    assert sh.deflection_m == pytest.approx(sag, abs=0.002)


def test_reach_ends_keeps_within_the_box_and_never_shortens():
    p = ShapeParams()
    own = np.array([-1.0, 1.2])
    along = np.linspace(-3.0, 3.0, 2000)  # points near the surface run on past the box
    assert reach_ends(own, along, 2.0, p) == pytest.approx([-2.0, 2.0], abs=0.01)
    assert reach_ends(own, along[:10], 2.0, p) == pytest.approx(own)  # too few: own ends
    assert reach_ends(own, np.zeros(0), 2.0, p) == pytest.approx(own)
    short = np.linspace(-0.5, 0.5, 500)
    assert reach_ends(own, short, 2.0, p) == pytest.approx(own)
