"""The ``heracles`` command: help, demo, bad input gives exit code 2 and no partial output."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import geopandas as gpd
import numpy as np
import pytest
import shapely

from pyheracles import PointCloud
from pyheracles.cli import main
from pyheracles.io import write_cloud


@pytest.fixture
def small_site(tmp_path: Path, rng) -> tuple[Path, Path]:
    """A 40 x 40 m site in RD New with one 8 m high building and its footprint."""
    n = 20000
    xy = rng.uniform(0, 40, (n, 2))
    roof = (np.abs(xy - 20) < 5).all(axis=1)
    z = np.where(roof, 8.0, 0.0) + rng.normal(0, 0.02, n)
    cloud = PointCloud.from_world(np.column_stack([xy + [85000, 447000], z]), crs="EPSG:28992")
    cloud_path = write_cloud(cloud, tmp_path / "site.laz")
    layer = gpd.GeoDataFrame(
        {"name": ["hall"]}, geometry=[shapely.box(85015, 447015, 85025, 447025)], crs="EPSG:28992"
    )
    layer_path = tmp_path / "fp.gpkg"
    layer.to_file(layer_path, layer="footprints", driver="GPKG")
    return cloud_path, layer_path


def test_complex_command_writes_all_outputs(tmp_path: Path, small_site) -> None:
    cloud, layer = small_site
    out = tmp_path / "out"
    code = main(
        [
            "complex",
            str(cloud),
            "-l",
            f"building={layer}:footprints",
            "-o",
            str(out),
            "--per-object",
            "name",
        ]
    )
    assert code == 0
    assert {p.name for p in out.iterdir()} == {
        "segmented.laz",
        "objects.gpkg",
        "run.json",
        "objects",
    }
    run = json.loads((out / "run.json").read_text())
    c = run["counts"]
    assert c["objects"] + c["ground"] + c["remainder"] == c["total"] == 20000
    assert (out / "objects" / "hall.laz").is_file()
    objs = gpd.read_file(out / "objects.gpkg")
    assert objs.loc[0, "name"] == "hall" and objs.loc[0, "height"] == pytest.approx(8, abs=0.2)


@pytest.mark.parametrize(
    ("case", "message"),
    [
        ("missing_cloud", "file not found"),
        ("truncated", "truncated"),
        ("bad_layer_spec", "is not NAME=PATH"),
        ("missing_layer", "no layer named 'nope'"),
        ("crs_mismatch", "differs from the cloud"),
        ("outside", "no polygon overlaps the cloud"),
        ("invalid_polygon", "invalid polygons"),
        ("nan", "NaN"),
        ("empty", "no points"),
    ],
    ids=lambda v: str(v).split()[0].replace("=", "_"),
)
def test_bad_input_exit_code_2_and_no_output(
    tmp_path: Path, small_site, case: str, message: str, capsys
) -> None:
    cloud, layer = small_site
    spec = f"building={layer}:footprints"
    if case == "missing_cloud":
        cloud = tmp_path / "nope.laz"
    elif case == "truncated":
        data = cloud.read_bytes()
        cloud = tmp_path / "cut.laz"
        cloud.write_bytes(data[: len(data) // 3])
    elif case == "bad_layer_spec":
        spec = str(layer)
    elif case == "missing_layer":
        spec = f"building={layer}:nope"
    elif case in ("crs_mismatch", "outside", "invalid_polygon"):
        geom = {
            "crs_mismatch": shapely.box(85015, 447015, 85025, 447025),
            "outside": shapely.box(95015, 447015, 95025, 447025),
            "invalid_polygon": shapely.Polygon(
                [(85015, 447015), (85025, 447025), (85025, 447015), (85015, 447025)]
            ),
        }[case]
        crs = "EPSG:32631" if case == "crs_mismatch" else "EPSG:28992"
        path = tmp_path / f"{case}.gpkg"
        gpd.GeoDataFrame({"name": ["x"]}, geometry=[geom], crs=crs).to_file(path, driver="GPKG")
        spec = f"building={path}"
    elif case in ("nan", "empty"):
        xyz = np.array([[0.0, 0, 0]] * 30 + [[np.nan, 0, 0]]) if case == "nan" else np.zeros((0, 3))
        path = tmp_path / f"{case}.csv"
        np.savetxt(path, xyz, delimiter=",", header="x,y,z", comments="")
        cloud = path
    out = tmp_path / "out"
    code = main(["complex", str(cloud), "-l", spec, "-o", str(out), "--cloud-crs", "EPSG:28992"])
    err = capsys.readouterr().err
    assert code == 2, err
    assert message in " ".join(err.split())
    assert not out.exists() or not any(out.iterdir())
    assert not list(tmp_path.glob(".heracles-partial-*"))  # staging folder removed
    assert not list(tmp_path.glob(".out.*"))


def test_non_empty_output_folder_is_refused(tmp_path: Path, small_site, capsys) -> None:
    cloud, layer = small_site
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("x")
    assert main(["complex", str(cloud), "-l", f"b={layer}", "-o", str(out)]) == 2
    assert "not empty" in capsys.readouterr().err


def test_module_entry_point_and_help() -> None:
    res = subprocess.run(
        [sys.executable, "-m", "pyheracles", "--help"], capture_output=True, text=True, check=False
    )
    assert res.returncode == 0
    assert "complex" in res.stdout and "demo" in res.stdout


def test_demo_command(tmp_path: Path, capsys) -> None:
    out = tmp_path / "demo"
    assert main(["demo", "-o", str(out), "--points", "80000", "--seed", "3"]) == 0
    assert (out / "overview.png").stat().st_size > 10_000
    assert (out / "result" / "evaluation.csv").is_file()
    assert (out / "scene" / "cloud.laz").is_file()
    # run.json names the inputs where they are now (scene/), not the deleted staging folder
    run = json.loads((out / "result" / "run.json").read_text())
    for item in run["inputs"]:
        assert Path(item["path"]).is_file(), item
        assert Path(item["path"]).parent == (out / "scene").resolve()
    assert run["demo_scene"]["parameters"]["seed"] == 3
    assert run["demo_scene"]["parameters"]["n_points"] == 80000
    err = " ".join(capsys.readouterr().err.split())
    for warning in run["warnings"]:  # what run.json says is also on the screen
        assert f"warning: result: {warning}" in err


def test_every_output_option_has_the_same_names() -> None:
    """One spelling works everywhere: -o, --out and --outdir name the output folder."""
    import typer.main

    from pyheracles.cli import app

    group = typer.main.get_command(app)
    seen = 0
    for name, command in group.commands.items():  # type: ignore[attr-defined]
        for param in command.params:
            if "-o" in getattr(param, "opts", []):
                assert {"--out", "--outdir"} <= set(param.opts), (name, param.opts)
                seen += 1
    assert seen >= 10


# --- issue 15: every command survives a careless user --------------------------------------


@pytest.mark.parametrize(
    ("argv", "code", "expected"),
    [
        ([], 2, "Usage: heracles"),
        (["--version"], 0, "pyheracles 0."),
        (["nosuchcmd"], 2, "No such command 'nosuchcmd'"),
        (["ground"], 2, "Missing argument 'CLOUD'"),
        (["ground", "x.laz", "--bufer", "2"], 2, "No such option: --bufer"),
        (["ground", "x.laz", "-o", "o", "--dtm-cell", "abc"], 2, "Invalid value for '--dtm-cell'"),
        (["--help"], 0, "Usage: heracles"),
    ],
    ids=[
        "no-args",
        "version",
        "unknown-command",
        "missing-argument",
        "unknown-option",
        "wrong-type",
        "help",
    ],
)
def test_usage_errors_give_usage_and_exit_2(
    argv: list[str], code: int, expected: str, capsys, tmp_path: Path, monkeypatch
) -> None:
    monkeypatch.chdir(tmp_path)
    assert main(argv) == code
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err
    assert expected in " ".join((out + err).split())
    if code == 2 and argv:
        assert err.startswith("Usage: heracles") and len(err.strip().splitlines()) <= 4
    assert list(tmp_path.iterdir()) == []


def test_usage_errors_in_a_real_process(tmp_path: Path) -> None:
    """The console script itself: exit code 2 and no traceback (typer's own click)."""
    res = subprocess.run(
        [sys.executable, "-m", "pyheracles", "ground", "x.laz", "--bufer", "2"],
        capture_output=True, text=True, check=False, cwd=tmp_path,
    )  # fmt: skip
    assert res.returncode == 2 and "Traceback" not in res.stderr
    assert "No such option: --bufer" in res.stderr


def _fake_devices(monkeypatch, mount: Path) -> None:
    """Renames across ``mount`` (a mount point) fail with EXDEV, as on a USB drive."""
    import errno
    import os

    def device(p) -> str:
        return "mount" if Path(p).resolve().is_relative_to(mount.resolve()) else "root"

    for name in ("replace", "rename"):
        real = getattr(os, name)

        def fake(src, dst, *args, _real=real, **kwargs):
            if device(src) != device(dst):
                raise OSError(errno.EXDEV, "Invalid cross-device link", str(src), None, str(dst))
            return _real(src, dst, *args, **kwargs)

        monkeypatch.setattr(os, name, fake)


@pytest.mark.parametrize("where", ["mount", "new-folder-on-mount"])
def test_output_dir_on_a_mount_point(tmp_path: Path, monkeypatch, where: str) -> None:
    from pyheracles.cli.common import STAGING_PREFIX, output_dir
    from pyheracles.io.atomic import atomic_write_text

    mount = tmp_path / "usb"
    mount.mkdir()
    _fake_devices(monkeypatch, mount)
    out = mount if where == "mount" else mount / "new"
    with output_dir(out) as stage:
        assert stage.parent == mount and stage.name.startswith(STAGING_PREFIX)
        atomic_write_text(stage / "a.txt", "x")
        atomic_write_text(stage / "sub" / "b.txt", "y")
    assert sorted(p.name for p in out.iterdir()) == ["a.txt", "sub"]
    assert (out / "sub" / "b.txt").read_text() == "y"
    assert not list(mount.glob(f"{STAGING_PREFIX}*"))


def test_output_dir_stages_beside_a_new_folder_and_cleans_up(tmp_path: Path) -> None:
    from pyheracles.cli.common import STAGING_PREFIX, output_dir

    out = tmp_path / "a" / "b" / "out"
    with pytest.raises(RuntimeError), output_dir(out) as stage:
        assert stage.parent == out.parent and stage.name.startswith(STAGING_PREFIX)
        (stage / "half.laz").write_bytes(b"LASF")
        raise RuntimeError("step failed")
    assert list(tmp_path.iterdir()) == []  # nor the parents made for it
    existing = tmp_path / "existing"
    existing.mkdir()
    with pytest.raises(KeyboardInterrupt), output_dir(existing) as stage:
        (stage / "half.laz").write_bytes(b"LASF")
        raise KeyboardInterrupt
    assert list(existing.iterdir()) == []


@pytest.mark.parametrize(
    ("errno_name", "exists"),
    [("EACCES", True), ("EROFS", True), ("EACCES", False), ("EROFS", False)],
)
def test_unwritable_output_folder(
    tmp_path: Path, small_site, monkeypatch, capsys, errno_name: str, exists: bool
) -> None:
    """Read-only, immutable or forbidden output folders: a message naming it, exit 2."""
    import errno
    import tempfile

    cloud, _ = small_site
    out = tmp_path / "locked"
    if exists:
        out.mkdir()

    def refuse(*args, dir=None, **kwargs):
        code = getattr(errno, errno_name)
        raise OSError(code, os.strerror(code), str(dir))

    import os

    monkeypatch.setattr(tempfile, "mkdtemp", refuse)
    assert main(["ground", str(cloud), "-o", str(out)]) == 2
    err = " ".join(capsys.readouterr().err.split())
    assert "Traceback" not in err and str(out) in err and "Fix:" in err
    assert "-o" in err


def test_output_folder_inside_a_file(tmp_path: Path, small_site, capsys) -> None:
    cloud, _ = small_site
    out = cloud / "out"  # the cloud is a regular file
    assert main(["ground", str(cloud), "-o", str(out)]) == 2
    err = " ".join(capsys.readouterr().err.split())
    assert "Traceback" not in err and f"{cloud} is a file" in err


def test_folder_that_cannot_be_created(tmp_path: Path, small_site, monkeypatch, capsys) -> None:
    import errno

    cloud, _ = small_site
    real = Path.mkdir

    def mkdir(self, *args, **kwargs):
        if self.name == "parent":
            raise PermissionError(errno.EACCES, "Permission denied", str(self))
        return real(self, *args, **kwargs)

    monkeypatch.setattr(Path, "mkdir", mkdir)
    out = tmp_path / "parent" / "out"
    assert main(["ground", str(cloud), "-o", str(out)]) == 2
    err = " ".join(capsys.readouterr().err.split())
    assert "cannot create the output folder" in err and str(out) in err


def test_disk_full_while_writing(tmp_path: Path, small_site, monkeypatch, capsys) -> None:
    """ENOSPC from a writer: one line naming the output file, exit 2, nothing left."""
    import errno

    import laspy

    cloud, _ = small_site

    def full(self, destination, *args, **kwargs):
        Path(destination).write_bytes(b"LASF")
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(laspy.LasData, "write", full)
    out = tmp_path / "out"
    before = sorted(tmp_path.iterdir())
    assert main(["ground", str(cloud), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert f"{out / 'ground.laz'}: No space left on device" in " ".join(err.split())
    assert sorted(tmp_path.iterdir()) == before


def test_unexpected_error_is_one_line_and_debug_reraises(
    tmp_path: Path, small_site, monkeypatch, capsys
) -> None:
    cloud, _ = small_site

    def boom(*args, **kwargs):
        raise ZeroDivisionError("float division by zero")

    monkeypatch.setattr("pyheracles.ground.extract_ground", boom)
    out = tmp_path / "out"
    assert main(["ground", str(cloud), "-o", str(out)]) == 1
    err = capsys.readouterr().err
    assert err.strip().splitlines() == [
        "internal error: ZeroDivisionError: float division by zero (please report; rerun "
        "with --debug for the traceback)"
    ]
    assert not out.exists()
    with pytest.raises(ZeroDivisionError):
        main(["--debug", "ground", str(cloud), "-o", str(out)])
    assert not out.exists()


def test_warnings_of_run_json_are_printed(tmp_path: Path, small_site, rng, capsys) -> None:
    """The cloud has no CRS: the note is in run.json AND on the screen (stderr)."""
    _, layer = small_site
    xy = rng.uniform(0, 40, (20000, 2))
    z = np.where((np.abs(xy - 20) < 5).all(axis=1), 8.0, 0.0)
    cloud = write_cloud(
        PointCloud.from_world(np.column_stack([xy + [85000, 447000], z])), tmp_path / "nocrs.laz"
    )
    out = tmp_path / "out"
    assert main(["complex", str(cloud), "-l", f"building={layer}:footprints", "-o", str(out)]) == 0
    run = json.loads((out / "run.json").read_text())
    recorded = [*run["warnings"], *run["notes"]]
    assert any("no CRS" in w for w in recorded)
    err = " ".join(capsys.readouterr().err.split())
    for warning in recorded:
        assert f"warning: {warning}" in err


def test_pipeline_status_is_the_real_one(tmp_path: Path) -> None:
    from pyheracles.cli.pipeline import _status
    from pyheracles.provenance import write_run_json

    folder = tmp_path / "step2" / "supports" / "hall"
    write_run_json(folder, step="supports", extra={"warnings": ["no support found"]})
    row = {"status": "ok", "step": "supports", "name": "hall", "n_objects": 0}
    assert _status(row, tmp_path) == "no support found"
    assert _status({**row, "n_objects": 2}, tmp_path) == "ok; no support found"
    assert _status({**row, "name": "other"}, tmp_path) == "ok"
    assert _status({**row, "status": "skipped: empty"}, tmp_path) == "skipped: empty"


def _all_options() -> set[str]:
    import typer.main

    from pyheracles.cli import app

    group = typer.main.get_command(app)
    names = {o for p in group.params for o in getattr(p, "opts", [])}
    for command in group.commands.values():  # type: ignore[attr-defined]
        for p in command.params:
            names.update(getattr(p, "opts", []))
            names.update(getattr(p, "secondary_opts", []))
    return names


#: References in hints to other tools, not to heracles options or Python names.
_EXTERNAL = (
    "colmap model_converter --output_type TXT",
    "shapely.make_valid",
    "pyheracles[e57]",
    "PDAL filters.range",
)


def _hints() -> list[tuple[str, str]]:
    """Every ``hint=`` string of the package (f-string fields become ``X``)."""
    import ast

    import pyheracles

    root = Path(pyheracles.__file__).parent

    def text(node: ast.AST) -> str:
        if isinstance(node, ast.Constant) and isinstance(node.value, str):
            return node.value
        if isinstance(node, ast.JoinedStr):
            return "".join(text(v) if isinstance(v, ast.Constant) else "X" for v in node.values)
        if isinstance(node, ast.BinOp):
            return text(node.left) + text(node.right)
        return "X"

    found = []
    for path in sorted(root.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Call):
                for kw in node.keywords:
                    if kw.arg == "hint":
                        found.append(
                            (f"{path.relative_to(root)}:{kw.value.lineno}", text(kw.value))
                        )
    return found


def test_hints_name_real_options() -> None:
    """Every --option in a hint exists; Python names are said to be Python."""
    import re

    options = _all_options()
    hints = _hints()
    assert len(hints) > 50
    for where, hint in hints:
        for ext in _EXTERNAL:
            hint = hint.replace(ext, "")
        for option in re.findall(r"(?<![\w-])--[a-z][a-z0-9-]*", hint):
            assert option in options, f"{where}: {option} is not an option of heracles"
        python, _, _ = hint.partition("in Python:")
        python = re.sub(r"\b(e\.g|i\.e)\.", "", python)
        python = re.sub(r"\b[a-z_][a-z0-9_]*=", "", python)  # KEY=VALUE of an option such as --set
        names = re.findall(r"\b[a-z][a-z0-9]*(?:_[a-z0-9]+)+\b|\b[a-z]+\.[a-z_]+\b", python)
        names = [n for n in names if not re.fullmatch(r"[a-z]+\.(gpkg|laz|las|csv|txt|xml|psz)", n)]
        assert not names, f"{where}: {names} in {hint!r} are no CLI options (say 'in Python:')"


def test_options_are_kebab_case_and_arguments_upper_case() -> None:
    import typer.main

    from pyheracles.cli import app

    group = typer.main.get_command(app)
    for name, command in group.commands.items():  # type: ignore[attr-defined]
        for p in command.params:
            if type(p).__name__.endswith("Option"):
                for opt in [*p.opts, *getattr(p, "secondary_opts", [])]:
                    assert re.fullmatch(r"-[a-z]|--[a-z][a-z0-9]*(-[a-z0-9]+)*", opt), (name, opt)
            else:
                shown = p.metavar or p.name
                assert re.fullmatch(r"[A-Z][A-Z0-9_]*", shown), (name, shown)


def test_stage_spinner_and_quiet(tmp_path: Path, small_site, monkeypatch) -> None:
    import io

    from rich.console import Console

    from pyheracles import progress
    from pyheracles.errors import InputError

    buf = io.StringIO()
    with progress.enabled(Console(file=buf, force_terminal=True, width=100)):
        with progress.stage("fitting cuboids"):
            pass
    assert "fitting cuboids" in buf.getvalue()
    with progress.stage("outside enabled"):  # a no-op: library code never prints
        pass
    seen = []

    def spy(*args, **kwargs):
        seen.append(progress.is_quiet())
        raise InputError("stop here")

    monkeypatch.setattr("pyheracles.ground.extract_ground", spy)
    cloud, _ = small_site
    assert main(["--quiet", "ground", str(cloud), "-o", str(tmp_path / "q")]) == 2
    assert main(["ground", str(cloud), "-o", str(tmp_path / "q")]) == 2
    assert seen == [True, False] and not progress.is_quiet()
    progress.set_quiet(True)
    buf = io.StringIO()
    with progress.enabled(Console(file=buf, force_terminal=True)), progress.stage("hidden"):
        pass
    progress.set_quiet(False)
    assert buf.getvalue() == ""


def test_a_message_kept_as_warning_and_note_is_printed_once(tmp_path: Path, capsys) -> None:
    """``heracles walls`` on a cloud too small for a wall kept its note under "warnings" and
    "notes" of run.json, and the screen showed it twice."""
    cloud = write_cloud(
        PointCloud.from_world(np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 2.0]])),
        tmp_path / "three.laz",
    )
    out = tmp_path / "out"
    assert main(["walls", str(cloud), "-o", str(out)]) == 0
    run = json.loads((out / "run.json").read_text())
    note = run["notes"][0]
    assert note in run["warnings"]
    assert capsys.readouterr().err.count(f"warning: {note}") == 1
