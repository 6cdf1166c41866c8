"""Things that are no supports (issue 12): wall pieces (mode 4: "a jamb is a wall
edge"), pulpit stems and a lying drum (mode 8: clutter and debris taken for broken
supports).

Built from draws of the supports family: draw 3 (a ruined portico whose wall pieces
between windows, cut off in the section, became a pier), draw 15 (a portico whose
wall between windows with 1.6 m sills left 0.16 m slivers of wall as piers) and draw 17
(a ruined peristyle whose pulpit stems became broken columns and a fallen drum a
pier)."""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.building import segment_building
from pyheracles.supports.carriers import thin_free_columns
from pyheracles.supports.piers import (
    FOOT_FROM_M,
    FOOT_TO_M,
    MAX_NARROW_LAYERS,
    foot_on_wall_line,
    narrow_share,
)
from pyheracles.synthetic.families import simulate


def _plane(rng, x0, x1, y0, y1, z0, z1, n):
    """Points on an axis-aligned rectangle (one coordinate range is a single value)."""
    return np.c_[rng.uniform(x0, x1, n), rng.uniform(y0, y1, n), rng.uniform(z0, z1, n)]


def _foot_test(foot: np.ndarray, own_xy: np.ndarray) -> bool:
    cell = 0.05
    band = (foot[:, 2] > FOOT_FROM_M) & (foot[:, 2] < FOOT_TO_M)
    foot = foot[band]
    layer = np.floor((foot[:, 2] - FOOT_FROM_M) / cell).astype(np.int64)
    rng = np.random.default_rng(0)
    return foot_on_wall_line(foot[:, :2], layer, own_xy, 0.03, cell, rng)


def test_wall_piece_between_windows_has_the_wall_at_its_foot() -> None:
    """Draw 15's sliver: a piece 0.55 m long of a wall 0.8 m thick between two windows,
    seen on its room face only; below the sills the wall runs on flush with that face.
    A free pier of the same size has a fence on its axis, a bench against it and a wall
    10 cm behind its face (an anta's wall) at its foot: no face of it is flush with them."""
    rng = np.random.default_rng(15)
    # the piece's own face at the section (x from -0.27 to 0.27, room face at y = 0)
    own = np.c_[rng.uniform(-0.27, 0.27, 200), rng.normal(0.0, 0.003, 200)]
    wall_foot = np.vstack(
        [
            _plane(rng, -1.7, -0.42, 0.0, 0.0, 0.0, 0.6, 3000),  # sill wall, room face
            _plane(rng, 0.42, 1.7, 0.0, 0.0, 0.0, 0.6, 3000),
        ]
    )
    wall_foot[:, 1] += rng.normal(0, 0.003, len(wall_foot))
    assert _foot_test(wall_foot, own)

    pier = np.vstack(
        [np.c_[rng.uniform(-0.27, 0.27, 200), np.full(200, s)] for s in (-0.2, 0.2)]
        + [np.c_[np.full(100, s), rng.uniform(-0.2, 0.2, 100)] for s in (-0.27, 0.27)]
    )
    fence = np.vstack(
        [_plane(rng, x, x + 0.02, -0.01, 0.01, 0.0, 1.0, 80) for x in np.arange(0.42, 1.7, 0.12)]
        + [_plane(rng, 0.42, 1.7, -0.01, 0.01, 0.95, 1.0, 500)]
    )
    bench = _plane(rng, -0.9, -0.3, 0.25, 0.65, 0.43, 0.45, 800)  # seat against a side
    anta_wall = _plane(rng, -1.7, -0.42, -0.1, -0.1, 0.0, 0.6, 3000)
    assert not _foot_test(np.vstack([fence, bench, anta_wall]), pier)


@pytest.mark.xfail(
    strict=True,
    reason=(
        "with the simulator's noise drawn per ray, a piece of the broken wall (99.5 % wall "
        "points) is a ninth support again: 1.6 x 0.89 m between a door and a window whose "
        "sill is 0.21 m high, the wall runs on from one of its ends only (in 2 bands of its "
        "height from the door's side, in none from the window's): not fixed (see "
        "cookies.walled_band_count); the wall's corner between a window and a door of "
        "noise draws 2 and 3 is a wall piece (tests/test_supports_corner_pieces.py)"
    ),
)
def test_ruin_wall_piece_is_no_pier_on_draw_3() -> None:
    """Draw 3, a ruined portico of 8 columns: a piece of its broken wall, 0.42 m x 0.16 m
    in the low section and standing 1.3 m, was a ninth support (a pier of 99 % wall
    points); its foot stands in the wall that runs on beside it.  The simulator's ray
    casting (Embree) is not bit-reproducible across CPUs: on an AMD EPYC (AVX2) this
    draw has 423,372 points (not 423,399), the piece is 0.62 m x 0.22 m, walled beyond
    one end only, and stands 1.21 m, lower than a broken column (1.5 m); a fence post
    beside the columns carries its rail 1.66 m up while they stand 3.9 m tall."""
    sim = simulate("supports", 3)
    res = sim.clouds["cloud"]
    _, found, _, _ = segment_building(res.xyz)
    wall_code = {v: k for k, v in sim.scene.class_names.items()}["wall"]
    ok = ~res.outlier
    columns = found.objects["class"] == "column"
    assert columns.sum() == 8  # the eight columns, on any machine
    for k in found.objects["instance"][columns]:
        assert np.mean(res.class_id[ok & (found.instance == k)] == wall_code) < 0.1
    for k in found.objects["instance"]:
        mine = ok & (found.instance == k)
        assert np.mean(res.class_id[mine] == wall_code) < 0.5, f"support {k} is a wall"
    assert len(found.objects) == 8
    assert columns.all()


def test_thin_post_carrying_nothing_is_no_broken_column() -> None:
    """Draw 17, a ruined peristyle of columns 1.19 m in radius: three pulpit stems
    (0.12 m, 2.1-2.6 m tall, carrying nothing: their desk stays within the cookie) were
    taken for broken columns.  A broken column of the building, as thick as the columns
    that carry, stays; with no column carrying (a roofless ruin, where the stems came
    back once their rings were whole), the thickest column is the reference."""
    rows = [{"class": "column", "radius_m": 1.19}] * 4 + [
        {"class": "column", "radius_m": 0.12},
        {"class": "column", "radius_m": 1.17},  # a broken column
        {"class": "pier", "radius_m": float("nan")},
        {"class": "column", "radius_m": 0.12},
        {"class": "column", "radius_m": 0.55},  # a broken aisle column (ratio 0.45)
    ]
    carries = [True] * 4 + [False] * 5
    assert thin_free_columns(rows, carries) == {4, 7}
    assert thin_free_columns(rows, [False] * len(rows)) == {4, 7}
    assert thin_free_columns(rows[4:5], [False]) == set()  # no thicker column: kept


def test_lying_drum_is_no_pier_an_occluded_pier_is() -> None:
    """Draw 17: a fallen drum of a 1.19 m column, lying on its side and carrying nothing,
    was a pier (its end disc cut by the low section 1.2 m above the floor is a 1.9 m x
    0.46 m rectangle); above and below that chord the disc is narrower at both ends.  A
    prism pier whose lower half is in the shadow of a pew at one end keeps its section's
    other end."""
    rng = np.random.default_rng(17)
    radius, zc, h_sec = 1.05, 1.05, 1.2
    t = rng.uniform(0, 2 * np.pi, 20_000)
    rr = radius * np.sqrt(rng.uniform(0, 1, 20_000))
    disc = np.c_[rr * np.cos(t), rng.uniform(-0.2, 0.2, 20_000), zc + rr * np.sin(t)]
    half_chord = np.sqrt(radius**2 - (h_sec - zc) ** 2)
    sh = {"centre": np.zeros(2), "angle": 0.0, "half": np.array([half_chord, 0.2])}
    assert narrow_share(disc[:, :2], disc[:, 2], sh, 0.01, 0.05) > MAX_NARROW_LAYERS

    pier = _plane(rng, -0.5, 0.5, 0.2, 0.2, 0.0, 3.0, 20_000)
    shadow = (pier[:, 2] < 1.5) & (pier[:, 0] < -0.1)  # a pew hides one end below 1.5 m
    pier = pier[~shadow]
    sh = {"centre": np.zeros(2), "angle": 0.0, "half": np.array([0.5, 0.2])}
    assert narrow_share(pier[:, :2], pier[:, 2], sh, 0.01, 0.05) == 0.0
