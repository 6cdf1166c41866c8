"""A building's corner between openings is a wall piece: the wall faces flush with its
sides are found on the faces' own lines (issue 12, mode 4: "a jamb is a wall edge").

Built from draws 6 and 7 of the supports family: the corner of a building between a
door in one wall and a window in the other, seen from outside (its two outer faces, a
2.4 x 2.2 m and a 2.1 x 1.9 m "pier"), is one with both walls, each wall's outer face
running on beyond one of its ends: a corner in the bands of its height
(:func:`~pyheracles.supports.piers.walled_piece`).  The face lines of the band test were
lines through two points picked at random, which hold all of a face's points within the
tolerance while tilted or shifted by up to it: at the piece's end the line lay 1-2.5 cm
off the face (draw 16: 2.3 cm off the piece's side over the door, the tolerance is 3
cm), was not "flush" with it, and the corner was never seen
(:func:`~pyheracles.supports.piers.refit_line`).
"""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.supports.cookies import cookies, walled_band_count
from pyheracles.supports.core import SupportParams, scales
from pyheracles.supports.piers import face_lines

STEP = 0.02  # point spacing of the synthetic faces, metres
HALF = np.array([0.6, 0.4])  # the piece, metres
TOP = 3.45  # its top and the wall's top (no ceiling), metres
H_SEC = 1.9  # the section it was found in, metres
SEEDS = range(6)  # noise draws of the synthetic scenes


def _face(fixed: int, at: float, lo: float, hi: float, z0: float, z1: float) -> np.ndarray:
    """A vertical face at coordinate ``fixed`` (0: x, 1: y) = ``at``, from ``lo`` to
    ``hi`` along the other coordinate and ``z0`` to ``z1`` up."""
    uu, zz = np.meshgrid(np.arange(lo, hi + 1e-9, STEP), np.arange(z0, z1 + 1e-9, STEP))
    u = uu.ravel()
    xy = np.c_[np.full(u.size, at), u] if fixed == 0 else np.c_[u, np.full(u.size, at)]
    return np.c_[xy, zz.ravel()]


def _anta(rng: np.random.Generator) -> np.ndarray:
    """The piece's faces from the floor to ``TOP``, a floor and the wall of an anta,
    flush with its face y = -0.4 beyond its low x end over its whole height; nothing
    beyond its high y end."""
    hx, hy = HALF
    parts = [
        _face(1, -hy, -hx, hx, 0.0, TOP),
        _face(1, hy, -hx, hx, 0.0, TOP),
        _face(0, -hx, -hy, hy, 0.0, TOP),
        _face(0, hx, -hy, hy, 0.0, TOP),
        _face(1, -hy, -hx - 2.0, -hx - 0.02, 0.0, TOP),
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
def test_anta_walled_beyond_one_end_stays(seed: int) -> None:
    """A pier at the end of a wall running flush into it (an anta), free beyond its
    other end, is walled in no band (the lines fitted to the faces make no corner of
    the wall's face and the anta's)."""
    assert _walled_bands(_anta(np.random.default_rng(seed))) == 0


def test_face_lines_lie_on_the_faces() -> None:
    """The outer and inner faces of a wall 0.36 m thick beyond a piece's end and the
    outer face of the wall turning at it (3.5 mm noise, tolerance 3 cm): each line
    found lies within 5 mm of its face at the piece's end, over 20 noise draws (through
    two points picked at random, 1-2.5 cm off in about half of them)."""
    for seed in range(20):
        rng = np.random.default_rng(seed)
        outer = np.c_[rng.uniform(-2.1, -0.75, 1500), np.full(1500, -0.4)]
        inner = np.c_[rng.uniform(-2.1, -0.75, 1000), np.full(1000, -0.04)]
        turning = np.c_[np.full(800, 0.6), rng.uniform(0.55, 1.9, 800)]
        q = np.vstack([outer, inner, turning])
        q += rng.normal(0.0, 0.0035, q.shape)
        lines = face_lines(q, 0.03, np.random.default_rng(0), n_lines=3)
        assert len(lines) == 3
        for d, off, inl in lines:
            nrm = np.array([-d[1], d[0]])
            if abs(d[0]) > abs(d[1]):  # along x: y on the line at the piece's end
                face = -0.4 if np.median(q[inl, 1]) < -0.2 else -0.04
                at = (off - nrm[0] * -0.6) / nrm[1]
            else:  # along y: x on the line at the piece's end
                face = 0.6
                at = (off - nrm[1] * 0.4) / nrm[0]
            assert abs(at - face) < 0.005, (seed, d, off)


#: The building corner of draw 7 (plan x, y, metres) that was a pier.
CORNERS = {7: (18.57, 12.46)}


@pytest.mark.slow
@pytest.mark.parametrize(("seed", "noise_draw"), [(7, 0)])
def test_building_corners_are_no_piers(seed: int, noise_draw: int) -> None:
    """Draw 7 itself: the building's corner between a door and a window, seen from
    outside, is no support (it was a pier of 99.6 % wall points, 2.1 x 1.9 m).  On noise
    draws 1-3 of the scene it stays a pier (issue 12 open)."""
    from pyheracles.building import segment_building
    from pyheracles.synthetic.families import simulate

    sim = simulate("supports", seed, noise_draw=noise_draw)
    _, found, _, _ = segment_building(sim.clouds["cloud"].xyz)
    objects = found.objects
    near = np.hypot(objects["x"] - CORNERS[seed][0], objects["y"] - CORNERS[seed][1]) < 1.0
    assert not near.any()
