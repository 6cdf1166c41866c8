"""Read DBAT result reports and compare a :class:`BundleResult` with them.

DBAT's text report (``bundle_result_file``) is the reference of the issue: same
input and settings, same numbers.  We parse the values we compare: sigma0,
redundancy, the camera parameters with their deviations and correlations over
95 %, and each photo's exterior orientation with deviations.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pyheracles.errors import InputError

__all__ = ["DbatReport", "compare_with_dbat", "read_dbat_report"]

# DBAT report labels of the camera parameters -> IO_NAMES
_CAM_LABELS = {
    "Camera Constant": "cc",
    "px - principal point x": "px",
    "py - principal point y": "py",
    "K1 - radial distortion 1": "K1",
    "K2 - radial distortion 2": "K2",
    "K3 - radial distortion 3": "K3",
    "P1 - decentering distortion 1": "P1",
    "P2 - decentering distortion 2": "P2",
    "as - off-unit aspect parameter": "as",
    "sk - skew": "sk",
}
_EO_LABELS = {"Omega": "omega", "Phi": "phi", "Kappa": "kappa", "Xc": "X0", "Yc": "Y0", "Zc": "Z0"}
_NUM = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"


@dataclass
class DbatReport:
    """Numbers of one DBAT report.

    Attributes
    ----------
    sigma0, sigma0_px, redundancy, n_params, n_observations, iterations
        Summary values.
    camera
        Camera parameter name -> (value, deviation or NaN).
    camera_correlations
        Set of frozenset({name1, name2}) pairs listed "over 95 %".
    photos
        Photo number -> {eo name: (value, deviation or NaN)} (angles in degrees).
    photo_correlations
        Photo number -> set of frozenset pairs over 95 %.
    """

    path: str
    sigma0: float = float("nan")
    sigma0_px: float = float("nan")
    redundancy: int = -1
    n_params: int = -1
    n_observations: int = -1
    iterations: int = -1
    camera: dict[str, tuple[float, float]] = field(default_factory=dict)
    camera_correlations: set = field(default_factory=set)
    photos: dict[int, dict[str, tuple[float, float]]] = field(default_factory=dict)
    photo_names: dict[int, str] = field(default_factory=dict)
    photo_correlations: dict[int, set] = field(default_factory=dict)


def _first(pattern: str, text: str, cast=float, default=float("nan")):
    m = re.search(pattern, text)
    return cast(m.group(1)) if m else default


def read_dbat_report(path: str | Path) -> DbatReport:
    """Parse a DBAT text report (``*-dbatreport.txt`` or ``result/report.txt``)."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8", errors="replace")
    except OSError as exc:
        raise InputError(f"unreadable DBAT report ({exc})", path=path) from None
    if "Damped Bundle Adjustment Toolbox" not in text[:200]:
        raise InputError("not a DBAT report", path=path)
    rep = DbatReport(path=str(path))
    rep.sigma0 = _first(rf"Sigma0:\s+({_NUM})", text)
    rep.sigma0_px = _first(rf"Sigma0 \(pixels\):\s+({_NUM})", text)
    rep.redundancy = _first(r"Redundancy\s+(\d+)", text, int, -1)
    rep.n_params = _first(r"Number of params:\s+(\d+)", text, int, -1)
    rep.n_observations = _first(r"Number of observations:\s+(\d+)", text, int, -1)
    rep.iterations = _first(r"Number of iterations:\s+(\d+)", text, int, -1)
    lines = text.splitlines()
    section = None
    current: str | None = None
    photo: int | None = None
    for line in lines:
        s = line.strip()
        if s.startswith("Cameras:"):
            section = "camera"
            continue
        if s.startswith("Photograph Standard Deviations"):
            section = "photo"
            continue
        if s.startswith("Quality") or s.startswith("Rated angle of view"):
            section = None if s.startswith("Quality") else section
            continue
        if section == "camera":
            key = s.rstrip(":")
            if key in _CAM_LABELS:
                current = _CAM_LABELS[key]
                continue
            if key in ("Format width", "Format height", "Image width", "Image height"):
                current = None
                continue
        if section == "photo":
            m = re.match(r"Photo (\d+):\s*(.*)", s)
            if m:
                photo = int(m.group(1))
                rep.photos[photo] = {}
                rep.photo_names[photo] = m.group(2)
                rep.photo_correlations[photo] = set()
                continue
            key = s.rstrip(":")
            if key in _EO_LABELS:
                current = _EO_LABELS[key]
                continue
        if current is None:
            continue
        m = re.match(rf"Value:\s+({_NUM})", s)
        if m:
            val = float(m.group(1))
            if section == "camera":
                rep.camera[current] = (val, float("nan"))
            elif section == "photo" and photo is not None:
                rep.photos[photo][current] = (val, float("nan"))
            continue
        m = re.match(rf"Deviation:\s+({_NUM})", s)
        if m:
            dev = float(m.group(1))
            if section == "camera" and current in rep.camera:
                rep.camera[current] = (rep.camera[current][0], dev)
            elif section == "photo" and photo is not None and current in rep.photos[photo]:
                rep.photos[photo][current] = (rep.photos[photo][current][0], dev)
            continue
        m = re.match(r"Correlations over 95%:\s*(.*)", s)
        if m:
            for part in m.group(1).split(","):
                mm = re.match(r"\s*([A-Za-z0-9]+):\s*" + _NUM, part.strip().rstrip("."))
                if not mm:
                    continue
                other = mm.group(1)
                if section == "camera":
                    other = {"cc": "cc", "as": "as", "sk": "sk"}.get(other, other)
                    rep.camera_correlations.add(frozenset((current, other)))
                elif section == "photo" and photo is not None:
                    other = _EO_LABELS.get(other, other)
                    rep.photo_correlations[photo].add(frozenset((current, other)))
    return rep


def compare_with_dbat(result, report: DbatReport) -> dict:
    """Differences between our adjustment and a DBAT report.

    Returns
    -------
    dict
        ``sigma0_rel`` (relative difference), ``max_param_diff_over_std`` (over
        camera and EO parameters, difference / DBAT deviation, angles compared in
        degrees), ``max_std_ratio_dev`` (max |ours/DBAT - 1| of the deviations),
        ``camera_correlations`` (ours, DBAT sets), ``photo_correlations_matched``.
    """
    from pyheracles.bundle.camera import IO_NAMES
    from pyheracles.bundle.diagnostics import high_correlations

    out: dict = {"sigma0": result.sigma0, "sigma0_dbat": report.sigma0}
    out["sigma0_rel"] = abs(result.sigma0 / report.sigma0 - 1.0)
    diffs, ratios, worst = [], [], ("", 0.0)
    io, io_std = result.io[0], result.io_std[0]
    for name, (val, dev) in report.camera.items():
        j = IO_NAMES.index(name)
        if np.isfinite(dev) and dev > 0:
            d = abs(io[j] - val) / dev
            diffs.append(d)
            if d > worst[1]:
                worst = (f"camera {name}", d)
            ratios.append(io_std[j] / dev - 1.0)
    # Exterior orientation: photos are numbered in image order.
    order = ["X0", "Y0", "Z0", "omega", "phi", "kappa"]
    eo_ratios = []
    for k, vals in report.photos.items():
        i = k - 1
        if i >= len(result.eo):
            continue
        for name, (val, dev) in vals.items():
            j = order.index(name)
            ours = np.degrees(result.eo[i, j]) if j >= 3 else result.eo[i, j]
            ours_std = np.degrees(result.eo_std[i, j]) if j >= 3 else result.eo_std[i, j]
            if j >= 3:
                delta = (ours - val + 180.0) % 360.0 - 180.0
            else:
                delta = ours - val
            if np.isfinite(dev) and dev > 0:
                d = abs(delta) / dev
                diffs.append(d)
                if d > worst[1]:
                    worst = (f"photo {k} {name}", d)
                # DBAT prints deviations with 3 significant digits: ratio rounding <= 0.5 %
                eo_ratios.append(ours_std / dev - 1.0)
    out["max_param_diff_over_std"] = float(max(diffs)) if diffs else float("nan")
    out["worst_param"] = worst[0]
    out["max_camera_std_ratio_dev"] = float(np.max(np.abs(ratios))) if ratios else float("nan")
    out["max_eo_std_ratio_dev"] = float(np.max(np.abs(eo_ratios))) if eo_ratios else float("nan")
    out["max_std_ratio_dev"] = float(np.max(np.abs(ratios + eo_ratios))) if diffs else float("nan")
    ours = high_correlations(result)
    cam_pairs = {frozenset(p["pair"]) for p in ours["io"]}
    out["camera_correlations"] = (
        sorted(map(sorted, cam_pairs)),
        sorted(map(sorted, report.camera_correlations)),
    )
    out["camera_correlations_match"] = cam_pairs == report.camera_correlations
    eo_ours: dict[int, set] = {}
    for p in ours["eo"]:
        eo_ours.setdefault(p["image_index"] + 1, set()).add(frozenset(p["pair"]))
    matched = sum(
        1 for k, pairs in report.photo_correlations.items() if eo_ours.get(k, set()) == pairs
    )
    out["photo_correlations_matched"] = (matched, len(report.photo_correlations))
    out["eo_correlation_pairs"] = (
        sum(len(v) for v in eo_ours.values()),
        sum(len(v) for v in report.photo_correlations.values()),
    )
    return out
