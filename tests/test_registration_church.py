"""Church generator, target measurement and the three integration strategies."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

from pyheracles.errors import DegenerateGeometryError, InputError
from pyheracles.registration.checkpoints import check_points
from pyheracles.registration.points import PointList, pair_points
from pyheracles.registration.strategies import (
    CloudMeasurements,
    block_adjustment,
    free_network,
    georeference_independent,
)
from pyheracles.registration.targets import (
    fit_sphere,
    measure_plane_corner,
    measure_spheres,
)
from pyheracles.registration.transform import apply_to_points
from pyheracles.synthetic.church import ChurchParams, make_church

SCALE_EXT = 0.8  # model scale of the generated exterior frame


@pytest.fixture(scope="module")
def scene():
    return make_church(ChurchParams(spacing_m=0.25, window_spacing_m=0.05), rng=3)


@pytest.fixture(scope="module")
def measured(scene):
    me = measure_spheres(scene.exterior, scene.targets_exterior, 0.0725 * SCALE_EXT)
    mi = measure_spheres(scene.interior, scene.targets_interior, 0.0725)
    return me, mi


def _check_rms(scene, me, mi, T_e, T_i) -> float:
    meas = PointList(
        me.ids + mi.ids, np.vstack([apply_to_points(T_e, me.xyz), apply_to_points(T_i, mi.xyz)])
    )
    pr = pair_points(meas, scene.check, unmatched="ignore")
    return check_points(pr.b, pr.a, pr.ids).rms["3d"]


def test_church_geometry(scene) -> None:
    assert len(scene.windows) == 24
    assert scene.exterior.attributes["surface"].max() == 6
    # the exterior frame is a similarity with scale 0.8, the interior a rigid frame
    assert np.cbrt(np.linalg.det(scene.T_world_exterior[:3, :3])) == pytest.approx(1 / 0.8)
    assert np.cbrt(np.linalg.det(scene.T_world_interior[:3, :3])) == pytest.approx(1.0)
    # pane points of both clouds, in the world, lie 2 cm apart (two faces of the glass)
    pe = apply_to_points(
        scene.T_world_exterior,
        scene.exterior.world_xyz()[scene.exterior.attributes["surface"] == 3],
    )
    pi = apply_to_points(
        scene.T_world_interior,
        scene.interior.world_xyz()[scene.interior.attributes["surface"] == 3],
    )
    d, _ = cKDTree(pe).query(pi[:2000])
    assert 0.015 < np.median(d) < 0.04
    # manual ties agree in the world within the picking noise
    te = apply_to_points(scene.T_world_exterior, scene.manual_ties_exterior.xyz)
    ti = apply_to_points(scene.T_world_interior, scene.manual_ties_interior.xyz)
    assert np.sqrt(np.mean((te - ti) ** 2)) < 0.02


def test_sphere_fit_exact_and_measured(scene, measured) -> None:
    rng = np.random.default_rng(0)
    v = rng.normal(size=(500, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    fit = fit_sphere(v[v[:, 2] > 0] * 0.1 + [1, 2, 3])
    np.testing.assert_allclose(fit.centre, [1, 2, 3], atol=1e-9)
    assert fit.radius == pytest.approx(0.1)
    me, mi = measured
    true = scene.targets_true_world
    we = apply_to_points(scene.T_world_exterior, me.xyz)
    wi = apply_to_points(scene.T_world_interior, mi.xyz)
    assert np.abs(we - true.select(me.ids).xyz).max() < 0.003
    assert np.abs(wi - true.select(mi.ids).xyz).max() < 0.002


def test_sphere_not_found(scene) -> None:
    far = PointList(("X",), [[1e4, 1e4, 1e4]])
    with pytest.raises(DegenerateGeometryError, match="'X'"):
        measure_spheres(scene.interior, far, 0.0725)


def test_plane_corner_of_a_window(scene) -> None:
    corner_world = scene.corners_world.xyz[5]
    T_iw = np.linalg.inv(scene.T_world_interior)
    approx = apply_to_points(T_iw, corner_world)[0] + [0.02, -0.01, 0.02]
    cloud = scene.interior
    c = measure_plane_corner(cloud.xyz, approx - cloud.offset, search_m=0.2, rng=1)
    found = apply_to_points(scene.T_world_interior, c.point + cloud.offset)[0]
    # the corner found lies on the inner face of the pane: 1 cm from the mid-plane
    assert 0.004 < np.linalg.norm(found - corner_world) < 0.02
    assert c.condition > 0.9


def test_independent_free_network_block(scene, measured) -> None:
    me, mi = measured
    E = CloudMeasurements("exterior", me, with_scale=True)
    I = CloudMeasurements("interior", mi, with_scale=False)
    ind = georeference_independent([E, I], scene.control)
    rms_ind = _check_rms(
        scene, me, mi, ind["exterior"].T_target_source, ind["interior"].T_target_source
    )
    fn = free_network(E, I, scene.manual_ties_exterior, scene.manual_ties_interior, scene.control)
    rms_fn = _check_rms(scene, me, mi, fn.T_world_base, fn.T_world_other)
    e2 = PointList(
        me.ids + scene.manual_ties_exterior.ids,
        np.vstack([me.xyz, scene.manual_ties_exterior.xyz]),
        np.vstack([me.sigma, scene.manual_ties_exterior.sigma]),
    )
    i2 = PointList(
        mi.ids + scene.manual_ties_interior.ids,
        np.vstack([mi.xyz, scene.manual_ties_interior.xyz]),
        np.vstack([mi.sigma, scene.manual_ties_interior.sigma]),
    )
    blk = block_adjustment(
        [CloudMeasurements("exterior", e2, True), CloudMeasurements("interior", i2, False)],
        scene.control,
    )
    rms_blk = _check_rms(scene, me, mi, blk.transforms["exterior"], blk.transforms["interior"])
    # survey noise 3 mm per coordinate -> about 5-6 mm 3D on check points
    for rms in (rms_ind, rms_fn, rms_blk):
        assert 0.003 < rms < 0.012
    assert blk.converged and 0.7 < blk.sigma0 < 1.4
    assert ind["interior"].parameters["scale"] == 1.0
    assert ind["exterior"].parameters["scale"] == pytest.approx(1 / SCALE_EXT, rel=1e-3)
    assert set(blk.observations["kind"]) == {"control", "tie", "control_coordinates"}
    np.testing.assert_allclose(blk.transforms["interior"], scene.T_world_interior, atol=2e-3)


def test_block_with_unconnected_cloud(scene, measured) -> None:
    me, _ = measured
    lonely = PointList(("a", "b", "c"), np.eye(3))
    with pytest.raises(InputError, match="cannot connect cloud"):
        block_adjustment(
            [CloudMeasurements("exterior", me), CloudMeasurements("lonely", lonely)],
            scene.control,
        )
