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
