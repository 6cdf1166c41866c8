"""A pier ending a wall (an anta) is cut off the wall's stub at the step of their faces.

Supports draw 13 (and 16, 21, 28, 34, 35): the side wall of a portico, 0.55 m thick,
ends in an anta 0.73 x 0.58 m standing 0.08-0.1 m proud of the wall's faces.  The
section island held the anta and 0.7 m of the wall behind it, and so did its support:
1674 of its 3176 points wall, its box 1.28 x 0.70 m (error 0.55 m).  Along the axis the
wall runs on, the anta's outline is as wide as the anta and the wall's set in on both
sides (or on its one face seen): the support ends at the anta's back face.

The synthetic tests build that outline (faces as grids of points, over the full
height); the slow test runs step 2 on the draw and noise draws 1-2.
"""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.supports.antae import anta_cut, end_at_anta, face_angle
from supports_draws import scored_supports_draw, vertical_face

TOL = 0.03  # surface tolerance of the draw's scales, metres
STEP = 0.02  # point spacing on the faces, metres
W, D = 0.73, 0.58  # the anta across and along the wall, metres
T = 0.55  # the wall's thickness, metres (set in by 0.09 m on each side)
H = 3.8  # height, metres


def anta(
    wall_faces: tuple[bool, bool] = (True, True),
    wall_len: float = 0.7,
    thickness: float = T,
    seed: int = 0,
) -> np.ndarray:
    """Points of an anta (front face at y = D, sides x = +-W/2, its back at y = 0) and
    the wall running on from its back to y = -``wall_len`` (its faces at x = +-
    ``thickness``/2, those of ``wall_faces`` seen, and its end face)."""
    faces = [
        vertical_face(1, D, -W / 2, W / 2, 0.0, H, STEP),  # front
        vertical_face(0, -W / 2, 0.0, D, 0.0, H, STEP),  # sides
        vertical_face(0, W / 2, 0.0, D, 0.0, H, STEP),
    ]
    if wall_len > 0:
        faces.append(vertical_face(1, -wall_len, -thickness / 2, thickness / 2, 0.0, H, STEP))
        for k, x in enumerate((-thickness / 2, thickness / 2)):
            if wall_faces[k]:
                faces.append(vertical_face(0, x, -wall_len, 0.0, 0.0, H, STEP))
    p = np.vstack(faces)
    return p + np.random.default_rng(seed).normal(0.0, 0.002, p.shape)


def section_rect(p: np.ndarray) -> tuple[np.ndarray, float]:
    """The section rectangle of the island: the outline's box, turned a little as the
    outline of a stepped island is (draw 13: 4.5 degrees)."""
    lo, hi = p[:, :2].min(axis=0), p[:, :2].max(axis=0)
    return (lo + hi) / 2, np.radians(4.5)


@pytest.mark.parametrize("seed", range(3))
@pytest.mark.parametrize("faces", [(True, True), (True, False), (False, True)])
def test_anta_is_cut_at_its_back_face(seed: int, faces: tuple[bool, bool]) -> None:
    """The wall's stub (both its faces seen, or one) is cut off; the support keeps the
    anta, its section shape is the anta's rectangle."""
    p = anta(faces, seed=seed)
    centre, angle = section_rect(p)
    sh = {"class": "pier", "centre": centre, "angle": angle, "half": np.array([0.5, 0.7])}
    out = end_at_anta(np.arange(len(p)), p, sh, TOL)
    assert out is not None
    idx, rho, kept = out
    assert np.array_equal(p[idx], kept)
    assert kept[:, 1].min() > -0.02  # no wall
    assert np.count_nonzero(p[:, 1] > 0.01) == np.count_nonzero(kept[:, 1] > 0.01)  # the anta
    assert sorted(2 * sh["half"]) == pytest.approx(sorted([W, D]), abs=0.02)
    assert np.abs(rho).max() < 0.02  # its faces on the new rectangle


def test_long_wall_seen_on_one_face() -> None:
    """A ruined side wall running on 2 m, one face seen (draw 21's anta 39)."""
    p = anta((True, False), wall_len=2.0)
    centre, angle = section_rect(p)
    cut = anta_cut(p, centre, angle, TOL, 2 * TOL)
    assert cut is not None
    axis, sign, at, ang = cut
    u = (p[:, :2] - centre) @ np.array([[np.cos(ang), -np.sin(ang)], [np.sin(ang), np.cos(ang)]])
    assert u[:, axis][p[:, 1] < -0.1].max() * sign > at * sign  # the wall is beyond the cut


@pytest.mark.parametrize("seed", range(3))
def test_wall_end_flush_or_free_pier_is_not_cut(seed: int) -> None:
    """No step: a wall flush with the pier's sides, a free pier, a free pier of which one
    side face was seen in part (draw 30's pier 9: its other side runs on beyond)."""
    flush = anta(thickness=W, seed=seed)
    free = anta(wall_len=0.0, seed=seed)
    part = free[(free[:, 0] > -W / 2 + 0.01) | (free[:, 1] > D - 0.2)]  # one side: 0.2 m
    for p in (flush, free, part):
        centre, angle = section_rect(p)
        assert anta_cut(p, centre, angle, TOL, 2 * TOL) is None


def test_cross_shaped_pier_is_not_cut() -> None:
    """Narrower arms at both ends of an axis: no wall running on from one end."""
    p = anta(wall_len=0.7)
    q = p.copy()
    q[:, 1] = D - q[:, 1]  # the stub mirrored beyond the front
    both = np.vstack([p[p[:, 1] < 0.0], q])
    centre, angle = section_rect(both)
    assert anta_cut(both, centre, angle, TOL, 2 * TOL) is None


def test_face_angle_of_a_stepped_outline() -> None:
    """The faces' direction, not that of the stepped outline's rectangle."""
    p = anta()
    for start in (np.radians(4.5), np.radians(-8.0), np.radians(93.0)):
        a = np.degrees(face_angle(p[:, :2], start, TOL)) % 90.0
        assert min(a, 90.0 - a) < 0.2


@pytest.mark.slow
@pytest.mark.parametrize("noise_draw", [0, 1, 2])
def test_draw_13_antae_boxes(noise_draw: int) -> None:
    """Draw 13: the two antae of the portico's side walls, their boxes within 2 cm
    where both faces across a side were seen (before: 0.55 and 1.39 m on the draw's
    own scan)."""
    m = scored_supports_draw(13, noise_draw=noise_draw)
    assert m["pier_box_err_m"]["24"] <= 0.02
