"""An anta: the end of a wall thickened into a pier, seen square on from its end.

Draw 8 of the supports family: the cella wall of a peristyle (0.86 m thick) ends in an
anta 1.06 m wide and 0.69 m deep, 10 cm proud of the wall's faces on each side.  At the
section, the anta's end face was a dense "wall" island, its two sides and the wall's
faces behind it a point every 7-10 cm.  The wall faces, stepped back 10 cm from the
anta's sides, lay within the old 10 cm tolerance of the sides' lines, so the sides
"ran on" into the wall and the anta was taken for a piece of it, as a door reveal is
(``sections.face_and_sides``, ``steps.side_on_line``).  A wall end whose faces run on
flush with the sides (a door reveal, a plain wall end) stays a wall.
"""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.supports.core import SupportParams
from pyheracles.supports.sections import section_islands
from pyheracles.supports.steps import side_on_line

DIST = 0.03  # clustering distance of the draw's section, metres
WIDTH = 1.06  # the anta across the wall, metres
DEPTH = 0.66  # the anta along the wall, metres


def _line(a: tuple[float, float], b: tuple[float, float], step: float) -> np.ndarray:
    n = max(2, round(float(np.hypot(b[0] - a[0], b[1] - a[1])) / step) + 1)
    t = np.linspace(0.0, 1.0, n)[:, None]
    return np.asarray(a) + t * (np.asarray(b) - np.asarray(a))


def wall_end(step_m: float, seed: int) -> np.ndarray:
    """Section points of a wall ending in a pier: the end face (x = 0, dense), its two
    sides running back along +x to ``DEPTH`` (a point every 10 cm) and the wall's two
    faces from 0.15 m behind the pier on to 3 m, ``step_m`` inside the pier's sides
    (a point every 7 cm)."""
    rng = np.random.default_rng(seed)
    lo, hi = 0.0, WIDTH
    p = np.vstack(
        [
            _line((0.0, lo), (0.0, hi), 0.0025),
            _line((0.03, lo), (DEPTH, lo), 0.1),
            _line((0.03, hi), (0.25, hi), 0.1),  # the far side, grazed: a few points
            _line((DEPTH + 0.15, lo + step_m), (3.0, lo + step_m), 0.07),
            _line((DEPTH + 0.15, hi - step_m), (3.0, hi - step_m), 0.07),
        ]
    )
    return p + rng.normal(0.0, 0.002, p.shape)


@pytest.mark.parametrize("seed", range(3))
def test_anta_standing_proud_of_its_wall_is_a_pier(seed: int) -> None:
    islands = section_islands(wall_end(0.1, seed), SupportParams(), DIST)
    piers = [i for i in islands if i.kind == "pier"]
    assert len(piers) == 1, [i.kind for i in islands]
    assert np.allclose(sorted(piers[0].size), [DEPTH, WIDTH], atol=0.05)
    assert np.allclose(piers[0].center, [DEPTH / 2, WIDTH / 2], atol=0.05)


@pytest.mark.parametrize("seed", range(3))
def test_wall_end_flush_with_its_faces_is_no_pier(seed: int) -> None:
    """The same outline with the wall's faces on the sides' lines: a plain wall end (the
    reveal of an opening), not a pier."""
    islands = section_islands(wall_end(0.0, seed), SupportParams(), DIST)
    assert not [i for i in islands if i.kind == "pier"]


def test_side_on_its_own_line() -> None:
    """The side's points are those on the line of the candidate nearest the face's end;
    a face 10 cm behind it is not taken, one within the tolerance is."""
    t = np.array([0.0, 0.004, -0.003, 0.1, 0.1, 0.02])
    cand = np.array([True, True, True, True, True, False])
    mask, x = side_on_line(t, cand, 0.001, 0.03)
    assert mask.tolist() == [True, True, True, False, False, False]
    assert x == pytest.approx(0.0)
    mask, x = side_on_line(t, np.zeros(6, bool), 0.5, 0.03)
    assert not mask.any() and x == 0.5


@pytest.mark.parametrize("seed", range(3))
def test_inner_corner_with_the_outer_face_behind_is_no_pier(seed: int) -> None:
    """Draw 30: in the inner corner of a building, a 1.85 m piece of the rear wall's
    inner face (occluded beyond) and, 0.7 m behind it, the rear wall's outer face, three
    points every 13 cm from the corner to 3.4 m: the outer-face points at the piece's
    ends are no sides of a pier, the face they lie on runs on past it
    (``steps.back_on_wall_face``)."""
    rng = np.random.default_rng(seed)
    clumps = np.repeat(np.c_[0.13 * np.arange(-5, 27), np.full(32, -0.7)], 3, axis=0)
    p = np.vstack(
        [
            _line((0.0, 0.0), (1.85, 0.0), 0.02),  # the rear wall's inner face, seen
            clumps,  # its outer face, crossed by scan lines 13 cm apart
            _line((0.0, 0.25), (0.0, 3.0), 0.05),  # the side wall's inner face, not at the corner
            _line((-0.7, -0.65), (-0.7, 3.0), 0.05),  # and its outer face
        ]
    )
    p = p + rng.normal(0.0, 0.002, p.shape)
    islands = section_islands(p, SupportParams(), 0.055)
    assert not [i for i in islands if i.kind == "pier"], [
        (i.kind, np.round(i.center, 2)) for i in islands if i.kind != "noise"
    ]
