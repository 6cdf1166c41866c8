"""Step 2b (issue 13): a member's deflection is its bow's sag over its scanned length.

The issue defines a member's deflection as the largest deviation of its scanned
centre line from straight.  Roof sweep: a post's cuboid runs on through the tie it
stands on (its side faces go on in the tie's, coplanar), and a few points of the
purlin over its head are labelled to it.  The sag was given over the cuboid's
length (or faces followed past its ends), 1.2-1.7 times the true sag of the
post's scanned length (seeds 1, 3 and 6: queen posts, struts, +5 to +16 mm).  The
chord is now the member's scanned length: its own points in slices holding at
least ``min_face_points`` of them (:func:`scanned_ends`).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from member_points import surface_points
from pyheracles.beams import BeamCuboid
from pyheracles.beams.deflection import member_shape, scanned_ends
from pyheracles.synthetic.families.roof_frame import member_between


def _bent_post(sag: float):
    m = member_between("p", "post", [0, 0, 0.0], [0, 0, 2.0], 0.14, 0.14, [1.0, 0.0, 0.0])
    return replace(m, deflection_m=sag)


@pytest.mark.parametrize("sag", [0.012, 0.024])
def test_the_sag_is_given_over_the_scanned_length_not_a_cuboid_run_on(sag):
    rng = np.random.default_rng(6)
    m = _bent_post(sag)
    pts = surface_points(m, 30_000, 0.002, rng)
    # a few points of the purlin over the post's head, labelled to the post (more
    # than a slice past its end: nearer, they are taken with the end's points)
    strays = np.column_stack(
        [rng.uniform(-0.07, 0.07, 5), rng.uniform(-0.07, 0.07, 5), rng.uniform(2.12, 2.3, 5)]
    )
    pts = np.vstack([pts, strays])
    # the post's cuboid fitted 0.4 m too long at its foot, down through the tie
    axes = np.column_stack([m.axis, m.side, m.up])
    cub = BeamCuboid(m.centre - 0.2 * m.axis, axes, m.length + 0.4, m.width, m.height, 0.003, 4)
    sh = member_shape(pts, cub, np.ones(len(pts), dtype=bool))
    # the scanned length: the post itself (the strays left out)
    assert np.ptp(sh.chord_m) == pytest.approx(m.length, abs=0.03)
    # over the cuboid's 2.4 m the sag would be (2.4 / 2)^2 = 1.44 times the true one
    assert sh.deflection_m == pytest.approx(sag, abs=0.0015)


def test_scanned_ends_leave_out_sparse_strays_and_keep_sparse_ends():
    rng = np.random.default_rng(0)
    dense = rng.uniform(0.0, 3.0, 3000)  # 100 points a slice
    sparse_end = rng.uniform(3.0, 3.3, 40)  # a sparse end: about 13 a slice
    strays = np.array([3.8, 3.85, 3.9, -0.6, -0.62])
    ends = scanned_ends(np.concatenate([dense, sparse_end, strays]), 0.1, 8)
    assert ends[0] == pytest.approx(0.0, abs=0.01)
    assert ends[1] == pytest.approx(3.3, abs=0.02)
    assert np.isnan(scanned_ends(np.zeros(0), 0.1, 8)).all()
