"""The bands of a pier candidate's height end with the band right under its top (issue
12, mode 4: "a jamb is a wall edge").

Built from draw 16 of the supports family: the corner of a building between a door in
one wall and a window in the other, seen from outside (a 2.1 x 1.2 m "pier" of 99.7 %
wall points), is one with both walls over the lintels only, in the top 0.5 m under its
top at 3.5 m; there each wall's outer face runs on beyond one of its ends, a corner
(:func:`~pyheracles.supports.piers.walled_piece`).  The bands every 0.2 m from its foot
stopped 0.12 m short of the top and one of them held the corner; two are needed
(:func:`~pyheracles.supports.cookies.walled_band_count`).
"""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.supports.cookies import MIN_WALLED_BANDS, cookies, walled_band_count
from pyheracles.supports.core import SupportParams, scales

STEP = 0.02  # point spacing of the synthetic faces, metres
HALF = np.array([0.6, 0.4])  # the corner piece, metres
TOP = 3.45  # its top and the walls' tops (no ceiling), metres
OVER = 3.0  # the lintels of the door and the window beside it, metres
H_SEC = 1.9  # the section it was found in, metres
SEEDS = range(6)  # noise draws of the synthetic scenes
#: The building corner of draw 16 (plan x, y, metres) that was a pier.
CORNER_16 = (0.69, 0.24)


def _face(fixed: int, at: float, lo: float, hi: float, z0: float, z1: float) -> np.ndarray:
    """A vertical face at coordinate ``fixed`` (0: x, 1: y) = ``at``, from ``lo`` to
    ``hi`` along the other coordinate and ``z0`` to ``z1`` up."""
    uu, zz = np.meshgrid(np.arange(lo, hi + 1e-9, STEP), np.arange(z0, z1 + 1e-9, STEP))
    u = uu.ravel()
    xy = np.c_[np.full(u.size, at), u] if fixed == 0 else np.c_[u, np.full(u.size, at)]
    return np.c_[xy, zz.ravel()]


def _scene(walls_from: float, rng: np.random.Generator) -> np.ndarray:
    """The piece's faces from the floor to ``TOP``, a floor and the outer faces of the
    two walls meeting at it from ``walls_from`` up: the face y = -0.4 beyond its low x
    end, the face x = 0.6 beyond its high y end (a door under one, a window under the
    other)."""
    hx, hy = HALF
    parts = [
        _face(1, -hy, -hx, hx, 0.0, TOP),
        _face(1, hy, -hx, hx, 0.0, TOP),
        _face(0, -hx, -hy, hy, 0.0, TOP),
        _face(0, hx, -hy, hy, 0.0, TOP),
        _face(1, -hy, -hx - 2.0, -hx - 0.02, walls_from, TOP),
        _face(0, hx, hy + 0.02, hy + 2.0, walls_from, TOP),
    ]
    fx, fy = np.meshgrid(np.arange(-3.0, 3.0, 0.05), np.arange(-3.0, 3.0, 0.05))
    parts.append(np.c_[fx.ravel(), fy.ravel(), np.zeros(fx.size)])
    p = np.vstack(parts)
    return p + rng.normal(0.0, 0.0035, p.shape)


def _walled_bands(p: np.ndarray) -> int:
    """:func:`walled_band_count` of the piece (centred at the origin along x) from the
    floor to ``TOP``, found in the section at ``H_SEC``."""
    params = SupportParams()
    sc = scales(STEP, params)
    sh = {"class": "pier", "centre": np.zeros(2), "angle": 0.0, "half": HALF.copy()}
    sh["buffer"] = max(params.buffer_min_m, params.pier_buffer_fraction * float(HALF.max()))
    order = np.argsort(p[:, 2], kind="stable")
    z_sorted = p[order, 2]

    def band(z_lo: float, z_hi: float) -> np.ndarray:
        a, b = np.searchsorted(z_sorted, [z_lo, z_hi])
        return order[a:b]

    (idx, rho, _), = cookies(p, [sh], params)  # fmt: skip
    return walled_band_count(p, p[idx], rho, sh, sc, H_SEC, (0.0, TOP), band)


@pytest.mark.parametrize("seed", SEEDS)
def test_corner_walled_over_the_lintels_is_a_wall_piece(seed: int) -> None:
    """Both walls run on from the corner piece over the lintels only, 0.45 m under its
    top: a corner in at least two bands, the last right under its top, in every noise
    draw."""
    rng = np.random.default_rng(seed)
    assert _walled_bands(_scene(OVER, rng)) >= MIN_WALLED_BANDS


@pytest.mark.parametrize("seed", SEEDS)
def test_corner_walled_over_its_top_layers_only_stays(seed: int) -> None:
    """Walls meeting it in the top 0.15 m only (an architrave's ends resting on a pier
    at a corner, say): fewer than half the layers of any band, a pier."""
    rng = np.random.default_rng(seed)
    assert _walled_bands(_scene(TOP - 0.15, rng)) < MIN_WALLED_BANDS


@pytest.mark.slow
def test_draw_16_building_corner_is_no_pier() -> None:
    """Draw 16 itself: the building's corner between a door and a window, seen from
    outside, is no support."""
    from pyheracles.building import segment_building
    from pyheracles.synthetic.families import simulate

    sim = simulate("supports", 16)
    _, found, _, _ = segment_building(sim.clouds["cloud"].xyz)
    objects = found.objects
    near = np.hypot(objects["x"] - CORNER_16[0], objects["y"] - CORNER_16[1]) < 1.0
    assert not near.any()
