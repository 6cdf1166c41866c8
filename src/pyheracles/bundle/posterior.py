"""Posterior statistics of a converged bundle adjustment.

The covariance of the camera parameters (inverse of the reduced camera
system), each object point's 3x3 covariance block, and the redundancy numbers
of the image and prior observations (for data snooping).
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING

import numpy as np
import scipy.linalg

if TYPE_CHECKING:
    from pyheracles.bundle.adjust import BundleResult
    from pyheracles.bundle.schur import PointCameraSystem

__all__ = ["posterior_covariance", "prior_redundancy", "redundancy_numbers"]


def posterior_covariance(res: BundleResult, ne: PointCameraSystem, fac, d) -> None:
    """Posterior covariance: camera block and each point's 3x3 block, times sigma0^2.

    Times (DBAT's split) go to ``res.timings``: ``cov_prep`` (inverse of the
    reduced camera system), ``cov_io`` and ``cov_eo`` (their blocks and
    standard deviations), ``cov_op`` (every point's 3x3 block and, from the
    same blocks of ``S^-1``, the redundancy numbers of the image observations).
    """
    net = res.network
    s02 = res.sigma0**2
    nc = net.n_cam_cols
    t = time.perf_counter()
    if nc:
        # Inverse from the Cholesky factor (LAPACK potri: 2/3 of cho_solve on the identity).
        inv_tri, info = scipy.linalg.lapack.dpotri(fac[0], lower=fac[1])
        if info == 0:
            tri = np.tril(inv_tri) if fac[1] else np.triu(inv_tri)
            inv_scaled = tri + tri.T - np.diag(np.diag(tri))
        else:  # pragma: no cover - the factor came from a successful cho_factor
            inv_scaled = scipy.linalg.cho_solve(fac, np.eye(nc), check_finite=False)
        cov_cam = inv_scaled / d[:, None] / d[None, :]
    else:
        cov_cam = np.zeros((0, 0))
    res.cov_cam = s02 * cov_cam
    var_cam = np.diag(res.cov_cam)
    res.timings["cov_prep"] = time.perf_counter() - t
    t = time.perf_counter()
    io_std = np.zeros_like(res.io)
    io_std[net.io_free] = np.sqrt(np.clip(var_cam[net.io_col[net.io_free]], 0, None))
    res.io_std = io_std
    res.timings["cov_io"] = time.perf_counter() - t
    t = time.perf_counter()
    eo_std = np.zeros_like(res.eo)
    eo_std[net.eo_free] = np.sqrt(np.clip(var_cam[net.eo_col[net.eo_free]], 0, None))
    res.eo_std = eo_std
    res.timings["cov_eo"] = time.perf_counter() - t
    t = time.perf_counter()
    cov_p, hat = ne.posterior(cov_cam)
    res.timings["cov_op"] = time.perf_counter() - t
    fixed = ~net.op_free
    cov_p[fixed.nonzero()[0], fixed.nonzero()[1], :] = 0.0
    cov_p[fixed.nonzero()[0], :, fixed.nonzero()[1]] = 0.0
    res.cov_xyz = s02 * cov_p
    res.xyz_std = np.sqrt(np.clip(np.einsum("nii->ni", res.cov_xyz), 0, None))
    res.redundancy_numbers = 1.0 - hat


def redundancy_numbers(res: BundleResult, ne: PointCameraSystem, jac=None) -> np.ndarray:
    """Redundancy number of every image coordinate: ``1 - diag(J N^-1 J^T)`` (weighted).

    The diagonal is computed with the point covariance blocks in
    :meth:`PointCameraSystem.posterior` (per image pair, from ``S^-1``);
    this returns it (computing it if :func:`posterior_covariance` has not).
    The sum over all observations (and priors) equals the redundancy.
    """
    if res.redundancy_numbers is None:
        s02 = res.sigma0**2 if res.sigma0 > 0 else 1.0
        _, hat = ne.posterior(res.cov_cam / s02)
        res.redundancy_numbers = 1.0 - hat
    return res.redundancy_numbers


def prior_redundancy(res: BundleResult) -> np.ndarray:
    """Redundancy numbers of the prior (EO, then object point) observations."""
    net = res.network
    s02 = res.sigma0**2 if res.sigma0 > 0 else 1.0
    eo_m = np.isfinite(net.eo_prior_std)
    op_m = np.isfinite(net.op_prior_std)
    q_eo = np.diag(res.cov_cam)[net.eo_col[eo_m]] / s02
    q_op = np.einsum("nii->ni", res.cov_xyz)[op_m] / s02
    return np.concatenate(
        [1.0 - q_eo / net.eo_prior_std[eo_m] ** 2, 1.0 - q_op / net.op_prior_std[op_m] ** 2]
    )
