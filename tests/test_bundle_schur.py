"""The reduced camera system and the posterior statistics against a dense solution.

The image-pair Schur complement (``pyheracles.bundle.schur``) must give the same
camera covariance, point covariance blocks and redundancy numbers as the inverse
of the full dense normal matrix ``J^T W J`` (with the prior observations), here
on a small two-camera network where that inverse is cheap.  The control point
test compares each point with the median of the *other* points.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from pyheracles.bundle import bundle_adjust
from pyheracles.bundle.camera import image_residuals
from pyheracles.bundle.diagnostics import control_point_test
from pyheracles.bundle.network import prepare_network
from pyheracles.synthetic.network import NetworkParameters, make_network


@pytest.fixture(scope="module")
def two_cameras():
    project, truth = make_network(NetworkParameters(n_images=12, n_points=300, n_control=6), 3)
    cam2 = dataclasses.replace(project.cameras[0], id=2, name="second")
    project = project.replace(
        cameras=(project.cameras[0], cam2),
        image_camera=np.arange(project.n_images) % 2,
        estimate_io=np.repeat(project.estimate_io, 2, axis=0),
    )
    return project, truth


def _dense_inverse(res):
    """Inverse of the dense normal matrix at the solution, and the weighted Jacobian."""
    net = res.network
    p = net.project
    _, (d_xyz, d_eo, d_io) = image_residuals(
        res.io[net.obs_cam], res.eo, res.xyz[p.obs_point], net.uv_mm, net.model,
        jacobian=True, obs_image=p.obs_image,
    )  # fmt: skip
    m, npt, nc = p.n_observations, p.n_points, net.n_cam_cols
    w = net.sqrt_w[:, :, None]
    jac = np.zeros((2 * m, 3 * npt + nc))
    rows = np.arange(2 * m).reshape(m, 2)
    for k in range(m):
        pt, img, cam = p.obs_point[k], p.obs_image[k], net.obs_cam[k]
        jac[rows[k][:, None], 3 * pt + np.arange(3)] = (d_xyz[k] * w[k]) * net.op_free[pt]
        for j in np.flatnonzero(net.eo_free[img]):
            jac[rows[k], 3 * npt + net.eo_col[img, j]] = d_eo[k, :, j] * w[k, :, 0]
        for j in np.flatnonzero(net.io_free[cam]):
            jac[rows[k], 3 * npt + net.io_col[cam, j]] = d_io[k, :, j] * w[k, :, 0]
    normal = jac.T @ jac
    op = np.argwhere(np.isfinite(net.op_prior_std))
    normal[3 * op[:, 0] + op[:, 1], 3 * op[:, 0] + op[:, 1]] += (
        1.0 / net.op_prior_std[op[:, 0], op[:, 1]] ** 2
    )
    eo = np.argwhere(np.isfinite(net.eo_prior_std))
    cols = 3 * npt + net.eo_col[eo[:, 0], eo[:, 1]]
    normal[cols, cols] += 1.0 / net.eo_prior_std[eo[:, 0], eo[:, 1]] ** 2
    return np.linalg.inv(normal), jac


def _close(a: np.ndarray, b: np.ndarray, tol: float = 1e-5) -> bool:
    """Equal to ``tol`` on the correlation scale (|a_ij - b_ij| / sqrt(b_ii b_jj))."""
    d = np.sqrt(np.abs(np.einsum("...ii->...i", b)))
    den = d[..., :, None] * d[..., None, :]
    return bool(np.all(np.abs(a - b) <= tol * np.where(den > 0, den, 1.0)))


def test_posterior_matches_dense_inverse(two_cameras):
    project, _ = two_cameras
    res = bundle_adjust(project)
    q, jac = _dense_inverse(res)
    npt = project.n_points
    s02 = res.sigma0**2
    q_cam = q[3 * npt :, 3 * npt :]
    assert _close(res.cov_cam / s02, q_cam)
    blocks = np.array([q[3 * i : 3 * i + 3, 3 * i : 3 * i + 3] for i in range(npt)])
    free = res.network.op_free
    blocks[~free] = 0.0  # fixed coordinates have no variance
    assert _close(res.cov_xyz / s02, blocks)
    hat = np.einsum("ij,jk,ik->i", jac, q, jac).reshape(-1, 2)
    assert np.allclose(res.redundancy_numbers, 1.0 - hat, atol=1e-6)
    # the redundancy numbers of all observations add up to the redundancy
    total = res.redundancy_numbers.sum() + res.prior_redundancy_numbers.sum()
    assert total == pytest.approx(res.redundancy, rel=1e-8)


def test_control_test_compares_with_the_other_points(two_cameras):
    """Two gross points of four: with the median of all four (themselves included)
    neither stood out; against the median of the others both do."""
    project, truth = two_cameras
    net = prepare_network(project)
    ctrl = np.flatnonzero(net.project.point_role == "control")[:4]
    keep = np.isin(np.arange(project.n_points), ctrl) | (project.point_role != "control")
    role = np.where(keep, project.point_role, "tie")
    xyz = np.where((role == "control")[:, None], truth["xyz"], np.nan)
    xyz[ctrl[0], 0] += 0.5
    xyz[ctrl[1], 2] -= 0.6
    net = prepare_network(project.replace(point_role=role, xyz=xyz))
    io = np.array([c.io_vector() for c in net.project.cameras])
    io[:] = truth["io"]
    test = control_point_test(net, io, truth["eo"], 0.5)
    ids = project.point_ids[ctrl]
    assert sorted(test["gross"]) == sorted(ids[:2].tolist())
    d = {q["id"]: q for q in test["points"]}
    assert d[ids[0]]["median_others"] < 0.1 < d[ids[0]]["delta_norm"]
    assert test["median_delta"] > 0.5 * d[ids[0]]["delta_norm"] / 5  # the old rule's median
    assert "median |delta| of the other tested points" in test["rule"]
