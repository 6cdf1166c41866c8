"""ICP: real Stanford bunny scans with their true poses, synthetic scene, no overlap."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from pyheracles.errors import InputError
from pyheracles.registration.icp import ICPParams, icp


def bunny_poses(folder: Path) -> dict[str, np.ndarray]:
    """4x4 T_world_scan from bun.conf: p_world = R(q)^-1 p + t, q read as (x, y, z, w)."""
    poses = {}
    for line in (folder / "bun.conf").read_text().splitlines():
        f = line.split()
        if f and f[0] == "bmesh":
            T = np.eye(4)
            T[:3, :3] = Rotation.from_quat(np.array(f[5:9], float)).inv().as_matrix()
            T[:3, 3] = np.array(f[2:5], float)
            poses[f[1]] = T
    return poses


def _errors(T: np.ndarray, T_true: np.ndarray) -> tuple[float, float]:
    dR = T[:3, :3] @ T_true[:3, :3].T
    return (
        float(np.degrees(np.linalg.norm(Rotation.from_matrix(dR).as_rotvec()))),
        float(np.linalg.norm(T[:3, 3] - T_true[:3, 3])),
    )


@pytest.mark.realdata
def test_icp_recovers_true_bunny_pose(shared_data: Path) -> None:
    from pyheracles.io import read_cloud

    folder = shared_data / "bunny"
    poses = bunny_poses(folder)
    target = read_cloud(folder / "bun000.ply")
    source = read_cloud(folder / "bun045.ply")
    T_true = np.linalg.inv(poses["bun000.ply"]) @ poses["bun045.ply"]
    pert = np.eye(4)
    pert[:3, :3] = Rotation.from_euler("xyz", [3, -2, 4], degrees=True).as_matrix()
    pert[:3, 3] = [0.005, -0.004, 0.003]
    start_rot, _ = _errors(pert @ T_true, T_true)
    res = icp(source, target, pert @ T_true)
    rot_err, trans_err = _errors(res.T_target_source, T_true)
    assert start_rot > 4.0
    assert res.converged
    assert rot_err < 0.2  # degrees; the published poses agree to about 0.5 mm
    assert trans_err < 0.5e-3  # metres
    assert res.rms_point_to_plane_m < 0.4e-3
    assert 0.8 < res.overlap_fraction < 1.0


def test_icp_synthetic_surface_large_coordinates() -> None:
    rng = np.random.default_rng(0)
    n = 40_000
    uv = rng.uniform(0, 10, (n, 2))
    z = 0.4 * np.sin(uv[:, 0]) * np.cos(0.7 * uv[:, 1]) + 0.05 * uv[:, 0]
    world = np.column_stack([uv, z]) + np.array([1049800.0, 6842300.0, 140.0])
    target = world + rng.normal(0, 0.002, world.shape)
    from pyheracles.cloud import PointCloud

    T_true = np.eye(4)
    T_true[:3, :3] = Rotation.from_euler("xyz", [0.5, -0.3, 2.0], degrees=True).as_matrix()
    T_true[:3, 3] = world.mean(0) - T_true[:3, :3] @ world.mean(0) + [0.03, -0.02, 0.01]
    # source = points expressed in a frame where T_true maps them onto the target
    src_world = (world - T_true[:3, 3]) @ np.linalg.inv(T_true[:3, :3]).T
    src_world = src_world[rng.permutation(n)] + rng.normal(0, 0.002, world.shape)
    res = icp(
        PointCloud.from_world(src_world),
        PointCloud.from_world(target),
        params=ICPParams(max_correspondence_m=0.3),
    )
    rot_err, _ = _errors(res.T_target_source, T_true)
    moved = src_world @ res.T_target_source[:3, :3].T + res.T_target_source[:3, 3]
    truth = src_world @ T_true[:3, :3].T + T_true[:3, 3]
    assert rot_err < 0.02
    assert np.abs(moved - truth).max() < 2e-3
    assert res.converged and res.overlap_fraction > 0.95


def test_icp_clouds_without_overlap() -> None:
    rng = np.random.default_rng(1)
    a = rng.uniform(0, 1, (2000, 3))
    with pytest.raises(InputError, match="do not overlap"):
        icp(a + 50.0, a)
