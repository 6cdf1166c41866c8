"""Clutter touching a column, told from its plinth by the shaft's own surface.

Supports draw 4: a bench seat 3-21 cm beyond a column's shaft (533 points) stayed in the
column, because a board tangent to a round shaft fills half the sectors of its layer.
"""

from __future__ import annotations

import numpy as np

from pyheracles.supports.clutter import off_shaft

R, H, NOISE = 0.25, 4.0, 0.002


def _shaft(rng: np.random.Generator, n: int, half_seen: bool) -> np.ndarray:
    lo, hi = (-0.5 * np.pi, 0.5 * np.pi) if half_seen else (-np.pi, np.pi)
    th = rng.uniform(lo, hi, n)
    z = rng.uniform(0.3, H, n)
    r = R + rng.normal(0.0, NOISE, n)
    return np.c_[r * np.cos(th), r * np.sin(th), z]


def _plinth(rng: np.random.Generator, n: int) -> np.ndarray:
    """A square plinth 0.7 m wide, 0.3 m tall: its four sides."""
    s = rng.uniform(-0.35, 0.35, n)
    z = rng.uniform(0.0, 0.3, n)
    side = rng.integers(0, 4, n)
    x = np.where(side < 2, np.where(side == 0, 0.35, -0.35), s)
    y = np.where(side < 2, s, np.where(side == 2, 0.35, -0.35))
    return np.c_[x, y, z] + rng.normal(0.0, NOISE, (n, 3))


def _seat(rng: np.random.Generator, n: int) -> np.ndarray:
    """A bench seat 0.4 m deep at 1.05 m, its long side tangent to the shaft."""
    x = rng.uniform(R, R + 0.4, n)
    y = rng.uniform(-1.0, 1.0, n)
    keep = np.hypot(x, y) > R + 0.01
    return np.c_[x, y, rng.normal(1.05, NOISE, n)][keep]


ROW = {"z_min": 0.0, "height_m": H, "radius_bottom_m": R, "radius_top_m": R,
       "radius_m": R, "base_top_m": 0.3, "capital_bottom_m": float("nan")}  # fmt: skip


def _mask(pts: np.ndarray, row: dict) -> np.ndarray:
    return off_shaft(pts, np.zeros(3), np.array([0.0, 0.0, 1.0]), row, 0.01)


def test_a_bench_seat_touching_a_column_is_off_its_shaft() -> None:
    rng = np.random.default_rng(4)
    for half_seen in (False, True):  # seen all round, or from one side only
        shaft, seat = _shaft(rng, 20_000, half_seen), _seat(rng, 1500)
        seat = seat[seat[:, 0] > 0] if half_seen else seat
        off = _mask(np.vstack([shaft, seat]), ROW)
        assert not off[: len(shaft)].any()
        assert off[len(shaft) :].mean() > 0.9


def test_a_plinth_stays_even_when_its_band_was_not_found() -> None:
    rng = np.random.default_rng(5)
    pts = np.vstack([_shaft(rng, 20_000, False), _plinth(rng, 4000)])
    row = {**ROW, "base_top_m": float("nan")}  # the plinth band not measured
    assert not _mask(pts, row).any()


def test_the_arrises_of_a_deeply_fluted_column_stay() -> None:
    """Draw 22: 1.24 m columns with flutes 6 cm deep; their arrises stand 3 cm proud of the
    mean radius and were taken for clutter while the threshold ignored the flutes."""
    rng = np.random.default_rng(22)
    n, radius, depth, flutes = 40_000, 1.24, 0.06, 24
    th = rng.uniform(-np.pi, np.pi, n)
    # flutes: the surface dips by up to ``depth`` between arrises
    r = radius + depth / 2 - depth * np.abs(np.sin(flutes * th / 2)) + rng.normal(0, NOISE, n)
    z = rng.uniform(0.3, 8.0, n)
    pts = np.c_[r * np.cos(th), r * np.sin(th), z]
    mean_r = float(np.mean(r))
    row = {**ROW, "height_m": 8.0, "radius_bottom_m": mean_r, "radius_top_m": mean_r,
           "radius_m": mean_r}  # fmt: skip
    assert not _mask(pts, row).any()
