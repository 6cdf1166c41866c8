"""The ``church`` scene family: draws, frames, windows, targets and the files for registration."""

from __future__ import annotations

import numpy as np
import pytest
from shapely.geometry import Polygon

from pyheracles.errors import InputError
from pyheracles.registration.points import read_point_groups, read_points
from pyheracles.synthetic.families import simulate
from pyheracles.synthetic.families.church import RANGES, THESIS, draw_params
from pyheracles.synthetic.families.church_geometry import SHAPES, opening_outline

#: A small church drawn quickly (two stations inside, four outside, coarse steps).
SMALL = {
    "nave_length_m": 15.0,
    "nave_width_m": 8.0,
    "nave_height_m": 7.0,
    "aisles": False,
    "apse": False,
    "tower": "south",
    "tower_size_m": 4.0,
    "n_bays": 3,
    "n_gable_windows": 1,
    "n_doors": 2,
    "window_style": "round",
    "leaded_share": 1.0,
    "pane_thickness_m": 0.02,
    "n_interior_stations": 2,
    "interior_step_deg": 0.5,
    "exterior_kind": "tls",
    "n_exterior_stations": 4,
    "exterior_step_deg": 0.6,
    "detail_scans": False,
    "n_gravestones": 4,
    "interior_levelled": True,
    "exterior_levelled": False,
    "max_tilt_deg": 1.5,
    "outlier_share": 0.005,
}


@pytest.fixture(scope="module")
def sim():
    return simulate("church", 5, **SMALL)


def _scene_xyz(sim, name: str) -> np.ndarray:
    T = sim.transforms[name]
    return sim.clouds[name].xyz @ T[:3, :3].T + T[:3, 3]


def _codes(names: dict[int, str], *wanted: str) -> list[int]:
    return [k for k, v in names.items() if v in wanted]


def test_same_seed_same_scene() -> None:
    import numpy.random as npr

    from pyheracles.synthetic.families.church_layout import build_church

    p = draw_params(5, **SMALL)
    assert p == draw_params(5, **SMALL)
    a, _ = build_church(p, npr.default_rng([5, 1]))
    b, _ = build_church(p, npr.default_rng([5, 1]))
    np.testing.assert_array_equal(a.scene.triangles, b.scene.triangles)
    assert a.scene.objects == b.scene.objects
    assert draw_params(6, **SMALL) != p


def test_drawn_parameters_stay_in_their_ranges() -> None:
    for seed in range(150):
        p = draw_params(seed)
        for name, spec in RANGES.items():
            v = getattr(p, name)
            if spec[0] == "p":
                assert isinstance(v, bool)
            elif spec[0] == "int":
                assert spec[1] <= v <= spec[2], name
            elif spec[0] == "choice":
                assert v in spec[1], name
            elif name == "splay_m":
                assert v == 0.0 or spec[0] <= v <= spec[1]
            else:
                assert spec[0] <= v <= spec[1], name
        for side in ("interior", "exterior"):
            tx, ty, tz, om, ph, ka = getattr(p, f"{side}_frame")
            assert max(abs(tx), abs(ty)) <= 600 and abs(tz) <= 60 and 0 <= ka < 360
            if getattr(p, f"{side}_levelled"):
                assert om == ph == 0.0
            else:
                assert max(abs(om), abs(ph)) <= p.max_tilt_deg


def test_overrides_and_unknown_names() -> None:
    p = draw_params(3, wall_thickness_m=0.9, exterior_kind="tls")
    q = draw_params(3)
    assert p.wall_thickness_m == 0.9 and p.exterior_kind == "tls"
    assert p.nave_length_m == q.nave_length_m  # fixing one field leaves the others
    with pytest.raises(InputError, match="wall_thickness_m"):
        simulate("church", 0, wall_thicknes_m=0.5)
    with pytest.raises(InputError, match="exterior_kind"):
        draw_params(0, exterior_kind="lidar")
    with pytest.raises(InputError, match="6 numbers"):
        draw_params(0, interior_frame=(1.0, 2.0))
    t = draw_params(7, layout="thesis")
    assert all(getattr(t, k) == v for k, v in THESIS.items())


def test_each_cloud_in_its_own_rigid_frame(sim) -> None:
    p = sim.params
    for name in ("interior", "exterior"):
        T = sim.transforms[name]
        R = T[:3, :3]
        np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)
        assert np.linalg.det(R) == pytest.approx(1.0)
        np.testing.assert_allclose(T[:3, 3], p[f"{name}_frame"][:3])
    # the interior is levelled (rotation about z only), the exterior tilted
    np.testing.assert_allclose(sim.transforms["interior"][2, :3], [0, 0, 1], atol=1e-12)
    tilt = np.degrees(np.arccos(sim.transforms["exterior"][2, 2]))
    assert 0.0 < tilt <= np.hypot(1.5, 1.5)
    # the clouds are far from the scene frame, the floor maps back to z = 0
    res = sim.clouds["interior"]
    floor = np.isin(res.class_id, _codes(sim.scene.class_names, "floor")) & ~res.outlier
    assert np.abs(res.xyz[floor].mean(0)).max() > 20.0
    z = _scene_xyz(sim, "interior")[floor, 2]
    assert abs(np.median(z)) < 0.003
    T_ei = sim.extras["T_exterior_interior"]
    np.testing.assert_allclose(
        sim.transforms["exterior"] @ T_ei, sim.transforms["interior"], atol=1e-9
    )


def test_reference_labels_are_consistent(sim) -> None:
    objects = {o["instance"]: o for o in sim.scene.objects}
    assert len(objects) == len(sim.scene.objects)  # one record per instance
    for name, res in sim.clouds.items():
        good = ~res.outlier
        inst = np.unique(res.instance[good])
        assert 0 not in inst
        assert set(inst.tolist()) <= set(objects)
        for k in inst:  # the point's class is its object's class
            cls = np.unique(res.class_id[good & (res.instance == k)])
            assert [sim.scene.class_names[int(c)] for c in cls] == [objects[int(k)]["class"]]
        # outliers: flagged, without a reference, about the drawn share
        assert (res.instance[res.outlier] == 0).all()
        share = res.outlier.mean()
        assert 0.5 * SMALL["outlier_share"] < share < 0.1
        assert set(np.unique(res.point_source_id).tolist()) == set(
            range(1, len(sim.extras["stations"][name]) + 1)
        )


def test_window_objects_give_the_pane_geometry(sim) -> None:
    windows = [o for o in sim.scene.objects if o["class"] == "window"]
    assert len(windows) == sim.params["counts"]["windows"] >= 3
    walls = {o["name"]: o for o in sim.scene.objects if o["class"] == "wall"}
    for w in windows:
        ring = np.asarray(w["outline_m"])
        n = np.asarray(w["plane"]["normal"])
        np.testing.assert_allclose(ring @ n, w["plane"]["d"], atol=1e-9)  # on the mid-plane
        assert w["thickness_m"] == 0.02
        assert w["leaded"] and w["shape"] in SHAPES
        wall = walls[w["wall"]]
        depth = wall["outer_plane"]["d"] - ring @ np.asarray(wall["outer_plane"]["normal"])
        assert 0.0 < depth.min() and depth.max() < wall["thickness_m"]
        np.testing.assert_allclose(depth, w["depth_from_outer_face_m"], atol=1e-9)
        sharp = np.asarray(w["sharp_corners_m"])
        assert len(sharp) == {"rect": 4, "round": 2, "pointed": 3}[w["shape"]]
        assert np.min(np.linalg.norm(ring[:, None] - sharp[None], axis=2), axis=0).max() < 1e-9


def test_outlines_of_every_shape() -> None:
    for shape in SHAPES:
        ring = opening_outline(shape, 1.2, 2.0, 0.9)
        poly = Polygon(ring)
        assert poly.is_valid and poly.exterior.is_ccw
        assert ring[:, 0].min() == pytest.approx(-0.6) and ring[:, 0].max() == pytest.approx(0.6)
        top = {"rect": 2.0, "round": 2.6, "pointed": 2.0 + np.sqrt(0.81 - 0.09)}[shape]
        assert ring[:, 1].max() == pytest.approx(top)
        # the splayed outline (offset 0.1) has as many vertices, and contains it
        grown = opening_outline(shape, 1.4, 2.1, 1.0) - [0.0, 0.1]
        assert len(grown) == len(ring) and Polygon(grown).contains(poly)


def test_glass_returns_few_and_weak_points(sim) -> None:
    from scipy.spatial import cKDTree

    res = sim.clouds["interior"]
    parts = sim.scene.part_names
    xyz = _scene_xyz(sim, "interior")
    pane = np.isin(res.part, _codes(parts, "pane")) & ~res.outlier
    face = np.isin(res.part, _codes(parts, "inner_face")) & ~res.outlier
    centres = np.array([o["plane"]["point"] for o in sim.scene.objects if o["class"] == "window"])
    near = cKDTree(centres).query(xyz)[0] < 1.5
    spacing = {}
    for key, m in (("pane", pane & near), ("face", face & near)):
        d, _ = cKDTree(xyz[m]).query(xyz[m], k=2)
        spacing[key] = np.median(d[:, 1])
    assert pane.sum() > 0
    assert spacing["pane"] > 2.0 * spacing["face"]  # most beams pass through the glass
    assert np.median(res.intensity[pane]) < 0.5 * np.median(res.intensity[face])
    # leaded lights: the cames are metal strips standing out of the glass
    assert np.isin(res.part, _codes(parts, "came")).any()


def test_targets_control_and_check(sim) -> None:
    ex = sim.extras
    control, check = ex["control"], ex["check"]
    assert {i[:5] for i in control.ids} == {"GCP_E", "GCP_I"}
    assert {i[:5] for i in check.ids} == {"CHK_E", "CHK_I"}
    assert sum(i.startswith("GCP_I") for i in control.ids) >= 3
    assert sum(i.startswith("CHK_I") for i in check.ids) >= 3
    truth = ex["targets_true"]
    scene = truth[truth.frame == "scene"].set_index("id")
    for pl in (control, check):  # surveyed within a few sigma of the true centres
        err = pl.xyz - scene.loc[list(pl.ids), ["X", "Y", "Z"]].to_numpy(float)
        assert np.abs(err).max() < 6 * 1.5 * sim.params["control_sigma_m"]
    for name in ("interior", "exterior"):
        picks = ex["targets_measured"][name]
        local = truth[truth.frame == name].set_index("id").loc[list(picks.ids)]
        assert (local["n_points"] >= 30).all()
        d = np.linalg.norm(picks.xyz - local[["X", "Y", "Z"]].to_numpy(float), axis=1)
        assert d.max() < 0.2  # the operator's click, refined by a sphere fit
        side = "I" if name == "interior" else "E"
        assert sum(i[-3] == side for i in picks.ids) >= 3


def test_cli_writes_the_draw_and_files_georef_reads(sim, tmp_path) -> None:
    from pyheracles.cli import main
    from pyheracles.registration.transform import read_transform_json

    out = tmp_path / "sim"
    assert (
        main(
            [
                "simulate",
                "--family",
                "church",
                "--seed",
                "5",
                "-o",
                str(out),
                *[f"--set={k}={v}" for k, v in SMALL.items()],
            ]
        )
        == 0
    )
    for f in (
        "interior.laz",
        "exterior.laz",
        "truth_interior.npz",
        "truth_exterior.npz",
        "scene.json",
        "preview.png",
        "control.csv",
        "check.csv",
        "targets.csv",
        "targets_interior.csv",
        "targets_exterior.csv",
        "targets_true.csv",
        "window_corners.csv",
        "check_interior.csv",
    ):
        assert (out / f).is_file(), f
    import laspy

    # the same seed and parameters give the same points (the CLI drew it again)
    las = laspy.read(out / "interior.laz")
    truth = np.load(out / "truth_interior.npz")
    assert len(las.x) == len(truth["instance"]) == len(sim.clouds["interior"])
    np.testing.assert_array_equal(truth["instance"], sim.clouds["interior"].instance)
    np.testing.assert_array_equal(truth["outlier"], sim.clouds["interior"].outlier)
    np.testing.assert_allclose(
        np.column_stack([las.x, las.y, las.z]), sim.clouds["interior"].xyz, atol=1e-4
    )
    np.testing.assert_allclose(truth["T_scene_cloud"], sim.transforms["interior"])
    assert read_points(out / "control.csv").sigma is not None
    groups = read_point_groups(out / "targets.csv")
    assert set(groups) == {"interior", "exterior"}
    # georeference the interior on its control spheres with the files as written
    code = main(
        [
            "georef",
            str(out / "interior.laz"),
            "--control",
            str(out / "control.csv"),
            "--measured",
            str(out / "targets_interior.csv"),
            "--rigid",
            "interior",
            "--sphere-radius",
            str(sim.extras["target_radius_m"]),
            "-o",
            str(tmp_path / "geo"),
        ]
    )
    assert code == 0
    T = read_transform_json(tmp_path / "geo" / "transform_interior.json")
    probe = sim.clouds["interior"].xyz[::5000]
    err = (probe @ T[:3, :3].T + T[:3, 3]) - _scene_xyz(sim, "interior")[::5000]
    # the four interior spheres stand about 1.6 m high: the tilt is weakly determined, and
    # the cloud's far ends are off by what the adjustment's own precision says (and no more)
    sigma = _propagated_sigma(tmp_path / "geo" / "transform_interior.json", probe)
    assert np.abs(err).max() < 0.05
    assert (np.abs(err) <= 4 * sigma + 0.001).all(), (np.abs(err) / sigma).max()
    assert np.median(np.abs(err)) < 0.01


def _propagated_sigma(path, xyz: np.ndarray) -> np.ndarray:
    """Standard deviation per coordinate of the transformed points, from the transform's
    parameters, their standard deviations and correlations (first-order propagation)."""
    import json

    from scipy.spatial.transform import Rotation

    est = json.loads(path.read_text(encoding="utf-8"))["estimation"]
    names = est["correlation"]["names"]
    sd = np.array([est["std"][n] for n in names])
    cov = np.array(est["correlation"]["matrix"]) * np.outer(sd, sd)
    p0 = np.array([est["parameters"][n] for n in names])

    def apply(p: np.ndarray) -> np.ndarray:
        return xyz @ Rotation.from_euler("xyz", p[3:6]).as_matrix().T + p[:3]

    np.testing.assert_allclose(apply(p0), xyz @ np.array(est["T_target_source"])[:3, :3].T
                               + np.array(est["T_target_source"])[:3, 3], atol=1e-6)  # fmt: skip
    h = 1e-6
    jac = np.stack([(apply(p0 + h * e) - apply(p0 - h * e)) / (2 * h) for e in np.eye(len(p0))], -1)
    return np.sqrt(np.einsum("nik,kl,nil->ni", jac, cov, jac))


def test_photogrammetry_exterior_sees_no_glass() -> None:
    s = simulate(
        "church",
        11,
        **{**SMALL, "exterior_kind": "photogrammetry", "n_cameras": 8, "n_exterior_targets": 5},
    )
    res = s.clouds["exterior"]
    assert not np.isin(res.part, _codes(s.scene.part_names, "pane")).any()
    walls = np.isin(res.class_id, _codes(s.scene.class_names, "wall"))
    assert walls.mean() > 0.2
    assert len(s.extras["targets_measured"]["exterior"]) >= 3
    assert s.params["exterior_step_effective_deg"] is None
