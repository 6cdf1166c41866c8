"""CLI: heracles register / georef / checkpoints on the generated church."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from pyheracles.cli import main
from pyheracles.io import read_cloud, write_cloud
from pyheracles.registration.points import PointList, write_points
from pyheracles.registration.targets import measure_spheres
from pyheracles.registration.transform import apply_to_points, read_transform_json
from pyheracles.synthetic.church import ChurchParams, make_church


@pytest.fixture(scope="module")
def files(tmp_path_factory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("church")
    s = make_church(ChurchParams(spacing_m=0.3, window_spacing_m=0.1), rng=5)
    write_cloud(s.exterior, d / "exterior.laz")
    write_cloud(s.interior, d / "interior.laz")
    write_points(d / "ties_ext.csv", s.manual_ties_exterior)
    write_points(d / "ties_int.csv", s.manual_ties_interior)
    write_points(d / "control.csv", s.control)
    write_points(d / "check.csv", s.check)
    # sphere centres measured in the clouds (the operator's targets list)
    write_points(
        d / "targets_ext.csv", measure_spheres(s.exterior, s.targets_exterior, 0.0725 * 0.8)
    )
    write_points(d / "targets_int.csv", measure_spheres(s.interior, s.targets_interior, 0.0725))
    np.save(d / "T_ext_int.npy", s.T_exterior_interior)
    np.save(d / "T_world_int.npy", s.T_world_interior)
    return {p.stem: p for p in d.iterdir()} | {"dir": d}


def test_register_with_manual_tie_points(files, tmp_path: Path) -> None:
    out = tmp_path / "reg"
    code = main(
        ["register", str(files["interior"]), str(files["exterior"]),
         "--tiepoints", str(files["ties_int"]), "--tiepoints", str(files["ties_ext"]),
         "-o", str(out)]
    )  # fmt: skip
    assert code == 0
    T = read_transform_json(out / "transform.json")
    T_true = np.load(files["T_ext_int"])
    probe = read_cloud(files["interior"]).world_xyz()[::997]
    err = apply_to_points(T, probe) - apply_to_points(T_true, probe)
    assert np.abs(err).max() < 0.02  # 1 cm picking noise, 36 tie points
    data = json.loads((out / "transform.json").read_text())
    assert data["estimation"]["std"]["kappa"] > 0
    assert (out / "interior_registered.laz").is_file() and (out / "run.json").is_file()


def test_georef_block_then_checkpoints(files, tmp_path: Path) -> None:
    geo = tmp_path / "geo"
    # tie points join the measured target lists (ids shared by both clouds)
    for side in ("ext", "int"):
        from pyheracles.registration.points import read_points

        t, m = read_points(files[f"ties_{side}"]), read_points(files[f"targets_{side}"])
        write_points(
            files["dir"] / f"meas_{side}.csv",
            PointList(m.ids + t.ids, np.vstack([m.xyz, t.xyz]), np.vstack([m.sigma, t.sigma])),
        )
    code = main(
        ["georef", str(files["exterior"]), str(files["interior"]),
         "--control", str(files["control"]),
         "--measured", str(files["dir"] / "meas_ext.csv"),
         "--measured", str(files["dir"] / "meas_int.csv"),
         "--strategy", "block", "--rigid", "interior", "-o", str(geo)]
    )  # fmt: skip
    assert code == 0
    T = read_transform_json(geo / "transform_interior.json")
    np.testing.assert_allclose(T, np.load(files["T_world_int"]), atol=0.005)
    qc = tmp_path / "qc"
    code = main(
        ["checkpoints", str(geo / "interior_georef.laz"), "--points", str(files["check"]),
         "--sphere-radius", "0.0725", "-o", str(qc)]
    )  # fmt: skip
    # the exterior check spheres are not in the interior cloud: a clear error
    assert code == 2
    int_check = files["dir"] / "check_int.csv"
    from pyheracles.registration.points import read_points

    chk = read_points(files["check"])
    write_points(int_check, chk.select([i for i in chk.ids if i.startswith("CHK_I")]))
    code = main(
        ["checkpoints", str(geo / "interior_georef.laz"), "--points", str(int_check),
         "--sphere-radius", "0.0725", "-o", str(qc)]
    )  # fmt: skip
    assert code == 0
    rep = json.loads((qc / "checkpoints.json").read_text())
    assert rep["rms_m"]["3d"] < 0.03  # targets fitted in a LAZ quantised at 1 mm
    assert (qc / "residual_map.png").read_bytes()[:4] == b"\x89PNG"


def test_bad_inputs_exit_2(files, tmp_path: Path, capsys) -> None:
    two = tmp_path / "two.csv"
    two.write_text("id,X,Y,Z\nA,0,0,0\nB,1,0,0\n")
    code = main(
        ["register", str(files["interior"]), str(files["exterior"]),
         "--tiepoints", str(two), "--tiepoints", str(two), "-o", str(tmp_path / "x")]
    )  # fmt: skip
    assert code == 2
    assert "at least 3" in capsys.readouterr().err
    code = main(
        ["register", str(files["interior"]), str(files["exterior"]),
         "--tiepoints", str(files["ties_int"]), "--tiepoints", str(files["control"]),
         "-o", str(tmp_path / "y")]
    )  # fmt: skip
    assert code == 2
    assert "unmatched point ids" in capsys.readouterr().err
    code = main(
        ["register", str(files["interior"]), str(files["exterior"]), "-o", str(tmp_path / "z")]
    )
    assert code == 2


@pytest.mark.realdata
def test_register_bunny_with_icp(shared_data: Path, tmp_path: Path) -> None:
    """Real scans: rough tie points (1 cm noise) then ICP reach the published pose."""
    from test_registration_icp import bunny_poses

    folder = shared_data / "bunny"
    poses = bunny_poses(folder)
    T_true = np.linalg.inv(poses["bun000.ply"]) @ poses["bun045.ply"]
    src = read_cloud(folder / "bun045.ply").world_xyz()
    rng = np.random.default_rng(3)
    pick = src[rng.choice(len(src), 6, replace=False)]
    ids = [f"P{i}" for i in range(6)]
    write_points(tmp_path / "s.csv", PointList(ids, pick))
    write_points(
        tmp_path / "t.csv",
        PointList(ids, apply_to_points(T_true, pick) + rng.normal(0, 0.002, pick.shape)),
    )
    out = tmp_path / "reg"
    code = main(
        ["register", str(folder / "bun045.ply"), str(folder / "bun000.ply"),
         "--tiepoints", str(tmp_path / "s.csv"), "--tiepoints", str(tmp_path / "t.csv"),
         "--model", "rigid", "--estimator", "lsq", "--icp", "-o", str(out)]
    )  # fmt: skip
    assert code == 0
    T = read_transform_json(out / "transform.json")
    err = apply_to_points(T, src[::50]) - apply_to_points(T_true, src[::50])
    assert np.abs(err).max() < 1e-3  # metres; the tie points alone are off by ~2 mm
    icp_report = json.loads((out / "transform.json").read_text())["icp"]
    assert icp_report["converged"] and icp_report["overlap_fraction"] > 0.8


# ----------------------------------------------------------------------------- issue 15
def test_georef_and_register_write_the_given_crs(files, tmp_path: Path, capsys) -> None:
    from pyheracles.registration.points import read_points

    meas = []
    for side in ("ext", "int"):
        t, m = read_points(files[f"ties_{side}"]), read_points(files[f"targets_{side}"])
        meas.append(tmp_path / f"meas_{side}.csv")
        write_points(
            meas[-1],
            PointList(m.ids + t.ids, np.vstack([m.xyz, t.xyz]), np.vstack([m.sigma, t.sigma])),
        )
    args = ["georef", str(files["exterior"]), str(files["interior"]),
            "--control", str(files["control"]), "--measured", str(meas[0]),
            "--measured", str(meas[1]), "--strategy", "block", "--rigid", "interior"]  # fmt: skip
    assert main([*args, "--crs", "EPSG:2154", "-o", str(tmp_path / "geo")]) == 0
    assert read_cloud(tmp_path / "geo" / "interior_georef.laz").crs.to_epsg() == 2154
    tj = json.loads((tmp_path / "geo" / "transform_interior.json").read_text())
    assert tj["target_crs"] == "EPSG:2154"
    assert json.loads((tmp_path / "geo" / "georef.json").read_text())["crs"] == "EPSG:2154"
    assert json.loads((tmp_path / "geo" / "run.json").read_text())["crs"] == "EPSG:2154"
    # without --crs the outputs have none, and the run says so
    capsys.readouterr()
    assert main([*args, "-o", str(tmp_path / "geo2")]) == 0
    assert "give no CRS: the outputs have none (use --crs)" in capsys.readouterr().err
    assert read_cloud(tmp_path / "geo2" / "interior_georef.laz").crs is None
    # a bad CRS: exit 2 before any work, no output
    assert main([*args, "--crs", "Lambert-93", "-o", str(tmp_path / "geo3")]) == 2
    assert "--crs 'Lambert-93' is not a coordinate reference system" in capsys.readouterr().err
    assert not (tmp_path / "geo3").exists()
    # register: the target's CRS (none here) or --crs
    reg = ["register", str(files["interior"]), str(files["exterior"]), "--tiepoints",
           str(files["ties_int"]), "--tiepoints", str(files["ties_ext"])]  # fmt: skip
    assert main([*reg, "--crs", "EPSG:32631", "-o", str(tmp_path / "reg")]) == 0
    assert read_cloud(tmp_path / "reg" / "interior_registered.laz").crs.to_epsg() == 32631
    tj = json.loads((tmp_path / "reg" / "transform.json").read_text())
    assert tj["target_crs"] == "EPSG:32631"
    assert main([*reg, "--crs", "nowhere", "-o", str(tmp_path / "reg2")]) == 2


def test_checkpoints_without_output_folder_and_in_another_frame(files, tmp_path, capsys):
    from pyheracles.registration.points import read_points

    chk = read_points(files["check"])
    int_check = tmp_path / "check_int.csv"
    write_points(int_check, chk.select([i for i in chk.ids if i.startswith("CHK_I")]))
    # world check points for the interior scan in its scanner frame: a clear error
    code = main(["checkpoints", str(files["interior"]), "--points", str(int_check),
                 "--sphere-radius", "0.0725"])  # fmt: skip
    assert code == 2
    err = " ".join(capsys.readouterr().err.split())
    assert "none of the 5 points lies within the cloud interior.laz" in err
    assert "another frame" in err
    # in the scanner frame, without -o: the residuals are shown and the user told
    local = tmp_path / "check_int_local.csv"
    T = np.linalg.inv(np.load(files["T_world_int"]))
    world = read_points(int_check)
    write_points(local, PointList(world.ids, apply_to_points(T, world.xyz)))
    code = main(["checkpoints", str(files["interior"]), "--points", str(local),
                 "--sphere-radius", "0.0725"])  # fmt: skip
    assert code == 0
    captured = capsys.readouterr()
    assert "RMS" in captured.out
    assert "no output folder given: nothing written (use -o DIR)" in captured.err


def _readme_commands(*names: str) -> list[list[str]]:
    """The ``heracles NAME ...`` commands of the README's QC-2 example block."""
    import shlex

    text = (Path(__file__).resolve().parents[1] / "README.md").read_text(encoding="utf-8")
    block = text.split("## QC-2")[1].split("```bash")[1].split("```")[0]
    lines = block.replace("\\\n", " ").splitlines()
    out = []
    for line in lines:
        words = shlex.split(line, comments=True)
        if words[:1] == ["heracles"] and words[1] in names:
            out.append(words[1:])
    return out


def test_readme_georef_and_checkpoints_example_runs(tmp_path: Path, monkeypatch) -> None:
    """Issue 15, defect 17: the README's georef + checkpoints commands, verbatim, on the
    generated church written under the README's file names."""
    from pyheracles.registration.points import read_points

    s = make_church(ChurchParams(spacing_m=0.3, window_spacing_m=0.1), rng=5)
    write_cloud(s.exterior, tmp_path / "exterior.laz")
    write_cloud(s.interior, tmp_path / "interior.laz")
    write_points(tmp_path / "gcp.csv", s.control)
    for side, cloud, targets, ties, radius in (
        ("ext", s.exterior, s.targets_exterior, s.manual_ties_exterior, 0.0725 * 0.8),
        ("int", s.interior, s.targets_interior, s.manual_ties_interior, 0.0725),
    ):
        m = measure_spheres(cloud, targets, radius)  # sphere centres measured in the cloud
        write_points(
            tmp_path / f"{side}_targets.csv",
            PointList(m.ids + ties.ids, np.vstack([m.xyz, ties.xyz]),
                      np.vstack([m.sigma, ties.sigma])),
        )  # fmt: skip
    write_points(
        tmp_path / "chk_interior.csv", s.check.select([i for i in s.check.ids if "_I" in i])
    )
    commands = _readme_commands("georef", "checkpoints")
    assert [c[0] for c in commands] == ["georef", "checkpoints"]
    monkeypatch.chdir(tmp_path)
    for command in commands:
        assert main(command) == 0, command
    rep = json.loads((tmp_path / "qc" / "checkpoints.json").read_text())
    assert rep["n_points"] == 5 and rep["rms_m"]["3d"] < 0.03
    assert read_points(tmp_path / "chk_interior.csv").ids == tuple(p["id"] for p in rep["points"])
