"""Nearest descriptors by brute force: the matching step of global registration.

Putative correspondences between two clouds' FPFH descriptors
(:func:`match_descriptors`), and the nearest descriptor of a cloud's own
points among its far-away parts (:func:`nearest_far_descriptors`, for the
search of a target's symmetries in :mod:`~pyheracles.registration.global_registration`).
Why brute force and not a k-d tree: see :func:`two_nearest`.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

__all__ = ["match_descriptors", "nearest_far_descriptors", "ranking_factors", "two_nearest"]


def ranking_factors(
    x: NDArray[np.float32], y: NDArray[np.float32]
) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
    """``[x, 1]`` and ``[y, -|y|^2 / 2]^T``: their product ``x.y - |y|^2 / 2`` ranks the
    rows of ``y`` by their distance to each row of ``x`` (larger: nearer)."""
    x_aug = np.hstack([x, np.ones((len(x), 1), dtype=np.float32)])
    y_aug = np.vstack([y.T, np.float32(-0.5) * np.einsum("ij,ij->i", y, y)[None, :]])
    return x_aug, y_aug


def two_nearest(
    x: NDArray[np.float64], y: NDArray[np.float64], rows: int = 256
) -> tuple[NDArray[np.float64], NDArray[np.intp]]:
    """Distances and indices of the (up to) two nearest rows of ``y`` for every row of ``x``.

    Brute force by blocks of matrix products (float32, ``|x - y|^2 = |x|^2 + |y|^2 -
    2 x.y``, ranked by ``x.y - |y|^2 / 2``, the second term folded into the product as
    one more column): for a few thousand descriptors of 33 dimensions several times
    faster than a k-d tree, which degrades to a linear scan in that many dimensions
    anyway.  Blocks of ``rows`` rows (a few MB of scores) stay in the processor's
    cache between the product and the two passes that pick the best columns.
    """
    k = min(2, len(y))
    xf = np.ascontiguousarray(x, dtype=np.float32)
    yf = np.ascontiguousarray(y, dtype=np.float32)
    x_aug, y_aug = ranking_factors(xf, yf)
    best = np.empty((len(xf), k))
    j_out = np.empty((len(xf), k), dtype=np.intp)
    buffer = np.empty((min(rows, len(xf)), len(yf)), dtype=np.float32)
    for s in range(0, len(xf), rows):
        score = buffer[: min(rows, len(xf) - s)]
        np.matmul(x_aug[s : s + rows], y_aug, out=score)
        r = np.arange(len(score))
        for c in range(k):
            j = score.argmax(axis=1)
            j_out[s : s + rows, c] = j
            best[s : s + rows, c] = score[r, j]
            score[r, j] = -np.inf
    x2 = np.einsum("ij,ij->i", xf, xf).astype(np.float64)
    d2 = x2[:, None] - 2.0 * best
    return np.sqrt(np.maximum(d2, 0.0)), j_out


def match_descriptors(
    fs: NDArray[np.float64],
    ft: NDArray[np.float64],
    *,
    ratio: float | None = None,
    min_mutual: int = 200,
    max_matches: int = 5_000,
) -> tuple[NDArray[np.intp], NDArray[np.intp], int]:
    """Putative correspondences between two descriptor sets.

    Mutual nearest neighbours (Euclidean on the given vectors, brute force);
    with ``ratio`` only those passing Lowe's test; when fewer than
    ``min_mutual`` remain, the one-way matches of both directions are added.
    The ``max_matches`` with the smallest distance ratio are kept.

    Returns
    -------
    source_index, target_index, n_mutual
    """
    # both directions at once (numpy releases the interpreter lock in the products and
    # the passes over them): one per core
    with ThreadPoolExecutor(max_workers=1) as pool:
        backward = pool.submit(two_nearest, ft, fs)
        ds, js = two_nearest(fs, ft)
        dt, jt = backward.result()

    def lowe(d: NDArray[np.float64]) -> NDArray[np.float64]:
        if d.shape[1] < 2:
            return np.zeros(len(d))
        return d[:, 0] / np.maximum(d[:, 1], 1e-12)

    rs, rt = lowe(ds), lowe(dt)
    s2t, t2s = js[:, 0], jt[:, 0]
    mutual = t2s[s2t] == np.arange(len(fs))
    if ratio is not None:
        mutual &= (rs < ratio) & (rt[s2t] < ratio)
    src = np.flatnonzero(mutual)
    tgt = s2t[src]
    score = rs[src]
    n_mutual = len(src)
    if n_mutual < min_mutual:
        one_s = np.flatnonzero(~mutual if ratio is None else (~mutual) & (rs < ratio))
        one_t = np.flatnonzero(t2s >= 0 if ratio is None else rt < ratio)
        one_t = one_t[s2t[t2s[one_t]] != one_t]  # the mutual ones are already in
        src = np.concatenate([src, one_s, t2s[one_t]])
        tgt = np.concatenate([tgt, s2t[one_s], one_t])
        score = np.concatenate([score, rs[one_s] + 1.0, rt[one_t] + 1.0])  # mutual first
        pair = np.unique(np.stack([src, tgt], axis=1), axis=0, return_index=True)[1]
        src, tgt, score = src[pair], tgt[pair], score[pair]
    if len(src) > max_matches:
        keep = np.argsort(score, kind="stable")[:max_matches]
        src, tgt = src[keep], tgt[keep]
    return src, tgt, n_mutual


def nearest_far_descriptors(
    desc: NDArray[np.float64],
    pts: NDArray[np.float64],
    rows: NDArray[np.intp],
    min_m: float,
    block: int = 256,
) -> NDArray[np.intp]:
    """For each of ``rows``, the row of ``desc`` nearest to its descriptor among those
    of the points at least ``min_m`` metres from it (brute force as :func:`two_nearest`,
    the nearby points masked out of the scores)."""
    x_aug, y_aug = ranking_factors(
        np.ascontiguousarray(desc[rows], dtype=np.float32),
        np.ascontiguousarray(desc, dtype=np.float32),
    )
    near = cKDTree(pts).query_ball_point(pts[rows], min_m, workers=-1, return_sorted=False)
    lens = np.array([len(n) for n in near])
    r_near = np.repeat(np.arange(len(rows)), lens)
    c_near = np.concatenate([np.asarray(n, dtype=np.intp) for n in near])
    starts = np.searchsorted(r_near, np.arange(0, len(rows), block))
    out = np.empty(len(rows), dtype=np.intp)
    buffer = np.empty((min(block, len(rows)), len(desc)), dtype=np.float32)
    for b, s in enumerate(range(0, len(rows), block)):
        score = buffer[: min(block, len(rows) - s)]
        np.matmul(x_aug[s : s + block], y_aug, out=score)
        e = starts[b + 1] if b + 1 < len(starts) else len(r_near)
        score[r_near[starts[b] : e] - s, c_near[starts[b] : e]] = -np.inf
        out[s : s + block] = score.argmax(axis=1)
    return out
