"""``heracles bundle`` end to end on the DBAT camera calibration script."""

from __future__ import annotations

import json

import pytest

from pyheracles.cli import main

pytestmark = pytest.mark.realdata


def test_cli_bundle_camcaldemo(shared_data, tmp_path):
    script = shared_data / "dbat" / "script" / "camcaldemo" / "camcaldemo.xml"
    out = tmp_path / "camcal"
    assert main(["bundle", str(script), "-o", str(out)]) == 0
    rep = json.loads((out / "report.json").read_text())
    assert rep["sigma0"] == pytest.approx(1.6148, rel=1e-4)
    assert rep["redundancy"] == 3725
    cam = rep["cameras"][0]
    assert cam["values"]["cc"] == pytest.approx(7.457, abs=0.1 * 0.00105)
    assert cam["std"]["K1"] == pytest.approx(2.21e-05, rel=0.02)
    assert [c["pair"] for c in cam["high_correlations"]] == [["K2", "K3"]]
    assert len(rep["images"]) == 21 and len(rep["control_points"]["points"]) == 4
    text = (out / "report.txt").read_text()
    assert "Sigma0:                 1.6148" in text
    assert "Correlations over 95%: K3:-97.9%." in text
    for name in ("radial_distortion.png", "eo_std_hist.png", "image_stats.png", "run.json"):
        assert (out / name).stat().st_size > 0


def test_cli_bundle_photomodeler_with_control(shared_data, tmp_path):
    root = shared_data / "dbat" / "dbat"
    out = tmp_path / "pm"
    args = ["bundle", str(root / "pmexports" / "camcal-pmexport.txt"), "--control",
            str(root / "ref" / "camcal-fixed.txt"), "--model", "3", "--default-io", "7.3",
            "--estimate", "cc,px,py,as,K1,K2,K3,P1,P2", "--no-plots", "-o", str(out)]  # fmt: skip
    assert main(args) == 0
    rep = json.loads((out / "report.json").read_text())
    assert rep["sigma0"] == pytest.approx(1.6148, rel=1e-4)


def test_cli_bundle_bad_input(tmp_path):
    bad = tmp_path / "nothing.xml"
    bad.write_text("not xml at all <")
    assert main(["bundle", str(bad), "-o", str(tmp_path / "o")]) == 2
    assert main(["bundle", str(tmp_path / "absent.xml"), "-o", str(tmp_path / "o")]) == 2


def test_cli_bundle_prior_positions(shared_data, tmp_path):
    root = shared_data / "dbat" / "prague2016" / "sxb"
    out = tmp_path / "sxb"
    args = ["bundle", str(root / "pmexports" / "wsmart-with-orient-pmexport.txt"),
            "--control", str(root / "ref" / "ctrlpts-weighted.txt"),
            "--positions", str(root / "ref" / "fake-camera-positions.txt"),
            "--resect", "--no-plots", "-o", str(out)]  # fmt: skip
    assert main(args) == 0
    rep = json.loads((out / "report.json").read_text())
    assert rep["sigma0"] == pytest.approx(1.06942, rel=1e-4)  # DBAT sxb-prior-eo report
    assert rep["n_observations"] == 2452


def test_cli_bundle_script_by_relative_path(shared_data, tmp_path, monkeypatch):
    """A DBAT script named relative to the working directory ($HERE was joined twice)."""
    monkeypatch.chdir(shared_data.parent)
    script = (shared_data / "dbat" / "script" / "camcaldemo" / "camcaldemo.xml").relative_to(
        shared_data.parent
    )
    out = tmp_path / "rel"
    assert main(["bundle", str(script), "--no-plots", "-o", str(out)]) == 0
    assert json.loads((out / "report.json").read_text())["redundancy"] == 3725
