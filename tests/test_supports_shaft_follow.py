"""A shaft is followed through the sparse stretches of its height (issue 12, step 2a,
shafts cut where sparse).

Draw 33 of the supports family: columns of 1.2 m radius, 15 m tall, found in a low
section, are scanned densely up to 6-9 m (500-3400 points per 0.5 m) and on a few lines
above (8-37 points per 0.5 m, 0.2-0.3 m apart).  The final clustering, at the gap of the
section's spacing, kept them only up to 7.2 and 9.8 m; ending far below what the others
carry, they were dropped as posts under nothing (columns 13 and 14 missed).
:func:`~pyheracles.supports.shaft_follow.follow_shaft` follows the kept part on through
the points on its shaft's surface, at the spacing of each stretch.
"""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.supports.shaft_follow import follow_shaft
from supports_draws import scored_supports_draw

GAP = 0.074  # the final clustering's voxel at draw 33 column 13's section
TOL = 0.05
R = 1.2


def _shaft(seed: int, dense_top: float = 7.0) -> np.ndarray:
    """A column of radius ``R`` at the origin tapering 0.02 m per metre: seen over 150
    degrees on a 3 cm grid from 2 m to ``dense_top``, above it up to 15 m on four
    vertical scan lines 15 degrees apart with a point every 0.2 m (3 mm noise)."""
    rng = np.random.default_rng(seed)
    az, z = np.meshgrid(np.radians(np.arange(-75, 75, 1.5)), np.arange(2.0, dense_top, 0.03))
    az_s, z_s = np.meshgrid(np.radians([10.0, 25.0, 40.0, 55.0]), np.arange(dense_top, 15.0, 0.2))
    t, zz = np.r_[az.ravel(), az_s.ravel()], np.r_[z.ravel(), z_s.ravel()]
    r = R - 0.02 * (zz - 2.0)
    p = np.c_[r * np.cos(t), r * np.sin(t), zz]
    return p + rng.normal(0, 0.003, p.shape)


def _rho(p: np.ndarray) -> np.ndarray:
    """Offsets from the section circle (radius ``R`` at the origin), metres."""
    return np.hypot(p[:, 0], p[:, 1]) - R


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_sparse_upper_shaft_is_followed(seed: int) -> None:
    """The four scan lines above the dense band join the kept shaft up to its top."""
    p = _shaft(seed)
    kept = p[:, 2] < 7.0
    out = follow_shaft(p, _rho(p), kept, GAP, TOL)
    assert out[kept].all()
    assert out.sum() == len(p)
    assert p[out, 2].max() > 14.7


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_twin_beside_it_is_not_taken(seed: int) -> None:
    """Sparse lines of the other twin of a plinth (its surface 2.9 m off this one's
    outline, inside the cookie) stay out; the shaft's own lines still join."""
    p = _shaft(seed)
    rng = np.random.default_rng(seed + 10)
    zt = np.arange(7.0, 15.0, 0.2)
    twin = np.c_[np.full(zt.size, R + 2.9), rng.normal(0, 0.1, zt.size), zt]
    q = np.r_[p, twin]
    kept = np.r_[p[:, 2] < 7.0, np.zeros(len(twin), dtype=bool)]
    out = follow_shaft(q, _rho(q), kept, GAP, TOL)
    assert not out[len(p) :].any()
    assert out[: len(p)].all()


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_dense_piece_beyond_a_gap_is_not_joined(seed: int) -> None:
    """A piece as dense as the section above a gap the clustering did not cross (a
    capital over an unseen face, something standing on it) is not followed into: the
    stretch is no sparser than the section."""
    p = _shaft(seed, dense_top=7.0)
    p = p[p[:, 2] < 7.0]
    rng = np.random.default_rng(seed)
    az, z = np.meshgrid(np.radians(np.arange(-75, 75, 1.5)), np.arange(8.0, 9.0, 0.03))
    r = R - 0.02 * (z.ravel() - 2.0)
    piece = np.c_[r * np.cos(az.ravel()), r * np.sin(az.ravel()), z.ravel()]
    q = np.r_[p, piece + rng.normal(0, 0.003, piece.shape)]
    kept = q[:, 2] < 7.0
    out = follow_shaft(q, _rho(q), kept, GAP, TOL)
    assert not out[len(p) :].any()


def test_nothing_beyond_keeps_the_shaft() -> None:
    """A shaft with nothing beyond its kept part is returned as it was."""
    p = _shaft(0)
    p = p[p[:, 2] < 7.0]
    kept = np.ones(len(p), dtype=bool)
    assert follow_shaft(p, _rho(p), kept, GAP, TOL).all()


@pytest.mark.slow
@pytest.mark.parametrize("noise_draw", [0, 3])
def test_draw_33_column_14_is_found(noise_draw: int) -> None:
    """Draw 33 of the supports family (noise draws 0 and 3): column 14, dense up to
    9.8 m and on few lines above, is followed to its top and found; no false support
    appears."""
    m = scored_supports_draw(33, noise_draw=noise_draw)
    missed = {f["instance"] for f in m["failures"] if f["mode"] == "missed"}
    assert 14 not in missed
    assert m["n_supports_found"] <= m["n_supports_visible"] + 1  # + the jamb of draw 33
