"""A pier candidate inside a wall's opening (between the wall's two faces, which run on
beyond both of its ends) is a reveal or a jamb, no pier (supports.openings; supports
draw 28: a window reveal of a 1.33 m wall found as a pier on noise draws 0, 1 and 3)."""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.supports.openings import in_wall_opening

TOL = 0.015
BIN = 0.05
THICK = 1.33  # the wall of draw 28
JAMBS = (1.1, 2.0)  # the window's reveals along the wall (x), metres


def segment(a: tuple[float, float], b: tuple[float, float], step: float) -> np.ndarray:
    """Points every ``step`` along the segment from ``a`` to ``b``."""
    n = max(2, int(np.hypot(b[0] - a[0], b[1] - a[1]) / step))
    t = np.linspace(0.0, 1.0, n)[:, None]
    return (1 - t) * np.asarray(a) + t * np.asarray(b)


def wall_with_window(rng: np.random.Generator, reveal: tuple[float, float]) -> np.ndarray:
    """Section points of a wall along x (faces y = 0 and y = -THICK) with a window
    between the JAMBS, and the part ``reveal`` (y from, to) of its left reveal seen (the
    scan line through the opening reaches little of it), with noise."""
    x0, x1 = JAMBS
    parts = [
        segment((-3.0, 0.0), (x0, 0.0), 0.01),
        segment((-3.0, -THICK), (x0, -THICK), 0.01),
        segment((x1, 0.0), (5.0, 0.0), 0.01),
        segment((x1, -THICK), (5.0, -THICK), 0.01),
        segment((x0, reveal[0]), (x0, reveal[1]), 0.03),
        segment((-3.0, 0.0), (-3.0, 2.0), 0.01),  # a wall meeting it
    ]
    p = np.vstack(parts)
    return p + rng.normal(0.0, TOL / 3, p.shape)


def opening(xy: np.ndarray, centre, angle: float, half, rng: np.random.Generator) -> bool:
    """:func:`in_wall_opening` of a candidate's section rectangle among ``xy``."""
    return in_wall_opening(xy, np.array(centre), angle, np.array(half), TOL, BIN, rng)


@pytest.mark.parametrize("noise", range(8))
@pytest.mark.parametrize(
    ("centre", "angle", "half"),
    [
        ((1.1, -0.91), np.pi / 2, (0.28, 0.01)),  # the reveal's face alone (noise draw 0)
        ((1.49, -0.92), 0.0, (0.38, 0.25)),  # with what is seen through it (draw 1)
        ((0.99, -0.67), np.pi / 2, (0.67, 0.15)),  # the reveal across the wall (draw 3)
    ],
)
def test_reveal_is_in_the_opening(noise, centre, angle, half):
    rng = np.random.default_rng(noise)
    xy = wall_with_window(rng, (-1.2, -0.6))
    assert opening(xy, centre, angle, half, rng)


@pytest.mark.parametrize("noise", range(8))
def test_free_pier_before_the_wall_is_not(noise):
    """A pier 0.6 m in front of the wall's face: the wall on one side of it only."""
    rng = np.random.default_rng(noise)
    pier = np.vstack([segment((0.0, 0.6), (0.8, 0.6), 0.01), segment((0.0, 0.6), (0.0, 1.4), 0.01)])
    xy = np.vstack([wall_with_window(rng, (-1.2, -0.6)), pier + rng.normal(0, TOL / 3, pier.shape)])
    assert not opening(xy, (0.4, 1.0), 0.0, (0.4, 0.4), rng)


@pytest.mark.parametrize("noise", range(8))
def test_respond_on_the_wall_face_is_not(noise):
    """A respond standing 0.3 m out of the wall's inner face: outside the wall."""
    rng = np.random.default_rng(noise)
    xy = wall_with_window(rng, (-1.2, -0.6))
    xy = xy[~((np.abs(xy[:, 0] + 1.0) < 0.3) & (np.abs(xy[:, 1]) < 0.05))]
    bump = np.vstack(
        [segment((-1.3, 0.0), (-1.3, 0.3), 0.01), segment((-1.3, 0.3), (-0.7, 0.3), 0.01)]
    )
    xy = np.vstack([xy, bump + rng.normal(0, TOL / 3, bump.shape)])
    assert not in_wall_opening(
        xy, np.array([-1.0, 0.15]), 0.0, np.array([0.3, 0.15]), TOL, BIN, rng
    )


@pytest.mark.parametrize("noise", range(8))
def test_anta_ending_the_wall_is_not(noise):
    """A pier ending the wall (the wall runs on beyond one of its ends only)."""
    rng = np.random.default_rng(noise)
    xy = wall_with_window(rng, (-1.2, -0.6))
    xy = xy[xy[:, 0] < 0.5]  # the wall ends at x = 0.5 in a pier 0.8 m long
    pier = np.vstack(
        [segment((0.5, 0.1), (1.3, 0.1), 0.01), segment((1.3, 0.1), (1.3, -1.43), 0.01)]
    )
    xy = np.vstack([xy, pier + rng.normal(0, TOL / 3, pier.shape)])
    assert not in_wall_opening(
        xy, np.array([0.9, -0.66]), 0.0, np.array([0.4, 0.77]), TOL, BIN, rng
    )


@pytest.mark.slow
@pytest.mark.parametrize("noise_draw", [0, 1, 3])
def test_draw_28_window_reveal_is_no_pier(noise_draw):
    """Draw 28: the window reveal of a 1.33 m wall was a pier on noise draws 0, 1 and 3;
    its seven supports are found, no jamb."""
    from supports_draws import scored_supports_draw

    m = scored_supports_draw(28, noise_draw=noise_draw)
    assert not [f for f in m["failures"] if f["mode"] == "jamb_as_pier"]
    assert m["n_supports_found"] == m["n_supports_true"] == m["n_matched"] == 7
