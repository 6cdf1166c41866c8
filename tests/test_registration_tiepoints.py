"""Automatic tie points through the window panes of the generated church."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

from pyheracles.cloud import PointCloud
from pyheracles.errors import InputError
from pyheracles.registration.tiepoints import detect_pane_corners, find_tie_points
from pyheracles.registration.transform import apply_to_cloud, apply_to_points
from pyheracles.synthetic.church import ChurchParams, make_church


@pytest.fixture(scope="module")
def scene():
    return make_church(ChurchParams(spacing_m=0.3, window_spacing_m=0.035), rng=11)


def test_pane_corners_on_the_mid_plane(scene) -> None:
    corners, table, _, _ = detect_pane_corners(scene.interior)
    world = apply_to_points(scene.T_world_interior, corners + scene.interior.offset)
    d, _ = cKDTree(scene.corners_world.xyz).query(world)
    assert table["pane"].nunique() >= 20  # of 24 panes
    assert len(corners) >= 80
    assert np.median(d) < 0.008  # 3 mm scanner noise


def test_tie_points_recover_the_interior_pose(scene) -> None:
    exterior_world = apply_to_cloud(scene.exterior, scene.T_world_exterior)
    res = find_tie_points(scene.interior, exterior_world)
    assert len(res.source) >= 35  # the thesis found 35 from 24 openings
    assert res.similarity.rms()["3d"] < 0.02
    T = res.similarity.T_target_source
    # transform error at the far end of the church (30 m)
    probe = scene.interior.world_xyz()[::500]
    err = apply_to_points(T, probe) - apply_to_points(scene.T_world_interior, probe)
    assert np.abs(err).max() < 0.01
    # every tie point is a true window corner seen from both sides
    w_s = apply_to_points(scene.T_world_interior, res.source.xyz)
    d, _ = cKDTree(scene.corners_world.xyz).query(w_s)
    assert d.max() < 0.03


def test_clouds_without_panes(scene) -> None:
    rng = np.random.default_rng(0)
    flat = PointCloud(xyz=np.column_stack([rng.uniform(0, 5, (5000, 2)), np.zeros(5000)]))
    with pytest.raises(InputError, match="no window pane corners"):
        find_tie_points(flat, scene.interior)
