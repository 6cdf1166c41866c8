"""Primitive fitting: known shapes, noise and outliers, recovery to explicit tolerances."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from pyheracles.geometry.fitting import (
    FailedFit,
    MSACParams,
    fit_circle,
    fit_circle_msac,
    fit_cylinder,
    fit_line,
    fit_oriented_box,
    fit_plane,
    fit_plane_msac,
    min_area_rectangle,
)


def _box_surface(rng: np.random.Generator, half: np.ndarray, n: int) -> np.ndarray:
    p = rng.uniform(-1, 1, (n, 3)) * half
    k = rng.integers(0, 3, n)
    rows = np.arange(n)
    p[rows, k] = np.sign(p[rows, k]) * half[k]
    return p


def test_plane_lsq_and_msac_with_outliers() -> None:
    rng = np.random.default_rng(0)
    xy = rng.uniform(0, 10, (4000, 2))
    n_true = np.array([0.1, -0.2, 1.0])
    n_true /= np.linalg.norm(n_true)
    z = (3.0 - n_true[0] * xy[:, 0] - n_true[1] * xy[:, 1]) / n_true[2]
    pts = np.c_[xy, z] + rng.normal(0, 0.003, (4000, 3))
    assert abs(fit_plane(pts).normal @ n_true) > 0.99999
    pts[:1200, 2] += rng.uniform(0.5, 4, 1200)  # 30 % clutter above the plane
    fit = fit_plane_msac(pts, MSACParams(threshold=0.015), rng=1)
    assert fit
    assert abs(fit.normal @ n_true) > 0.9999
    assert fit.d == pytest.approx(3.0, abs=0.003)
    assert fit.inliers[1200:].mean() > 0.95 and fit.inliers[:1200].mean() < 0.02
    # deterministic for a seed
    again = fit_plane_msac(pts, MSACParams(threshold=0.015), rng=1)
    np.testing.assert_array_equal(fit.inliers, again.inliers)


def test_failures_are_falsy() -> None:
    line = np.c_[np.arange(10.0), 2 * np.arange(10.0), np.zeros(10)]
    assert isinstance(fit_plane(line), FailedFit) and not fit_plane(line)
    assert not fit_circle(np.zeros((2, 2)))
    assert not fit_circle(np.c_[np.arange(5.0), np.arange(5.0)])
    assert not fit_oriented_box(line)
    assert not fit_cylinder(np.zeros((3, 3)))
    with pytest.raises(ValueError, match="method"):
        fit_circle(np.ones((5, 2)), method="pratt")


def test_circle_algebraic_geometric_and_msac() -> None:
    rng = np.random.default_rng(2)
    t = rng.uniform(0, np.pi, 500)  # half arc: algebraic is biased, geometric is not
    xy = np.c_[4 + 0.5 * np.cos(t), -2 + 0.5 * np.sin(t)] + rng.normal(0, 0.005, (500, 2))
    geo = fit_circle(xy)
    assert geo.radius == pytest.approx(0.5, abs=0.002)
    np.testing.assert_allclose(geo.center, [4, -2], atol=0.003)
    assert geo.rms == pytest.approx(0.005, rel=0.2)
    alg = fit_circle(xy, method="algebraic")
    assert alg.radius == pytest.approx(0.5, abs=0.02)
    xy[:150] = rng.uniform(3, 5, (150, 2))
    robust = fit_circle_msac(xy, MSACParams(threshold=0.015), rng=0)
    assert robust.radius == pytest.approx(0.5, abs=0.003)
    assert robust.inliers[150:].mean() > 0.95


def test_line() -> None:
    rng = np.random.default_rng(3)
    s = rng.uniform(-5, 5, 300)
    d = np.array([1.0, 2.0, 2.0]) / 3
    pts = np.outer(s, d) + np.ones(3) + rng.normal(0, 0.01, (300, 3))
    fit = fit_line(pts)
    assert abs(fit.direction @ d) > 0.99999
    assert fit.distance(pts).mean() < 0.02


@pytest.mark.parametrize("hint", [None, (0.0, 0.0, 1.0)])
def test_cylinder_radius_within_1cm_with_5mm_noise(hint: tuple[float, float, float] | None) -> None:
    rng = np.random.default_rng(4)
    axis = Rotation.from_euler("xy", [3, -2], degrees=True).apply([0, 0, 1])
    u = np.cross(axis, [1, 0, 0])
    u /= np.linalg.norm(u)
    w = np.cross(axis, u)
    t, h = rng.uniform(0, 2 * np.pi, 6000), rng.uniform(0, 5, 6000)
    pts = (
        np.array([2.0, 3.0, 0.0])
        + np.outer(h, axis)
        + 0.35 * (np.outer(np.cos(t), u) + np.outer(np.sin(t), w))
        + rng.normal(0, 0.005, (6000, 3))
    )
    fit = fit_cylinder(pts, axis_hint=hint)
    assert fit.radius == pytest.approx(0.35, abs=0.002)
    assert abs(fit.axis @ axis) > 0.9999
    assert fit.height == pytest.approx(5.0, abs=0.05)
    assert fit.rms == pytest.approx(0.005 * np.sqrt(2 / 3) * np.sqrt(1.5), rel=0.3)


def test_oriented_box_rotated_with_outliers() -> None:
    rng = np.random.default_rng(5)
    half = np.array([2.0, 1.0, 0.5])
    rot = Rotation.from_euler("xyz", [20, 30, 40], degrees=True).as_matrix()
    pts = _box_surface(rng, half, 20000) @ rot.T + [5, 6, 7] + rng.normal(0, 0.005, (20000, 3))
    pts[:1000] = rng.uniform(0, 10, (1000, 3))  # 5 % gross outliers
    fit = fit_oriented_box(pts)
    assert fit
    np.testing.assert_allclose(fit.centre, [5, 6, 7], atol=0.005)
    np.testing.assert_allclose(fit.extents, 2 * half, atol=0.01)
    np.testing.assert_allclose(np.abs(fit.axes.T @ rot), np.eye(3), atol=0.002)
    assert np.linalg.det(fit.axes) == pytest.approx(1.0)
    assert fit.rms < 0.01
    assert fit.inliers[:1000].mean() < 0.5


def test_oriented_box_square_pier_with_up_axis() -> None:
    rng = np.random.default_rng(6)
    n = 8000
    p = rng.uniform(-1, 1, (n, 3)) * [0.3, 0.3, 2.0]
    k = rng.integers(0, 2, n)  # lateral faces only: the pier ends are not scanned
    p[np.arange(n), k] = np.sign(p[np.arange(n), k]) * 0.3
    rz = Rotation.from_euler("z", 30, degrees=True).as_matrix()
    fit = fit_oriented_box(p @ rz.T + rng.normal(0, 0.005, (n, 3)), up=(0, 0, 1))
    np.testing.assert_allclose(fit.extents, [4.0, 0.6, 0.6], atol=0.02)
    assert abs(fit.axes[2, 0]) > 0.9999  # longest axis is the vertical
    face_dir = fit.axes[:2, 1]
    assert abs(np.cos(np.deg2rad(30)) * abs(face_dir[0]) + 0.5 * abs(face_dir[1])) > 0.999 or (
        abs(-0.5 * face_dir[0] + np.cos(np.deg2rad(30)) * face_dir[1]) > 0.999
    )


def test_min_area_rectangle() -> None:
    rng = np.random.default_rng(7)
    p = rng.uniform(-1, 1, (500, 2)) * [1.5, 0.4]
    a = np.deg2rad(25)
    rot = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    centre, ang, size = min_area_rectangle(p @ rot.T + [3, 4])
    np.testing.assert_allclose(size, [3.0, 0.8], atol=0.03)
    np.testing.assert_allclose(centre, [3, 4], atol=0.03)
    assert np.mod(ang - a, np.pi) == pytest.approx(0, abs=0.02)
