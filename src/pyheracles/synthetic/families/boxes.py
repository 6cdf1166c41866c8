"""Oriented boxes of the generated scenes: overlap (separating axes) and distance to a point.

A box is its centre, ``rows`` (its three unit axes as rows) and its half extents,
all in metres.  Used to keep stored objects, ladders and boarding clear of the
members of a roof frame and to label points by the member that holds them.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["obb_distance_to_point", "obb_overlap", "obb_overlap_many"]


def obb_overlap(
    c1: ArrayLike,
    r1: ArrayLike,
    h1: ArrayLike,
    c2: ArrayLike,
    r2: ArrayLike,
    h2: ArrayLike,
    tol: float = 0.0,
) -> bool:
    """Whether two oriented boxes (centre, rows = unit axes, half extents) come within ``tol``.

    Separating-axis test over the 15 candidate axes.
    """
    return bool(
        obb_overlap_many(
            c1,
            r1,
            h1,
            np.asarray(c2, float)[None],
            np.asarray(r2, float)[None],
            np.asarray(h2, float)[None],
            tol,
        )[0]
    )


def obb_overlap_many(
    c: ArrayLike,
    r: ArrayLike,
    h: ArrayLike,
    centres: ArrayLike,
    rows: ArrayLike,
    halves: ArrayLike,
    tol: float = 0.0,
) -> NDArray[np.bool_]:
    """:func:`obb_overlap` of one box against ``n`` boxes (arrays of centres, rows, halves)."""
    c, r, h = np.asarray(c, float), np.asarray(r, float), np.asarray(h, float)
    C, R, H = np.asarray(centres, float), np.asarray(rows, float), np.asarray(halves, float)
    n = len(C)
    if n == 0:
        return np.zeros(0, bool)
    A = np.broadcast_to(r, (n, 3, 3))
    cr = np.cross(A[:, :, None, :], R[:, None, :, :]).reshape(n, 9, 3)
    axes = np.concatenate([A, R, cr], axis=1)  # (n, 15, 3)
    norm = np.linalg.norm(axes, axis=2)
    valid = norm > 1e-9
    axes = axes / np.maximum(norm, 1e-12)[..., None]
    dist = np.abs(np.einsum("nkj,nj->nk", axes, C - c))
    ra = np.einsum("i,nki->nk", h, np.abs(np.einsum("ij,nkj->nki", r, axes)))
    rb = np.einsum("ni,nki->nk", H, np.abs(np.einsum("nij,nkj->nki", R, axes)))
    return ~(valid & (dist > ra + rb + tol)).any(axis=1)


def obb_distance_to_point(c: ArrayLike, rows: ArrayLike, h: ArrayLike, p: ArrayLike) -> float:
    """Distance from a point to an oriented box (0 inside), metres."""
    local = np.asarray(rows, float) @ (np.asarray(p, float) - np.asarray(c, float))
    q = np.abs(local) - np.asarray(h, float)
    return float(np.linalg.norm(np.maximum(q, 0.0)))
