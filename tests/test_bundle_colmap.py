"""COLMAP text model reader, tested on a small synthetic model written in COLMAP conventions."""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.bundle import BundleParameters, bundle_adjust, read_project
from pyheracles.bundle.readers.colmap import quaternion_to_matrix
from pyheracles.errors import InputError


def _matrix_to_quaternion(r: np.ndarray) -> np.ndarray:
    w = np.sqrt(max(1e-12, 1 + np.trace(r))) / 2
    return np.array([w, (r[2, 1] - r[1, 2]) / (4 * w), (r[0, 2] - r[2, 0]) / (4 * w),
                     (r[1, 0] - r[0, 1]) / (4 * w)])  # fmt: skip


def _write_model(folder, rng, noise_px=0.3):
    fx, fy, cx, cy, w, h = 1500.0, 1510.0, 640.0, 470.0, 1280, 960
    xyz = np.column_stack([rng.uniform(-2, 2, 300), rng.uniform(-1.5, 1.5, 300),
                           rng.uniform(-0.5, 0.5, 300)])  # fmt: skip
    poses = []
    for k in range(6):
        yaw = np.radians(-25 + 10 * k)
        # world-to-camera: camera at distance 6 on a circle, looking at the origin (+z forward)
        c = np.array([6 * np.sin(yaw), 0.3 * (k % 2), -6 * np.cos(yaw)])
        zc = -c / np.linalg.norm(c)
        xc = np.cross([0, 1, 0], zc)
        xc /= np.linalg.norm(xc)
        yc = np.cross(zc, xc)
        r = np.vstack([xc, yc, zc])
        poses.append((r, -r @ c, c))
    (folder / "cameras.txt").write_text(f"# test\n1 PINHOLE {w} {h} {fx} {fy} {cx} {cy}\n")
    img_lines, tracks = [], {i: [] for i in range(len(xyz))}
    for k, (r, t, _) in enumerate(poses):
        pc = xyz @ r.T + t
        uv = np.column_stack([fx * pc[:, 0] / pc[:, 2] + cx, fy * pc[:, 1] / pc[:, 2] + cy])
        uv += rng.normal(0, noise_px, uv.shape)
        q = _matrix_to_quaternion(r)
        img_lines.append(f"{k + 1} {' '.join(map(str, q))} {' '.join(map(str, t))} 1 im{k}.jpg")
        entries = []
        for i in range(len(xyz)):
            tracks[i].append((k + 1, i))
            entries.append(f"{uv[i, 0]} {uv[i, 1]} {i + 1}")
        entries.append("10.0 10.0 -1")  # an unmatched keypoint
        img_lines.append(" ".join(entries))
    (folder / "images.txt").write_text("\n".join(img_lines) + "\n")
    pts = [f"{i + 1} {x} {y} {z} 0 0 0 0.5 " + " ".join(f"{a} {b}" for a, b in tracks[i])
           for i, (x, y, z) in enumerate(xyz)]  # fmt: skip
    (folder / "points3D.txt").write_text("\n".join(pts) + "\n")
    return xyz, poses


def test_quaternion_round_trip(rng):
    q = rng.normal(size=(20, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    r = quaternion_to_matrix(q)
    back = np.array([_matrix_to_quaternion(m) for m in r])
    assert np.allclose(np.abs(np.einsum("ij,ij->i", back, q)), 1.0, atol=1e-9)


def test_colmap_synthetic_model(tmp_path, rng):
    xyz, poses = _write_model(tmp_path, rng)
    project = read_project(tmp_path)
    assert (project.n_images, project.n_points, project.n_observations) == (6, 300, 1800)
    assert project.cameras[0].aspect_diff == pytest.approx(1510 / 1500 - 1)
    res = bundle_adjust(project, BundleParameters(estimate_io=(), max_iterations=30))
    # 0.3 px noise against a 1 px prior: sigma0 ~ 0.3
    assert res.sigma0 == pytest.approx(0.3, rel=0.15)
    # The reference camera keeps its pose; the others land on the truth within 5 sigma.
    centres = np.array([c for _, _, c in poses])
    z = np.abs(res.eo[:, :3] - centres) / np.maximum(res.eo_std[:, :3], 1e-12)
    assert z[1:].max() < 5.0
    assert np.abs(res.xyz - xyz).max() < 0.01


def test_colmap_bad_model(tmp_path):
    (tmp_path / "images.txt").write_text("1 1 0 0 0 0 0 0 7 a.jpg\n\n")
    (tmp_path / "cameras.txt").write_text("1 FISHEYE 10 10 1 2 3\n")
    with pytest.raises(InputError, match="camera model FISHEYE is not supported"):
        read_project(tmp_path)
