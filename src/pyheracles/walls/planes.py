"""Planes of walls: least-squares fits, plane frames, plane intersections, thinning."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pyheracles.errors import InputError
from pyheracles.walls.model import Array

__all__ = ["fit_vertical", "grid_components", "intersect_planes", "plane_frame", "voxel_sample"]


def intersect_planes(normals: ArrayLike, ds: ArrayLike) -> Array:
    """Least-squares intersection point of planes ``n_i . x = d_i`` (``intersectMultPlanes``).

    Minimum-norm solution when the planes do not fix a point (two planes: the point of
    their line nearest the origin; vertical planes only: z = 0).
    """
    n = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    d = np.asarray(ds, dtype=np.float64).reshape(-1)
    if len(n) != len(d) or len(n) < 1:
        raise InputError("intersect_planes needs as many offsets as normals (at least one)")
    x, *_ = np.linalg.lstsq(n, d, rcond=None)
    return x


def voxel_sample(xyz: Array, size: float) -> NDArray[np.int64]:
    """Index of one point per occupied cube (the first in input order)."""
    cells = np.floor((xyz - xyz.min(axis=0)) / size).astype(np.int64)
    dims = cells.max(axis=0) + 1
    if float(np.prod(dims.astype(np.float64))) >= 2.0**62:  # no single integer key
        _, first = np.unique(cells, axis=0, return_index=True)
    else:  # one integer per cube: a 1D sort, far faster than unique rows
        key = (cells[:, 0] * dims[1] + cells[:, 1]) * dims[2] + cells[:, 2]
        _, first = np.unique(key, return_index=True)
    return np.sort(first)


def fit_vertical(p: Array) -> tuple[Array, float, float]:
    """Plane of points by least squares (3D PCA); normal with a deterministic sign."""
    c = p.mean(axis=0)
    _, _, vt = np.linalg.svd(p - c, full_matrices=False)
    n = vt[-1]
    big = int(np.argmax(np.abs(n[:2])))
    if n[big] < 0:
        n = -n
    res = (p - c) @ n
    return n, float(n @ c), float(np.sqrt(np.mean(res**2)))


def plane_frame(n: Array, d: float) -> tuple[Array, Array]:
    """Origin on the plane (above the local origin) and the horizontal in-plane axis."""
    h = np.array([n[0], n[1], 0.0])
    h /= np.linalg.norm(h)
    u = np.array([-h[1], h[0], 0.0])
    origin = h * d / max(float(n @ h), 1e-9)
    return origin, u


def grid_components(mask: NDArray[np.bool_], grow: int) -> tuple[NDArray[np.int32], int]:
    from scipy import ndimage

    m = ndimage.binary_dilation(mask, iterations=grow) if grow else mask
    lab, k = ndimage.label(m)
    lab[~mask] = 0
    return lab, k
