"""Step 2b (issue 13): a seen face's edge strip does not set the edge of a sparse face across it.

Roof draw 14 (``python benchmarks/bench_framework.py --sweep 1 --first-seed
14``): a common rafter seen densely on one upper or lower face and sparsely on
one side (600-800 points per square metre, the upper face 5-20 times as dense),
its other upper or lower face hidden. The hidden side is read from where the
side's points end; the free points on the side's plane restore its edge strips,
and those at the corner with the dense seen face (its own edge strip, on both
planes) piled up there at several times the side's density: the profile's half-
density level was the pile's, both edges closed in round it, and the hidden
side came out 3 cm inside the rafter (height 131 mm of 161). The seen side is
located by its own face: the points on its plane are left out of the edge
reading.
"""

from __future__ import annotations

import numpy as np
import pytest

from member_points import facet_along_x
from pyheracles.beams.cuboids import fit_beam_cuboid
from pyheracles.beams.model import StraightFacet
from pyheracles.beams.sections import off_seen_sides

X, Y, Z = np.eye(3)
LENGTH, WIDTH, DEPTH = 3.0, 0.133, 0.161
NOISE = 0.002
#: Points per square metre of the seen upper face and of the sparse side.
DENSE, SPARSE = 20_000, 600
#: Edge strip of blended normals left out of the facets, metres.
STRIP = 0.02
#: Scan-line bin of the step on this cloud, metres.
BIN_M = 0.011


def rafter_seen_on_top_and_one_side(
    rng: np.random.Generator,
) -> tuple[np.ndarray, list[StraightFacet], np.ndarray]:
    """The upper face (z = DEPTH) densely, the side y = +WIDTH/2 sparsely, the
    underside hidden; returns the facet points, the two facets and the free points."""
    n_t = int(DENSE * LENGTH * WIDTH)
    top = np.column_stack(
        [rng.uniform(0, LENGTH, n_t), rng.uniform(-WIDTH / 2, WIDTH / 2, n_t), np.full(n_t, DEPTH)]
    )
    n_s = int(SPARSE * LENGTH * DEPTH)
    side = np.column_stack(
        [rng.uniform(0, LENGTH, n_s), np.full(n_s, WIDTH / 2), rng.uniform(0, DEPTH, n_s)]
    )
    top = top + rng.normal(scale=NOISE, size=top.shape)
    side = side + rng.normal(scale=NOISE, size=side.shape)
    in_t = np.abs(top[:, 1]) <= WIDTH / 2 - STRIP
    in_s = (side[:, 2] >= STRIP) & (side[:, 2] <= DEPTH - STRIP)
    xyz = np.vstack([top[in_t], side[in_s]])
    k = int(in_t.sum())
    facets = [facet_along_x(xyz, np.arange(k), Z), facet_along_x(xyz, np.arange(k, len(xyz)), Y)]
    return xyz, facets, np.vstack([top[~in_t], side[~in_s]])


@pytest.mark.parametrize("seed", range(6))
def test_the_hidden_side_of_a_sparse_face_is_not_drawn_to_the_seen_corner(seed):
    xyz, facets, free = rafter_seen_on_top_and_one_side(np.random.default_rng(seed))
    cub = fit_beam_cuboid(xyz, facets, bin_m=BIN_M, free=free)
    assert cub.height == pytest.approx(DEPTH, abs=0.01)  # 21 mm short before
    assert cub.width == pytest.approx(WIDTH, abs=0.006)


def test_off_seen_sides_leaves_out_the_seen_end_only():
    vals = np.concatenate([np.linspace(0.0, 0.16, 200), np.full(300, 0.16)])
    tol = np.array([0.01])
    out = off_seen_sides(vals, np.array([0.16]), tol)
    assert out.max() < 0.15 and out.min() == 0.0
    # a face in the middle of the profile is no side: all kept
    assert len(off_seen_sides(vals, np.array([0.08]), tol)) == len(vals)
    assert len(off_seen_sides(vals, np.zeros(0), np.zeros(0))) == len(vals)
    assert len(off_seen_sides(vals[:5], np.array([0.16]), tol)) == 5
