"""A wall face scanned sparsely runs on beyond a wall piece's end (issue 12, mode 4: "a
jamb is a wall edge": the wall beyond it, in line with it).

Built from draw 34 of the supports family (a ruined portico whose side wall, 0.62 m
thick, has a ragged top between 2.5 and 7.8 m): the section at 5.35 m cuts the wall's
highest stretches between the dips of its top into "piers" 1.9 x 0.62 m and 0.5 x
0.3 m; below the dips the wall runs on beyond both their ends, flush with their faces.
Scanned from afar, its faces hold a point every 10-20 cm along and up, and the bands
of the wall-piece test (5 cm layers, 5 cm bins beyond the end, all but one of them
filled in half the layers) found no wall running on in any band: both were piers.
Read from the gaps between its points (:func:`runs_on_sparse`), the face runs on.
"""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.supports.sparse_faces import SPARSE_GAP_M, runs_on_sparse
from supports_draws import extract_pier_piece, scored_supports_draw

STEP = 0.016  # the cloud's median spacing in draw 34, metres
HALF = np.array([0.95, 0.31])  # the piece: 1.9 m along the wall, 0.62 m thick
LOW, TOP = 2.5, 7.2  # the wall's top beside the piece and the piece's own top, metres
H_SEC = 5.35  # the section it was found in, metres
SEEDS = range(6)  # noise draws
NOISE_DRAWS_34 = (0, 2, 3)  # noise draws of family draw 34 checked


def _face(
    y: float, u0: float, u1: float, z1: float, gap: float, rng: np.random.Generator
) -> np.ndarray:
    """A wall face at ``y`` from ``u0`` to ``u1``, floor to ``z1``, scanned on a grid of
    ``gap`` (jittered: the scan lines are not parallel to the wall)."""
    uu, zz = np.meshgrid(np.arange(u0, u1, gap), np.arange(0.0, z1, 0.7 * gap))
    u = uu.ravel() + rng.uniform(-0.3, 0.3, uu.size) * gap
    z = zz.ravel() + rng.uniform(-0.3, 0.3, zz.size) * gap
    return np.c_[u, np.full(u.size, y), z]


def _scene(walled: bool, gap: float, rng: np.random.Generator) -> np.ndarray:
    """The piece's two faces (dense at the section, as seen: a face of 94 points in
    draw 34) up to ``TOP`` and, ``walled``, the wall beyond both its ends up to ``LOW``
    over 2.5 m, its faces flush with the piece's, all scanned at ``gap``; a floor."""
    parts = []
    for y in (-HALF[1], HALF[1]):
        parts.append(_face(y, -HALF[0], HALF[0], TOP, 0.5 * gap, rng))
        if walled:
            parts.append(_face(y, -HALF[0] - 2.5, -HALF[0] - 0.02, LOW, gap, rng))
            parts.append(_face(y, HALF[0] + 0.02, HALF[0] + 2.5, LOW, gap, rng))
    fx, fy = np.meshgrid(np.arange(-4.0, 4.0, 0.05), np.arange(-2.0, 2.0, 0.05))
    parts.append(np.c_[fx.ravel(), fy.ravel(), np.zeros(fx.size)])
    p = np.vstack(parts)
    return p + rng.normal(0.0, 0.003, p.shape)


def _extract(p: np.ndarray) -> tuple[object, dict]:
    """:func:`extract_support` of the piece's section shape in ``p``."""
    return extract_pier_piece(p, HALF, STEP, H_SEC, (0.0, TOP + 0.5))


@pytest.mark.parametrize("seed", SEEDS)
def test_sparse_wall_running_on_below_the_dips_makes_a_wall_piece(seed: int) -> None:
    """The wall beyond both ends, flush with the piece's faces, scanned every 12-15 cm:
    a wall piece in every noise draw."""
    rng = np.random.default_rng(seed)
    kept, sh = _extract(_scene(True, 0.12 + 0.03 * rng.random(), rng))
    assert kept is None
    assert sh.get("wall_edge")


@pytest.mark.parametrize("seed", SEEDS)
def test_free_pier_scanned_sparsely_stays(seed: int) -> None:
    """The same piece standing free (no wall beyond its ends) stays a pier."""
    rng = np.random.default_rng(seed)
    kept, sh = _extract(_scene(False, 0.12 + 0.03 * rng.random(), rng))
    assert kept is not None
    assert not sh.get("wall_edge")


def test_runs_on_sparse_reads_gaps() -> None:
    """A face every 15 cm along and up runs on; one with an opening (a gap wider than
    ``SPARSE_GAP_M``) next to the end, or a sill one layer high, does not."""
    cell, n_layers = 0.05, 8
    uu, zz = np.meshgrid(np.arange(0.16, 1.5, 0.15), np.arange(0.0, 0.4, 0.15))
    dist, layer = uu.ravel(), np.floor(zz.ravel() / cell).astype(np.int64)
    assert runs_on_sparse(dist, layer, n_layers, cell, 0.3, 0.15)
    far = dist > 0.15 + SPARSE_GAP_M + 0.05  # an opening next to the end
    assert not runs_on_sparse(dist[far], layer[far], n_layers, cell, 0.3, 0.15)
    sill = layer == 0
    assert not runs_on_sparse(dist[sill], layer[sill], n_layers, cell, 0.3, 0.15)


def test_dense_face_with_a_hole_is_judged_by_its_cells() -> None:
    """A face scanned densely (1.6 cm) with a hole 15 cm wide next to the end (supports
    draw 30: the architrave over an anta, in the shadow of the anta's capital) is not
    read from its gaps: the hole is a shadow or an opening, not a gap between scan
    lines."""
    cell, n_layers = 0.05, 8
    uu, zz = np.meshgrid(np.arange(0.16, 1.5, 0.016), np.arange(0.0, 0.4, 0.016))
    dist, layer = uu.ravel(), np.floor(zz.ravel() / cell).astype(np.int64)
    hole = (dist > 0.18) & (dist < 0.33)
    assert not runs_on_sparse(dist[~hole], layer[~hole], n_layers, cell, 0.3, 0.15)


@pytest.mark.slow
@pytest.mark.parametrize("noise_draw", NOISE_DRAWS_34)
def test_draw_34_ruin_wall_pieces_are_no_piers(noise_draw: int) -> None:
    """Draw 34 itself: no piece of its ruined side wall is found as a pier (two were,
    both 100 % wall points, on the draw's own scan)."""
    scores = scored_supports_draw(34, noise_draw=noise_draw)
    assert not [f for f in scores["failures"] if f["mode"] == "jamb_as_pier"]


@pytest.mark.slow
@pytest.mark.parametrize("noise_draw", (0, 1))
def test_draw_30_antae_under_their_architrave_stay(noise_draw: int) -> None:
    """Draw 30 (a portico whose side walls end in antae under an architrave): the
    architrave's face, flush with an anta's front, runs on beyond its ends above the
    anta's capital, in the bands under the anta's own top, densely on one side and
    sparsely on the other.  Read from its gaps in the upper band (any 0.3 m within 1.5
    m), it walled the anta at both ends (noise draw 1), and in the bands of its height
    where the shadow of the capital is a hole in a dense face (noise draw 0): both
    antae stay piers."""
    scores = scored_supports_draw(30, noise_draw=noise_draw)
    assert not [f for f in scores["failures"] if f["mode"] == "missed" and f["class"] == "pier"]
