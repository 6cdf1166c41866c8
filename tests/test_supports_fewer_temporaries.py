"""The whole-cloud passes of step 2a without whole-cloud temporaries (issue 12, speed):
the cookie-cutter's candidate pass (compiled, in blocks of points on threads:
:func:`~pyheracles.supports.kernels.cookie_candidates`) and the keys of
:func:`~pyheracles.geometry.sections.sort_order` in place.

Each gives exactly what the plain whole-array expression it replaces gives (checked here
against that expression on small inputs), with far less memory allocated on the way
(checked with ``tracemalloc``, which sees numpy's allocations): on 10 M points the
allocation and page faults of those temporaries cost about as much CPU as the arithmetic.
"""

from __future__ import annotations

import tracemalloc
from collections.abc import Callable

import numpy as np
import pytest

from pyheracles.geometry.sections import sort_order
from pyheracles.supports import cookies as ck
from pyheracles.supports import kernels
from pyheracles.supports.core import SupportParams


def _cloud(n: int, seed: int = 0) -> np.ndarray:
    """A 20 x 12 m room 8 m tall: points everywhere, two columns 0.6 m apart."""
    rng = np.random.default_rng(seed)
    p = rng.uniform([0.0, 0.0, 0.0], [20.0, 12.0, 8.0], (n, 3))
    for cx in (5.0, 5.6):  # twin columns: their cookies overlap
        t = rng.uniform(0, 2 * np.pi, n // 200)
        ring = np.c_[cx + 0.25 * np.cos(t), 6.0 + 0.25 * np.sin(t), rng.uniform(0, 8, n // 200)]
        p = np.vstack([p, ring])
    return p[rng.permutation(len(p))]


def _shapes() -> list[dict]:
    col = {"class": "column", "half": np.array([0.25, 0.25]), "radius": 0.25}
    pier = {"class": "pier", "half": np.array([0.4, 0.3]), "angle": 0.3}
    return [
        {**col, "centre": np.array([5.0, 6.0]), "buffer": 0.3},
        {**col, "centre": np.array([5.6, 6.0]), "buffer": 0.35},
        {**pier, "centre": np.array([15.0, 3.0]), "buffer": 0.2},
    ]


def _plain_cookies(p: np.ndarray, shapes: list[dict]) -> list[tuple]:
    """The cookie-cutter as it was written on whole-cloud arrays (the reference)."""
    cell = 0.25
    x0, y0 = float(p[:, 0].min()), float(p[:, 1].min())
    ci = ((p[:, 0] - x0) * (1.0 / cell)).astype(np.int64)
    cj = ((p[:, 1] - y0) * (1.0 / cell)).astype(np.int64)
    width, height = int(ci.max()) + 1, int(cj.max()) + 1
    keys = cj * width + ci
    xy0 = np.array([x0, y0])
    near = np.zeros((height, width), dtype=bool)
    boxes = []
    for sh in shapes:
        reach = float(np.hypot(*sh["half"])) + sh["buffer"] + ck.RING_M
        lo = np.maximum(np.floor((sh["centre"] - reach - xy0) / cell).astype(int), 0)
        hi = np.minimum(
            np.floor((sh["centre"] + reach - xy0) / cell).astype(int), [width - 1, height - 1]
        )
        near[lo[1] : hi[1] + 1, lo[0] : hi[0] + 1] = True
        boxes.append((lo, hi))
    cand = np.flatnonzero(near.ravel()[keys])
    srt, ksorted = sort_order(keys[cand])
    korder = cand[srt]
    sid_l, idx_l, rho_l, ang_l = [], [], [], []
    for sid, (sh, (lo, hi)) in enumerate(zip(shapes, boxes, strict=True)):
        rows = np.arange(lo[1], hi[1] + 1) * width
        a = np.searchsorted(ksorted, rows + lo[0], side="left")
        b = np.searchsorted(ksorted, rows + hi[0], side="right")
        idx = np.concatenate([korder[i:j] for i, j in zip(a, b, strict=True)])
        rho, ang = ck.offset(np.take(p, idx, axis=0)[:, :2], sh)
        keep = rho <= sh["buffer"] + ck.RING_M
        sid_l.append(np.full(keep.sum(), sid))
        idx_l.append(idx[keep])
        rho_l.append(rho[keep])
        ang_l.append(ang[keep])
    sid_all, idx_all = np.concatenate(sid_l), np.concatenate(idx_l)
    rho_all, ang_all = np.concatenate(rho_l), np.concatenate(ang_l)
    shared = np.flatnonzero(np.bincount(idx_all, minlength=len(p))[idx_all] > 1)
    keep = np.ones(len(idx_all), dtype=bool)
    bufs = np.array([sh["buffer"] for sh in shapes])
    srt = shared[np.lexsort((rho_all[shared] / bufs[sid_all[shared]], idx_all[shared]))]
    first = np.r_[True, idx_all[srt][1:] != idx_all[srt][:-1]]
    keep[srt[~first]] = False
    sid_all, idx_all, rho_all, ang_all = sid_all[keep], idx_all[keep], rho_all[keep], ang_all[keep]
    bounds = np.r_[0, np.cumsum(np.bincount(sid_all, minlength=len(shapes)))]
    out = []
    for sid in range(len(shapes)):
        sel = slice(bounds[sid], bounds[sid + 1])
        srt, idx = sort_order(idx_all[sel])
        out.append((idx, rho_all[sel][srt], ang_all[sel][srt]))
    return out


def _peak_bytes(f: Callable[[], object]) -> int:
    """Peak bytes allocated (numpy arrays included) while ``f`` runs."""
    tracemalloc.start()
    try:
        f()
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


@pytest.mark.parametrize("threads", ["1", "2", "3"])
def test_cookies_in_blocks_match_the_whole_cloud_cutter(
    threads: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("HERACLES_THREADS", threads)  # blocks of points on threads
    monkeypatch.setattr(kernels, "MIN_BLOCK", 1000)
    p = _cloud(20_000)
    shapes = _shapes()
    got = ck.cookies(p, shapes, SupportParams())
    ref = _plain_cookies(p, shapes)
    assert len(got) == len(ref) == 3
    for g, r in zip(got, ref, strict=True):
        for a, b in zip(g, r, strict=True):
            assert a.dtype == b.dtype
            np.testing.assert_array_equal(a, b)
    # the twin columns shared points, each went to one cookie
    assert len(np.intersect1d(got[0][0], got[1][0])) == 0
    assert len(got[0][0]) > 50 and len(got[1][0]) > 50 and len(got[2][0]) > 10


def test_cookies_allocate_no_whole_cloud_arrays() -> None:
    """The candidate pass holds a block at a time and the shared-point count is one
    byte a point: the cutter allocates about 8 bytes a point of this cloud (5 % of it
    near a shape), not the ~40 (cell indices, keys, an int64 count) of the whole-cloud
    expressions."""
    p = _cloud(1_000_000)
    shapes = _shapes()
    peak = _peak_bytes(lambda: ck.cookies(p, shapes, SupportParams()))
    plain = _peak_bytes(lambda: _plain_cookies(p, shapes))
    assert plain > 30 * len(p), plain / len(p)  # what the cutter's pass used to take
    assert peak < 12 * len(p), peak / len(p)


@pytest.mark.parametrize("dtype", [np.float64, np.float32, np.int64, np.int32])
def test_sort_order_keys_in_place_give_the_same_order(dtype: type) -> None:
    rng = np.random.default_rng(1)
    v = (rng.normal(0, 3, 200_000) * (1000 if np.dtype(dtype).kind == "i" else 1)).astype(dtype)
    v[::7] = v[3]  # ties keep their input order
    order, srt = sort_order(v)
    np.testing.assert_array_equal(order, np.argsort(v, kind="stable"))
    np.testing.assert_array_equal(srt, v[order])
    col = np.c_[v, v, v][:, 2]  # a strided column, as the heights of an (N, 3) cloud
    np.testing.assert_array_equal(sort_order(col)[0], order)


def test_sort_order_allocates_three_arrays_at_most() -> None:
    """The keys are quantised, shifted and indexed in place: the peak is the int64 keys,
    the order and the sorted values (25 bytes a point with the check of the order),
    not a float copy, the product, the shift and a copy of the order as well (33)."""
    v = np.random.default_rng(2).uniform(0, 10, 1_000_000)
    sort_order(v)  # load the compiled sort (pyheracles.geometry.sort_kernels) first
    peak = _peak_bytes(lambda: sort_order(v))
    assert peak <= 27 * len(v), peak / len(v)
