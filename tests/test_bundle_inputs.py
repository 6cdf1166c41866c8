"""Bundle adjustment on inputs nobody prepared for it (issue 16): readers, control file
grammar, gross control points, duplicates, silent switches, failed runs, tau test."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest

from pyheracles.bundle import BundleParameters, BundleWarning, bundle_adjust
from pyheracles.bundle.diagnostics import data_snooping, tau_critical
from pyheracles.bundle.readers import read_control_points, read_photomodeler
from pyheracles.bundle.report import report_dict, report_text
from pyheracles.cli import main
from pyheracles.errors import DegenerateGeometryError, EstimationError, InputError
from pyheracles.synthetic.network import NetworkParameters, make_network


@pytest.fixture(scope="module")
def tiny():
    """A small fixed-control facade network (fast to adjust)."""
    return make_network(
        NetworkParameters(n_images=10, n_points=400, n_control=6, control_std_m=0.0), rng=7
    )


def write_pmexport(project, path, *, image_size=True, extra_marks=()):
    """A PhotoModeler 'Bundle Soln' export of ``project`` (camera model 3, no affinity)."""
    cam = project.cameras[0]
    iw, ih = cam.image_size_px
    fw, fh = cam.sensor_size_mm
    io = cam.io_vector()
    lines = ["Bundle Soln synthetic", f" 0.000500 20 {iw} {ih}" if image_size else " 0.000500 20"]
    lines.append(" 1.0 0.1 10.0 100.0 100.0 100.0 20.0 20.0 20.0")
    camline = f"{io[0]:.6f} {io[1]:.6f} {io[2]:.6f} {fw:.6f} {fh:.6f} 0 0 0 0 0"
    lines += [camline, " 0 0.007 0.005 0.5 0.5 0.001 0.0001 0.0001 0.001 0.001"]
    for i, name in enumerate(project.image_names):
        x, y, z = project.eo[i, :3]
        om, ph, ka = np.degrees(project.eo[i, 3:6])
        lines += [f"{i} images/{name}", f"{i} {x:.6f} {y:.6f} {z:.6f} {ka:.6f} {ph:.6f} {om:.6f}",
                  f"{i} 0.001 0.001 0.001 0.01 0.01 0.01", "", f"{i} {camline}",
                  f"{i} 0 0.007 0.005 0.5 0.5 0.001 0.0001 0.0001 0.001 0.001"]  # fmt: skip
    lines.append("")
    ctrl = np.flatnonzero(project.point_role == "control")
    for k in ctrl:
        x, y, z = project.xyz[k]
        lines.append(f"{project.point_ids[k]} {x:.6f} {y:.6f} {z:.6f} 0 0 0")
    lines.append("")
    for k in np.flatnonzero(project.point_role != "control"):
        lines.append(f"{project.point_ids[k]} 0 0 0 0 0 0")
    lines.append("")
    for i, p, (u, v), (su, sv) in zip(project.obs_image, project.obs_point, project.obs_uv_px,
                                      project.obs_std_px, strict=True):  # fmt: skip
        lines.append(f"{i} {project.point_ids[p]} {u:.4f} {v:.4f} {su} {sv}")
    lines += list(extra_marks)
    lines.append("")
    path.write_text("\n".join(lines) + "\n")
    return path


# --- readers -----------------------------------------------------------------------------


def test_pmexport_without_image_size_asks_for_it(tiny, tmp_path):
    project, _ = tiny
    f = write_pmexport(project, tmp_path / "nosize.txt", image_size=False)
    with pytest.raises(InputError, match=r"line 2 gives no image size.*--image-size"):
        read_photomodeler(f)
    got = read_photomodeler(f, model=3, image_size_px=project.cameras[0].image_size_px)
    assert got.cameras[0].image_size_px == project.cameras[0].image_size_px
    assert got.n_observations == project.n_observations
    with pytest.raises(InputError, match="line 2 gives the image size"):
        read_photomodeler(write_pmexport(project, tmp_path / "size.txt"), image_size_px=(10, 10))


def test_cli_image_size_option(tiny, tmp_path):
    project, _ = tiny
    f = write_pmexport(project, tmp_path / "nosize.txt", image_size=False)
    iw, ih = project.cameras[0].image_size_px
    out = tmp_path / "o"
    args = ["bundle", str(f), "--image-size", f"{iw}x{ih}", "--model", "3", "--estimate",
            "cc,px,py,K1,K2,P1,P2", "--no-plots", "-o", str(out)]  # fmt: skip
    assert main(args) == 0
    rep = json.loads((out / "report.json").read_text())
    assert 0.8 < rep["sigma0"] < 1.2
    assert main(["bundle", str(f), "--image-size", "big", "-o", str(tmp_path / "p")]) == 2


def _ctrl(tmp_path, text, name="ctrl.txt"):
    f = tmp_path / name
    f.write_text(text)
    return f


def test_control_numeric_name_and_label(tmp_path):
    # numeric label then X Y Z sX sY sZ: 7 numbers, one reading only
    c = read_control_points(_ctrl(tmp_path, "# surveyed\n90 17 1.0 2.0 3.0 0.01 0.01 0.02\n"))
    assert c["id"].tolist() == [90] and c["label"] == ["17"]
    assert c["xyz"].tolist() == [[1.0, 2.0, 3.0]] and c["std"].tolist() == [[0.01, 0.01, 0.02]]
    assert c["layout"] == ["id", "label", "X", "Y", "Z", "sX", "sY", "sZ"]
    assert c["echo"] == ["line 2: 90 17 1.0 2.0 3.0 0.01 0.01 0.02"]


def test_control_ambiguous_row_is_an_error_naming_the_line(tmp_path):
    # 'id name X Y Z' with a numeric name: before, the name became X and Z a 155 m std
    f = _ctrl(tmp_path, "# id name X Y Z\n\n3 501 12.0 40.0 155.0\n")
    with pytest.raises(InputError, match=r"ctrl.txt: line 3: 4 numbers after the id are ambig"):
        read_control_points(f)
    c = read_control_points(f, columns="id,label,X,Y,Z")
    assert c["label"] == ["501"] and c["xyz"].tolist() == [[12.0, 40.0, 155.0]]
    assert c["std"].tolist() == [[0.0, 0.0, 0.0]]
    h = read_control_points(_ctrl(tmp_path, "id;X;Y;Z;s\n3;12;40;155;0.01\n", "h.csv"))
    assert h["header"] and h["std"].tolist() == [[0.01] * 3] and h["label"] == ["3"]


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("1 A 0 0 0\n0 B 1 0 0\n", r"line 2: point id 0 is not a positive integer"),
        ("1 A 0 0 0\n-4 B 1 0 0\n", r"line 2: point id -4 is not a positive"),
        ("1 A 0 0 0\n2 B 1 0 0\n1 C 5 5 5\n", r"line 3: point id 1 already given on line 1"),
        ("CP1 0 1 0\n", r"line 1: the first column must be the numeric point id"),
        ("1 A 0 0\n", r"line 1: 2 numbers after the id and label; expected X Y Z, optionally"),
        ("1 A 0 0 0 0.1 0.2\n", r"line 1: 5 numbers"),
        ("1 A 0 0 0 -0.1\n", r"line 1: negative standard deviation"),
        ("1 A 0 0 x\n", r"line 1: 'x' is not a number"),
        ("id,name,east,X,Y,Z\n1,A,0,0,0,0\n", r"line 1: unknown column 'east'"),
        ("id,X,Y,Z\n1,0,0\n", r"line 2: 3 values for the 4 columns"),
        ("# nothing\n", r"no control point"),
    ],
)
def test_control_grammar_errors(tmp_path, text, match):
    with pytest.raises(InputError, match=match):
        read_control_points(_ctrl(tmp_path, text))


def test_cli_control_error_message_is_whole(tiny, tmp_path, capsys):
    project, _ = tiny
    f = write_pmexport(project, tmp_path / "pm.txt")
    bad = _ctrl(tmp_path, "1 A 0 0\n")
    assert main(["bundle", str(f), "--control", str(bad), "-o", str(tmp_path / "o")]) == 2
    err = " ".join(capsys.readouterr().err.split())
    assert "expected X Y Z, optionally followed by s or by sX sY sZ" in err


def test_control_file_echoed_in_report(tiny, tmp_path):
    project, _ = tiny
    ctrl = np.flatnonzero(project.point_role == "control")
    rows = [f"{project.point_ids[k]},CP{j},{x},{y},{z}" for j, (k, (x, y, z)) in
            enumerate(zip(ctrl, project.xyz[ctrl], strict=True))]  # fmt: skip
    f = _ctrl(tmp_path, "# Id,Name,X,Y,Z\n" + "\n".join(rows) + "\n")
    proj = project.with_control(read_control_points(f))
    res = bundle_adjust(proj)
    text = report_text(res)
    assert "Control file:" in text and "positional grammar" in text
    assert f"line 2: {rows[0]}" in text
    assert report_dict(res)["control_file"]["n_control"] == len(ctrl)


# --- gross control points ----------------------------------------------------------------


def test_gross_control_point_named_before_and_after(tiny):
    project, _ = tiny
    ctrl = np.flatnonzero(project.point_role == "control")
    bad_id = int(project.point_ids[ctrl[2]])
    xyz = project.xyz.copy()
    xyz[ctrl[2], 0] += 20.0  # the coordinates are 20 m from where the images put the point
    # the adjustment stalls; the diagnosis names the point
    with (
        pytest.warns(BundleWarning, match=rf"before the adjustment: {bad_id} \("),
        pytest.raises(EstimationError, match=rf"before the adjustment \[{bad_id}\]") as exc,
    ):
        bundle_adjust(project.replace(xyz=xyz))
    assert exc.value.diagnosis["control_test_before"]["gross"] == [bad_id]
    # 3 m off: the adjustment converges; named before and after (first = most discrepant)
    xyz[ctrl[2], 0] -= 17.0
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", BundleWarning)
        res = bundle_adjust(project.replace(xyz=xyz))
    said = [str(w.message) for w in caught]
    assert any(f"before the adjustment: {bad_id} (" in m for m in said), said
    assert any(f"after the adjustment: {bad_id} (" in m for m in said), said
    assert res.diagnosis["control_test_before"]["gross"] == [bad_id]
    assert res.diagnosis["control_test_after"]["gross"][0] == bad_id
    d = report_dict(res)
    assert d["gross_control_points"]["before"] == [bad_id]
    assert (
        f"Gross control/check point(s) before the adjustment (most discrepant first): {bad_id}."
        in report_text(res)
    )


def test_clean_network_has_no_gross_control_point(tiny):
    project, _ = tiny
    res = bundle_adjust(project)
    assert res.diagnosis["control_test_before"]["gross"] == []
    assert res.diagnosis["control_test_after"]["gross"] == []
    assert len(res.diagnosis["control_test_after"]["points"]) == int(
        (project.point_role == "control").sum()
    )


# --- duplicates and silent switches ---------------------------------------------------------


def test_duplicate_point_and_image_ids_are_errors(tiny):
    project, _ = tiny
    ids = project.point_ids.copy()
    ids[5] = ids[4]
    with pytest.raises(InputError, match=rf"point id\(s\) \[{ids[4]}\] occur more than once"):
        bundle_adjust(project.replace(point_ids=ids))
    im = project.image_ids.copy()
    im[1] = im[0]
    with pytest.raises(InputError, match=r"image id\(s\) \[1\] occur more than once"):
        bundle_adjust(project.replace(image_ids=im))


def test_duplicate_measurements_and_images_warn(tiny):
    project, _ = tiny
    dup = np.r_[np.arange(project.n_observations), [0, 1]]
    proj = project.replace(
        obs_image=project.obs_image[dup], obs_point=project.obs_point[dup],
        obs_uv_px=project.obs_uv_px[dup], obs_std_px=project.obs_std_px[dup],
        image_names=(project.image_names[1], *project.image_names[1:]),
    )  # fmt: skip
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", BundleWarning)
        res = bundle_adjust(proj, BundleParameters(covariance=False))
    text = " ".join(str(w.message) for w in caught)
    assert "2 duplicate image measurement(s)" in text
    assert "used by more than one image" in text
    assert res.project.n_observations == project.n_observations


def test_duplicate_control_ids(tiny, tmp_path):
    project, _ = tiny
    ctrl = {"id": np.array([1, 1]), "label": ["a", "b"], "xyz": np.zeros((2, 3)),
            "std": np.zeros((2, 3)), "role": ["control", "control"], "source": "c.txt"}  # fmt: skip
    with pytest.raises(InputError, match=r"c.txt: control point id\(s\) \[1\] given more than"):
        project.with_control(ctrl)
    # the same in a PhotoModeler export's control block: the lines are named
    f = write_pmexport(project, tmp_path / "pm.txt")
    lines = f.read_text().splitlines()
    k = int(np.flatnonzero(project.point_role == "control")[1])
    x, y, z = project.xyz[k]
    row = f"{project.point_ids[k]} {x:.6f} {y:.6f} {z:.6f} 0 0 0"
    lines.insert(lines.index(row) + 1, row)
    f.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError, match=r"control point id \d+ is given twice .*lines \d+, \d+"):
        read_photomodeler(f)


def test_affinity_under_model_1_warns(tiny):
    project, _ = tiny
    proj = project.with_model(1)
    with pytest.warns(BundleWarning, match="as requested but lens model 1 has no affinity"):
        bundle_adjust(
            proj,
            BundleParameters(
                estimate_io=("cc", "px", "py", "as", "K1", "K2", "P1", "P2"), covariance=False
            ),
        )


def test_no_control_warns_about_the_depend_datum(tiny):
    project, _ = tiny
    free = project.replace(
        point_role=np.full(project.n_points, "tie"), xyz=np.full_like(project.xyz, np.nan),
        xyz_std=np.full_like(project.xyz_std, np.nan), datum=None,
    )  # fmt: skip
    with pytest.warns(BundleWarning, match=r"0 fixed or weighted control point.*'depend'"):
        res = bundle_adjust(free, BundleParameters(covariance=False))
    assert res.network.datum == "depend"


def test_measurement_of_undefined_point_warns(tiny, tmp_path):
    project, _ = tiny
    f = write_pmexport(project, tmp_path / "pm.txt", extra_marks=["0 99999 10.0 10.0 1 1"])
    with pytest.warns(BundleWarning, match=r"1 image measurement\(s\) of point id\(s\) \[99999\]"):
        read_photomodeler(f, model=3)


# --- failed runs ------------------------------------------------------------------------------


def test_failed_run_carries_its_diagnosis(tiny):
    project, _ = tiny
    with pytest.raises(EstimationError, match="did not converge") as exc:
        bundle_adjust(project, BundleParameters(max_iterations=1))
    diag = exc.value.diagnosis
    assert diag["failed"] and diag["iterations"] == 1
    assert len(diag["residual_norm_history"]) == 2 and len(diag["worst_observations"]) == 20
    assert (
        diag["worst_observations"][0]["weighted_residual"]
        >= diag["worst_observations"][1]["weighted_residual"]
    )


def test_rank_deficient_run_carries_its_diagnosis(tiny):
    project, _ = tiny
    free = project.replace(
        point_role=np.full(project.n_points, "tie"), xyz=np.full_like(project.xyz, np.nan),
        xyz_std=np.full_like(project.xyz_std, np.nan),
    )  # fmt: skip
    with pytest.raises(DegenerateGeometryError, match="rank deficient") as exc:
        bundle_adjust(free, BundleParameters(datum="free"))
    assert len(exc.value.diagnosis["rank_deficiency"]) == 7


def test_cli_failed_run_writes_diagnosis(tiny, tmp_path):
    project, _ = tiny
    f = write_pmexport(project, tmp_path / "pm.txt")
    out = tmp_path / "o"
    args = ["bundle", str(f), "--model", "3", "--estimate", "cc,px,py,K1,K2,P1,P2",
            "--max-iterations", "1", "--no-plots", "-o", str(out)]  # fmt: skip
    assert main(args) == 1
    rep = json.loads((out / "report.json").read_text())
    assert rep["failed"] and rep["diagnosis"]["iterations"] == 1
    assert rep["diagnosis"]["worst_observations"]
    text = (out / "report.txt").read_text()
    assert "Bundle adjustment FAILED" in text and "Worst observations" in text
    assert (out / "run.json").is_file()


# --- data snooping ------------------------------------------------------------------------------


def test_tau_test_uses_the_posterior_sigma(tiny):
    project, _ = tiny
    # a priori sigma half the true noise: sigma0 ~ 2, the w-test flags clean observations
    proj = project.replace(obs_std_px=project.obs_std_px / 2)
    res = bundle_adjust(proj)
    assert 1.8 < res.sigma0 < 2.2
    w = data_snooping(res, test="w")
    tau = data_snooping(res, test="tau")
    assert w["n_flagged"] > 10 * max(tau["n_flagged"], 1)
    assert tau["n_flagged"] <= 5
    assert tau["critical"] == pytest.approx(tau_critical(res.redundancy, 0.001))
    res_tau = bundle_adjust(proj, BundleParameters(snooping="tau"))
    text = report_text(res_tau)
    assert "Data snooping (Pope tau test (posterior sigma0 = " in text
    assert "Data snooping (Baarda w-test (a priori" in report_text(res)
    assert report_dict(res_tau)["data_snooping"]["test"] == "tau"
    with pytest.raises(InputError, match="unknown data snooping test"):
        BundleParameters(snooping="t")


def test_tau_critical_value():
    from scipy.stats import norm

    assert tau_critical(10**7) == pytest.approx(norm.ppf(1 - 0.0005), rel=1e-6)
    assert tau_critical(50) < tau_critical(10**5)  # bounded by sqrt(r) for small r
    assert tau_critical(4) < 2.0


def test_report_json_lists_every_object_point(tiny):
    project, _ = tiny
    res = bundle_adjust(project)
    op = report_dict(res)["object_points"]
    assert len(op["id"]) == project.n_points == len(op["xyz"]) == len(op["std"])
    k = int(np.flatnonzero(project.point_role == "tie")[0])
    assert op["xyz"][k] == pytest.approx(res.xyz[k].tolist())
    assert op["std"][k] == pytest.approx(res.xyz_std[k].tolist())


# --- initialisation with scarce control ----------------------------------------------------


def test_scarce_control_starts_by_relative_orientation():
    """No image has an orientation and 3 control points only: before, 'image 1 sees only
    N control points'; now essential matrix + resection on the growing block."""
    project, truth = make_network(
        NetworkParameters(n_images=10, n_points=400, n_control=3, control_std_m=0.0), rng=7
    )
    blind = project.replace(eo=np.full_like(project.eo, np.nan))
    with pytest.warns(BundleWarning, match=r"initialised by relative orientation of images"):
        res = bundle_adjust(blind)
    assert 0.9 < res.sigma0 < 1.2
    assert np.abs(res.eo[:, :3] - truth["eo"][:, :3]).max() < 0.05


def test_essential_pose_recovers_relative_orientation(rng):
    from pyheracles.bundle.camera import rotation_matrix
    from pyheracles.bundle.initial import essential_pose

    x1 = rng.uniform([-2, -2, -12], [2, 2, -8], (30, 3))  # in front of camera 1 (-z)
    rot = rotation_matrix(np.array([[0.05, -0.2, 0.1]]))[0]
    t = np.array([1.0, 0.2, -0.1])
    x2 = x1 @ rot.T + t
    r_est, t_est = essential_pose(x1, x2)
    assert np.allclose(r_est, rot, atol=1e-8)
    assert np.allclose(t_est, t / np.linalg.norm(t), atol=1e-8)


def test_disconnected_image_is_named(tiny):
    project, _ = tiny
    # image 10 keeps only 4 of its points: not resectable from the block
    keep = (project.obs_image != 9) | (np.cumsum(project.obs_image == 9) <= 4)
    proj = project.replace(
        eo=np.full_like(project.eo, np.nan), obs_image=project.obs_image[keep],
        obs_point=project.obs_point[keep], obs_uv_px=project.obs_uv_px[keep],
        obs_std_px=project.obs_std_px[keep],
    )  # fmt: skip
    with (
        warnings.catch_warnings(),
        pytest.raises(DegenerateGeometryError, match=r"image\(s\) \[10\] see fewer than 6"),
    ):
        warnings.simplefilter("ignore", BundleWarning)
        bundle_adjust(proj)
