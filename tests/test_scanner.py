"""The scan simulator behaves like a scanner: spacing, shadows, grazing limit, noise, outliers."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

from pyheracles.errors import InputError
from pyheracles.synthetic.scanner import (
    AirborneSurvey,
    Outliers,
    PhotoViews,
    RayCaster,
    TLSStation,
    scan,
)
from pyheracles.synthetic.scene import FOLIAGE, GLASS, Scene

QUIET = {"noise_m": 0.0, "noise_per_m": 0.0, "detection": 1e-9, "mixed_pixel_share": 0.0}


def _wall_at(x: float, size: float = 40.0) -> Scene:
    s = Scene()
    s.add_quad(
        [[x, -size, -size], [x, size, -size], [x, size, size], [x, -size, size]],
        instance=1,
        class_name="wall",
        part="face",
    )
    return s


@pytest.mark.parametrize("r", [5.0, 20.0])
def test_spacing_on_a_facing_surface_is_range_times_step(r: float) -> None:
    step = 0.1
    res = scan(
        _wall_at(r),
        TLSStation(
            (0, 0, 0), step_deg=step, elevation_deg=(-10, 10), azimuth_deg=(-10, 10), **QUIET
        ),
        rng=0,
    )
    near = res.xyz[np.hypot(res.xyz[:, 1], res.xyz[:, 2]) < 0.05 * r]
    d, _ = cKDTree(near).query(near, k=2)
    expected = r * np.deg2rad(step)
    assert abs(np.median(d[:, 1]) / expected - 1) < 0.05


def test_shadow_behind_a_cylinder_matches_its_geometry() -> None:
    D, a, W = 5.0, 0.5, 15.0
    s = _wall_at(W)
    s.add_cylinder(
        [D, 0, -5], [0, 0, 1], 10.0, a, segments=256, instance=2, class_name="column", part="shaft"
    )
    res = scan(
        s,
        TLSStation((0, 0, 0), step_deg=0.05, elevation_deg=(-5, 5), azimuth_deg=(-20, 20), **QUIET),
        rng=0,
    )
    on_wall = res.instance == 1
    y = res.xyz[on_wall, 1][np.abs(res.xyz[on_wall, 2]) < 0.3]
    half = W * np.tan(np.arcsin(a / D))
    spacing = W * np.deg2rad(0.05)
    assert not np.any(np.abs(y) < half - spacing)  # nothing inside the shadow
    assert np.any((np.abs(y) > half) & (np.abs(y) < half + 3 * spacing))  # and the edge is sharp
    assert (res.instance == 2).sum() > 100


def test_no_point_below_the_grazing_limit() -> None:
    s = Scene()
    s.add_quad(
        [[-80, -80, 0], [80, -80, 0], [80, 80, 0], [-80, 80, 0]], class_name="floor", part="floor"
    )
    h, limit = 1.5, 8.0
    res = scan(s, TLSStation((0, 0, h), step_deg=0.2, grazing_limit_deg=limit, **QUIET), rng=0)
    dist = np.hypot(res.xyz[:, 0], res.xyz[:, 1])
    grazing = np.rad2deg(np.arctan2(h, dist))
    assert grazing.min() >= limit - 0.05
    assert dist.max() > 0.9 * h / np.tan(np.deg2rad(limit))


def test_blind_cone_under_the_tripod() -> None:
    s = Scene()
    s.add_quad([[-20, -20, 0], [20, -20, 0], [20, 20, 0], [-20, 20, 0]], class_name="floor")
    res = scan(s, TLSStation((0, 0, 1.5), step_deg=0.5, elevation_deg=(-60, 90), **QUIET), rng=0)
    dist = np.hypot(res.xyz[:, 0], res.xyz[:, 1])
    assert dist.min() >= 1.5 * np.tan(np.deg2rad(30)) * 0.98


def test_range_noise_follows_sigma_of_range() -> None:
    a, b = 0.002, 0.0002
    for r in (5.0, 30.0):
        res = scan(
            _wall_at(r),
            TLSStation(
                (0, 0, 0),
                step_deg=0.1,
                elevation_deg=(-5, 5),
                azimuth_deg=(-5, 5),
                noise_m=a,
                noise_per_m=b,
                detection=1e-9,
                mixed_pixel_share=0.0,
            ),
            rng=1,
        )
        err = res.xyz[:, 0] - r  # along the beam at near-normal incidence
        assert abs(err.std() / (a + b * r) - 1) < 0.08


def test_outlier_share_as_set_and_flagged() -> None:
    s = _wall_at(8.0)
    s.add_box([4, 2, 0], [0.02, 2, 2], class_name="window", part="pane", material=GLASS)
    res = scan(
        s, TLSStation((0, 0, 0), step_deg=0.2, **QUIET), outliers=Outliers(share=0.02), rng=3
    )
    names = s.part_names
    kinds = {names[p] for p in np.unique(res.part[res.outlier])}
    assert {"outlier_isolated", "outlier_cluster", "reflection"} <= kinds
    assert abs(res.outlier.mean() / 0.02 - 1) < 0.05
    assert (res.instance[res.outlier] == 0).all()
    assert (res.xyz[res.outlier, 2] < -1.15).any()  # some under the floor (multipath)


def test_glass_returns_few_weak_points_and_lets_the_beam_through() -> None:
    s = _wall_at(10.0)
    s.add_box([5, 0, 0], [0.02, 4, 4], class_name="window", part="pane", material=GLASS)
    res = scan(
        s,
        TLSStation(
            (0, 0, 0),
            step_deg=0.1,
            elevation_deg=(-15, 15),
            azimuth_deg=(-15, 15),
            mixed_pixel_share=0.0,
        ),
        rng=0,
    )
    pane = res.part == s.part_code("pane")
    # the whole field of view is behind the pane: each of its two faces stops about 10 %
    # of the beams (weak returns, some not detected), the rest returns from the wall
    behind = res.instance == 1
    assert 0.05 * behind.sum() < pane.sum() < 0.3 * behind.sum()
    assert np.median(res.intensity[pane]) < np.median(res.intensity[res.instance == 1])


@pytest.mark.parametrize("layers", [1, 2])
def test_share_of_glass_returns_is_one_minus_transmittance(layers: int) -> None:
    # one or two parallel glass faces in front of a wall, every return detected: a beam
    # stops at the first face with probability 1 - t, at the second with t (1 - t)
    s = _wall_at(10.0)
    for k in range(layers):
        x = 5.0 + 0.5 * k
        s.add_quad(
            [[x, -2, -2], [x, 2, -2], [x, 2, 2], [x, -2, 2]],
            instance=2 + k,
            class_name="window",
            part="pane",
            material=GLASS,
        )
    res = scan(
        s,
        TLSStation(
            (0, 0, 0), step_deg=0.1, elevation_deg=(-15, 15), azimuth_deg=(-15, 15), **QUIET
        ),
        rng=0,
    )
    inside = (np.abs(res.xyz[:, 1] / res.xyz[:, 0]) < 0.35) & (
        np.abs(res.xyz[:, 2] / np.hypot(res.xyz[:, 0], res.xyz[:, 1])) < 0.35
    )
    t = GLASS.transmittance
    n = inside.sum()
    assert n > 20_000
    first = np.mean(res.instance[inside] == 2)
    assert abs(first - (1 - t)) < 0.01
    if layers == 2:
        assert abs(np.mean(res.instance[inside] == 3) - t * (1 - t)) < 0.01
    assert abs(np.mean(res.instance[inside] == 1) - t**layers) < 0.015


def test_points_in_acquisition_order_and_stations_numbered() -> None:
    s = _wall_at(6.0)
    s.add_cylinder([3, 0, -3], [0, 0, 1], 6.0, 0.3, instance=2, class_name="column")
    st = [TLSStation((0, y, 0), step_deg=0.3, **QUIET) for y in (-2.0, 2.0)]
    res = scan(s, st, rng=0)
    assert np.all(np.diff(res.point_source_id.astype(int)) >= 0)
    assert set(np.unique(res.point_source_id)) == {1, 2}
    inst = res.instance[res.point_source_id == 1]
    assert np.any(np.diff(inst) < 0)  # labels interleave: not sorted by object
    again = scan(s, st, rng=0)
    np.testing.assert_array_equal(res.xyz, again.xyz)


def test_airborne_strips_and_multiple_returns_through_foliage() -> None:
    s = Scene()
    s.add_quad(
        [[-100, -100, 0], [100, -100, 0], [100, 100, 0], [-100, 100, 0]],
        class_name="ground",
        part="ground",
    )
    g = np.random.default_rng(0)
    c = np.array([0.0, 0.0, 8.0])
    tris = c + g.normal(0, [3, 3, 2], (4000, 1, 3)) + g.normal(0, 0.12, (4000, 3, 3))
    s.add_triangles(tris, instance=1, class_name="tree", part="crown", material=FOLIAGE)
    sv = AirborneSurvey(
        (-60, -60, 60, 60), altitude_m=400, density_per_m2=4, half_fov_deg=10, overlap=0.3
    )
    res = scan(s, sv, rng=0)
    assert len(np.unique(res.point_source_id)) >= 2
    under = np.hypot(res.xyz[:, 0], res.xyz[:, 1]) < 2
    assert res.number_of_returns[under].max() >= 2
    assert (res.return_number <= res.number_of_returns).all()
    ground_under = under & (res.class_id == s.class_code("ground"))
    assert ground_under.sum() > 0
    area = 120 * 120
    assert 3.0 < (res.return_number == 1).sum() / area < 12.0


def test_photogrammetry_needs_two_views() -> None:
    s = _wall_at(10.0, size=5)
    s.add_quad([[-5, 6, -5], [20, 6, -5], [20, 6, 5], [-5, 6, 5]], class_name="side", part="side")
    cams = np.array([[0.0, -1.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 0.0]])
    pv = PhotoViews(
        cams, cams + [10, 0, 0], focal_px=800, width_px=1200, height_px=900, pixel_step=4
    )
    res = scan(s, pv, rng=0)
    assert (res.instance == 1).sum() > 1000
    d, _ = cKDTree(res.xyz).query(res.xyz, k=2)
    assert np.median(d[:, 1]) > 0.005  # one point per matched pixel, no duplicates of views
    only_one = PhotoViews(cams[:1], cams[:1] + [10, 0, 0], min_views=1)
    assert len(scan(s, only_one, rng=0)) > 0
    with pytest.raises(InputError):
        scan(s, PhotoViews(cams[:1], cams[:1] + [10, 0, 0]), rng=0)


def test_same_hits_as_open3d_raycasting() -> None:
    o3d = pytest.importorskip("open3d", exc_type=ImportError)
    s = _wall_at(7.0)
    s.add_cylinder([3, 0.2, -3], [0.05, 0, 1], 6.0, 0.4, instance=2, class_name="column")
    g = np.random.default_rng(0)
    d = g.normal(size=(20000, 3))
    d[:, 0] = np.abs(d[:, 0]) * 3
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    t, _ = RayCaster(s).cast(np.zeros(3), d)
    sc = o3d.t.geometry.RaycastingScene()
    tris = s.triangles.reshape(-1, 3).astype(np.float32)
    sc.add_triangles(tris, np.arange(len(tris), dtype=np.uint32).reshape(-1, 3))
    rays = np.hstack([np.zeros_like(d), d]).astype(np.float32)
    t3 = sc.cast_rays(o3d.core.Tensor(rays))["t_hit"].numpy()
    both = np.isfinite(t) & np.isfinite(t3)
    assert both.mean() > 0.5 and (np.isfinite(t) == np.isfinite(t3)).mean() > 0.999
    assert np.abs(t[both] - t3[both]).max() < 1e-4


def test_bad_settings_are_refused() -> None:
    s = _wall_at(5.0)
    with pytest.raises(InputError, match="step"):
        scan(s, TLSStation((0, 0, 0), step_deg=0), rng=0)
    with pytest.raises(InputError, match="no acquisition"):
        scan(s, [], rng=0)
    with pytest.raises(InputError, match="outlier share"):
        scan(s, TLSStation((0, 0, 0)), outliers=Outliers(share=0.7), rng=0)
    with pytest.raises(InputError, match="no surfaces"):
        scan(Scene(), TLSStation((0, 0, 0)), rng=0)
