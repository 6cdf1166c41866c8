"""COLMAP text models and Metashape camera exports, written from one simulated network.

One block of cameras and points with known truth is projected with each
program's own camera model (COLMAP's OPENCV distortion, Metashape's f/cx/cy
from the image centre), written in its format, read back with perturbed initial
values and re-adjusted: the adjustment must recover the truth.  Bad input
(truncated files, camera models we do not have, an export without
measurements) gets one line naming the file and the fix, exit 2 on the CLI.
"""

from __future__ import annotations

import json
import warnings
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from pyheracles.bundle import BundleParameters, BundleWarning, bundle_adjust, read_project
from pyheracles.cli import main
from pyheracles.errors import InputError

W, H = 1600, 1200


def _f(v) -> str:
    return repr(float(v))


def _look_at(centre: np.ndarray, target: np.ndarray, roll: float) -> np.ndarray:
    """World-to-camera rotation, camera +z forward, y down (COLMAP and Agisoft)."""
    z = target - centre
    z /= np.linalg.norm(z)
    x = np.cross([0.0, 0.0, -1.0], z)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    r = np.vstack([x, y, z])
    c, s = np.cos(roll), np.sin(roll)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]]) @ r


def _block(rng, n_cam=8, n_pts=80):
    """A convergent block: cameras on a ring 6 m around a 4 x 3 x 1 m point volume."""
    xyz = np.column_stack([rng.uniform(-2, 2, n_pts), rng.uniform(-1.5, 1.5, n_pts),
                           rng.uniform(-0.5, 0.5, n_pts)])  # fmt: skip
    rots, centres = [], []
    for k in range(n_cam):
        a = 2 * np.pi * k / n_cam
        c = np.array([6 * np.cos(a), 6 * np.sin(a), 2.0 + 0.5 * (k % 2)])
        rots.append(_look_at(c, np.zeros(3), 0.1 * (k % 3 - 1)))
        centres.append(c)
    return xyz, np.array(rots), np.array(centres)


def _normalised(xyz, r, c):
    pc = (xyz - c) @ r.T
    assert np.all(pc[:, 2] > 0)
    return pc[:, 0] / pc[:, 2], pc[:, 1] / pc[:, 2]


def _perturbed(rng, r, c, ang=0.003, pos=0.03):
    """Initial values off the truth: a small rotation and a shifted centre."""
    w = rng.normal(0, ang, 3)
    k = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
    return (np.eye(3) + k + k @ k / 2) @ r, c + rng.normal(0, pos, 3)


def _quaternion(r: np.ndarray) -> np.ndarray:
    w = np.sqrt(max(1e-12, 1 + np.trace(r))) / 2
    return np.array([w, (r[2, 1] - r[1, 2]) / (4 * w), (r[0, 2] - r[2, 0]) / (4 * w),
                     (r[1, 0] - r[0, 1]) / (4 * w)])  # fmt: skip


def _helmert(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a`` moved onto ``b`` by the least-squares similarity (Umeyama)."""
    ma, mb = a.mean(0), b.mean(0)
    u, s, vt = np.linalg.svd((b - mb).T @ (a - ma))
    d = np.diag([1, 1, np.sign(np.linalg.det(u @ vt))])
    rot = u @ d @ vt
    scale = np.trace(np.diag(s) @ d) / np.sum((a - ma) ** 2)
    return scale * (a - ma) @ rot.T + mb


# --------------------------------------------------------------------------- COLMAP

OPENCV = (1400.0, 1400.0, 803.2, 596.5, -0.08, 0.03, 4e-4, -3e-4)  # fx fy cx cy k1 k2 p1 p2


def _colmap_project(x, y, par):
    """COLMAP's OPENCV camera model (src/colmap/sensor/models.h)."""
    fx, fy, cx, cy, k1, k2, p1, p2 = par
    r2 = x * x + y * y
    rad = k1 * r2 + k2 * r2 * r2
    xd = x * (1 + rad) + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
    yd = y * (1 + rad) + 2 * p2 * x * y + p1 * (r2 + 2 * y * y)
    return fx * xd + cx, fy * yd + cy


def _write_colmap(folder, rng, model="OPENCV", par=OPENCV, noise_px=0.3):
    xyz, rots, centres = _block(rng)
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "cameras.txt").write_text(
        "# Camera list with one line of data per camera:\n"
        f"1 {model} {W} {H} {' '.join(_f(v) for v in par)}\n"
    )
    lines = ["# Image list with two lines of data per image:"]
    tracks: dict[int, list[str]] = {i: [] for i in range(len(xyz))}
    for k, (r, c) in enumerate(zip(rots, centres, strict=True)):
        u, v = _colmap_project(*_normalised(xyz, r, c), OPENCV)
        u, v = u + rng.normal(0, noise_px, u.shape), v + rng.normal(0, noise_px, v.shape)
        r0, c0 = _perturbed(rng, r, c)
        q, t = _quaternion(r0), -r0 @ c0
        lines.append(f"{k + 1} {' '.join(map(_f, q))} {' '.join(map(_f, t))} 1 im{k:02d}.jpg")
        kp = [f"{_f(a)} {_f(b)} {i + 1}" for i, (a, b) in enumerate(zip(u, v, strict=True))]
        kp.append("12.5 13.5 -1")  # a keypoint without a 3D point
        lines.append(" ".join(kp))
        for i in range(len(xyz)):
            tracks[i].append(f"{k + 1} {i}")
    (folder / "images.txt").write_text("\n".join(lines) + "\n")
    x0 = xyz + rng.normal(0, 0.03, xyz.shape)
    (folder / "points3D.txt").write_text(
        "".join(
            f"{i + 1} {_f(a)} {_f(b)} {_f(c)} 128 128 128 0.4 {' '.join(tracks[i])}\n"
            for i, (a, b, c) in enumerate(x0)
        )
    )
    return xyz, centres


def test_colmap_model_recovers_the_truth(tmp_path, rng):
    """OPENCV distortion maps exactly onto the forward model: sigma0 = the noise."""
    xyz, centres = _write_colmap(tmp_path / "model", rng)
    project = read_project(tmp_path / "model")
    assert (project.n_images, project.n_points, project.n_observations) == (8, 80, 640)
    assert project.cameras[0].model == -1
    before = np.sqrt(np.mean(np.sum((_helmert(project.xyz, xyz) - xyz) ** 2, axis=1)))
    res = bundle_adjust(project, BundleParameters(estimate_io=(), max_iterations=30))
    assert res.converged and res.network.datum == "depend"
    assert res.sigma0 == pytest.approx(0.3, rel=0.15)  # 0.3 px noise, 1 px prior
    # The datum (one fixed image) is the perturbed one: compare up to a similarity.
    after = np.sqrt(np.mean(np.sum((_helmert(res.xyz, xyz) - xyz) ** 2, axis=1)))
    cam = np.sqrt(np.mean(np.sum((_helmert(res.eo[:, :3], centres) - centres) ** 2, axis=1)))
    assert before > 0.02 and after < 0.002 and cam < 0.01, (before, after, cam)


def test_colmap_cli_writes_the_report(tmp_path, rng):
    _write_colmap(tmp_path / "model", rng)
    out = tmp_path / "out"
    assert main(["bundle", str(tmp_path / "model"), "--no-plots", "-o", str(out)]) == 0
    rep = json.loads((out / "report.json").read_text())
    assert rep["sigma0"] == pytest.approx(0.3, rel=0.15)
    assert len(rep["object_points"]["id"]) == 80
    text = (out / "report.txt").read_text()
    assert "Forward (Computer Vision) model 1" in text and "Point Marking Residuals" in text


@pytest.mark.parametrize(
    ("mutate", "match"),
    [
        (lambda f: f.write_text("\n".join(f.read_text().splitlines()[:-1]) + "\n"),
         r"images.txt.*truncated: image line 16"),
        (lambda f: f.write_text(f.read_text()[:-40] + "\n"),
         r"images.txt.*line 17: keypoints must be X Y POINT3D_ID triples"),
    ],
)  # fmt: skip
def test_colmap_truncated_images(tmp_path, rng, capsys, mutate, match):
    _write_colmap(tmp_path / "m", rng)
    mutate(tmp_path / "m" / "images.txt")
    with pytest.raises(InputError, match=match) as exc:
        read_project(tmp_path / "m")
    assert "model_converter --output_type TXT" in str(exc.value)
    capsys.readouterr()
    assert main(["bundle", str(tmp_path / "m"), "-o", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert "images.txt" in err and "model_converter" in err and "Traceback" not in err


def test_colmap_unsupported_camera_model(tmp_path, rng, capsys):
    _write_colmap(tmp_path / "m", rng, model="OPENCV_FISHEYE")
    msg = r"cameras\.txt.*line 2: COLMAP camera model OPENCV_FISHEYE is not supported"
    with pytest.raises(InputError, match=msg) as exc:
        read_project(tmp_path / "m")
    assert "image_undistorter" in str(exc.value)
    assert main(["bundle", str(tmp_path / "m"), "-o", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "OPENCV_FISHEYE" in err and "Traceback" not in err


def test_colmap_binary_model_and_missing_points(tmp_path, rng):
    (tmp_path / "bin").mkdir()
    (tmp_path / "bin" / "images.bin").write_bytes(b"\0" * 8)
    with pytest.raises(InputError, match="binary COLMAP model") as exc:
        read_project(tmp_path / "bin")
    assert "--output_type TXT" in str(exc.value)
    # Keypoints of a 3D point absent from points3D.txt: counted, not silent.
    _write_colmap(tmp_path / "m", rng)
    pts = (tmp_path / "m" / "points3D.txt").read_text().splitlines()
    (tmp_path / "m" / "points3D.txt").write_text("\n".join(pts[1:]) + "\n")
    with pytest.warns(BundleWarning, match=r"8 keypoint\(s\) of 1 3D point\(s\) absent"):
        project = read_project(tmp_path / "m")
    assert project.n_points == 79


# ------------------------------------------------------------------------- Metashape

SENSOR = {"f": 1400.0, "cx": 3.2, "cy": -3.5}  # Metashape: cx, cy from the image centre
PIXEL_MM = 0.004


def _similarity_xml(parent, rot, trans, scale):
    t = ET.SubElement(parent, "transform")
    ET.SubElement(t, "rotation", locked="false").text = " ".join(map(_f, rot.ravel()))
    ET.SubElement(t, "translation", locked="false").text = " ".join(map(_f, trans))
    ET.SubElement(t, "scale", locked="false").text = _f(scale)


def _rotation(rng):
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return q * np.sign(np.linalg.det(q))


def _write_metashape(path, rng, noise_px=0.3, locations=True):
    """Camera export: chunk -> world and component -> chunk similarities, camera
    transforms in the component frame, markers with references and projections."""
    xyz, rots, centres = _block(rng)
    xyz, centres = xyz + [500.0, 300.0, 20.0], centres + [500.0, 300.0, 20.0]  # world
    rc, tc, sc = _rotation(rng), rng.normal(0, 50, 3), 0.7  # chunk -> world
    rk, tk, sk = _rotation(rng), rng.normal(0, 2, 3), 1.3  # component -> chunk

    def world_to_component(x):
        chunk = ((x - tc) @ rc) / sc
        return ((chunk - tk) @ rk) / sk

    doc = ET.Element("document", version="1.5.0")
    chunk = ET.SubElement(doc, "chunk", label="sim", enabled="true")
    sensors = ET.SubElement(chunk, "sensors", next_id="1")
    s = ET.SubElement(sensors, "sensor", id="0", label="sim (8mm)", type="frame")
    ET.SubElement(s, "resolution", width=str(W), height=str(H))
    ET.SubElement(s, "property", name="pixel_width", value=_f(PIXEL_MM))
    ET.SubElement(s, "property", name="pixel_height", value=_f(PIXEL_MM))
    cal = ET.SubElement(s, "calibration", type="frame", **{"class": "adjusted"})
    ET.SubElement(cal, "resolution", width=str(W), height=str(H))
    for k, v in SENSOR.items():
        ET.SubElement(cal, k).text = _f(v)
    comps = ET.SubElement(chunk, "components", next_id="1", active_id="0")
    comp = ET.SubElement(comps, "component", id="0", label="Component 1")
    _similarity_xml(comp, rk, tk, sk)
    cams = ET.SubElement(chunk, "cameras", next_id=str(len(rots)), next_group_id="0")
    obs = []
    for k, (r, c) in enumerate(zip(rots, centres, strict=True)):
        x, y = _normalised(xyz, r, c)
        u = W / 2 + SENSOR["cx"] + SENSOR["f"] * x + rng.normal(0, noise_px, x.shape)
        v = H / 2 + SENSOR["cy"] + SENSOR["f"] * y + rng.normal(0, noise_px, y.shape)
        obs.append((u, v))
        r0, c0 = _perturbed(rng, r, c, pos=0.05)
        # camera -> component: rotation R_c2w in the component frame, centre.
        m = np.eye(4)
        m[:3, :3] = rk.T @ rc.T @ r0.T
        m[:3, 3] = world_to_component(c0[None])[0]
        cam = ET.SubElement(cams, "camera", id=str(k), sensor_id="0", component_id="0",
                            label=f"IMG_{k:04d}")  # fmt: skip
        ET.SubElement(cam, "transform").text = " ".join(map(_f, m.ravel()))
    ET.SubElement(cams, "camera", id="99", sensor_id="0", label="not aligned")
    markers = ET.SubElement(chunk, "markers")
    control, check = list(range(0, 80, 10)), [5, 25, 45]
    for i in range(len(xyz)):
        mk = ET.SubElement(markers, "marker", id=str(i), label=f"point {i}")
        if i in control or i in check:
            ET.SubElement(mk, "reference", x=_f(xyz[i, 0]), y=_f(xyz[i, 1]),
                          z=_f(xyz[i, 2]), sx="0.002", sy="0.002", sz="0.003",
                          enabled="true" if i in control else "false")  # fmt: skip
    ET.SubElement(markers, "marker", id="200", label="lost").append(
        ET.Element("reference", x="1", y="2", z="3", enabled="true")
    )
    frames = ET.SubElement(chunk, "frames")
    fm = ET.SubElement(ET.SubElement(frames, "frame", id="0"), "markers")
    if locations:
        for i in range(len(xyz)):
            mk = ET.SubElement(fm, "marker", marker_id=str(i))
            for k, (u, v) in enumerate(obs):
                ET.SubElement(mk, "location", camera_id=str(k), pinned="true",
                              x=_f(u[i]), y=_f(v[i]))  # fmt: skip
    settings = ET.SubElement(chunk, "settings")
    ET.SubElement(settings, "property", name="accuracy_projections", value="0.3")
    _similarity_xml(chunk, rc, tc, sc)
    ET.ElementTree(doc).write(path, encoding="utf-8", xml_declaration=True)
    return xyz, centres, control, check


def test_metashape_export_recovers_the_truth(tmp_path, rng):
    xyz, centres, _, check = _write_metashape(tmp_path / "cams.xml", rng)
    with pytest.warns(BundleWarning) as said:
        project = read_project(tmp_path / "cams.xml")
    said = " | ".join(str(w.message) for w in said)
    assert "1 camera(s) disabled or not aligned" in said and "'lost'" in said
    assert project.meta["format"] == "metashape-xml"
    assert (project.n_images, project.n_points, project.n_observations) == (8, 80, 640)
    roles = list(project.point_role)
    assert (roles.count("control"), roles.count("check")) == (8, 3)
    cam = project.cameras[0]
    assert cam.cc_mm == pytest.approx(1400 * PIXEL_MM)
    assert np.allclose(cam.pp_mm, [(W / 2 + 3.2) * PIXEL_MM, (H / 2 - 3.5) * PIXEL_MM])
    assert np.abs(project.eo[:, :3] - centres).max() > 0.02  # perturbed initial values
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", BundleWarning)
        res = bundle_adjust(project, BundleParameters(estimate_io=()))
    assert res.converged and res.network.datum == "control"
    assert res.sigma0 == pytest.approx(1.0, rel=0.15)  # 0.3 px noise, 0.3 px accuracy
    # World frame through both similarities: cameras and every point on the truth.
    assert np.abs(res.eo[:, :3] - centres).max() < 0.01
    assert np.abs(res.xyz - xyz[project.point_ids]).max() < 0.005
    z = np.abs(res.eo[:, :3] - centres) / res.eo_std[:, :3]
    assert z.max() < 5.0
    from pyheracles.bundle.report import report_dict

    tab = report_dict(res)["quality"]["reference"]["check"]
    assert [r["id"] for r in tab["rows"]] == check and tab["rms"] < 0.005


def test_metashape_cli_and_bad_export(tmp_path, rng, capsys):
    _write_metashape(tmp_path / "cams.xml", rng)
    out = tmp_path / "out"
    assert main(["bundle", str(tmp_path / "cams.xml"), "--no-plots", "-o", str(out)]) == 0
    rep = json.loads((out / "report.json").read_text())
    assert rep["quality"]["reference"]["control"]["n"] == 8
    # An export without marker projections has nothing to adjust: say so and how.
    _write_metashape(tmp_path / "bare.xml", rng, locations=False)
    with pytest.raises(InputError, match="no image measurements") as exc:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", BundleWarning)
            read_project(tmp_path / "bare.xml")
    assert "markers' projections" in str(exc.value)
    capsys.readouterr()
    assert main(["bundle", str(tmp_path / "bare.xml"), "-o", str(tmp_path / "o2")]) == 2
    err = capsys.readouterr().err
    assert "bare.xml" in err and "Traceback" not in err
