"""Step 2b (issue 13), diagnostic: the share of each true face's points grown into a facet.

Roof draws 0-29 (``python benchmarks/bench_framework.py --sweep 30``): 82 of
the members whose size fails were seen on two faces and fitted from one.  For
67 of them more than half of the second face's points (a median of 451
points a face) lay in no facet at all: region growing never grew the face
(draw 19 members 20 and 24, draw 18 plates 38 and 39: the points' curvature
over their 24 neighbours, reaching across the edge into the first face, is
0.04-0.08 against a limit of 0.011-0.034).  The rows now carry that share per
face (``size_fail_members[*].in_facet_share``), so a sweep tells a face never
grown from one grown and grouped elsewhere.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

from bench_framework import face_facet_shares, size_detail
from pyheracles.beams import BeamCuboid


def _member(deflection: float = 0.0) -> dict:
    """A 4 m member along x, 10 cm wide (y), 16 cm high (z), as the roof family's truth."""
    cuboid = dict(
        centre=[0.0, 0.0, 3.0],
        axis=[1.0, 0.0, 0.0],
        side=[0.0, 1.0, 0.0],
        up=[0.0, 0.0, 1.0],
        length=4.0,
        width=0.10,
        height=0.16,
    )
    return dict(cuboid=cuboid, deflection_m=deflection, twist_deg=0.0, role="rafter", faces_seen=2)


def _faces(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Points on the member's underside (-up, 400) and on one side (+side, 150), away
    from the corners (a corner point lies on either face as its noise falls)."""
    t = rng.uniform(-1.9, 1.9, 550)
    under = np.column_stack([t[:400], rng.uniform(-0.04, 0.04, 400), np.full(400, 2.92)])
    side = np.column_stack([t[400:], np.full(150, 0.05), rng.uniform(2.93, 3.07, 150)])
    pts = np.vstack([under, side]) + rng.normal(0.0, 0.002, (550, 3))
    return pts, np.arange(550) < 400


@pytest.mark.parametrize("seed", range(3))
def test_a_face_never_grown_shows_a_share_of_zero(seed):
    pts, under = _faces(np.random.default_rng(seed))
    # the underside grown into a facet but for its edge strips, the side not at all
    in_facet = under & (np.abs(pts[:, 1]) < 0.032)
    shares = face_facet_shares(_member(), pts, in_facet)
    assert set(shares) == {"-up", "+side"}  # faces without a point are left out
    assert shares["+side"] == 0.0
    assert 0.7 <= shares["-up"] <= 0.9


def test_the_faces_follow_the_bent_centre_line():
    """A member sagging 3 cm: its underside at mid-length lies 3 cm under the straight box."""
    o = _member(deflection=0.03)
    rng = np.random.default_rng(0)
    t = rng.uniform(-1.9, 1.9, 400)
    sag = 0.03 * (1.0 - (t / 2.0) ** 2)
    pts = np.column_stack([t, rng.uniform(-0.045, 0.045, 400), 2.92 - sag])
    shares = face_facet_shares(o, pts, np.ones(400, dtype=bool))
    assert shares == {"-up": 1.0}


def test_size_detail_carries_the_shares_only_when_given():
    o = _member()
    pts, under = _faces(np.random.default_rng(1))
    cub = BeamCuboid(np.array([0.0, 0.0, 3.0]), np.eye(3), 4.0, 0.10, 0.16, 0.002, 2)
    assert "in_facet_share" not in size_detail(o, cub, pts)
    got = size_detail(o, cub, pts, under)["in_facet_share"]
    assert got == {"-up": 1.0, "+side": 0.0}
