"""Results do not depend on the size of the coordinates (issue 15, defect 19).

A cloud shifted by 10^9 m in x and y and 10^3 m in z, or the same points stored
with another LAS header offset, must give the same local coordinates and the
same ground masks.  Two causes were found and fixed: the local frame was
``world - floor(min)`` in float64, so points exactly on a cell edge (LAS data
are quantised, so many are) fell on either side depending on the offset; and the
CSF package's OpenMP threads race (the ground count changed from run to run).
"""

from __future__ import annotations

import copy
from pathlib import Path

import laspy
import numpy as np
import pytest

from pyheracles import PointCloud
from pyheracles.ground import extract_ground
from pyheracles.io import read_cloud, write_cloud

SHIFT = np.array([1e9, 1e9, 1e3])
METHODS = ("auto", "smrf", "csf")


def _terrain(rng: np.random.Generator, n: int = 12000) -> np.ndarray:
    """Sloped terrain with two buildings and a tree, on a 1 cm lattice (as a LAS file)."""
    xy = rng.uniform(0, 60, (n, 2))
    z = 0.05 * xy[:, 0] + 0.3 * np.sin(xy[:, 1] / 7) + rng.normal(0, 0.02, n)
    roof = (np.abs(xy[:, 0] - 20) < 6) & (np.abs(xy[:, 1] - 30) < 8)
    z[roof] += 7.0
    shed = (np.abs(xy[:, 0] - 45) < 3) & (np.abs(xy[:, 1] - 12) < 3)
    z[shed] += 3.0
    tree = np.hypot(xy[:, 0] - 40, xy[:, 1] - 45) < 4
    z[tree] += rng.uniform(2, 9, tree.sum())
    world = np.column_stack([xy + [512700.0, 5403547.0], z + 295.0])
    return np.round(world, 2)


def _masks(cloud: PointCloud) -> dict[str, np.ndarray]:
    return {m: extract_ground(cloud.xyz, m).mask for m in METHODS}


def _assert_same(a: PointCloud, b: PointCloud) -> None:
    np.testing.assert_array_equal(a.xyz, b.xyz)  # bit for bit
    np.testing.assert_allclose(b.offset - a.offset, SHIFT, rtol=0, atol=1e-6)
    ma, mb = _masks(a), _masks(b)
    for method in METHODS:
        assert ma[method].any(), method
        np.testing.assert_array_equal(ma[method], mb[method], err_msg=method)


def _shifted_las(src: Path, dst: Path) -> None:
    """The same integer coordinates with the header offsets moved by SHIFT."""
    las = laspy.read(src)
    header = copy.deepcopy(las.header)
    header.offsets = np.asarray(header.offsets) + SHIFT
    laspy.LasData(header, points=las.points.copy()).write(dst)


def test_generated_cloud_shifted_by_1e9_gives_identical_ground(tmp_path: Path, rng) -> None:
    world = _terrain(rng)
    scale = np.full(3, 0.01)
    base = PointCloud.from_world(world, scale=scale)
    _assert_same(base, PointCloud.from_world(world + SHIFT, scale=scale))
    # through the files a user would hand in: LAZ with a shifted header, and text
    path = write_cloud(base, tmp_path / "base.laz")
    _shifted_las(path, tmp_path / "shifted.laz")
    _assert_same(read_cloud(path), read_cloud(tmp_path / "shifted.laz"))
    np.savetxt(tmp_path / "shifted.xyz", world + SHIFT, fmt="%.2f")
    text = read_cloud(tmp_path / "shifted.xyz")
    np.testing.assert_array_equal(text.scale, scale)
    _assert_same(base, text)


def test_same_points_with_another_header_offset_give_the_same_local_frame(
    tmp_path: Path, rng
) -> None:
    world = _terrain(rng, 3000)
    path = write_cloud(PointCloud.from_world(world, scale=np.full(3, 0.01)), tmp_path / "a.las")
    las = laspy.read(path)
    header = copy.deepcopy(las.header)
    moved = np.array([123456.78, 7.77, -3.21])  # on the 1 cm lattice: same world points
    header.offsets = moved
    other = laspy.LasData(header, points=las.points.copy())
    step = np.round((np.asarray(las.header.offsets) - moved) / 0.01).astype(np.int64)
    other.X, other.Y, other.Z = las.X + step[0], las.Y + step[1], las.Z + step[2]
    other.write(tmp_path / "b.las")
    a, b = read_cloud(path), read_cloud(tmp_path / "b.las")
    np.testing.assert_allclose(a.world_xyz(), b.world_xyz(), rtol=0, atol=1e-6)
    np.testing.assert_array_equal(a.xyz, b.xyz)


@pytest.mark.realdata
@pytest.mark.slow
def test_csf_is_deterministic(shared_data: Path) -> None:
    """The package's OpenMP threads raced: 4988-4994 ground points on this crop before."""
    xyz = read_cloud(shared_data / "isprs_filtertest" / "samp11-utm.laz").xyz
    crop = xyz[xyz[:, 0] < np.quantile(xyz[:, 0], 0.25)]
    first = extract_ground(crop, "csf").mask
    for _ in range(2):
        np.testing.assert_array_equal(extract_ground(crop, "csf").mask, first)


@pytest.mark.realdata
@pytest.mark.slow
def test_isprs_sample_shifted_by_1e9_gives_identical_ground(
    shared_data: Path, tmp_path: Path
) -> None:
    src = shared_data / "isprs_filtertest" / "samp11-utm.laz"
    base = read_cloud(src)
    _shifted_las(src, tmp_path / "shifted.laz")
    _assert_same(base, read_cloud(tmp_path / "shifted.laz"))
    np.savetxt(tmp_path / "shifted.xyz", base.world_xyz() + SHIFT, fmt="%.2f")
    shifted_text = read_cloud(tmp_path / "shifted.xyz")
    np.testing.assert_array_equal(shifted_text.xyz, base.xyz)
    mask = extract_ground(shifted_text.xyz, "auto").mask
    np.testing.assert_array_equal(mask, extract_ground(base.xyz, "auto").mask)
