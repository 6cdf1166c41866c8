"""Step 2b (issue 13): a face broken by head-on noise is still one face.

Roof draw 21: a ridge seen from one station almost straight below it.  On the
middle of its underside, seen head-on, all the range noise (4 mm) lies across
the face; region growing broke it into regions too small for a straight facet,
so only two pieces of 1.31 and 0.73 m were left, 1.19 m apart (more than
``max_gap_m``) and each too short for a beam seen on one face: the ridge was
lost whole.  The points between the pieces still lie on the face:
:func:`~pyheracles.beams.grouping.face_filled` joins pieces whose gap they
fill, a shadow leaves the gap empty.
"""

from __future__ import annotations

import numpy as np

from grid_planes import grid_plane
from pyheracles.beams import StraightFacet, segment_beams
from pyheracles.beams.grouping import face_filled
from pyheracles.geometry.neighbours import build_tree

X, Y, Z = np.eye(3)
WIDTH, LENGTH, HEIGHT = 0.22, 4.0, 3.0
#: the clean pieces at the ends and the head-on middle, along x (metres)
PIECES = ((0.0, 1.2), (2.8, LENGTH))
MIDDLE = (1.2, 2.8)


def _underside(a: float, b: float, noise: float, rng) -> np.ndarray:
    """A stretch of a beam's underside seen from below: range noise along z."""
    p = grid_plane(np.array([a, -WIDTH / 2, HEIGHT]), X, Y, b - a, WIDTH, 0.007, rng, noise=0.0)
    p[:, 2] += rng.normal(scale=noise, size=len(p))
    p[:, :2] += rng.normal(scale=0.0015, size=(len(p), 2))
    return p


def _scene(middle_noise: float | None, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """A beam seen on its underside only, above a floor; labels 1 beam, 0 floor.

    ``middle_noise``: range noise of the middle stretch, metres; None: the
    middle is in a shadow (no points).
    """
    rng = np.random.default_rng(seed)
    parts = [_underside(a, b, 0.0015, rng) for a, b in PIECES]
    if middle_noise is not None:
        parts.append(_underside(*MIDDLE, middle_noise, rng))
    beam = np.vstack(parts)
    floor = grid_plane(np.array([-1.0, -2.0, 0.0]), X, Y, LENGTH + 2.0, 4.0, 0.03, rng)
    xyz = np.vstack([beam, floor])
    return xyz, np.r_[np.ones(len(beam), int), np.zeros(len(floor), int)]


def test_a_face_broken_by_head_on_noise_is_one_beam() -> None:
    xyz, lab = _scene(middle_noise=0.006)
    res = segment_beams(xyz)
    assert len(res.beams) == 1
    b = res.beams[0]
    assert abs(b.length - LENGTH) < 0.1
    assert abs(b.width - WIDTH) < 0.01
    assert np.mean(res.labels[lab == 1] == 1) > 0.9
    assert np.mean(res.labels[lab == 0] == 0) > 0.99


def _piece(xyz: np.ndarray, a: float, b: float) -> StraightFacet:
    idx = np.flatnonzero((xyz[:, 0] >= a) & (xyz[:, 0] < b) & (xyz[:, 2] > HEIGHT - 0.05))
    return StraightFacet(
        index=idx,
        normal=Z.copy(),
        axis=X.copy(),
        centre=xyz[idx].mean(axis=0),
        width=WIDTH,
        length=b - a,
        plane_rms=0.0015,
        parent=0,
    )


def _filled(middle_noise: float | None) -> bool:
    xyz, _ = _scene(middle_noise)
    fa, fb = (_piece(xyz, a, b) for a, b in PIECES)
    fill = np.ones(len(xyz), bool)
    fill[fa.index] = fill[fb.index] = False
    return face_filled(
        xyz, build_tree(xyz), fill, fa, fb, (0.0, PIECES[0][1]), (PIECES[1][0], LENGTH), 0.01
    )


def test_the_gap_is_filled_by_the_face_not_by_a_shadow() -> None:
    assert _filled(middle_noise=0.006)
    assert not _filled(middle_noise=None)


def test_pieces_across_a_shadow_stay_apart() -> None:
    xyz, _ = _scene(middle_noise=None)
    res = segment_beams(xyz)
    # each piece is too short for a beam seen on one face, and a shadow joins nothing
    assert all(b.length < 2.0 for b in res.beams)


def test_face_runs_group_the_runs_a_filled_gap_joins() -> None:
    from pyheracles.beams.grouping import face_runs

    def groups(middle_noise: float | None, fill_on: bool) -> list[list[list[int]]]:
        xyz, _ = _scene(middle_noise)
        facets = [_piece(xyz, a, b) for a, b in PIECES]
        fill = np.ones(len(xyz), bool)
        for f in facets:
            fill[f.index] = False
        return face_runs(
            xyz,
            facets,
            np.arange(2),
            parallel_deg=10.0,
            max_gap_m=1.0,
            width_range=(0.05, 0.6),
            fill=fill if fill_on else None,
            tree=build_tree(xyz),
            max_filled_gap_m=3.0,
        )

    # one group of the two runs (each piece a run: 1.6 m apart, over max_gap_m)
    assert sorted(map(sorted, groups(0.006, True)[0])) == [[0], [1]]
    assert len(groups(0.006, False)) == 2  # without the fill: two groups
    assert len(groups(None, True)) == 2  # a shadow: two groups
