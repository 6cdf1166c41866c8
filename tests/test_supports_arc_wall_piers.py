"""A pier shape that is an engaged column's arc with a stretch of the wall it stands in
is no support (issue 12, step 2a: the scorer's ``ring_split``).

Supports draw 38 (a hypostyle, 0.94 m engaged columns 0.30 m in front of their walls):
engaged column 24 was found in the low section; in the main section its arc next to the
wall and 1 m of the wall's face made one island, a pier holding a third of the column's
points (noise draws 0 and 2; 28-54 % of its section points on the ring, the rest on the
face) (:func:`pyheracles.supports.arcs.arc_wall_piers`).
"""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.supports.arcs import arc_wall_piers
from supports_draws import scored_supports_draw

R, OFF, TOL = 0.94, 0.30, 0.03


def _engaged() -> dict:
    """The engaged column at (0, OFF), its wall's face y = 0 (room at +y)."""
    return {"class": "engaged_column", "centre": np.array([0.0, OFF]), "radius": R,
            "half": np.array([R, R]), "angle": 0.0, "normal": np.array([0.0, 1.0]),
            "d": 0.0, "face_gap": 0.01}  # fmt: skip


def _pier(pts: np.ndarray) -> dict:
    """An axis-aligned pier shape round the points ``pts``."""
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    return {"class": "pier", "centre": (lo + hi) / 2, "half": (hi - lo) / 2, "angle": 0.0}


def _arc(rng: np.random.Generator, lo: float, hi: float, n: int) -> np.ndarray:
    a = np.radians(rng.uniform(lo, hi, n))
    return np.array([0.0, OFF]) + R * np.c_[np.cos(a), np.sin(a)] + rng.normal(0, 0.003, (n, 2))


def _wall(rng: np.random.Generator, x0: float, x1: float, n: int) -> np.ndarray:
    return np.c_[rng.uniform(x0, x1, n), rng.normal(0.0, 0.003, n)]


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("ring_share", [0.25, 0.5])
def test_arc_with_its_wall_is_no_pier(seed: int, ring_share: float) -> None:
    """The arc from the wall (-18.6 degrees) to 30 degrees and 1 m of the face beside
    it, in one pier shape: dropped."""
    rng = np.random.default_rng(seed)
    n_arc = int(60 * ring_share)
    pts = np.vstack([_arc(rng, -18.0, 30.0, n_arc), _wall(rng, 0.9, 1.9, 60 - n_arc)])
    assert arc_wall_piers(pts, [_engaged(), _pier(pts)], TOL) == {1}


@pytest.mark.parametrize("seed", range(4))
def test_respond_and_free_arc_stay(seed: int) -> None:
    """A respond on the wall next to the column (a 0.6 x 0.3 m bump: front face and
    flanks), and the same arc and wall with no engaged column (a free column's shape):
    kept."""
    rng = np.random.default_rng(seed)
    front = np.c_[rng.uniform(0.95, 1.55, 40), np.full(40, 0.3)]
    flanks = np.c_[np.repeat([0.95, 1.55], 10), rng.uniform(0.0, 0.3, 20)]
    bump = np.vstack([front, flanks]) + rng.normal(0, 0.003, (60, 2))
    assert arc_wall_piers(bump, [_engaged(), _pier(bump)], TOL) == set()
    pts = np.vstack([_arc(rng, -18.0, 30.0, 30), _wall(rng, 0.9, 1.9, 30)])
    free = {**_engaged(), "class": "column"}
    free.pop("normal")
    assert arc_wall_piers(pts, [free, _pier(pts)], TOL) == set()


@pytest.mark.slow
@pytest.mark.parametrize("noise_draw", [0, 1, 2, 3])
def test_draw_38_engaged_column_24_found_once(noise_draw: int) -> None:
    """Draw 38: engaged column 24 is not split over a pier of its arc and wall (before:
    ``ring_split`` on noise draws 0 and 2)."""
    m = scored_supports_draw(38, noise_draw=noise_draw)
    split = {f["instance"] for f in m["failures"] if f["mode"] == "ring_split"}
    assert 24 not in split
