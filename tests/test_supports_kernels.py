"""The compiled passes of step 2a (:mod:`pyheracles.supports.kernels`, issue 12 speed)
against plain numpy references on small inputs: the slab grid's cell keys, one slab's
occupied cells and linked components, and the cookie-cutter's candidates.  Each must
give exactly what the numpy code it replaced gave, on one thread and on several."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from pyheracles.supports import kernels
from pyheracles.supports.cookies import RING_M, offset, outline_table
from pyheracles.supports.height import LINK_STEPS, LINKS, SlabGrid


def _slab(n: int = 30_000, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """A 12 x 8 m room: scattered points, six column rings and a wall line; an
    order of its points (shuffled, as a z order is to the input)."""
    rng = np.random.default_rng(seed)
    p = rng.uniform([0.0, 0.0, 0.0], [12.0, 8.0, 5.0], (n // 3, 3))
    rings = []
    for cx in (2.0, 4.0, 6.0, 8.0, 10.0, 10.4):
        t = rng.uniform(0, 2 * np.pi, n // 9)
        r = 0.25 + rng.normal(0, 0.003, len(t))
        rings.append(np.c_[cx + r * np.cos(t), 4.0 + r * np.sin(t), rng.uniform(0, 5, len(t))])
    wall = np.c_[
        rng.uniform(0, 12, n // 6), rng.normal(7.5, 0.01, n // 6), rng.uniform(0, 5, n // 6)
    ]
    p = np.vstack([p, *rings, wall])
    return p, rng.permutation(len(p))


def _plain_keys(p: np.ndarray, idx: np.ndarray, cell: float) -> tuple:
    """SlabGrid's keys as numpy computed them before the kernel."""
    x, y = p[:, 0][idx], p[:, 1][idx]
    ci = ((x - float(x.min())) * (1.0 / cell)).astype(np.int64) + 2
    cj = ((y - float(y.min())) * (1.0 / cell)).astype(np.int64) + 2
    ny = int(cj.max()) + 3
    return x, y, ci * ny + cj, ny, (int(ci.max()) + 3) * ny


def _plain_components(cells, inv, x, y, ny, cell) -> tuple:
    """The cell centroids and the scipy components of the linked cells (the numpy code
    the kernel replaced)."""
    m = len(cells)
    n_in = np.bincount(inv, minlength=m)
    px = np.bincount(inv, x, minlength=m) / n_in
    py = np.bincount(inv, y, minlength=m) / n_in
    src, dst = [], []
    for di, dj in LINKS:
        nb = cells + (di * ny + dj)
        pos = np.minimum(np.searchsorted(cells, nb), m - 1)
        pos[cells[pos] != nb] = -1
        hit = np.flatnonzero(pos >= 0)
        d2 = (px[hit] - px[pos[hit]]) ** 2 + (py[hit] - py[pos[hit]]) ** 2
        close = d2 <= (2 * cell) ** 2
        src.append(hit[close])
        dst.append(pos[hit][close])
    a, b = np.concatenate(src), np.concatenate(dst)
    graph = coo_matrix((np.ones(len(a), dtype=np.int8), (a, b)), shape=(m, m))
    return connected_components(graph, directed=False)[1], px, py


@pytest.mark.parametrize("threads", ["1", "2"])
def test_slab_keys_match_numpy(threads: str, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("HERACLES_THREADS", threads)
    monkeypatch.setattr(kernels, "MIN_BLOCK", 1000)  # several blocks of the gather
    p, order = _slab()
    idx = order[: len(order) // 2]
    got = kernels.slab_keys(p, idx, 0.05)
    ref = _plain_keys(p, idx, 0.05)
    for g, r in zip(got, ref, strict=True):
        np.testing.assert_array_equal(g, r)
    assert got[2].dtype == np.int64


@pytest.mark.parametrize("cell", [0.03, 0.05, 0.2])
def test_slab_cells_and_components_match_numpy(cell: float) -> None:
    p, order = _slab(seed=1)
    x, y, key, ny, ncells = _plain_keys(p, order, cell)
    ids = np.full(ncells, -1, dtype=np.int32)
    for s, e in ((0, len(key)), (100, 5000), (7000, 7001)):  # slabs of one table
        cells, inv = kernels.occupied_cells(key[s:e], ids)
        ref_cells, ref_inv = np.unique(key[s:e], return_inverse=True)
        np.testing.assert_array_equal(cells, ref_cells)
        np.testing.assert_array_equal(inv, ref_inv.ravel())
        assert (ids == -1).all()  # the table is left as it was found
        comp, px, py = kernels.slab_components(
            cells, inv, x[s:e], y[s:e], ny, LINK_STEPS, (2 * cell) ** 2
        )
        ref_comp, ref_px, ref_py = _plain_components(cells, inv, x[s:e], y[s:e], ny, cell)
        np.testing.assert_array_equal(comp, ref_comp)
        np.testing.assert_array_equal(px, ref_px)
        np.testing.assert_array_equal(py, ref_py)
    assert comp.max() >= 0


def test_slab_grid_islands_on_the_sparse_path_match_the_dense_one(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Grids over ``DENSE_CELLS`` use ``np.unique`` for the occupied cells: same islands."""
    from pyheracles.supports import height
    from pyheracles.supports.core import SupportParams

    p, order = _slab(seed=2)
    zs = p[order, 2]
    order = order[np.argsort(zs, kind="stable")]
    params = SupportParams()
    dense = SlabGrid(p, order, 0.04)
    monkeypatch.setattr(height, "DENSE_CELLS", 0)
    sparse = SlabGrid(p, order, 0.04)
    assert dense.dense and not sparse.dense
    for s, e in ((0, len(order)), (3000, 9000)):
        a, b = dense.support_islands(s, e, params), sparse.support_islands(s, e, params)
        np.testing.assert_array_equal(a[0], b[0])
        np.testing.assert_array_equal(a[1], b[1])
    assert len(a[0]) >= 5  # the column rings


def _shapes() -> list[dict]:
    col = {"class": "column", "half": np.array([0.25, 0.25]), "radius": 0.25}
    pier = {"class": "pier", "half": np.array([0.4, 0.3]), "angle": 0.3, "radius": 0.5}
    return [
        {**col, "centre": np.array([10.0, 4.0]), "buffer": 0.3},
        {**col, "centre": np.array([10.4, 4.0]), "buffer": 0.35},
        {**pier, "centre": np.array([6.0, 4.0]), "buffer": 0.2},
        {**pier, "centre": np.array([0.1, 0.2]), "buffer": 0.2, "angle": -1.0},  # at a corner
    ]


@pytest.mark.parametrize("threads", ["1", "3"])
def test_cookie_candidates_hold_every_cookie_point_in_input_order(
    threads: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The candidates are the box points of numpy's cell test that are near the outline
    (with the rounding margin): every point numpy's offset keeps is one of them, in
    input order, and the pier's box corners (outside the reach) are not."""
    monkeypatch.setenv("HERACLES_THREADS", threads)
    monkeypatch.setattr(kernels, "MIN_BLOCK", 1000)
    p, _ = _slab(seed=3)
    shapes = _shapes()
    cell = 0.25
    x0, y0 = float(p[:, 0].min()), float(p[:, 1].min())
    width = int((float(p[:, 0].max()) - x0) * (1.0 / cell)) + 1
    height = int((float(p[:, 1].max()) - y0) * (1.0 / cell)) + 1
    ci = ((p[:, 0] - x0) * (1.0 / cell)).astype(np.int64)
    cj = ((p[:, 1] - y0) * (1.0 / cell)).astype(np.int64)
    boxes = []
    for sh in shapes:
        reach = float(np.hypot(*sh["half"])) + sh["buffer"] + RING_M
        lo = np.maximum(np.floor((sh["centre"] - reach - [x0, y0]) / cell).astype(int), 0)
        hi = np.minimum(
            np.floor((sh["centre"] + reach - [x0, y0]) / cell).astype(int), [width - 1, height - 1]
        )
        boxes.append((*lo, *hi))
    boxes = np.array(boxes)
    got = kernels.cookie_candidates(
        p, (x0, y0), cell, (height, width), boxes, *outline_table(shapes)
    )
    for sh, (lx, ly, hx, hy), cand in zip(shapes, boxes, got, strict=True):
        in_box = np.flatnonzero((ci >= lx) & (ci <= hx) & (cj >= ly) & (cj <= hy))
        rho, _ = offset(p[in_box, :2], sh)
        limit = sh["buffer"] + RING_M
        np.testing.assert_array_equal(cand, in_box[rho <= limit + kernels.REACH_MARGIN_M])
        assert np.isin(in_box[rho <= limit], cand).all()
        assert cand.dtype == np.intp and (np.diff(cand) > 0).all()
        assert len(cand) > 20
