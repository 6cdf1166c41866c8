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

from pyheracles.supports.cookies import MIN_WALLED_BANDS
from supports_draws import piece_among_walls, vertical_face, walled_bands_of_piece

STEP = 0.02  # point spacing of the synthetic faces, metres
HALF = np.array([0.6, 0.4])  # the corner piece, metres
TOP = 3.45  # its top and the walls' tops (no ceiling), metres
OVER = 3.0  # the lintels of the door and the window beside it, metres
H_SEC = 1.9  # the section it was found in, metres
SEEDS = range(6)  # noise draws of the synthetic scenes
#: The building corner of draw 16 (plan x, y, metres) that was a pier.
CORNER_16 = (0.69, 0.24)


def _scene(walls_from: float, rng: np.random.Generator) -> np.ndarray:
    """The piece's faces from the floor to ``TOP``, a floor and the outer faces of the
    two walls meeting at it from ``walls_from`` up: the face y = -0.4 beyond its low x
    end, the face x = 0.6 beyond its high y end (a door under one, a window under the
    other)."""
    hx, hy = HALF
    walls = [
        vertical_face(1, -hy, -hx - 2.0, -hx - 0.02, walls_from, TOP, STEP),
        vertical_face(0, hx, hy + 0.02, hy + 2.0, walls_from, TOP, STEP),
    ]
    return piece_among_walls(HALF, TOP, walls, STEP, rng)


@pytest.mark.parametrize("seed", SEEDS)
def test_corner_walled_over_the_lintels_is_a_wall_piece(seed: int) -> None:
    """Both walls run on from the corner piece over the lintels only, 0.45 m under its
    top: a corner in at least two bands, the last right under its top, in every noise
    draw."""
    rng = np.random.default_rng(seed)
    assert walled_bands_of_piece(_scene(OVER, rng), HALF, STEP, H_SEC, TOP) >= MIN_WALLED_BANDS


@pytest.mark.parametrize("seed", SEEDS)
def test_corner_walled_over_its_top_layers_only_stays(seed: int) -> None:
    """Walls meeting it in the top 0.15 m only (an architrave's ends resting on a pier
    at a corner, say): fewer than half the layers of any band, a pier."""
    rng = np.random.default_rng(seed)
    assert walled_bands_of_piece(_scene(TOP - 0.15, rng), HALF, STEP, H_SEC, TOP) < MIN_WALLED_BANDS


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
