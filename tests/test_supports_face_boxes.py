"""Faces of one pier joined into one box (issue 12, missed piers seen face-on).

Supports draw 12: the front and the back face of one 0.72 x 0.64 m pier are two face-on
lines 0.64 m apart, its left side seen at a graze (a few points): one box, not two
supports.  Two neighbouring piers across a passage are not one box: the side through a
face's end is open.
"""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.supports.face_boxes import FaceBoxParams, Part, one_box
from supports_draws import scored_supports_draw

TOL = 0.03  # surface tolerance, metres
MAX = 2.5  # max_support_size_m


def _line(a: tuple[float, float], b: tuple[float, float], step: float = 0.03) -> np.ndarray:
    n = max(2, int(np.hypot(b[0] - a[0], b[1] - a[1]) / step))
    return np.linspace(a, b, n)


def _box(parts: list[np.ndarray], rng: np.random.Generator) -> tuple[np.ndarray, list[int]]:
    xy = np.vstack(parts) + rng.normal(0, 0.003, (sum(len(q) for q in parts), 2))
    return xy, np.cumsum([0] + [len(q) for q in parts]).tolist()


@pytest.mark.parametrize("seed", range(3))
def test_front_and_back_face_with_a_grazed_side_are_one_box(seed: int) -> None:
    # draw 12, pier 30: back face from 17.94 (its corner shadowed), the side's points
    # 0.04-0.24 m apart
    rng = np.random.default_rng(seed)
    front = _line((17.66, 25.68), (18.35, 25.68))
    back = _line((17.94, 26.32), (18.36, 26.32))
    side = np.c_[np.full(5, 17.66), [25.72, 25.81, 25.90, 26.14, 26.15]]
    xy, cut = _box([front, back, side], rng)
    other = Part(np.arange(cut[1], cut[2]), 0.0, "face")
    box = one_box(xy, np.arange(cut[0], cut[1]), other, 0.0, MAX, TOL, FaceBoxParams())
    assert box is not None
    centre, _, size = box
    assert np.allclose(size, [0.70, 0.64], atol=0.03)
    assert np.allclose(centre, [18.01, 26.0], atol=0.03)


@pytest.mark.parametrize("seed", range(3))
def test_facing_sides_of_two_piers_are_no_box(seed: int) -> None:
    # two piers 0.64 m apart in a row: their facing sides are parallel lines as above,
    # but the passage between them leaves the sides through their ends open
    rng = np.random.default_rng(seed)
    right_of_a = _line((0.0, 0.0), (0.0, 0.7))
    left_of_b = _line((0.64, 0.0), (0.64, 0.7))
    front_of_a = _line((-0.6, 0.0), (-0.05, 0.0))  # the faces round them, beyond the gap
    front_of_b = _line((0.69, 0.0), (1.3, 0.0))
    xy, cut = _box([right_of_a, left_of_b, front_of_a, front_of_b], rng)
    other = Part(np.arange(cut[1], cut[2]), np.pi / 2, "face")
    assert (
        one_box(xy, np.arange(cut[0], cut[1]), other, np.pi / 2, MAX, TOL, FaceBoxParams()) is None
    )


@pytest.mark.parametrize("seed", range(3))
def test_side_of_one_pier_and_front_of_the_next_are_no_box(seed: int) -> None:
    # perpendicular faces of two piers 0.4 m apart: the corner is not turned
    rng = np.random.default_rng(seed)
    side_of_a = _line((0.0, 0.0), (0.0, 1.0))
    front_of_b = _line((0.4, 0.0), (1.4, 0.0))
    xy, cut = _box([side_of_a, front_of_b], rng)
    other = Part(np.arange(cut[1], cut[2]), 0.0, "face")
    assert (
        one_box(xy, np.arange(cut[0], cut[1]), other, np.pi / 2, MAX, TOL, FaceBoxParams()) is None
    )


@pytest.mark.parametrize("seed", range(3))
def test_face_beside_the_island_of_its_other_faces_is_one_box(seed: int) -> None:
    # draw 11, pier 2 (2.0 x 1.15 m): the left face a line, the top and right faces an
    # island; and no box when the island is further than a support is large
    rng = np.random.default_rng(seed)
    left = _line((8.0, 11.2), (8.0, 12.3))
    top = _line((8.1, 12.35), (10.0, 12.35))
    right = _line((10.0, 11.2), (10.0, 12.3))
    xy, cut = _box([left, top, right], rng)
    island = Part(np.arange(cut[1], cut[3]), 0.0, "shape", 0)
    box = one_box(xy, np.arange(cut[0], cut[1]), island, np.pi / 2, MAX, TOL, FaceBoxParams())
    assert box is not None
    assert np.allclose(sorted(box[2]), [1.15, 2.0], atol=0.05)
    assert (
        one_box(xy, np.arange(cut[0], cut[1]), island, np.pi / 2, 1.5, TOL, FaceBoxParams()) is None
    )


@pytest.mark.slow
@pytest.mark.parametrize("noise_draw", [0])
def test_pier_seen_on_two_faces_is_one_support_draw_12(noise_draw: int) -> None:
    """Draw 12 of the supports family: pier 30's front and back faces were two face-on
    supports (ring_split); joined, one."""
    m = scored_supports_draw(12, noise_draw=noise_draw)
    assert not [f for f in m["failures"] if f["mode"] == "ring_split" and f["instance"] == 30]
    assert m["n_matched"] >= 34
