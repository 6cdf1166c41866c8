"""A free pier candidate that reaches no farther than a tube in its layers is clutter.

Supports draws 1 and 35: scaffold standards (0.024 m tubes 3.8-9.8 m tall), cut as
piers where a ledger or a deck joined them in the section, were supports (boxes 0.125 x
0.039 m, 0.150 x 0.027 m).  A section island shorter than ``min_support_size_m`` every
way is noise; :func:`~pyheracles.supports.clutter.thin_pier` holds the points kept over
the height to the same bound, layer by layer.  A pier seen on one face only is as thin
as a fence, but reaches its face's width (draws 27 and 32: 0.16-0.28 m).
"""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.supports.clutter import plan_reach, thin_pier

NOISE = 0.003


def _tube(rng: np.random.Generator, x: float, y: float, r: float, z1: float, n: int) -> np.ndarray:
    th = rng.uniform(-0.5 * np.pi, 0.5 * np.pi, n)  # the side facing the scanner
    return np.c_[x + r * np.cos(th), y + r * np.sin(th), rng.uniform(0.0, z1, n)]


def _standard(rng: np.random.Generator) -> np.ndarray:
    """A scaffold's standard 6 m tall with stubs of its ledgers every 2 m."""
    pts = [_tube(rng, 0.0, 0.0, 0.024, 6.0, 3000)]
    for zl in (2.0, 4.0):
        u = rng.uniform(0.0, 0.15, 200)
        pts.append(np.c_[u, rng.normal(0.0, 0.01, 200), rng.normal(zl, 0.01, 200)])
    return np.vstack(pts) + rng.normal(0.0, NOISE, (3400, 3))


def _pier_two_faces(rng: np.random.Generator, side_share: float) -> np.ndarray:
    """A pier 0.5 x 0.15 m, 3 m tall: its long face seen fully, its short side face at a
    grazing angle (``side_share`` of the points)."""
    n = 5000
    n_side = int(side_share * n)
    face = np.c_[rng.uniform(-0.25, 0.25, n - n_side), np.full(n - n_side, -0.075)]
    side = np.c_[np.full(n_side, 0.25), rng.uniform(-0.075, 0.075, n_side)]
    xy = np.vstack([face, side])
    pts = np.c_[xy, rng.uniform(0.0, 3.0, n)]
    return pts + rng.normal(0.0, NOISE, pts.shape)


def test_a_scaffold_standard_is_thin() -> None:
    rng = np.random.default_rng(12)
    pts = _standard(rng)
    assert plan_reach(pts) < 0.1
    assert thin_pier(pts, 0.1)


@pytest.mark.parametrize("side_share", [0.0, 0.05, 0.5])
def test_a_pier_seen_on_one_face_is_not_thin(side_share: float) -> None:
    """Its long face alone, or with its side face at a grazing angle: it reaches the
    face's width in each layer."""
    rng = np.random.default_rng(3)
    pts = _pier_two_faces(rng, side_share)
    assert plan_reach(pts) > 0.4
    assert not thin_pier(pts, 0.1)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 35])
def test_scaffold_standards_are_no_supports_on_their_draws(seed: int) -> None:
    """Draws 1 (one scaffold standard) and 35 (three scaffold pieces): no found support
    is 90 % clutter."""
    from supports_draws import scored_supports_draw

    m = scored_supports_draw(seed)
    false = [
        f for f in m["failures"] if f["mode"] == "clutter_merged" and f["clutter_share"] >= 0.9
    ]
    assert not false, false
