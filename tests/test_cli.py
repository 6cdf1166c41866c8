"""The ``heracles`` command: help, demo, bad input gives exit code 2 and no partial output."""

from __future__ import annotations

import json
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
    assert not list(tmp_path.glob(".out.*"))  # staging folder removed


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


def test_demo_command(tmp_path: Path) -> None:
    out = tmp_path / "demo"
    assert main(["demo", "-o", str(out), "--points", "80000"]) == 0
    assert (out / "overview.png").stat().st_size > 10_000
    assert (out / "result" / "evaluation.csv").is_file()
    assert (out / "scene" / "cloud.laz").is_file()


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
