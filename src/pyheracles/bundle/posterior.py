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
    standard deviations), ``cov_op`` (every point's 3x3 block).
    """
    net = res.network
    s02 = res.sigma0**2
    nc = net.n_cam_cols
    t = time.perf_counter()
    if nc:
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
    cov_p = ne.point_covariances(cov_cam)
    fixed = ~net.op_free
    cov_p[fixed.nonzero()[0], fixed.nonzero()[1], :] = 0.0
    cov_p[fixed.nonzero()[0], :, fixed.nonzero()[1]] = 0.0
    res.cov_xyz = s02 * cov_p
    res.xyz_std = np.sqrt(np.clip(np.einsum("nii->ni", res.cov_xyz), 0, None))
    res.timings["cov_op"] = time.perf_counter() - t


def redundancy_numbers(res: BundleResult, ne: PointCameraSystem, jac, chunk=20000):
    """Redundancy number of every image coordinate: 1 - diag(J Q J^T) (weighted).

    ``Q = N^-1`` is assembled per observation from the point block, the camera
    block and their cross covariance ``-A^-1 B S^-1``; the sum over all
    observations (and priors) equals the redundancy.
    """
    net = res.network
    p = net.project
    d_xyz, d_eo, d_io = jac
    w = net.sqrt_w[:, :, None]
    s02 = res.sigma0**2 if res.sigma0 > 0 else 1.0
    q_cam = res.cov_cam / s02
    union = np.flatnonzero(net.io_free.any(axis=0))
    cols = np.concatenate([net.io_col[net.obs_cam][:, union], net.eo_col[p.obs_image]], axis=1)
    valid = cols >= 0
    jc = np.concatenate([d_io[:, :, union], d_eo], axis=2) * w * valid[:, None, :]
    jp = d_xyz * w * net.op_free[p.obs_point][:, None, :]
    q_pc_all = ne.cross_covariances(q_cam, cols)  # (m,3,L)
    qz = np.zeros((q_cam.shape[0] + 1,) * 2)
    qz[:-1, :-1] = q_cam
    cz = np.where(valid, cols, q_cam.shape[0])
    m = jp.shape[0]
    out = np.empty((m, 2))
    for start in range(0, m, chunk):
        sl = slice(start, min(m, start + chunk))
        q_pp = res.cov_xyz[p.obs_point[sl]] / s02
        q_cc = qz[cz[sl][:, :, None], cz[sl][:, None, :]]
        a, b = jp[sl], jc[sl]
        h = (
            np.einsum("kri,kij,krj->kr", a, q_pp, a)
            + np.einsum("kri,kij,krj->kr", b, q_cc, b)
            + 2 * np.einsum("kri,kij,krj->kr", a, q_pc_all[sl], b)
        )
        out[sl] = 1.0 - h
    return out


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
