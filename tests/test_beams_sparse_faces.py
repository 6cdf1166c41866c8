"""Step 2b (issue 13, causes 1 and 5): narrow faces scanned sparsely get facets.

Roof draw 8 (``python benchmarks/bench_framework.py --sweep 1 --first-seed 8``)
lost nine common rafters (8 x 10 cm) of its far slope, scanned at 1.5-3 cm,
before any facet: the 24 neighbours of region growing spanned 4-8 cm there,
the whole width of a face and round its edges, so every point's curvature was
4-5 times the threshold (0.06-0.07 against 0.015) and no region formed.  The
sparse parts no facet took are grown again with fewer neighbours
(:mod:`pyheracles.beams.sparse_faces`).
"""

from __future__ import annotations

import numpy as np
import pytest

from grid_planes import grid_plane
from member_points import best_f1
from pyheracles.beams import BeamParams, segment_beams
from pyheracles.beams.sparse_faces import SparseFaceParams, sparse_k, sparse_leftover
from pyheracles.geometry.neighbours import build_tree, point_spacing

X, Y, Z = np.eye(3)


def test_the_second_pass_takes_as_many_neighbours_over_the_same_radius():
    assert sparse_k(24, SparseFaceParams()) == 11
    assert sparse_k(24, SparseFaceParams(spacing_ratio=3.0)) == 8


def _near_tie_far_rafter(rng: np.random.Generator):
    """A tie at 4 mm near the station (label 1), a common rafter (8 x 10 cm) at 1.8 cm (2)."""
    lo, far = np.array([0.0, -0.08, 1.0]), np.array([3.0, 0.0, 2.0])
    parts = [
        grid_plane(lo, X, Y, 2.0, 0.16, 0.004, rng, noise=0.003),
        grid_plane(lo, X, Z, 2.0, 0.20, 0.004, rng, noise=0.003),
        grid_plane(far, X, Y, 0.08, 3.7, 0.018, rng, noise=0.003),
        grid_plane(far, Y, Z, 3.7, 0.101, 0.018, rng, noise=0.003),
    ]
    labels = [np.full(len(p), 1 if i < 2 else 2) for i, p in enumerate(parts)]
    return np.vstack(parts), np.concatenate(labels)


def test_sparse_leftover_keeps_the_sparse_points_only():
    xyz, truth = _near_tie_far_rafter(np.random.default_rng(8))
    left = np.arange(len(xyz))
    tree = build_tree(xyz)
    sparse = np.zeros(len(xyz), bool)
    sparse[sparse_leftover(xyz, tree, point_spacing(xyz, tree), left, SparseFaceParams())] = True
    # a few points in cells too thin to measure at the tie's ends count as sparse
    assert sparse[truth == 1].mean() < 0.05
    assert sparse[truth == 2].mean() > 0.8


# roof draw 8: the common rafters of the far bays (x 7.9-11.2 m), 8 x 10 cm, scanned
# at 1.5-3 cm; a crop of the draw's cloud with the purlins, plates and boarding round them
DRAW8_BOX = (np.array([7.9, -np.inf, -np.inf]), np.array([11.2, np.inf, np.inf]))
DRAW8_RAFTERS = tuple(range(55, 65))


def _draw8_crop(scan: int):
    """Roof draw 8 scanned with noise draw ``scan`` (0: its own), cropped to the far bays."""
    from pyheracles.synthetic.families import simulate

    sim = simulate("roof", 8, noise_draw=scan)
    res = sim.clouds["cloud"]
    lo, hi = DRAW8_BOX
    inside = np.all((res.xyz >= lo) & (res.xyz <= hi), axis=1) & ~res.outlier
    beam = next(k for k, v in sim.scene.class_names.items() if v == "beam")
    truth = np.where(res.class_id == beam, res.instance, 0)[inside]
    return res.xyz[inside], truth


def _found(xyz: np.ndarray, truth: np.ndarray, params: BeamParams | None = None) -> int:
    """How many of draw 8's far common rafters a beam takes at F1 >= 0.5."""
    labels = segment_beams(xyz, params).labels
    return sum(best_f1(truth, labels, m) >= 0.5 for m in DRAW8_RAFTERS)


@pytest.mark.slow
@pytest.mark.parametrize("scan", [0, 1, 2, 3])
def test_draw8_far_common_rafters_are_found_only_with_the_second_pass(scan):
    """Draw 8 and noise draws 1-3 of its scene: the second pass takes one far common rafter
    more than the first pass alone (measured on the final code of the session that landed
    it: 3, 3, 3, 2 without; 4, 4, 4, 3 with; the uncropped draw 8 sweep row gains 5
    members).  When it was written, on an earlier main: 3, 3, 3, 2 without; 5 with."""
    xyz, truth = _draw8_crop(scan)
    without = _found(xyz, truth, BeamParams(sparse_faces=False))
    assert without <= 3
    assert _found(xyz, truth) >= without + 1
