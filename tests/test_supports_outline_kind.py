"""Issue 12, missed supports: a pier seen from one corner is told from a wall by the
rectangle its points lie on, not by the smallest rectangle round them.

Built from draw 30 of the supports family (a portico of 15 m piers 2.0 x 1.77 m seen by
stations outside): the section of a pier seen from one corner is an L of its two faces
in view, whose smallest enclosing rectangle lies along its diagonal, 2.66 x 1.34 m:
longer than ``max_support_size_m`` (2.5 m), so the island was a wall and the pier was
missed (the L lies on the 2.03 x 1.77 m outline within 3 mm).  Here the L is rebuilt
with the draw's dimensions over several noise draws.
"""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.supports import SupportParams, section_islands
from pyheracles.supports.sections import classify_island
from supports_draws import scored_supports_draw

PARAMS = SupportParams()
SEEDS = range(6)  # noise draws of the same view


def _face(a, b, step: float) -> np.ndarray:
    n = max(2, int(np.hypot(*np.subtract(b, a)) / step))
    t = np.linspace(0.0, 1.0, n)[:, None]
    return np.asarray(a) + t * np.subtract(b, a)


def _corner_view(w: float, d: float, step: float, rng, noise: float = 0.003) -> np.ndarray:
    """Section points of a ``w`` x ``d`` pier seen from one corner (two faces, an L),
    two scan lines in the slab, ``noise`` metres of noise."""
    top = _face([-w / 2, d / 2], [w / 2, d / 2], step)
    side = _face([w / 2, d / 2], [w / 2, -d / 2], step)
    pts = np.vstack([top, side, top + [step / 2, 0], side + [0, step / 2]])
    return pts + rng.normal(0, noise, pts.shape) + [38.95, 13.63]


@pytest.mark.parametrize("seed", SEEDS)
def test_large_pier_seen_from_a_corner_is_no_wall(seed: int) -> None:
    """Draw 30's pier seen from a corner is a pier of its own size, not a wall."""
    xy = _corner_view(2.0, 1.77, 0.02, np.random.default_rng(seed))
    isl = classify_island(xy, np.arange(len(xy)), PARAMS)
    assert isl.kind == "pier", (isl.kind, isl.size)
    np.testing.assert_allclose(np.sort(isl.size), [1.77, 2.0], atol=0.03)
    islands = [i for i in section_islands(xy, PARAMS, 0.055) if i.kind != "noise"]
    assert [i.kind for i in islands] == ["pier"]


def test_walls_stay_walls() -> None:
    """A straight wall piece as long as draw 30's piers, two walls meeting at a corner 3
    m each way, and an L as large as the pier's whose points stray 2-3 cm off its outline
    (a plinth's corner among sparse points, draw 23) stay walls."""
    rng = np.random.default_rng(0)
    line = np.c_[np.linspace(0, 2.0, 200), np.zeros(200)] + rng.normal(0, 0.003, (200, 2))
    assert classify_island(line, np.arange(200), PARAMS).kind == "wall"
    corner = _corner_view(3.0, 3.0, 0.02, rng)
    assert classify_island(corner, np.arange(len(corner)), PARAMS).kind == "wall"
    rough = _corner_view(2.0, 1.77, 0.06, rng, noise=0.025)
    assert classify_island(rough, np.arange(len(rough)), PARAMS).kind == "wall"


@pytest.mark.slow
@pytest.mark.parametrize("noise_draw", [0, 1, 2, 3])
def test_draw_30_piers_found(noise_draw: int) -> None:
    """Draw 30 (noise draws 0-3): every 15 m pier of the portico is found as a pier
    (without the outline's kind, piers are missed in all four: three in noise draw 0)."""
    m = scored_supports_draw(30, noise_draw=noise_draw)
    lost = [f for f in m["failures"] if f.get("class") == "pier" or f.get("true") == "pier"]
    assert not lost, lost
