"""Eigen-decomposition of one symmetric 3x3 covariance, compiled for numba kernels.

Why hand-written: the k-NN covariance kernel (:mod:`pyheracles.geometry.knn_kernels`)
decomposes one matrix per point inside a ``prange`` loop, where numpy's
``eigh`` (LAPACK, one call per matrix with its allocation) costs more than the
neighbour search.  The closed form (trigonometric solution of the
characteristic cubic, eigenvectors from cross products of ``C - lambda I``)
needs a few dozen flops and no allocation; the rare ill-conditioned matrices
(two nearly equal eigenvalues) go to a cyclic Jacobi iteration.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numpy.typing import NDArray


@njit(cache=True)
def _jacobi3(m: NDArray[np.float64], vals: NDArray[np.float64], vecs: NDArray[np.float64]):
    """Cyclic Jacobi eigen-decomposition of a symmetric 3x3 matrix, ascending."""
    a = m.copy()
    v = np.eye(3)
    for _ in range(60):
        off = a[0, 1] ** 2 + a[0, 2] ** 2 + a[1, 2] ** 2
        scale = a[0, 0] ** 2 + a[1, 1] ** 2 + a[2, 2] ** 2
        if off <= 1e-36 * scale or off == 0.0:
            break
        for p, q in ((0, 1), (0, 2), (1, 2)):
            if a[p, q] == 0.0:
                continue
            theta = (a[q, q] - a[p, p]) / (2.0 * a[p, q])
            t = np.sign(theta) / (abs(theta) + np.sqrt(theta * theta + 1.0))
            if theta == 0.0:
                t = 1.0
            c = 1.0 / np.sqrt(t * t + 1.0)
            s = t * c
            for r in range(3):
                arp, arq = a[r, p], a[r, q]
                a[r, p] = c * arp - s * arq
                a[r, q] = s * arp + c * arq
            for r in range(3):
                apr, aqr = a[p, r], a[q, r]
                a[p, r] = c * apr - s * aqr
                a[q, r] = s * apr + c * aqr
            for r in range(3):
                vrp, vrq = v[r, p], v[r, q]
                v[r, p] = c * vrp - s * vrq
                v[r, q] = s * vrp + c * vrq
    d = np.array([a[0, 0], a[1, 1], a[2, 2]])
    order = np.argsort(d)
    for i in range(3):
        vals[i] = d[order[i]]
        for r in range(3):
            vecs[r, i] = v[r, order[i]]


@njit(cache=True, inline="always")
def _eigvec(a, b, c, d, e, f, lam, out):
    """Unit eigenvector of ``lam`` from the largest cross product of two rows of C - lam I.

    Returns the squared norm of that cross product (0 means it failed)."""
    r00, r01, r02 = a - lam, d, e
    r10, r11, r12 = d, b - lam, f
    r20, r21, r22 = e, f, c - lam
    best = -1.0
    bx = by = bz = 0.0
    for w in range(3):
        if w == 0:
            x = r01 * r12 - r02 * r11
            y = r02 * r10 - r00 * r12
            z = r00 * r11 - r01 * r10
        elif w == 1:
            x = r01 * r22 - r02 * r21
            y = r02 * r20 - r00 * r22
            z = r00 * r21 - r01 * r20
        else:
            x = r11 * r22 - r12 * r21
            y = r12 * r20 - r10 * r22
            z = r10 * r21 - r11 * r20
        nn = x * x + y * y + z * z
        if nn > best:
            best, bx, by, bz = nn, x, y, z
    if best > 0.0:
        s = 1.0 / np.sqrt(best)
        out[0], out[1], out[2] = bx * s, by * s, bz * s
    return best


@njit(cache=True)
def eigen_one(cov6, vals, vmin, vmax, directions, mat, jv, jw):
    """Eigen-decomposition of one covariance ``(xx, yy, zz, xy, xz, yz)``.

    ``vals`` ascending and clipped at 0, ``vmin`` the normal, ``vmax`` the main
    direction (if ``directions``).  ``mat``, ``jv`` and ``jw`` are scratch space.
    """
    a, b, c, d, e, f = cov6[0], cov6[1], cov6[2], cov6[3], cov6[4], cov6[5]
    q = (a + b + c) / 3.0
    p1 = d * d + e * e + f * f
    aq, bq, cq = a - q, b - q, c - q
    p2 = aq * aq + bq * bq + cq * cq + 2.0 * p1
    p = np.sqrt(p2 / 6.0)
    ok = p > 0.0
    r = 0.0
    if ok:
        det = aq * (bq * cq - f * f) - d * (d * cq - f * e) + e * (d * f - bq * e)
        r = det / (2.0 * p * p * p)
        r = min(max(r, -1.0), 1.0)
        # near |r| = 1 (two nearly equal eigenvalues) arccos loses half the digits:
        # leave those few matrices to the Jacobi iteration
        ok = abs(r) < 1.0 - 1e-5
    if ok:
        phi = np.arccos(r) / 3.0
        l_max = q + 2.0 * p * np.cos(phi)
        l_min = q + 2.0 * p * np.cos(phi + 2.0 * np.pi / 3.0)
        l_mid = 3.0 * q - l_max - l_min
        # sort the three (l_max >= l_mid >= l_min in exact arithmetic)
        lo_ = min(l_min, l_mid, l_max)
        hi_ = max(l_min, l_mid, l_max)
        mid_ = l_min + l_mid + l_max - lo_ - hi_
        vals[0], vals[1], vals[2] = max(lo_, 0.0), max(mid_, 0.0), max(hi_, 0.0)
        scale = max(abs(lo_), abs(hi_), 1e-300)
        tol = (1e-10 * scale * scale) ** 2  # on the squared cross-product norm
        ok = _eigvec(a, b, c, d, e, f, lo_, vmin) > tol
        if ok:
            # residual check |C v - lambda v| (catches nearly equal eigenvalues)
            x, y, z = vmin[0], vmin[1], vmin[2]
            rx = a * x + d * y + e * z - lo_ * x
            ry = d * x + b * y + f * z - lo_ * y
            rz = e * x + f * y + c * z - lo_ * z
            ok = np.sqrt(rx * rx + ry * ry + rz * rz) <= 1e-6 * scale
        if ok and directions:
            ok = _eigvec(a, b, c, d, e, f, hi_, vmax) > tol
            if ok:
                ok = abs(vmin[0] * vmax[0] + vmin[1] * vmax[1] + vmin[2] * vmax[2]) <= 1e-6
    if not ok:
        mat[0, 0], mat[1, 1], mat[2, 2] = a, b, c
        mat[0, 1] = mat[1, 0] = d
        mat[0, 2] = mat[2, 0] = e
        mat[1, 2] = mat[2, 1] = f
        _jacobi3(mat, jw, jv)
        for i in range(3):
            vals[i] = max(jw[i], 0.0)
            vmin[i] = jv[i, 0]
            if directions:
                vmax[i] = jv[i, 2]
