"""The compiled and batched parts of beams and region growing give numpy's numbers to the
bit (issue 13, speed): the kNN edge terms, the extreme quantiles of a band's offsets,
the repeated medians of a band's edges, box queries, and the points near other beams."""

from __future__ import annotations

import numpy as np

from pyheracles.beams.bands import across_quantiles, best_direction, edge_line_direction
from pyheracles.beams.deflection import (
    BoxIndex,
    ShapeParams,
    member_shape,
    member_shapes,
    near_beams,
    search_box,
)
from pyheracles.beams.model import BeamCuboid
from pyheracles.segment.edge_kernels import knn_edge_terms


def _numpy_edge_terms(xyz, normals, nbr):
    centre = 0.5 * (xyz.min(axis=0) + xyz.max(axis=0))
    pos = (xyz - centre).astype(np.float32)
    nrm = normals.astype(np.float32)
    ns, nd = nrm[:, None, :], nrm[nbr]
    d = pos[nbr] - pos[:, None, :]
    cosang = np.abs((ns * nd).sum(axis=2))
    resid = np.maximum(np.abs((ns * d).sum(axis=2)), np.abs((nd * d).sum(axis=2)))
    return cosang.ravel(), resid.ravel()


def test_knn_edge_terms_are_the_numpy_formulas() -> None:
    rng = np.random.default_rng(1)
    xyz = rng.uniform(-5, 5, (3000, 3)) + [1000.0, 2000.0, 30.0]
    normals = rng.normal(size=(3000, 3))
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    nbr = rng.integers(0, 3000, (3000, 11))
    centre = 0.5 * (xyz.min(axis=0) + xyz.max(axis=0))
    pos, nrm = (xyz - centre).astype(np.float32), normals.astype(np.float32)
    cosang, resid = np.empty((3000, 11), np.float32), np.empty((3000, 11), np.float32)
    knn_edge_terms(pos, nrm, nbr, cosang, resid)
    want = _numpy_edge_terms(xyz, normals, nbr)
    assert np.array_equal(cosang.ravel(), want[0]) and np.array_equal(resid.ravel(), want[1])


def test_extreme_quantiles_across_directions_are_numpys() -> None:
    rng = np.random.default_rng(2)
    for it in range(300):
        m = int(rng.integers(1, 40)) if it % 3 == 0 else int(rng.integers(40, 3001))
        q = rng.normal(size=(m, 2)) * [rng.uniform(0.1, 5), rng.uniform(0.001, 0.2)]
        if it % 5 == 0:
            q = np.sort(q, axis=0)  # scan order: every offset a new extreme
        if it % 7 == 0:
            q = np.round(q, 2)  # ties
        angles = rng.uniform(0, 3) + np.linspace(-0.1, 0.1, 41)
        s = -q[:, :1] * np.sin(angles) + q[:, 1:] * np.cos(angles)
        want = np.quantile(s, [0.005, 0.995], axis=0)
        assert np.array_equal(np.array(across_quantiles(q, angles, 0.005, 0.995)), want)


def test_hough_accumulator_of_best_direction_is_numpys() -> None:
    rng = np.random.default_rng(5)
    for it in range(100):
        m = int(rng.integers(1, 4001))
        q = rng.normal(size=(m, 2)) * [rng.uniform(0.1, 5), rng.uniform(0.01, 0.3)]
        if it % 4 == 0:
            q = np.round(q, 2)
        angles = np.arange(0.0, np.pi, np.radians(rng.choice([1.0, 5.0])))
        bin_m = float(rng.uniform(0.002, 0.05))
        s = -q[:, :1] * np.sin(angles) + q[:, 1:] * np.cos(angles)
        smin = s.min(axis=0)
        b = ((s - smin) / bin_m).astype(np.int64)
        nb = int(b.max()) + 1
        acc = np.bincount((b + np.arange(len(angles)) * nb).ravel(), minlength=nb * len(angles))
        acc = acc.reshape(len(angles), nb)
        acc = acc[:, :-2] + acc[:, 1:-1] + acc[:, 2:] if nb > 2 else acc
        ia, ib = divmod(int(acc.argmax()), acc.shape[1])
        want = (float(angles[ia]), float(smin[ia] + (ib + (1 if nb > 2 else 0) + 0.5) * bin_m))
        assert best_direction(q, angles, bin_m) == want


def test_edge_line_direction_row_medians_are_nanmedians() -> None:
    """The repeated medians of a band's edges: each row's median by a sort with the NaN
    of unpaired slices last, as np.nanmedian gives it; the direction stays robust."""
    from pyheracles.beams.bands import sorted_median

    rng = np.random.default_rng(3)
    for _ in range(200):
        n = int(rng.integers(2, 25))
        rows = rng.normal(size=(n, n))
        rows[rng.random((n, n)) < rng.uniform(0, 0.8)] = np.nan
        rows = rows[np.isfinite(rows).any(axis=1)]
        got = sorted_median(np.sort(rows, axis=1).ravel(), np.arange(len(rows)) * n,
                            np.isfinite(rows).sum(axis=1))  # fmt: skip
        assert np.array_equal(got, np.nanmedian(rows, axis=1))
    t = rng.uniform(0, 4, 2000)
    s = rng.uniform(-0.06, 0.06, 2000) + 0.01 * t
    s[:80] += rng.uniform(0.05, 0.2, 80)  # a flush face poking out of one edge
    assert abs(edge_line_direction(np.column_stack([t, s]), 0.0, 0.005) - np.arctan(0.01)) < 2e-3


def _box(centre, axis, length, width=0.16, height=0.2) -> BeamCuboid:
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    up = np.array([0.0, 0.0, 1.0]) if abs(a[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    w = np.cross(up, a)
    w /= np.linalg.norm(w)
    h = np.cross(a, w)
    return BeamCuboid(
        centre=np.asarray(centre, float), axes=np.column_stack([a, w, h]), length=length,
        width=width, height=height, rms=0.0, n_facets=0,
    )  # fmt: skip


def test_box_queries_and_points_near_other_beams() -> None:
    rng = np.random.default_rng(4)
    beams = [_box([0, 0, 0], [1, 0, 0], 4.0), _box([1, 0, 0.5], [1, 0, 1], 2.0),
             _box([0, 0, 0.2], [0, 1, 0], 3.0)]  # fmt: skip
    xyz = np.concatenate([b.centre + rng.uniform(-1, 1, (4000, 3)) * b.half_extents @ b.axes.T
                          * 1.1 for b in beams] + [rng.uniform(-3, 3, (3000, 3))])  # fmt: skip
    index = BoxIndex(xyz)
    for lo, hi in ([-1, -0.2, -0.3], [1, 0.2, 0.3]), ([0, -3, 0], [3, 3, 3]):
        lo, hi = np.array(lo, float), np.array(hi, float)
        want = np.flatnonzero(np.all((xyz >= lo) & (xyz <= hi), axis=1))
        assert np.array_equal(index.query(lo, hi), want)
    boxes, count, which = near_beams(xyz, beams, ShapeParams(surface_tol_m=0.012), index)
    for b, found in zip(beams, boxes, strict=True):
        assert np.array_equal(found, index.query(*search_box(b, ShapeParams())))
    d = np.array([b.signed_distance(xyz) for b in beams])
    assert np.array_equal(count, (d <= 0.012).sum(axis=0))
    one = count == 1
    assert np.array_equal(which[one], np.argmax(d[:, one] <= 0.012, axis=0))
    # the shapes with the points near other beams found once equal those found per pair
    labels = np.zeros(len(xyz), np.int32)
    for i in np.argsort(-d.min(axis=1).clip(max=0), kind="stable"):
        labels[np.abs(d[i]) <= 0.01] = i + 1
    shapes = member_shapes(xyz, labels, beams)
    for i, b in enumerate(beams):
        one_by_one = member_shape(xyz, b, labels == i + 1, other=labels > 0,
                                  others=beams[:i] + beams[i + 1:])  # fmt: skip
        assert str(one_by_one) == str(shapes[i])


def test_one_blas_thread_limits_blas_inside_and_restores_it() -> None:
    from threadpoolctl import threadpool_info

    from pyheracles.resources import one_blas_thread

    def blas_threads() -> list[int]:
        return [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"]

    before = blas_threads()
    a = np.random.default_rng(6).normal(size=(50_000, 3))
    with one_blas_thread():
        assert blas_threads() and set(blas_threads()) == {1}
        inside = a @ np.eye(3)[::-1]
    assert blas_threads() == before
    assert np.array_equal(inside, a @ np.eye(3)[::-1])
