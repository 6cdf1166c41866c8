"""Automatic tie points through the glazed openings of a church family draw."""

from __future__ import annotations

import numpy as np
import pytest

from pyheracles.cloud import PointCloud
from pyheracles.errors import InputError
from pyheracles.registration.panes import PaneParams, detect_openings
from pyheracles.registration.similarity import SimilarityParams
from pyheracles.registration.tiepoints import TiePointParams, find_tie_points
from pyheracles.registration.transform import apply_to_points
from pyheracles.synthetic.families import simulate

#: A small church: one nave, rectangular and round-headed lights, fine steps.
SMALL = {
    "nave_length_m": 16.0,
    "nave_width_m": 8.0,
    "nave_height_m": 7.0,
    "aisles": False,
    "apse": False,
    "tower": "none",
    "n_bays": 4,
    "n_gable_windows": 1,
    "window_style": "round",
    "pane_thickness_m": 0.02,
    "n_interior_stations": 2,
    "interior_step_deg": 0.12,
    "exterior_kind": "tls",
    "n_exterior_stations": 4,
    "exterior_step_deg": 0.12,
    "detail_scans": False,
    "n_gravestones": 2,
    "interior_levelled": True,
    "exterior_levelled": False,
    "max_tilt_deg": 1.0,
}


@pytest.fixture(scope="module")
def sim():
    return simulate("church", 7, **SMALL)


def _cloud(sim, name: str) -> PointCloud:
    return PointCloud.from_world(np.round(sim.clouds[name].xyz, 4), source=f"{name}.laz")


@pytest.mark.slow
def test_openings_on_the_pane_mid_plane(sim) -> None:
    cloud = _cloud(sim, "interior")
    ops = detect_openings(cloud.xyz, PaneParams(pane_thickness_m=0.02))
    T = sim.transforms["interior"]
    windows = [o for o in sim.scene.objects if o["class"] == "window"]
    centres = np.array([np.mean(w["box_corners_m"], axis=0) for w in windows])
    normals = np.array([w["plane"]["normal"] for w in windows])
    found = apply_to_points(T, np.array([o.centre for o in ops]) + cloud.offset)
    near = np.linalg.norm(found[:, None, :] - centres[None, :, :], axis=2).argmin(axis=1)
    depth = np.einsum("ij,ij->i", found - centres[near], normals[near])
    # most lights found, and on their mid-plane (2 cm glass compensated) within 1 cm
    assert len(np.unique(near)) >= 0.6 * len(windows)
    assert np.median(np.abs(depth)) < 0.01
    # the viewer side of an interior view is the inside: normals oppose the outward ones
    n_world = np.array([o.normal for o in ops]) @ T[:3, :3].T
    assert np.median(np.einsum("ij,ij->i", n_world, normals[near])) < -0.99


@pytest.mark.slow
def test_a_transform_is_right_or_refused(sim) -> None:
    # four exterior stations see few openings well: whatever comes back must be right
    interior, exterior = _cloud(sim, "interior"), _cloud(sim, "exterior")
    try:
        res = find_tie_points(
            interior,
            exterior,
            TiePointParams(pane_thickness_m=0.02),
            similarity=SimilarityParams(with_scale=False, estimator="danish"),
        )
    except InputError as exc:
        assert "no trustworthy match" in str(exc) or "disagree" in str(exc)
        return
    T = res.similarity.T_target_source
    T_true = np.linalg.inv(sim.transforms["exterior"]) @ sim.transforms["interior"]
    probe = interior.world_xyz()[::2000]
    err = apply_to_points(T, probe) - apply_to_points(T_true, probe)
    assert np.sqrt(np.mean(np.sum(err**2, axis=1))) < 0.015


def test_clouds_without_panes() -> None:
    rng = np.random.default_rng(0)
    flat = PointCloud(xyz=np.column_stack([rng.uniform(0, 5, (5000, 2)), np.zeros(5000)]))
    with pytest.raises(InputError, match="no glazed window openings"):
        find_tie_points(flat, flat)


def test_a_wall_without_openings_has_none() -> None:
    # a plain wall (with a shadow-like gap but nothing behind it) is no opening
    rng = np.random.default_rng(1)
    u = rng.uniform(0, 8, 60000)
    z = rng.uniform(0, 5, 60000)
    gap = (np.abs(u - 4) < 0.5) & (np.abs(z - 2.5) < 1.0)
    wall = np.column_stack([u[~gap], np.zeros((~gap).sum()), z[~gap]])
    assert detect_openings(wall + rng.normal(0, 0.002, wall.shape)) == []
