"""Bundle adjustment: camera model derivatives, synthetic networks with known truth, bad input."""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.bundle import (
    BundleParameters,
    BundleWarning,
    bundle_adjust,
    read_project,
)
from pyheracles.bundle.camera import image_residuals, rotation_matrix
from pyheracles.bundle.diagnostics import (
    control_point_residuals,
    data_snooping,
    high_correlations,
    image_statistics,
    ray_angles,
)
from pyheracles.bundle.initial import angles_from_rotation
from pyheracles.errors import DegenerateGeometryError, InputError
from pyheracles.synthetic.network import NetworkParameters, make_network


@pytest.fixture(scope="module")
def small_network():
    return make_network(NetworkParameters(n_images=16, n_points=1500, n_control=8), rng=3)


@pytest.mark.parametrize("model", [-1, 2, 3, 4, 5])
def test_jacobians_match_finite_differences(model, rng):
    m = 6
    io = np.tile([7.4, 3.6, 2.7, 0.01, 0.02, 4e-3, -5e-5, -2e-6, -6e-5, -4e-5], (m, 1))
    eo = np.tile([0.4, 1.8, 1.5, -0.6, -0.02, -3.1], (m, 1)) + rng.normal(0, 0.01, (m, 6))
    xyz = rng.uniform(0, 1, (m, 3))
    uv = rng.uniform(0, 5, (m, 2)) * [1, -1]
    r, (dx, de, di) = image_residuals(io, eo, xyz, uv, model, jacobian=True)
    for arr, analytic, name in ((xyz, dx, "xyz"), (eo, de, "eo"), (io, di, "io")):
        for j in range(arr.shape[1]):
            h = 1e-7 * max(1.0, abs(arr[0, j]))
            a = arr.copy()
            a[:, j] += h
            args = {"xyz": xyz, "eo": eo, "io": io, name: a}
            num = (image_residuals(args["io"], args["eo"], args["xyz"], uv, model) - r) / h
            scale = max(1.0, np.abs(analytic[:, :, j]).max())
            assert np.abs(num - analytic[:, :, j]).max() < 1e-5 * scale, (name, j)


def test_rotation_angles_round_trip(rng):
    ang = rng.uniform(-1.2, 1.2, (50, 3))
    rot = rotation_matrix(ang)
    assert np.allclose(np.einsum("nij,nkj->nik", rot, rot), np.eye(3), atol=1e-12)
    assert np.allclose(angles_from_rotation(rot), ang, atol=1e-10)


def test_synthetic_network_recovers_truth(small_network):
    project, truth = small_network
    res = bundle_adjust(project)
    assert res.converged
    # Noise is 0.5 px with matching a priori sigma: sigma0 ~ 1.
    assert 0.9 < res.sigma0 < 1.1
    # Estimated parameters within 4 posterior standard deviations of the truth.
    free = res.network.io_free[0]
    z_io = np.abs(res.io[0, free] - truth["io"][free]) / res.io_std[0, free]
    assert z_io.max() < 4.0
    z_xyz = np.abs(res.xyz - truth["xyz"]) / np.maximum(res.xyz_std, 1e-12)
    assert np.percentile(z_xyz, 99) < 4.0
    # Redundancy numbers add up to the redundancy (a strong check of the covariance).
    total = res.redundancy_numbers.sum() + res.prior_redundancy_numbers.sum()
    assert total == pytest.approx(res.redundancy, rel=1e-6)


def test_dampings_agree(small_network):
    project, _ = small_network
    ref = bundle_adjust(project)
    free = ref.network.io_free[0]
    for damping in ("gn", "lm"):
        res = bundle_adjust(project, BundleParameters(damping=damping, covariance=False))
        assert res.sigma0 == pytest.approx(ref.sigma0, rel=1e-7)
        # Same minimum: differences far below the posterior standard deviations.
        z = np.abs(res.io[0, free] - ref.io[0, free]) / ref.io_std[0, free]
        assert z.max() < 0.01


def test_diagnostics_on_synthetic(small_network):
    project, _ = small_network
    res = bundle_adjust(project)
    hc = high_correlations(res)
    assert {"io", "eo", "op"} <= set(hc)
    assert 0.0 <= hc["op"]["share"] <= 1.0
    angles = ray_angles(res)
    assert angles.shape == (project.n_points,)
    assert np.all((angles >= 0) & (angles <= 90.0))
    stats = image_statistics(res)
    assert sum(s["n_points"] for s in stats) == project.n_observations
    assert all(0 < s["coverage_hull"] <= s["coverage_rect"] <= 1 for s in stats)
    cp = control_point_residuals(res)
    assert len(cp["control"]["points"]) == int((project.point_role == "control").sum())


def test_data_snooping_flags_blunder(small_network):
    project, _ = small_network
    uv = project.obs_uv_px.copy()
    k = int(np.argmax(np.bincount(project.obs_point)[project.obs_point]))  # well-observed point
    uv[k, 0] += 15.0  # 30 sigma blunder
    res = bundle_adjust(project.replace(obs_uv_px=uv))
    ds = data_snooping(res)
    assert ds["n_flagged"] >= 1
    assert ds["flagged"][0] == k


def test_one_ray_point_dropped_with_warning(small_network):
    project, _ = small_network
    # Add a point observed in a single image.
    proj = project.replace(
        point_ids=np.append(project.point_ids, 999999),
        point_labels=(*project.point_labels, "lonely"),
        xyz=np.vstack([project.xyz, [np.nan] * 3]),
        xyz_std=np.vstack([project.xyz_std, [np.nan] * 3]),
        point_role=np.append(project.point_role, "tie"),
        obs_image=np.append(project.obs_image, 0),
        obs_point=np.append(project.obs_point, project.n_points),
        obs_uv_px=np.vstack([project.obs_uv_px, [100.0, 100.0]]),
        obs_std_px=np.vstack([project.obs_std_px, [0.5, 0.5]]),
    )
    with pytest.warns(BundleWarning, match="fewer than 2 images dropped"):
        res = bundle_adjust(proj, BundleParameters(covariance=False))
    assert res.project.n_points == project.n_points


def test_image_without_observations_is_an_input_error(small_network):
    project, _ = small_network
    keep = project.obs_image != 3
    proj = project.replace(
        obs_image=project.obs_image[keep],
        obs_point=project.obs_point[keep],
        obs_uv_px=project.obs_uv_px[keep],
        obs_std_px=project.obs_std_px[keep],
    )
    with (
        pytest.raises(InputError, match=r"image\(s\) \[4\] have no observations"),
        pytest.warns(BundleWarning),  # points seen only by image 4 and one other are dropped
    ):
        bundle_adjust(proj)


def test_unknown_camera_is_an_input_error(small_network):
    project, _ = small_network
    cam = project.image_camera.copy()
    cam[2] = 5
    with pytest.raises(InputError, match="unknown camera"):
        bundle_adjust(project.replace(image_camera=cam))


def test_missing_datum_names_the_undetermined_parameters(small_network):
    project, _ = small_network
    free = project.replace(
        point_role=np.full(project.n_points, "tie"),
        xyz=np.full_like(project.xyz, np.nan),
        xyz_std=np.full_like(project.xyz_std, np.nan),
    )
    with pytest.raises(DegenerateGeometryError, match="control points"):
        bundle_adjust(free, BundleParameters(datum="control"))
    # Without datum and with every EO free, the normal matrix is singular.
    estimate_all = free.replace(datum="none")
    with pytest.raises(DegenerateGeometryError, match="rank deficient"):
        bundle_adjust(estimate_all, BundleParameters(datum="free"))


def test_depend_datum_without_control(small_network):
    project, _ = small_network
    free = project.replace(
        point_role=np.full(project.n_points, "tie"),
        xyz=np.full_like(project.xyz, np.nan),
        xyz_std=np.full_like(project.xyz_std, np.nan),
        datum=None,
    )
    with pytest.warns(BundleWarning, match="the datum is a dependent relative orientation"):
        res = bundle_adjust(free)
    assert res.network.datum == "depend"
    # 7 datum parameters fixed: 6 of the reference image + 1 base coordinate.
    assert (~res.network.eo_free).sum() == 7
    assert 0.9 < res.sigma0 < 1.1


def test_bad_parameters_and_unreadable_project(tmp_path):
    with pytest.raises(InputError, match="unknown damping"):
        BundleParameters(damping="newton")
    bad = tmp_path / "broken.xml"
    bad.write_text("<document><input>")
    with pytest.raises(InputError, match="unreadable DBAT script"):
        read_project(bad)
    with pytest.raises(InputError, match="not found"):
        read_project(tmp_path / "absent.xml")
    txt = tmp_path / "junk.txt"
    txt.write_text("hello\nworld\n")
    with pytest.raises(InputError):
        read_project(txt)


def test_two_cameras_self_calibration(small_network):
    """Two physical cameras (alternate images), both self-calibrated: exercises the
    per-(point, camera) coupling blocks of the Schur complement."""
    project, truth = small_network
    cam2 = project.cameras[0].with_io(project.cameras[0].io_vector())
    cam2 = type(cam2)(**{**cam2.__dict__, "id": 2})
    image_camera = np.arange(project.n_images) % 2
    two = project.replace(
        cameras=(project.cameras[0], cam2),
        image_camera=image_camera,
        estimate_io=np.repeat(project.estimate_io, 2, axis=0),
    )
    res = bundle_adjust(two)
    assert res.converged and 0.9 < res.sigma0 < 1.1
    total = res.redundancy_numbers.sum() + res.prior_redundancy_numbers.sum()
    assert total == pytest.approx(res.redundancy, rel=1e-6)
    assert (
        res.n_parameters
        == bundle_adjust(project, BundleParameters(covariance=False)).n_parameters + 7
    )
    for ci in range(2):
        free = res.network.io_free[ci]
        z = np.abs(res.io[ci, free] - truth["io"][free]) / res.io_std[ci, free]
        assert z.max() < 4.5
