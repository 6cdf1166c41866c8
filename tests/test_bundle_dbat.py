"""Bundle adjustment against DBAT's own reports (../shared/data/dbat), same input and settings.

Tolerances of issue 6: sigma0 within 0.5 %, camera parameters and exterior
orientations within 0.1 of DBAT's standard deviation, posterior standard
deviations within 2 %, the same high-correlation pairs.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from pyheracles.bundle import BundleParameters, BundleWarning, bundle_adjust, read_project
from pyheracles.bundle.dbatreport import compare_with_dbat, read_dbat_report
from pyheracles.bundle.readers import (
    read_camera_positions,
    read_control_points,
    read_photomodeler,
)
from pyheracles.errors import DegenerateGeometryError, InputError

pytestmark = pytest.mark.realdata

CAMCAL_IO = ("cc", "px", "py", "as", "K1", "K2", "K3", "P1", "P2")


def _check(result, report_path, *, std_tol=0.02):
    cmp = compare_with_dbat(result, read_dbat_report(report_path))
    assert cmp["sigma0_rel"] < 0.005, cmp
    assert cmp["max_param_diff_over_std"] < 0.1, cmp
    # DBAT prints deviations with 3 significant digits (up to 0.5 % rounding).
    assert cmp["max_std_ratio_dev"] < std_tol, cmp
    assert cmp["camera_correlations_match"], cmp
    matched, total = cmp["photo_correlations_matched"]
    assert matched == total, cmp
    return cmp


def test_camcaldemo_script(shared_data):
    root = shared_data / "dbat" / "script" / "camcaldemo"
    res = bundle_adjust(read_project(root / "camcaldemo.xml"))
    rep = read_dbat_report(root / "result" / "report.txt")
    assert res.redundancy == rep.redundancy == 3725
    assert res.n_parameters == rep.n_params
    _check(res, root / "result" / "report.txt")


def test_romabundledemo_script(shared_data):
    """181 k observations, dependent relative orientation, self-calibration (~6 s)."""
    root = shared_data / "dbat" / "script" / "romabundledemo"
    res = bundle_adjust(read_project(root / "romabundledemo.xml"))
    rep = read_dbat_report(root / "result" / "report.txt")
    assert res.redundancy == rep.redundancy == 101801
    assert res.iterations == rep.iterations == 5
    assert res.sigma0 == pytest.approx(0.582769, rel=1e-5)
    _check(res, root / "result" / "report.txt")
    # Same sum of squares as DBAT's "Last error" (185.94).
    assert res.history["residual_norm"][-1] == pytest.approx(185.94, abs=0.01)


@pytest.mark.parametrize(
    ("export", "report", "model"),
    [
        ("camcal-pmexport.txt", "camcal-dbatreport.txt", 3),
        ("camcal-pmexport.txt", "camcal-dbatreport-model-1.txt", -1),
        ("camcal-pmexport.txt", "camcal-dbatreport-model1.txt", 1),
        ("camcal-pmexport.txt", "camcal-dbatreport-model2.txt", 2),
        ("camcal-pmexport.txt", "camcal-dbatreport-model3.txt", 3),
        ("camcal-pmexport.txt", "camcal-dbatreport-model4.txt", 4),
        ("camcal-pmexport.txt", "camcal-dbatreport-model5.txt", 5),
        ("camcal-pmexport5.txt", "camcal-dbatreport5.txt", 3),
    ],
)
def test_photomodeler_camcal(shared_data, export, report, model):
    root = shared_data / "dbat" / "dbat"
    ctrl = read_control_points(root / "ref" / "camcal-fixed.txt")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", BundleWarning)
        project = (
            read_photomodeler(root / "pmexports" / export, model=model)
            .with_control(ctrl)
            .with_default_io(7.3)
        )
        res = bundle_adjust(project, BundleParameters(estimate_io=CAMCAL_IO))
    said = [str(w.message) for w in caught]
    # Said, not silent: the 5-point export measures points it does not define; lens
    # models without affinity drop the requested 'as' (DBAT drops it too).
    expected = []
    if export == "camcal-pmexport5.txt":
        expected.append("image measurement(s) of point id(s)")
    if model in (-1, 1, 2):
        expected.append(f"as requested but lens model {model} has no affinity")
    assert len(said) == len(expected) and all(
        e in m for e, m in zip(expected, said, strict=True)
    ), said
    _check(res, root / "dbatexports" / report)


def _prague(shared_data, sub, stub, orient, weighted):
    root = shared_data / "dbat" / "prague2016" / sub
    project = read_photomodeler(root / "pmexports" / f"{stub}-{orient}-pmexport.txt", model=1)
    ctrl = read_control_points(root / "ref" / f"ctrlpts-{'weighted' if weighted else 'fixed'}.txt")
    # As DBAT's prague2016_pm demo: shift the reference to PhotoModeler's control frame.
    pm = project.point_role == "control"
    ids = project.point_ids[pm]
    k = np.clip(np.searchsorted(ctrl["id"], ids), 0, len(ctrl["id"]) - 1)
    ok = ctrl["id"][k] == ids
    ctrl["xyz"] = ctrl["xyz"] + (project.xyz[pm][ok] - ctrl["xyz"][k[ok]]).mean(axis=0)
    return project.with_control(ctrl), root / "dbatexports" / f"{stub}-{orient}-dbatreport.txt"


@pytest.mark.parametrize("orient", ["no-orient", "with-orient"])
@pytest.mark.parametrize(
    ("sub", "stub", "weighted"),
    [
        ("cam", "fixed", False),
        ("cam", "weighted", True),
        ("sxb", "f-op0", False),
        ("sxb", "w-op0", True),
        ("sxb", "w-op1", True),
        ("sxb", "wsmart", True),
    ],
)
def test_prague2016_photomodeler(shared_data, sub, stub, weighted, orient):
    project, report = _prague(shared_data, sub, stub, orient, weighted)
    res = bundle_adjust(project, BundleParameters(estimate_io=()))
    assert res.redundancy == read_dbat_report(report).redundancy
    _check(res, report)


@pytest.mark.parametrize("prior", [False, True])
def test_sxb_prior_camera_positions(shared_data, prior):
    """DBAT's sxb_prior_eo demo: world-frame control, optional GNSS-like camera positions."""
    root = shared_data / "dbat" / "prague2016" / "sxb"
    project = read_photomodeler(root / "pmexports" / "wsmart-with-orient-pmexport.txt", model=1)
    project = project.with_control(read_control_points(root / "ref" / "ctrlpts-weighted.txt"))
    # The export is in PhotoModeler's local frame: re-initialise by resection (as DBAT).
    project = project.replace(needs_resection=True)
    if prior:
        positions = read_camera_positions(root / "ref" / "fake-camera-positions.txt")
        project = project.with_prior_positions(positions)
    res = bundle_adjust(project, BundleParameters(estimate_io=()))
    report = root / "dbatexports" / f"sxb-{'prior-eo' if prior else 'no-prior-eo'}-dbatreport.txt"
    rep = read_dbat_report(report)
    assert res.n_observations == rep.n_observations
    assert res.redundancy == rep.redundancy
    _check(res, report)


def test_photoscan_sxb(shared_data):
    """PhotoScan project re-processed by DBAT (markers 0.1 px, tie points 1 px, weighted GCP)."""
    root = shared_data / "dbat" / "prague2016" / "sxb" / "psprojects"
    project = read_project(root / "sxb.psz")
    assert (project.n_images, project.n_points) == (5, 1182)
    res = bundle_adjust(project, BundleParameters(estimate_io=()))
    rep = read_dbat_report(root / "sxb-dbatreport.txt")
    assert res.redundancy == rep.redundancy == 4604
    assert res.n_observations == rep.n_observations == 8180
    _check(res, root / "sxb-dbatreport.txt")


def test_unreadable_photoscan(tmp_path):
    bad = tmp_path / "x.psz"
    bad.write_bytes(b"PK not really a zip")
    with pytest.raises(InputError, match="unreadable PhotoScan project"):
        read_project(bad)


def test_camcal_without_datum_names_rank_deficiency(shared_data):
    """DBAT's no-datum demo fails with a numerical rank deficiency of 7."""
    root = shared_data / "dbat" / "dbat"
    project = read_photomodeler(root / "pmexports" / "camcal-pmexport.txt", model=3)
    with pytest.raises(DegenerateGeometryError, match="rank defect 7") as exc:
        bundle_adjust(
            project.with_default_io(7.3),
            BundleParameters(estimate_io=CAMCAL_IO, datum="free"),
        )
    assert "datum is undefined" in str(exc.value)


def test_camcal_missing_observations_dropped_with_warning(shared_data):
    """DBAT fails structurally (deficiency 6): points 13 and 60 lost all observations.

    We drop the two points with a warning and adjust the rest.
    """
    root = shared_data / "dbat" / "dbat"
    ctrl = read_control_points(root / "ref" / "camcal-fixed.txt")
    project = read_photomodeler(root / "pmexports" / "camcal-pmexport-missing-obs.txt", model=3)
    with pytest.warns(BundleWarning, match=r"2 point\(s\) without image observations"):
        res = bundle_adjust(project.with_control(ctrl), BundleParameters(estimate_io=CAMCAL_IO))
    assert 13 not in res.project.point_ids and 60 not in res.project.point_ids
    assert res.n_parameters == 423 - 6


def test_camcal_one_ray_point_dropped_with_warning(shared_data):
    """DBAT fails structurally (deficiency 1); we drop the one-ray point and warn."""
    root = shared_data / "dbat" / "dbat"
    ctrl = read_control_points(root / "ref" / "camcal-fixed.txt")
    project = read_photomodeler(root / "pmexports" / "camcal-pmexport-1ray.txt", model=3)
    with pytest.warns(BundleWarning, match="fewer than 2 images dropped"):
        res = bundle_adjust(project.with_control(ctrl), BundleParameters(estimate_io=CAMCAL_IO))
    assert res.converged


def test_unreadable_dbat_report(tmp_path):
    bad = tmp_path / "report.txt"
    bad.write_text("something else")
    with pytest.raises(InputError, match="not a DBAT report"):
        read_dbat_report(bad)
