"""Tests of the faster forms of beam stages: same results as the direct computations."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy import ndimage

from pyheracles.beams import BeamCuboid, BeamParams, BeamResult
from pyheracles.beams.facets import disk_opening


def _disk(rad: int) -> np.ndarray:
    yy, xx = np.mgrid[-rad : rad + 1, -rad : rad + 1]
    return xx**2 + yy**2 <= rad**2


def _blobby_grid(rng: np.random.Generator) -> np.ndarray:
    """Scattered cells plus a few disks and a strip, some touching the grid's border."""
    shape = tuple(int(s) for s in rng.integers(3, 120, 2))
    grid = rng.random(shape) < rng.uniform(0.3, 1.0)
    yy, xx = np.mgrid[: shape[0], : shape[1]]
    for _ in range(3):
        c, r = rng.integers(0, shape), int(rng.integers(1, 40))
        grid |= (yy - c[0]) ** 2 + (xx - c[1]) ** 2 <= r * r
    grid[:, int(rng.integers(0, shape[1])) :][: int(rng.integers(1, 6))] = True
    return grid


def test_disk_opening_is_binary_opening_by_the_disk():
    rng = np.random.default_rng(5)
    for _ in range(60):
        grid = _blobby_grid(rng)
        rad = int(rng.integers(0, 16))
        expect = ndimage.binary_opening(grid, structure=_disk(rad))
        np.testing.assert_array_equal(disk_opening(grid, rad), expect)
    # nothing survives: empty, not an error
    strip = np.zeros((40, 40), bool)
    strip[10:14] = True
    assert not disk_opening(strip, 5).any()
    assert not disk_opening(np.zeros((0, 7), bool), 3).any()


def _reference_signed_distance(cub: BeamCuboid, points: np.ndarray) -> np.ndarray:
    """The textbook form: norm of the positive part plus the (negative) largest part."""
    local = (np.asarray(points, dtype=np.float64) - cub.centre) @ cub.axes
    q = np.abs(local) - cub.half_extents
    return np.linalg.norm(np.maximum(q, 0.0), axis=1) + np.minimum(q.max(axis=1), 0.0)


def test_signed_distance_matches_the_direct_formula_bit_for_bit():
    rng = np.random.default_rng(9)
    for _ in range(100):
        axes, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        cub = BeamCuboid(
            centre=rng.normal(size=3),
            axes=axes,
            length=float(rng.uniform(0.1, 6.0)),
            width=float(rng.uniform(0.04, 0.4)),
            height=float(rng.uniform(0.04, 0.4)),
            rms=0.0,
            n_facets=2,
        )
        pts = rng.normal(size=(int(rng.integers(0, 3000)), 3)) * rng.uniform(0.05, 4.0)
        pts[::11] = np.nan
        got = cub.signed_distance(pts)
        np.testing.assert_array_equal(got, _reference_signed_distance(cub, pts))
        # a list of points works too and the input is not changed
        before = pts.copy()
        np.testing.assert_array_equal(cub.signed_distance(pts.tolist()), got)
        np.testing.assert_array_equal(pts, before)


def test_picture_draws_every_point_with_beams_over_the_remainder(tmp_path: Path):
    pytest.importorskip("matplotlib")
    from matplotlib.image import imread

    from pyheracles.cli.beams import plot_beams

    rng = np.random.default_rng(3)
    # 300 000 remainder points on a floor and 30 000 points of one beam above it: in the
    # plan the beam covers the floor; more points than the old 200 000-point sample
    floor = np.column_stack([rng.uniform(0, 4, 300_000), rng.uniform(0, 4, 300_000),
                             np.zeros(300_000)])  # fmt: skip
    beam = np.column_stack([rng.uniform(0.5, 3.5, 30_000), rng.uniform(1.9, 2.1, 30_000),
                            rng.uniform(1.0, 1.2, 30_000)])  # fmt: skip
    xyz = np.vstack([beam[:15_000], floor, beam[15_000:]])
    labels = np.zeros(len(xyz), dtype=np.int32)
    labels[:15_000] = 1
    labels[-15_000:] = 1
    cub = BeamCuboid(np.array([2.0, 2.0, 1.1]), np.eye(3), 3.0, 0.2, 0.2, 0.0, 2)
    res = BeamResult(labels, (cub,), labels.copy(), labels.copy(), np.array([0, 1], np.int32),
                     BeamParams())  # fmt: skip
    path = plot_beams(xyz, res, tmp_path / "beams.png")
    img = imread(path)[..., :3]
    blue = np.array([0.12, 0.47, 0.71])  # tab20's first colour: beam 1
    grey = np.array([0.75, 0.75, 0.75])
    is_blue = np.abs(img - blue).max(axis=2) < 0.03
    is_grey = np.abs(img - grey).max(axis=2) < 0.03
    assert is_blue.sum() > 2000 and is_grey.sum() > 20_000
    # plan (left third): the beam's strip is blue although 100 floor points lie under each
    # of its cells (the beam is painted last)
    left = img.shape[1] // 3
    rows = np.flatnonzero(is_blue[:, :left].sum(axis=1) > 100)
    assert len(rows) >= 5
    mid = rows[len(rows) // 2]
    cols = np.flatnonzero(is_blue[mid, :left])
    span = slice(cols.min(), cols.max() + 1)  # the beam's length in the plan
    blue_row, grey_row = is_blue[mid, span].sum(), is_grey[mid, span].sum()
    assert blue_row > 0.95 * (blue_row + grey_row)
