"""report.html: self-contained, lists every object, and draws in a real headless browser."""

from __future__ import annotations

import os
import re
import shutil
import time
from pathlib import Path

import numpy as np
import pytest

from pyheracles.cli import main
from pyheracles.errors import InputError
from pyheracles.report.colours import GROUND, REMAINDER, object_colours
from pyheracles.report.html import build_report

ARTIFACTS = Path(__file__).resolve().parents[1] / "test-artifacts"
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
CHROMEDRIVER = shutil.which("chromedriver")


@pytest.fixture(scope="module")
def demo_out(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("demo") / "demo"
    assert main(["demo", "-o", str(out)]) == 0
    return out


def _result_dir(demo: Path) -> Path:
    return next(p.parent for p in demo.rglob("run.json") if (p.parent / "segmented.laz").exists())


def test_object_colours_are_never_grey_nor_repeated() -> None:
    cols = object_colours(300)
    assert ((cols.max(1) - cols.min(1)) > 0.3).all()
    assert len({tuple(np.round(c, 3)) for c in cols}) == 300
    for grey in (GROUND, REMAINDER):
        assert np.abs(cols - np.asarray(grey)).sum(1).min() > 0.3


def _sample(n_obj: int = 3, per: int = 50, seed: int = 0):
    from pyheracles.report.folder import CloudSample

    rng = np.random.default_rng(seed)
    inst = np.repeat(np.arange(n_obj + 2), per)  # 0: ground or remainder
    ground = (inst == 0) & (np.arange(len(inst)) % 2 == 0)
    rng.shuffle(inst)
    xyz = rng.uniform(0, 20, (len(inst), 3)).astype(np.float32)
    return CloudSample(xyz, np.array([1000.0, 2000.0, 0.0]), inst, ground, len(inst), "EPSG:28992")


def test_scene_groups_cover_every_point_once() -> None:
    import base64

    from pyheracles.report.view3d import view3d_scene

    s = _sample()
    names = {i: f"obj{i}" for i in range(1, 5)}
    scene = view3d_scene(s, names, {1: [["k", "v"]]}, classes={1: "pier", 2: "pier"})
    pts = np.frombuffer(base64.b64decode(scene["points"]), "<f4").reshape(-1, 3)
    assert len(pts) == len(s.xyz) == sum(g["count"] for g in scene["groups"])
    ends = [g["start"] + g["count"] for g in scene["groups"]]
    assert [g["start"] for g in scene["groups"]] == [0, *ends[:-1]]  # contiguous, in order
    for g in scene["groups"]:  # each range holds exactly that group's points
        block = pts[g["start"] : g["start"] + g["count"]]
        if "instance" in g:
            want = s.xyz[s.instance == g["instance"]]
        else:
            want = s.xyz[(s.instance == 0) & (s.ground == (g["name"] == "ground"))]
        assert sorted(map(tuple, block)) == sorted(map(tuple, want))
    assert {c["name"] for c in scene["classes"]} == {"ground", "remainder", "pier", "object"}
    assert len({g["colour"] for g in scene["groups"]}) == len(scene["groups"])


def test_faces_are_triangulated_in_their_plane_with_holes() -> None:
    from pyheracles.report.surfaces import cityjson_surfaces, face_triangles

    def area(t: np.ndarray) -> float:
        a = t.reshape(-1, 3, 3)
        return float(
            0.5 * np.linalg.norm(np.cross(a[:, 1] - a[:, 0], a[:, 2] - a[:, 0]), axis=1).sum()
        )

    wall = np.array([[0, 0, 0], [4, 3, 0], [4, 3, 3], [0, 0, 3.0]])  # 5 m x 3 m, vertical
    window = np.array([[0.8, 0.6, 1], [1.6, 1.2, 1], [1.6, 1.2, 2], [0.8, 0.6, 2.0]])  # 1 x 1
    tri, edges = face_triangles([wall, window])
    assert area(tri) == pytest.approx(15 - 1)
    assert len(edges) == 2 * 8
    n = np.cross(wall[1] - wall[0], wall[3] - wall[0])
    assert np.allclose((tri - wall[0]) @ n, 0, atol=1e-9)  # in the plane
    cube = {  # unit cube with semantics, as CityJSON 2.0 writes it (quantised)
        "transform": {"scale": [0.001] * 3, "translate": [100.0, 200.0, 0.0]},
        "vertices": [[x, y, z] for z in (0, 1000) for y in (0, 1000) for x in (0, 1000)],
        "CityObjects": {"b": {"type": "Building", "geometry": [{
            "type": "Solid", "lod": "2.2",
            "boundaries": [[[[0, 2, 3, 1]], [[4, 5, 7, 6]], [[0, 1, 5, 4]], [[1, 3, 7, 5]],
                            [[3, 2, 6, 7]], [[2, 0, 4, 6]]]],
            "semantics": {"surfaces": [{"type": "GroundSurface"}, {"type": "RoofSurface"},
                                       {"type": "WallSurface"}],
                          "values": [[0, 1, 2, 2, 2, 2]]}}]}},
    }  # fmt: skip
    sets = {x.name: x for x in cityjson_surfaces(cube, np.array([100.0, 200.0, 0.0]))}
    assert area(sets["roofs (CityJSON)"].triangles) == pytest.approx(1.0)
    assert area(sets["walls (CityJSON)"].triangles) == pytest.approx(4.0)
    assert np.allclose(sets["roofs (CityJSON)"].triangles[:, 2], 1.0)


def test_cameras_residuals_and_primitives_become_overlays() -> None:
    import base64

    import pandas as pd

    from pyheracles.report.view3d import camera_overlays, primitive_lines, residual_overlays

    report = {
        "cameras": [{"id": 1, "image_size_px": [4000, 3000], "pixel_size_mm": [0.005, 0.005],
                     "values": {"cc": 20.0}}],
        "images": [{"id": k, "name": f"im{k}", "camera": 1, "X0": k, "Y0": 0.0, "Z0": 5.0,
                    "omega_deg": 0.0, "phi_deg": 0.0, "kappa_deg": 0.0, "rms_px": 0.1 * k,
                    "n_points": 10} for k in range(1, 4)],
        "object_points": {"id": [1, 2], "label": ["A", "B"], "role": ["control", "tie"],
                          "xyz": [[0, 0, 0], [1, 1, 0]], "std": [[0, 0, 0], [1e-3] * 3],
                          "rays": [3, 2]},
    }  # fmt: skip
    markers, lines = camera_overlays(report, np.zeros(3), 10.0)
    assert [m["name"] for m in markers] == ["camera stations", "control points", "tie points"]
    seg = np.frombuffer(base64.b64decode(lines[0]["xyz"]), "<f4").reshape(-1, 2, 3)
    assert len(seg) == 3 * 10  # 4 rays, 4 frame edges, 2 up-marker edges per image
    assert np.all(seg[:, :, 2] <= 5.0 + 1e-6)  # omega = phi = 0: the cameras look down
    mk, ln = residual_overlays("check", np.array([[1.0, 2, 3], [4, 5, 6]]),
                               np.array([[0.01, 0, 0], [0, 0.02, 0]]), ["p1", "p2"],
                               np.zeros(3), 100.0)  # fmt: skip
    v = np.frombuffer(base64.b64decode(ln[0]["xyz"]), "<f4").reshape(-1, 2, 3)
    assert np.linalg.norm(v[:, 1] - v[:, 0], axis=1).max() == pytest.approx(5.0, rel=1e-5)
    assert mk[0]["labels"] == ["p1", "p2"] and "x 250" in ln[0]["name"]
    table = pd.DataFrame({"instance": [1, 2], "radius_m": [0.2, np.nan], "x": [1.0, 5.0],
                          "y": [1.0, 5.0], "z_min": [0.0, 0.0], "z_max": [3.0, 2.0],
                          "box_length_m": [np.nan, 0.6], "box_width_m": [np.nan, 0.4],
                          "box_height_m": [np.nan, 2.0]})  # fmt: skip
    segs = primitive_lines(table, np.zeros(3)).reshape(-1, 2, 3)
    assert len(segs) == 2 * 24 + 4 + 12  # cylinder: 2 rings + 4 generators; box: 12 edges
    assert segs[..., 2].max() == pytest.approx(3.0) and segs[..., 2].min() == pytest.approx(0.0)


def test_plan_names_every_object_and_automatic_fields_are_read_from_source() -> None:
    import dataclasses
    import importlib

    from pyheracles.report import html as report_html
    from pyheracles.report.plan import plan_svg

    s = _sample(n_obj=4)
    svg = plan_svg(s, {i: f"Mande {i}" for i in range(1, 6)}, missing=["B20"], title="t")
    for i in range(1, 5):
        assert f"Mande {i}" in svg
    assert "EPSG:28992" in svg and "B20" in svg and "data:image/png;base64," in svg
    import base64
    import io

    from PIL import Image

    png = base64.b64decode(svg.split("data:image/png;base64,", 1)[1].split('"', 1)[0])
    img = np.asarray(Image.open(io.BytesIO(png)).convert("RGBA")).reshape(-1, 4)
    drawn = {tuple(int(v) for v in c[:3]) for c in np.unique(img[img[:, 3] > 0], axis=0)}
    for c in object_colours(4):  # every object's colour is on the map
        assert tuple(int(v) for v in np.round(255 * c)) in drawn
    for step, spec in report_html.PARAMS_OF_STEP.items():
        mod, cls = spec.split(":")
        want = {f.name for f in dataclasses.fields(getattr(importlib.import_module(mod), cls))
                if f.default is None}  # fmt: skip
        assert report_html.auto_fields_from_source(mod, cls) == want, step


def test_check_points_alone_get_a_3d_view(tmp_path: Path) -> None:
    import json

    (tmp_path / "run.json").write_text(json.dumps({"step": "checkpoints", "version": "0"}))
    pts = [{"id": f"C{k}", "reference": [215000.0 + k, 9253000.0, 7.0 + k], "vx": 0.01 * k,
            "vy": -0.01, "vz": 0.002} for k in range(4)]  # fmt: skip
    (tmp_path / "checkpoints.json").write_text(json.dumps({"points": pts}))
    page = build_report(tmp_path).read_text("utf-8")
    assert 'id="view3d-data"' in page and "check points: residuals" in page
    for k in range(4):
        assert f'"C{k}"' in page


def test_report_is_self_contained_and_lists_every_object(demo_out: Path) -> None:
    res = _result_dir(demo_out)
    t = time.perf_counter()
    path = build_report(res)
    elapsed = time.perf_counter() - t
    page = path.read_text(encoding="utf-8")
    assert path.stat().st_size < 15e6
    assert not re.search(r"<script[^>]+src=", page)  # no CDN, nothing fetched
    assert not re.search(r"<link[^>]+href=\"?https?:", page)
    import pyogrio

    objects = pyogrio.read_dataframe(res / "objects.gpkg")
    for name in objects["name"].dropna():
        assert str(name) in page
    assert page.count("<tr>") >= len(objects)
    assert "got no points" in page  # warnings shown
    assert "UTM" in page  # the CRS named
    assert "automatic" in page  # automatic values marked
    assert "Plotly." not in page  # the 3D view is the page's own WebGL viewer
    assert "F1 per object" in page and "<svg" in page
    assert elapsed < 30  # generous here: the 3 s target is measured in benchmarks


def test_report_command_and_bad_folder(demo_out: Path, tmp_path: Path, capsys) -> None:
    res = _result_dir(demo_out)
    assert main(["report", str(res), "--max-points", "20000"]) == 0
    assert (res / "report.html").exists()
    with pytest.raises(InputError, match=r"run\.json"):
        build_report(tmp_path)
    assert main(["report", str(tmp_path / "nope")]) == 2


def _browser():
    webdriver = pytest.importorskip("selenium.webdriver")
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service

    if not (CHROMIUM and CHROMEDRIVER):
        if os.environ.get("CI"):
            pytest.fail("CI must install chromium and chromium-driver (see .ci/run)")
        pytest.skip("chromium / chromedriver not installed")
    o = Options()
    for a in (
        "--headless=new",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-dev-shm-usage",
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--enable-unsafe-swiftshader",
        "--use-angle=swiftshader",
        "--window-size=1300,1800",
    ):
        o.add_argument(a)
    o.binary_location = CHROMIUM
    o.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    return webdriver.Chrome(service=Service(CHROMEDRIVER), options=o)


def _canvas_pixels(d) -> np.ndarray:
    """The 3D view's canvas as RGB, read back from the page (its drawing buffer is preserved)."""
    import base64
    import io

    from PIL import Image

    uri = d.execute_script("return document.getElementById('view3d-canvas').toDataURL('image/png')")
    png = base64.b64decode(uri.split(",", 1)[1])
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"))


def check_in_browser(report: Path, name: str, n_objects: int | None) -> dict[str, float]:
    """Open a report headless: no JS error, the 3D view draws, the table has every object."""
    d = _browser()
    try:
        d.set_page_load_timeout(180)
        d.get(report.resolve().as_uri())
        frame = None
        for _ in range(1200):
            frame = d.execute_script("return window.heraclesFirstFrameMs")
            if frame:
                break
            time.sleep(0.1)
        errors = [e for e in d.get_log("browser") if e["level"] == "SEVERE"]
        assert not errors, errors
        ARTIFACTS.mkdir(exist_ok=True)
        d.save_screenshot(str(ARTIFACTS / f"report_{name}.png"))
        if d.find_elements("id", "view3d"):
            assert frame and frame > 0, "the 3D view never finished its first frame"
            d.find_element("id", "view3d").screenshot(str(ARTIFACTS / f"view3d_{name}.png"))
            img = _canvas_pixels(d)
            drawn = np.any(img < 245, axis=2)  # the background is white
            assert drawn.mean() > 0.002, "the 3D view is blank"
            assert len(np.unique(img[drawn], axis=0)) > 8, "the 3D view has almost no colours"
            stats = d.execute_script("return window.heraclesViewStats")
            entries = d.find_elements("css selector", "#view3d-legend .v3-entry")
            assert len(entries) >= stats["groups"], "every colour of the view is in its legend"
        if n_objects is not None:
            rows = d.find_elements("css selector", "#objects-table tbody tr")
            assert len(rows) == n_objects
        return {"first_frame_ms": float(frame or 0)}
    finally:
        d.quit()


@pytest.mark.slow
def test_3d_view_picks_toggles_and_names(demo_out: Path) -> None:
    """Only one object left visible: a click on it names it; hiding it blanks the view."""
    res = _result_dir(demo_out)
    report = build_report(res, max_points=60_000)
    import pyogrio

    objects = pyogrio.read_dataframe(res / "objects.gpkg")
    target = str(objects.sort_values("n_points").iloc[-1]["name"])  # the biggest object
    d = _browser()
    try:
        d.get(report.resolve().as_uri())
        for _ in range(600):
            if d.execute_script("return window.heraclesFirstFrameMs"):
                break
            time.sleep(0.1)
        assert d.execute_script("return window.heraclesFocus(arguments[0])", target)
        time.sleep(0.3)
        d.execute_script("""
            var name = arguments[0];
            document.querySelectorAll('#view3d-legend input').forEach(function (cb) {
              if (cb.checked) { cb.click(); } });
            document.querySelectorAll('#view3d-legend .v3-entry').forEach(function (e) {
              if (e.querySelector('.v3-name').textContent === name) {
                e.querySelector('input').click(); } });""", target)  # fmt: skip
        time.sleep(0.3)
        hits = d.execute_script("""
            var c = document.getElementById('view3d-canvas');
            var r = c.getBoundingClientRect(), out = [];
            function send(t, x, y) { c.dispatchEvent(new PointerEvent(t, {clientX: x, clientY: y,
              button: 0, bubbles: true, pointerId: 1})); }
            for (var i = 1; i < 10; i++) { for (var j = 1; j < 10; j++) {
              var x = r.left + r.width * i / 10, y = r.top + r.height * j / 10;
              send('pointerdown', x, y); send('pointerup', x, y);
              var b = document.querySelector('#view3d-info b');
              if (b) { out.push([b.textContent, x, y]); }
            } }
            if (out.length) { send('pointerdown', out[0][1], out[0][2]);
                              send('pointerup', out[0][1], out[0][2]); }  // show the first again
            return out.map(function (h) { return h[0]; });""")  # fmt: skip
        assert hits, "no click on the visible object picked it"
        assert set(hits) == {target}
        info = d.find_element("id", "view3d-info").text
        assert "point (world)" in info and "n_points" in info
        d.execute_script("""
            document.querySelectorAll('#view3d-legend input').forEach(function (cb) {
              if (cb.checked) { cb.click(); } });""")  # fmt: skip
        time.sleep(0.5)
        img = _canvas_pixels(d)
        corner = img[: int(0.85 * img.shape[0]), int(0.15 * img.shape[1]) :]  # without the axes
        assert np.all(corner >= 245), "hidden objects are still drawn"
        d.find_element("id", "view3d-colour").send_keys("class")
        assert not [e for e in d.get_log("browser") if e["level"] == "SEVERE"]
    finally:
        d.quit()


def test_demo_report_in_a_real_browser(demo_out: Path) -> None:
    res = _result_dir(demo_out)
    build_report(res)
    import pyogrio

    n = len(pyogrio.read_dataframe(res / "objects.gpkg"))
    check_in_browser(res / "report.html", "demo", n)


def _objects_in(folder: Path) -> int:
    import pandas as pd

    if (folder / "objects.gpkg").exists():
        import pyogrio

        return len(pyogrio.read_dataframe(folder / "objects.gpkg"))
    return len(pd.read_csv(folder / "objects.csv"))


def test_supports_beams_and_registration_reports_in_a_real_browser(tmp_path: Path) -> None:
    from pyheracles.cloud import PointCloud
    from pyheracles.io import write_cloud
    from pyheracles.registration.points import write_points
    from pyheracles.synthetic.buildings import building_scene
    from pyheracles.synthetic.church import ChurchParams, make_church
    from pyheracles.synthetic.truss import TrussParams, make_truss_roof

    scene = building_scene("pavilion", spacing_m=0.08, rng=7)
    src = tmp_path / "pavilion.laz"
    write_cloud(PointCloud.from_world(scene.xyz + np.array([1000.0, 2000.0, 50.0])), src)
    assert main(["supports", str(src), "-o", str(tmp_path / "sup")]) == 0
    roof = make_truss_roof(TrussParams(n_points=60_000), rng=3)
    write_cloud(PointCloud.from_world(roof.xyz), tmp_path / "roof.laz")
    assert main(["beams", str(tmp_path / "roof.laz"), "-o", str(tmp_path / "beams")]) == 0
    s = make_church(ChurchParams(spacing_m=0.3, window_spacing_m=0.1), rng=5)
    write_cloud(s.exterior, tmp_path / "exterior.laz")
    write_cloud(s.interior, tmp_path / "interior.laz")
    write_points(tmp_path / "ties_ext.csv", s.manual_ties_exterior)
    write_points(tmp_path / "ties_int.csv", s.manual_ties_interior)
    assert main(["register", str(tmp_path / "interior.laz"), str(tmp_path / "exterior.laz"),
                 "--tiepoints", str(tmp_path / "ties_int.csv"),
                 "--tiepoints", str(tmp_path / "ties_ext.csv"),
                 "-o", str(tmp_path / "reg")]) == 0  # fmt: skip
    for name in ("sup", "beams", "reg"):
        report = tmp_path / name / "report.html"
        assert report.exists(), f"{name}: the command wrote no report.html"
        n = _objects_in(tmp_path / name) if name != "reg" else None
        check_in_browser(report, name, n)
    page = (tmp_path / "sup" / "report.html").read_text(encoding="utf-8")
    assert "fitted primitives" in page
    assert "tie points: residuals" in (tmp_path / "reg" / "report.html").read_text("utf-8")


def test_bundle_report_in_a_real_browser(shared_data: Path, tmp_path: Path) -> None:
    d = shared_data / "dbat" / "dbat"
    out = tmp_path / "bundle"
    assert (
        main(
            [
                "bundle",
                str(d / "pmexports" / "camcal-pmexport.txt"),
                "--control",
                str(d / "ref" / "camcal-fixed.txt"),
                "-o",
                str(out),
            ]
        )
        == 0
    )
    import json

    images = json.loads((out / "report.json").read_text())["images"]
    check_in_browser(out / "report.html", "bundle", len(images))
