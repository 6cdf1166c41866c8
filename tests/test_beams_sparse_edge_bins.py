"""Step 2b (issue 13): a sparse face's edge is read in bins finer than a scan line.

Roof draw 4's common rafters (``python benchmarks/bench_framework.py --sweep 1
--first-seed 4``), seen on the underside and one side, their tops hidden by the
boarding, take the top from where the side's points end
(:func:`~pyheracles.beams.sections.face_edges`).  The side is sparse (fewer than
80 points per scan-line bin across it) and was read in bins of a scan line (8 mm)
aligned on the profile's first point: where the last bin straddled the top and the
boarding's few points at the corner filled it past half the plateau count, the top
was the last point, 5-6 mm out; leaving the seen underside's corner strip out of
the profile (:func:`~pyheracles.beams.sections.off_seen_sides`) only moved the
bins, and three of eight noise draws of the scene failed.  The profile is now read
as a dense one is, in bins of a quarter scan line with a running mean over one,
whatever their alignment.
"""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.beams.cuboids import fit_beam_cuboid
from pyheracles.beams.sections import face_edges
from test_beams_hidden_side_surface import BIN_M, DEPTH, rafter_under_boarding

#: Range noise of the side's points across it, metres (the scene's 2.5 mm along rays
#: meeting the side at a slant).
SIDE_NOISE = 0.001
#: Side points per metre of the profile (a 4 m side at 1600 points per square metre).
SIDE_DENSITY = 6_400


@pytest.mark.parametrize("boarding", [0.0, 1.0, 2.0])
def test_hidden_top_of_a_sparse_rafter(boarding):
    """Eight noise draws, no boarding or boarding 1-2 times the side's density:
    the depth within 4 mm (before: 4.4 mm too shallow, 6.1 and 6.2 mm too deep)."""
    errors = []
    for seed in range(8):
        xyz, facets, free = rafter_under_boarding(np.random.default_rng(seed), boarding)
        errors.append(fit_beam_cuboid(xyz, facets, bin_m=BIN_M, free=free).height - DEPTH)
    assert np.max(np.abs(errors)) <= 0.004


def test_edge_whatever_the_bins_alignment():
    """A sparse profile ending at DEPTH with 30 points of a surface at its edge,
    its start moved by eighths of a bin (64 draws): the far edge within 5 mm
    (before: up to 7 mm out, where the last bin straddled the edge)."""
    errors = []
    for seed in range(8):
        for k in range(8):
            rng = np.random.default_rng(100 * seed + k)
            start = 0.02 + k * BIN_M / 8
            n = int(SIDE_DENSITY * (DEPTH - start))
            side = rng.uniform(start, DEPTH, n) + rng.normal(scale=SIDE_NOISE, size=n)
            tail = DEPTH + rng.normal(scale=2 * SIDE_NOISE, size=30)
            lo, hi = face_edges(np.concatenate([side, tail]), BIN_M)
            errors.append(hi - DEPTH)
            assert lo == pytest.approx(start, abs=0.003)
    assert np.max(np.abs(errors)) <= 0.005
