"""Responds on the building's wall face lines (supports.line_responds): a pier against a
wall whose section holds no wall island beside it (supports draw 37: the long walls of
a nave scanned at a grazing angle from inside, broken into pieces shorter than a
support; eleven responds of 0.39 x 0.3 m missed)."""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.supports.core import SupportParams, scales
from pyheracles.supports.detect import support_shapes
from pyheracles.supports.line_responds import face_lines, line_responds
from pyheracles.supports.sections import section_islands

SPACING = 0.009  # draw 37's point spacing, metres
INSIDE = np.array([4.0, 5.0])  # a plan point inside the building (the room is +y)


def chunked_line(a: np.ndarray, b: np.ndarray, rng, chunk=0.1, gap=0.06) -> np.ndarray:
    """Points from ``a`` to ``b`` in chunks ``chunk`` long (1 cm apart) with gaps of
    about ``gap``: a face seen at a grazing angle, its scan lines far apart."""
    length = float(np.hypot(*(b - a)))
    u = (b - a) / length
    t, out = 0.0, []
    while t < length:
        s = np.arange(t, min(t + chunk, length), 0.01)
        out.append(a + np.outer(s, u))
        t += chunk + gap * rng.uniform(0.7, 1.3)
    p = np.vstack(out)
    return p + rng.normal(0.0, 0.002, p.shape)


def respond(x0: float, width: float, depth: float, rng, front_gap=(0.15, 0.27)) -> np.ndarray:
    """A respond's outline out of the face ``y = 0``: its front broken by a gap (a few
    missing scan lines) and its two sides sparse."""
    xs = np.arange(x0, x0 + width, 0.01)
    lo, hi = x0 + front_gap[0], x0 + front_gap[1]
    front = np.c_[xs[(xs < lo) | (xs > hi)], np.full(np.sum((xs < lo) | (xs > hi)), depth)]
    ys = np.arange(0.02, depth, 0.025)
    sides = np.vstack([np.c_[np.full(len(ys), x0), ys], np.c_[np.full(len(ys), x0 + width), ys]])
    p = np.vstack([front, sides])
    return p + rng.normal(0.0, 0.002, p.shape)


def wall_with(rng, *parts: np.ndarray, x1: float = 9.0, behind=(3.8, 4.19)) -> np.ndarray:
    """A wall face ``y = 0`` from 0 to ``x1`` in chunks, none in the shadow of a
    respond between ``behind``, with ``parts`` added."""
    face = chunked_line(np.array([0.0, 0.0]), np.array([x1, 0.0]), rng)
    face = face[(face[:, 0] < behind[0]) | (face[:, 0] > behind[1])]
    return np.vstack([face, *parts])


def run(xy: np.ndarray) -> list[dict]:
    params = SupportParams()
    return line_responds(xy, INSIDE, params, scales(SPACING, params))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_respond_on_a_broken_wall_is_found(seed):
    rng = np.random.default_rng(seed)
    xy = wall_with(rng, respond(3.8, 0.39, 0.3, rng))
    found = run(xy)
    assert len(found) == 1
    sh = found[0]
    assert sh["class"] == "pier" and sh["respond"]
    assert np.allclose(sh["centre"], [3.8 + 0.195, 0.15], atol=0.03)
    assert np.allclose(2 * sh["half"], [0.39, 0.3], atol=0.04)
    assert np.allclose(sh["normal"], [0.0, 1.0], atol=0.01)


def test_section_islands_miss_it():
    """The stage on the section's islands does not see it: the wall is no island."""
    rng = np.random.default_rng(0)
    xy = wall_with(rng, respond(3.8, 0.39, 0.3, rng))
    params = SupportParams()
    sc = scales(SPACING, params)
    islands = section_islands(xy, params, sc.distance)
    assert not any(i.kind == "wall" for i in islands)
    shapes, _ = support_shapes(xy, islands, params, sc, np.random.default_rng(0))
    assert not any(sh.get("respond") for sh in shapes)


def test_reveals_of_an_opening_are_no_respond():
    """A window in a thick wall: its reveals run out of the room, its outer face beyond;
    nothing stands into the room."""
    rng = np.random.default_rng(3)
    inner = [
        chunked_line(np.array([0.0, 0.0]), np.array([3.8, 0.0]), rng),
        chunked_line(np.array([4.8, 0.0]), np.array([9.0, 0.0]), rng),
    ]
    reveals = [
        chunked_line(np.array([x, 0.0]), np.array([x, -0.6]), rng, gap=0.02) for x in (3.8, 4.8)
    ]
    outer = chunked_line(np.array([0.0, -0.6]), np.array([9.0, -0.6]), rng)
    assert run(np.vstack([*inner, *reveals, outer])) == []


def test_window_frame_in_a_thick_wall_is_no_respond():
    """A thick wall's opening seen from the room: its inner face is a line, its outer
    face another; the reveals and the window's frame half-way stand out of the outer
    face towards the room, between the two faces (supports draw 28)."""
    rng = np.random.default_rng(7)
    inner = [
        chunked_line(np.array([0.0, 0.0]), np.array([3.85, 0.0]), rng),
        chunked_line(np.array([4.5, 0.0]), np.array([9.0, 0.0]), rng),
    ]
    outer = [
        chunked_line(np.array([0.0, -1.33]), np.array([3.85, -1.33]), rng),
        chunked_line(np.array([4.5, -1.33]), np.array([9.0, -1.33]), rng),
    ]
    reveals = [
        chunked_line(np.array([x, -0.02]), np.array([x, -1.31]), rng, gap=0.02) for x in (3.85, 4.5)
    ]
    frame = chunked_line(np.array([3.86, -0.65]), np.array([4.49, -0.65]), rng, gap=0.02)
    assert run(np.vstack([*inner, *outer, *reveals, frame])) == []


def test_wall_stub_crossing_the_face_is_no_respond():
    """A cross wall's end within a respond's depth of the face: 0.25 m thick, 1.2 m
    long, more elongated than a pier (supports draw 28)."""
    rng = np.random.default_rng(8)
    sides = [
        chunked_line(np.array([x, 0.02]), np.array([x, 1.2]), rng, gap=0.02) for x in (4.0, 4.25)
    ]
    xs = np.arange(4.0, 4.25, 0.01)
    end = np.c_[xs, np.full(len(xs), 1.2)]
    assert run(wall_with(rng, *sides, end, behind=(4.0, 4.25))) == []


def test_wall_end_turning_into_the_room_is_no_respond():
    """A wall that ends in a corner (a jamb, a return) has no face beyond that end."""
    rng = np.random.default_rng(4)
    face = chunked_line(np.array([0.0, 0.0]), np.array([4.0, 0.0]), rng)
    ret = chunked_line(np.array([4.0, 0.02]), np.array([4.0, 0.4]), rng, gap=0.02)
    assert run(np.vstack([face, ret])) == []


def test_pier_standing_off_the_wall_is_no_respond():
    """A free pier half a metre in front of the wall does not touch its face."""
    rng = np.random.default_rng(5)
    pier = respond(3.8, 0.4, 0.4, rng, front_gap=(0.0, 0.0)) + [0.0, 0.5]
    xs = np.arange(3.8, 4.2, 0.01)
    back = np.c_[xs, np.full(len(xs), 0.5)]
    assert run(wall_with(rng, pier, back, behind=(0.0, 0.0))) == []


def test_row_of_pier_fronts_is_no_face_line():
    """The fronts of a row of piers lie on one line over a small share of its span."""
    rng = np.random.default_rng(6)
    xs = np.arange(0.0, 0.4, 0.01)
    fronts = [np.c_[x + xs, np.zeros(len(xs))] for x in np.arange(0.0, 20.0, 2.5)]
    assert face_lines(np.vstack(fronts), 0.03, rng) == []


@pytest.mark.slow
@pytest.mark.parametrize("noise_draw", [1, 2])
def test_draw37_responds_on_broken_walls(noise_draw):
    """Supports draw 37: the responds on the long walls whose section holds no wall
    island beside them are found (main: 47, 49, 51, 55, 61 missed on the own scan and
    on noise draw 1, 54 and 56 supports matched): at least three of the five are
    (the own scan: all five, matched 62; noise draw 1: four, matched 61; noise draw
    2: three)."""
    from pyheracles.building import segment_building
    from pyheracles.synthetic.families import simulate
    from pyheracles.synthetic.families.supports_score import score_supports

    sim = simulate("supports", 37, noise_draw=noise_draw)
    seg, found, _, _ = segment_building(sim.clouds["cloud"].xyz)
    m = score_supports(
        sim, found.instance, found.objects, section_height=found.section_height,
        attic_mask=seg.class_id == 2,
    )  # fmt: skip
    missed = {f["instance"] for f in m["failures"] if f["mode"] == "missed"}
    assert len(missed & {47, 49, 51, 55, 61}) <= 2
