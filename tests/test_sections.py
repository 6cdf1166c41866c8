"""Horizontal slices, hull areas and circularity."""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.geometry.sections import (
    SliceParams,
    circularity,
    hull_area_perimeter,
    slab_mask,
    slice_profile,
    slices,
    sort_order,
)


def test_hull_area_perimeter_and_degenerate_input() -> None:
    sq = np.array([[0, 0], [2, 0], [2, 1], [0, 1], [1, 0.5]], dtype=float)
    assert hull_area_perimeter(sq) == pytest.approx((2.0, 6.0))
    assert hull_area_perimeter(np.zeros((0, 2))) == (0.0, 0.0)
    assert hull_area_perimeter(np.array([[0.0, 0.0], [3.0, 4.0]])) == (0.0, 10.0)
    line = np.c_[np.arange(5.0), np.zeros(5)]
    assert hull_area_perimeter(line) == (0.0, 8.0)


def test_circularity_disc_square_and_thesis_threshold() -> None:
    rng = np.random.default_rng(0)
    t = rng.uniform(0, 2 * np.pi, 2000)
    disc = np.c_[np.cos(t), np.sin(t)] * 0.3 + rng.normal(0, 0.002, (2000, 2))
    assert circularity(disc) == pytest.approx(1.0, abs=0.02)
    s = rng.uniform(-1, 1, 2000)
    side = rng.integers(0, 4, 2000)
    square = np.where(side[:, None] < 2, np.c_[s, np.where(side == 0, -1, 1)],
                      np.c_[np.where(side == 2, -1, 1), s])  # fmt: skip
    assert circularity(square) == pytest.approx(4 / np.pi, abs=0.02)
    # the thesis threshold 1.12 separates the two
    assert circularity(disc) < 1.12 < circularity(square)
    assert circularity(np.c_[np.arange(4.0), np.arange(4.0)]) == float("inf")


def test_slices_match_brute_force() -> None:
    rng = np.random.default_rng(1)
    z = rng.uniform(0, 10, 5000)
    centres = np.arange(0.5, 10, 0.7)
    order, starts, ends = slices(z, centres, 0.1)
    for c, s, e in zip(centres, starts, ends, strict=True):
        np.testing.assert_array_equal(np.sort(order[s:e]), np.flatnonzero(slab_mask(z, c, 0.1)))


def test_slice_profile_of_a_stepped_tower() -> None:
    # a 4 x 4 m box up to 3 m, then a 2 x 2 m box up to 5 m (lateral faces only)
    rng = np.random.default_rng(2)

    def box_sides(half: float, z0: float, z1: float, n: int) -> np.ndarray:
        s = rng.uniform(-half, half, n)
        k = rng.integers(0, 4, n)
        xy = np.where(k[:, None] < 2, np.c_[s, np.where(k == 0, -half, half)],
                      np.c_[np.where(k == 2, -half, half), s])  # fmt: skip
        return np.c_[xy, rng.uniform(z0, z1, n)]

    pts = np.vstack([box_sides(2.0, 0.0, 3.0, 60000), box_sides(1.0, 3.0, 5.0, 30000)])
    prof = slice_profile(pts, SliceParams(interval_m=0.2, thickness_m=0.05))
    assert prof.heights[0] == pytest.approx(pts[:, 2].min() + 0.125, abs=1e-9)
    low, high = prof.heights < 2.9, prof.heights > 3.1
    np.testing.assert_allclose(prof.areas[low], 16.0, rtol=0.02)
    np.testing.assert_allclose(prof.areas[high], 4.0, rtol=0.03)
    assert (prof.counts > 0).all()
    assert len(slice_profile(np.zeros((0, 3))).heights) == 0


def test_slice_params_validated() -> None:
    with pytest.raises(ValueError, match="interval_m"):
        SliceParams(interval_m=0)
    with pytest.raises(ValueError, match="ground_tolerance_m"):
        SliceParams(ground_tolerance_m=-1)


@pytest.mark.parametrize("n", [10, 200_000])
def test_sort_order_exact_with_near_ties_ints_and_nan(n: int) -> None:
    rng = np.random.default_rng(1)
    # values closer than the quantisation step come out of the int64 sort swapped and
    # must be repaired: a few coarse levels plus offsets of 1e-13 m
    z = rng.integers(0, 50, n) * 0.2 + rng.integers(0, 3, n) * 1e-13 + 100.0
    order, srt = sort_order(z)
    assert np.array_equal(np.sort(order), np.arange(n))  # a permutation
    assert np.array_equal(srt, z[order])
    assert np.array_equal(srt, np.sort(z))
    k = rng.integers(-5, 1000, n)
    order, srt = sort_order(k)
    assert np.array_equal(srt, np.sort(k))
    assert np.array_equal(k[order], srt)
    # stable for integer keys: equal keys keep their input order
    assert np.all(np.diff(order)[np.diff(srt) == 0] > 0)
    for k in (rng.integers(0, 2**62, n), rng.integers(0, 2, n).astype(bool)):
        order, srt = sort_order(k)  # too wide for exact integer keys / not a number
        assert np.array_equal(srt, np.sort(k)) and np.array_equal(k[order], srt)
    # a few near-ties only: repaired locally
    z = rng.uniform(0, 10, n)
    z[:5] = z[5:10] + 1e-13
    order, srt = sort_order(z)
    assert np.array_equal(srt, np.sort(z)) and np.array_equal(z[order], srt)
    z[::7] = np.nan
    order, srt = sort_order(z)
    assert np.array_equal(srt, np.sort(z), equal_nan=True)
