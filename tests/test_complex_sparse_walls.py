"""Sparse walls climbing a slope (issue 17, complex-family draw 5).

At 0.11 points/m^2 (spacing 2.5 m, clustering distance 7.6 m) a 140 m wall running 22 m
up a slope has 13 points, a few of them 30-50 m from the rest.  Three rules took such
lone points for foliage or a crown: the neighbour vote counted the nearest candidates
however far off (a crown 30 m away), the crown peel measured an inside point against
whatever the buffer ring held beside it (a branch, the wall's lower end downhill), and
the ring's height limit compared the wall's upper end with the top of its points inside
the polygon, lower down the slope.
"""

from __future__ import annotations

import numpy as np

from pyheracles.complex import ComplexParams
from pyheracles.complex.clusters import level_heights, object_points, vote_scattered
from pyheracles.complex.crowns import crown_pass
from pyheracles.complex.params import resolve_params
from test_complex_foliage import run_complex_draw


def test_a_lone_point_is_not_voted_foliage_by_candidates_far_off() -> None:
    """A smooth point with no candidate within the clustering distance (7.5 m) keeps its
    own answer: its 8 nearest candidates are a crown 40 m away."""
    rp = resolve_params(ComplexParams(), 2.5)
    rng = np.random.default_rng(0)
    lone = np.array([[0.0, 0.0, 5.0]])
    crown = np.column_stack(
        [rng.uniform(40, 45, 30), rng.uniform(0, 5, 30), rng.uniform(10, 15, 30)]
    )
    roof = np.column_stack(
        [rng.uniform(-95, -80, 30), rng.uniform(0, 10, 30), 5.0 + 0.05 * rng.random(30)]
    )
    xyz = np.concatenate([lone, crown, roof])
    scattered = np.r_[False, np.ones(30, bool), np.zeros(30, bool)]
    flipped = vote_scattered(xyz, scattered, np.ones(len(xyz), bool), rp)
    assert not flipped[0]
    # amid the crown's points it is voted foliage, as before
    amid = np.concatenate([np.array([[42.0, 2.0, 13.0]]), crown, roof])
    assert vote_scattered(amid, scattered, np.ones(len(amid), bool), rp)[0]


def test_an_inside_point_is_not_raised_over_what_the_ring_holds() -> None:
    """A wall point inside the polygon, 6 m from a branch the buffer ring caught 3 m
    lower, with a crown off the polygon around it: the surface beside it is the object's
    inside the polygon (none within the 7.6 m reach), not the branch."""
    xyz = np.array(
        [
            [0.0, 0.0, 5.84],  # the wall's point inside the polygon
            [6.0, 0.0, 2.94],  # a branch in the buffer ring
            [40.0, 0.0, 0.0],  # the wall's other points, far off
            [40.0, 3.0, 0.0],
            [3.0, 3.0, 8.0],  # a crown off the polygon
            [4.0, -2.0, 9.0],
            [2.0, 4.0, 7.0],
        ]
    )
    members = np.arange(4)
    off = np.arange(4, 7)
    outside = np.array([False, True, False, False])
    flag = crown_pass(xyz, members, off, 7.6, 1.0, 0.2, outside=outside)
    assert not flag[0]
    # a point in the ring is still measured against all the object's points beside it
    ring = np.array([True, True, False, False])
    assert crown_pass(xyz, members, off, 7.6, 1.0, 0.2, outside=ring)[0]


def _wall_up_a_slope() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A wall 2 m over a 30 % slope, a point every 2 m for 40 m; its last 10 m lie in the
    buffer ring (0.05 m off the polygon).  Returns the points, their distance to the
    polygon and the terrain under XY positions."""
    x = np.arange(0.0, 40.1, 2.0)
    xyz = np.column_stack([x, np.zeros_like(x), 0.3 * x + 2.0])
    dist = np.where(x > 30.0, 0.05, 0.0)
    return xyz, dist, lambda xy: 0.3 * xy[:, 0]


def test_the_upper_end_of_a_wall_up_a_slope_is_the_walls() -> None:
    """Draw 5, W05: the wall's upper end in the buffer ring stood over the top of its
    points inside the polygon plus 1 m; over the terrain it stands as high as the rest."""
    xyz, dist, terrain = _wall_up_a_slope()
    rp = resolve_params(ComplexParams(), 1.0)
    cand = np.arange(len(xyz))
    scattered = np.zeros(len(xyz), bool)
    keep = object_points(xyz, cand, dist, scattered, rp, terrain=terrain)
    assert keep.all()
    # without the terrain the ring's top end goes, as before
    assert not object_points(xyz, cand, dist, scattered, rp)[dist > 0].all()


def test_a_roof_over_sloping_ground_is_measured_in_z() -> None:
    """A flat roof is level in Z, not over the slope under it."""
    x = np.arange(0.0, 20.1, 1.0)
    roof = np.column_stack([x, np.zeros_like(x), np.full_like(x, 10.0)])
    part = np.ones(len(x), bool)
    assert np.array_equal(level_heights(roof, lambda xy: 0.3 * xy[:, 0], part), roof[:, 2])
    xyz, _, terrain = _wall_up_a_slope()
    assert np.allclose(level_heights(xyz, terrain, np.ones(len(xyz), bool)), 2.0)
    nan = level_heights(xyz, lambda xy: np.full(len(xy), np.nan), np.ones(len(xyz), bool))
    assert np.array_equal(nan, xyz[:, 2])  # no terrain known: Z


def test_the_sparse_walls_of_draw_5() -> None:
    """Draw 5: W03 (13 points, 4 of them lone, up the slope) F1 0.82 -> >= 0.9, W05's
    upper end kept (0.95 -> 1.0); the draw meets both targets (median 0.952 -> >= 0.96)."""
    _, f1 = run_complex_draw(5)
    assert f1["wall/W03"] >= 0.9 and f1["wall/W05"] >= 0.99
    scores = np.array(list(f1.values()))
    assert np.median(scores) >= 0.96 and np.mean(scores >= 0.9) >= 0.9
