"""A few stray points touching a support do not turn a square pier into a ring.

Draw 8 of the supports family: a 0.3 x 0.3 m pier seen square on from one side, its
other faces grazed, with a tail of six points 0.4 m long (a rope or a sign touching it)
in its section group.  The tail set the extent of the outline rectangle, which turned
to the pier's diagonal (2.2 cm RMS), while the circle of 0.16 m radius ignored it
(1.5 cm): the pier became a ring, a column that then carried nothing and was dropped.
Circle and rectangle are now compared on the points the circle explains.
"""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.supports.core import SupportParams
from pyheracles.supports.rings import ring_fit
from pyheracles.supports.sections import classify_island, sparse_group

CENTRE = np.array([21.2, 1.4])
#: the six tail points of the draw, relative to the pier's centre (metres)
TAIL = np.array(
    [[-0.037, -0.374], [-0.034, -0.364], [0.008, -0.23], [-0.01, -0.286], [0.013, -0.212],
     [-0.087, -0.537]]
)  # fmt: skip


def _face(a: list[float], b: list[float], n: int) -> np.ndarray:
    t = np.linspace(0.0, 1.0, n)[:, None]
    return np.asarray(a) + t * (np.asarray(b) - np.asarray(a))


def pier_with_tail(rng: np.random.Generator) -> np.ndarray:
    """The section group of draw 8's pier: point counts per face as in the draw (one
    face dense and partly seen, one half dense, two grazed), the tail, 2 mm noise."""
    h = 0.15
    pts = np.vstack(
        [
            _face([-0.147, -h], [0.025, -h], 616),
            _face([-h, -0.15], [-h, 0.116], 257),
            _face([-0.117, h], [0.129, h], 31),
            _face([h, -0.11], [h, 0.11], 24),
            TAIL,
        ]
    )
    return pts + rng.normal(0.0, 0.002, pts.shape) + CENTRE


def ring_with_tail(rng: np.random.Generator, radius: float = 0.16) -> np.ndarray:
    """A column ring seen over 270 degrees with the same tail."""
    a = rng.uniform(-0.75 * np.pi, 0.75 * np.pi, 600)
    ring = radius * np.c_[np.cos(a), np.sin(a)]
    pts = np.vstack([ring, TAIL])
    return pts + rng.normal(0.0, 0.002, pts.shape) + CENTRE


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_square_pier_with_a_tail_is_no_ring(seed: int) -> None:
    p = pier_with_tail(np.random.default_rng(seed))
    idx = np.arange(len(p))
    assert ring_fit(p) is None
    isl = classify_island(p, idx, SupportParams())
    assert isl.kind == "pier"
    assert "column" not in [i.kind for i in sparse_group(p, idx, SupportParams())]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_ring_with_a_tail_stays_a_column(seed: int) -> None:
    p = ring_with_tail(np.random.default_rng(seed))
    idx = np.arange(len(p))
    fit = ring_fit(p)
    assert fit is not None
    assert abs(fit[1] - 0.16) < 0.01
    isl = classify_island(p, idx, SupportParams())
    assert isl.kind == "column"
    assert abs(isl.radius - 0.16) < 0.01
