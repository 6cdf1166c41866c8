"""Step 2b (issue 13): the depth behind a beam seen on one face ends where its side ends.

Roof draw 6 (``python benchmarks/bench_framework.py --sweep 1 --first-seed 6``):
a piece of common rafter 18 seen on its side alone had its depth read from the
points going back from the side's lower edge: its underside, 9 cm deep, and
past a gap holding a few stray points a surface 24-26 cm behind the face whose
105 points outnumbered the underside's 70 in a narrower range.  The
half-density level of the whole profile was that surface's and the depth came
out 0.255 m for 0.087; the piece's section then matched no other piece of the
rafter and it stayed apart, 1.7 m from the rest (its deflection read over a
third of the length, -5.1 mm).  The side is read from the face back to its
first gap (:func:`~pyheracles.beams.one_face.side_run`).
"""

from __future__ import annotations

import numpy as np
import pytest

from grid_planes import grid_plane
from pyheracles.beams import StraightFacet
from pyheracles.beams.one_face import fit_one_face_cuboid, side_run
from pyheracles.geometry.neighbours import build_tree

X, Y, Z = np.eye(3)
LENGTH, WIDTH, DEPTH = 2.0, 0.087, 0.095
NOISE = 0.002
#: The other surface behind the beam, metres behind the seen face (draw 6: 0.24-0.26).
PILE = (0.24, 0.26)
BIN_M = 0.008


def _noisy(p: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    return p + rng.normal(scale=NOISE, size=p.shape)


def side_seen_rafter(
    rng: np.random.Generator, pile: bool = True
) -> tuple[np.ndarray, StraightFacet]:
    """A rafter along y seen on its side (x = 0, the body at x > 0) and, sparsely, on
    its underside (z = 0); with ``pile``, a strip of another surface at the
    underside's level ``PILE`` behind the face, 3 times as dense per metre as the
    underside, and a few stray points between them; a wall 2 m in front (the
    room's side).  Returns the points and the side's facet."""
    side = grid_plane(np.zeros(3), Y, Z, LENGTH, DEPTH, 0.008, rng)
    n_u = int(35 * LENGTH)
    under = np.column_stack(
        [rng.uniform(0, WIDTH, n_u), rng.uniform(0, LENGTH, n_u), np.zeros(n_u)]
    )
    parts = [side, _noisy(under, rng)]
    if pile:
        n_p = int(90 * LENGTH)
        strip = np.column_stack(
            [rng.uniform(*PILE, n_p), rng.uniform(0, LENGTH, n_p), np.zeros(n_p)]
        )
        n_s = int(12 * LENGTH)
        stray = np.column_stack(
            [rng.uniform(WIDTH + 0.01, PILE[0], n_s), rng.uniform(0, LENGTH, n_s), np.zeros(n_s)]
        )
        parts += [_noisy(strip, rng), _noisy(stray, rng)]
    wall = grid_plane(np.array([-2.0, -0.5, -1.0]), Y, Z, LENGTH + 1.0, 2.5, 0.03, rng)
    parts.append(wall)
    xyz = np.vstack(parts)
    index = np.arange(len(side))
    pts = xyz[index]
    facet = StraightFacet(
        index=index,
        normal=-X,
        axis=Y.copy(),
        centre=pts.mean(axis=0),
        width=DEPTH,
        length=LENGTH,
        plane_rms=NOISE,
        parent=1,
    )
    return xyz, facet


def _depth(xyz: np.ndarray, facet: StraightFacet) -> float:
    cub = fit_one_face_cuboid(xyz, build_tree(xyz), [facet], xyz[::5], bin_m=BIN_M, max_depth_m=0.6)
    assert cub is not None and cub.height_measured
    # the face is vertical: its width is the height, the depth behind it the width
    assert cub.height == pytest.approx(DEPTH, abs=0.01)
    return cub.width


@pytest.mark.parametrize("seed", range(4))
def test_a_surface_behind_the_side_does_not_deepen_the_beam(seed):
    """Four noise draws: the depth within 8 mm (0.24-0.26 m before)."""
    xyz, facet = side_seen_rafter(np.random.default_rng(seed))
    assert _depth(xyz, facet) == pytest.approx(WIDTH, abs=0.008)


@pytest.mark.parametrize("seed", range(2))
def test_without_the_surface_the_depth_is_the_side_s(seed):
    xyz, facet = side_seen_rafter(np.random.default_rng(seed), pile=False)
    assert _depth(xyz, facet) == pytest.approx(WIDTH, abs=0.008)


def test_side_run_stops_at_the_first_gap():
    rng = np.random.default_rng(0)
    side = rng.uniform(0.0, 0.09, 70)
    stray = rng.uniform(0.1, 0.24, 8)
    pile = rng.uniform(0.24, 0.26, 105)
    run = side_run(np.concatenate([side, stray, pile]), 0.009)
    assert run.max() < 0.14
    assert len(run) >= 70
    # a side without a gap is kept whole
    assert len(side_run(side, 0.009)) == len(side)


def test_a_side_seen_on_a_few_points_is_read_to_its_hidden_corner():
    """Roof draw 8, common rafter 65 seen on its underside: the side going back
    from one edge holds 4 points near the face (a grazing view), then none, then
    the boarding on the rafter's top at its depth (1 cm bins: 2, 1, 1, 0, 0, 0,
    21, 352).  The first gap came after 4 points and the depth was 0.053 m for
    0.107; a run needs ``min_points`` before its end: the whole profile is read."""
    rng = np.random.default_rng(8)
    near = np.array([0.0, 0.004, 0.012, 0.022])
    corner = rng.uniform(0.06, 0.07, 21)
    top = rng.uniform(0.07, 0.08, 352)
    depth = np.concatenate([near, corner, top])
    assert len(side_run(depth, 0.0088)) == len(depth)
    # with 70 points of side before the gap it still ends there (draw 6)
    side = rng.uniform(0.0, 0.09, 70)
    pile = rng.uniform(0.24, 0.26, 105)
    assert side_run(np.concatenate([side, pile]), 0.0088).max() < 0.14
