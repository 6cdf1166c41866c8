"""report.txt against DBAT 0.9.2's own result files, section by section.

* every heading and every label DBAT prints is in our report (environment lines
  naming DBAT's and MATLAB's versions excepted: ours name pyheracles and Python);
* the numbers of the quality sections (photo coverage, ray counts, residual
  extremes, point angles, control point tables) match DBAT's to its printed
  precision (one unit in DBAT's last printed digit, for rounding at a boundary).
"""

from __future__ import annotations

import json
import re
import warnings

import numpy as np
import pytest

from pyheracles.bundle import BundleParameters, bundle_adjust
from pyheracles.bundle.quality import angle_summary, distortion_significance
from pyheracles.bundle.readers import read_control_points, read_photomodeler
from pyheracles.bundle.report import report_dict, report_text, write_reports

pytestmark = pytest.mark.realdata

CAMCAL_IO = ("cc", "px", "py", "as", "K1", "K2", "K3", "P1", "P2")
# Lines naming DBAT's own software environment: ours name pyheracles and Python.
ENVIRONMENT = {"DBAT version", "MATLAB version"}
_NUM = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")


def _keys(text: str) -> set[tuple[int, str]]:
    """(indent, heading or label) of every line: the text before ': ' or the whole
    line when it has no digit (section headings)."""
    out = set()
    for line in text.splitlines():
        s = line.strip()
        if not s:
            continue
        indent = len(line) - len(line.lstrip())
        m = re.match(r"([^:]*?[A-Za-z)\]][^:]*?)\s*:", s)
        if m and not re.search(r"\d", m.group(1)) and not s.startswith("Photo "):
            out.add((indent, m.group(1)))
        elif not re.search(r"\d", s):
            out.add((indent, s))
    return out


def _section(text: str, start: str, stop: str) -> list[str]:
    lines = text.splitlines()
    i = next(k for k, s in enumerate(lines) if s.strip().startswith(start))
    j = next(k for k in range(i + 1, len(lines)) if lines[k].strip().startswith(stop))
    return lines[i:j]


def _tolerance(token: str) -> float:
    """One unit in the last printed digit of a DBAT number."""
    mant, _, exp = token.lower().partition("e")
    dec = len(mant.split(".")[1]) if "." in mant else 0
    return 10.0 ** (-dec + (int(exp) if exp else 0)) * 1.0001


def _assert_numbers_match(ours: list[str], theirs: list[str], what: str) -> int:
    assert len(ours) == len(theirs), (what, len(ours), len(theirs))
    n = 0
    for a, b in zip(ours, theirs, strict=True):
        ta, tb = _NUM.findall(a), _NUM.findall(b)
        assert len(ta) == len(tb), (what, a, b)
        for x, y in zip(ta, tb, strict=True):
            assert abs(float(x) - float(y)) <= _tolerance(y), (what, a, b)
            n += 1
        # The words around the numbers (labels, ids' context) are DBAT's too.
        assert _NUM.sub("#", a).split() == _NUM.sub("#", b).split(), (what, a, b)
    return n


@pytest.fixture(scope="module")
def camcal(shared_data):
    root = shared_data / "dbat" / "dbat"
    ctrl = read_control_points(root / "ref" / "camcal-fixed.txt")
    project = (
        read_photomodeler(root / "pmexports" / "camcal-pmexport.txt", model=3)
        .with_control(ctrl)
        .with_default_io(7.3)
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = bundle_adjust(project, BundleParameters(estimate_io=CAMCAL_IO))
    return res, (root / "dbatexports" / "camcal-dbatreport.txt").read_text()


@pytest.fixture(scope="module")
def sxb(shared_data):
    """DBAT's sxb_no_prior_eo demo: weighted control in the world frame, resection."""
    root = shared_data / "dbat" / "prague2016" / "sxb"
    project = read_photomodeler(root / "pmexports" / "wsmart-with-orient-pmexport.txt", model=1)
    project = project.with_control(read_control_points(root / "ref" / "ctrlpts-weighted.txt"))
    res = bundle_adjust(project.replace(needs_resection=True), BundleParameters(estimate_io=()))
    return res, (root / "dbatexports" / "sxb-no-prior-eo-dbatreport.txt").read_text()


@pytest.mark.parametrize("case", ["camcal", "sxb"])
def test_every_dbat_section_is_present(case, request):
    res, dbat = request.getfixturevalue(case)
    ours = _keys(report_text(res))
    theirs = {k for k in _keys(dbat) if k[1] not in ENVIRONMENT}
    missing = sorted(theirs - ours)
    assert not missing, missing
    assert len(theirs) > 90  # the comparison covers DBAT's whole layout


def test_sxb_quality_numbers_match_dbat(sxb):
    """Coverage, ray counts, residual extremes, angles, control point tables."""
    res, dbat = sxb
    ours = report_text(res)
    n = 0
    for start, stop in (
        ("Photo point coverage:", "Photo Coverage"),
        ("Point Measurements", "Point Precision"),
        ("CP", "OP"),
        ("Ctrl measurements", "Check measurements"),
    ):
        n += _assert_numbers_match(_section(ours, start, stop), _section(dbat, start, stop), start)
    # OP angles: extremes and the smallest angles (DBAT lists the images of another
    # point there when control points precede: compare ids and angles only).
    a, b = _section(ours, "OP", "Ctrl measurements"), _section(dbat, "OP", "Ctrl")
    n += _assert_numbers_match([s.split("(")[0] for s in a], [s.split("(")[0] for s in b], "OP")
    assert n > 700, n


def test_camcal_quality_numbers_match_dbat(camcal):
    """Self-calibration: significance of the distortion parameters, angle of view,
    coverage, residual extremes, angles with the smallest ones and their images."""
    res, dbat = camcal
    ours = report_text(res)
    n = 0
    sig = re.compile(r"\s+(Significance|Cumulative significance):")
    n += _assert_numbers_match(
        [s for s in ours.splitlines() if sig.match(s)],
        [s for s in dbat.splitlines() if sig.match(s)],
        "significance",
    )
    for start, stop in (
        ("Rated angle of view", "Largest distortion"),
        ("Photographs", "Point Precision"),
        ("Point Angles", "Ctrl measurements"),
        ("Ctrl measurements", "Check measurements"),
    ):
        n += _assert_numbers_match(_section(ours, start, stop), _section(dbat, start, stop), start)
    assert n > 250, n


def test_significance_follows_the_estimate(camcal):
    """A coefficient at zero is not significant; the p value is a chi-square CDF."""
    res, _ = camcal
    io = res.io.copy()
    io[0, 7] = 0.0  # K3
    res0 = type(res)(**{**res.__dict__, "io": io})
    sig = distortion_significance(res0)[0]
    assert sig["significance"]["K3"] == pytest.approx(0.0, abs=1e-12)
    assert "K3" in sig["failed"] and "K1" not in sig["failed"]
    assert 0.0 < sig["cumulative"]["K3"] <= 1.0


def test_smallest_angles_rule(camcal):
    res, _ = camcal
    a = np.full(res.project.n_points, 60.0)
    tie = np.flatnonzero(res.project.point_role == "tie")
    a[tie[:5]] = [10.0, 10.5, 11.0, 11.5, 30.0]
    listed = angle_summary(res, a)["OP"]["smallest"]
    # limit = 1.1 x 11.0 + 0.1 = 12.2 degrees: four points.
    assert [s["angle"] for s in listed] == [10.0, 10.5, 11.0, 11.5]
    assert all(len(s["images"]) == res.project.rays()[tie[0]] for s in listed[:1])


def test_report_json_has_every_point_and_the_quality(camcal, tmp_path):
    res, _ = camcal
    paths = write_reports(res, tmp_path, plots=False)
    rep = json.loads(paths["report_json"].read_text())
    pts = rep["object_points"]
    assert len(pts["id"]) == len(pts["xyz"]) == len(pts["std"]) == res.project.n_points
    assert np.allclose(pts["xyz"], res.xyz, atol=1e-8)
    assert np.allclose(pts["std"], res.xyz_std, atol=1e-11)
    q = rep["quality"]
    assert q["reference"]["control"]["n"] == 4 and q["reference"]["check"] is None
    assert set(q["significance"][0]["significance"]) == {"K1", "K2", "K3", "P1", "as"}
    for k in ("cov_prep", "cov_io", "cov_eo", "cov_op"):
        assert rep["timings_s"][k] >= 0.0
    assert report_dict(res)["quality"]["coverage"][0]["union"]["hull"] == pytest.approx(
        q["coverage"][0]["union"]["hull"]
    )
