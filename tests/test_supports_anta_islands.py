"""Antae in a section (issue 12): a pier island ending a set-in wall, the wall's stub in
line beyond it, is no piece of that wall (supports draw 34: anta 15, 0.82 x 0.66 m,
ending a wall 0.62 m thick, was missed; its stub was an island of its own beyond it)."""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.supports.anta_islands import anta_islands
from pyheracles.supports.core import SupportParams, scales
from pyheracles.supports.detect import wall_pieces
from pyheracles.supports.sections import section_islands

STEP = 0.016


def line(
    a: tuple[float, float], b: tuple[float, float], rng: np.random.Generator, step: float = STEP
) -> np.ndarray:
    """Section points from ``a`` to ``b`` every ``step`` metres, 3 mm of noise."""
    n = max(2, int(np.hypot(b[0] - a[0], b[1] - a[1]) / step))
    t = np.linspace(0.0, 1.0, n)[:, None]
    return np.asarray(a) + t * (np.asarray(b) - np.asarray(a)) + rng.normal(0, 0.003, (n, 2))


def anta_section(
    inset: float,
    rng: np.random.Generator,
    gap: float = 0.12,
    stub: float = 0.67,
    flush_left: bool = False,
) -> np.ndarray:
    """The section of a pier 0.82 x 0.66 m (y from 0 to 0.66) ending a wall set in by
    ``inset`` on both sides, the wall's stub running 0.55 m down from y = -0.12 (the
    corner's shadow cuts it off the pier), then a door 1.3 m wide and the wall again
    over 0.6 m: as draw 34 saw its anta 15 from the room and the portico."""
    hw, wall = 0.41, 0.41 - inset
    left = hw if flush_left else wall
    parts = [
        line((-hw, 0.66), (hw, 0.66), rng, 3 * STEP),  # front, seen at a glancing angle
        line((-hw, 0.0), (-hw, 0.66), rng, 2 * STEP),  # sides
        line((hw, 0.0), (hw, 0.66), rng, 2 * STEP),
        line((-hw, 0.0), (-left, 0.0), rng),  # the steps to the wall
        line((wall, 0.0), (hw, 0.0), rng),
        line((-left, -gap), (-left, -stub), rng),  # the stub, up to a door
        line((wall, -gap), (wall, -stub), rng),
        line((-left, -stub), (wall, -stub), rng),
        line((-left, -2.0), (-left, -2.6), rng),  # the wall beyond the door
        line((wall, -2.0), (wall, -2.6), rng),
        line((-left, -2.0), (wall, -2.0), rng),
    ]
    return np.vstack(parts)


def islands_of(xy: np.ndarray) -> tuple[list, object]:
    params = SupportParams()
    sc = scales(STEP, params)
    return section_islands(xy, params, sc.distance), sc


def at_anta(islands: list, ks: set[int]) -> list[int]:
    """The islands among ``ks`` at the anta's centre."""
    return [k for k in ks if np.hypot(*(islands[k].center - [0.0, 0.33])) < 0.1]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_anta_ending_a_set_in_wall_is_no_wall_piece(seed: int) -> None:
    xy = anta_section(0.1, np.random.default_rng(seed), stub=0.8)
    islands, sc = islands_of(xy)
    assert at_anta(islands, wall_pieces(xy, islands, sc))  # the stub goes on in line
    antae = anta_islands(xy, islands, sc.tol, sc.distance, max(0.05, 3.0 * STEP))
    assert at_anta(islands, antae)
    assert not at_anta(islands, wall_pieces(xy, islands, sc, antae))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_piece_of_a_flush_wall_is_no_anta(seed: int) -> None:
    # the same outline with the wall as thick as the "pier": a piece of that wall
    xy = anta_section(0.0, np.random.default_rng(seed), stub=0.8)
    islands, sc = islands_of(xy)
    assert at_anta(islands, wall_pieces(xy, islands, sc))
    assert not anta_islands(xy, islands, sc.tol, sc.distance, max(0.05, 3.0 * STEP))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_wall_flush_with_one_face_is_no_anta(seed: int) -> None:
    # a thinner wall going on flush with one face of a thick one (draw 6: a building's
    # corner seen from outside, x -1.4-0.7): no anta, whose wall is set in on both sides
    xy = anta_section(0.28, np.random.default_rng(seed), stub=0.8, flush_left=True)
    islands, sc = islands_of(xy)
    assert not at_anta(islands, anta_islands(xy, islands, sc.tol, sc.distance, 3.0 * STEP))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_outline_seen_on_one_side_is_no_anta(seed: int) -> None:
    # the same island with one side face in the shadow (its last point only): the
    # "step" to the stub is the end of the face seen, no pier's outline (draw 34: pieces
    # of the front wall between doors, x 3.4 and 7.9, stepped in past their last points)
    xy = anta_section(0.1, np.random.default_rng(seed), stub=0.8)
    side = (np.abs(xy[:, 0] - 0.41) < 0.02) & (xy[:, 1] > 0.05)
    xy = xy[~side | (xy[:, 1] > 0.6)]
    islands, sc = islands_of(xy)
    assert not at_anta(islands, anta_islands(xy, islands, sc.tol, sc.distance, 3.0 * STEP))


@pytest.mark.slow
@pytest.mark.parametrize("noise_draw", [0, 1])
def test_draw_34_finds_its_anta(noise_draw: int) -> None:
    from supports_draws import scored_supports_draw

    m = scored_supports_draw(34, noise_draw=noise_draw)
    missed = [f["instance"] for f in m["failures"] if f["mode"] == "missed"]
    assert 15 not in missed
