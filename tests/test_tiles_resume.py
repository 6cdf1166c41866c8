"""City scale: a killed worker or run resumes to identical outputs; bad input (issue 19)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import geopandas as gpd
import laspy
import numpy as np
import pyogrio
import pytest
import shapely
from pyproj import CRS

from pyheracles.cli import main
from pyheracles.tiles import run_tiles, split_las

RD = "EPSG:28992"
X0, Y0 = 85_000.0, 447_000.0


def _scene(rng: np.random.Generator, side: float = 120.0) -> tuple[np.ndarray, gpd.GeoDataFrame]:
    """Sloping ground on a 0.4 m lattice and box buildings (walls and roof), some across cuts."""
    g = np.mgrid[0:side:0.4, 0:side:0.4].reshape(2, -1).T + rng.uniform(-0.1, 0.1, (1, 2))
    keep = np.ones(len(g), bool)
    parts, polys = [], []
    for k in range(9):
        x0, y0 = 8 + (k % 3) * 38 + rng.uniform(0, 8), 8 + (k // 3) * 38 + rng.uniform(0, 8)
        x1, y1, h = x0 + rng.uniform(10, 22), y0 + rng.uniform(10, 22), rng.uniform(4, 10)
        inside = (g[:, 0] > x0) & (g[:, 0] < x1) & (g[:, 1] > y0) & (g[:, 1] < y1)
        keep &= ~inside
        parts.append(np.column_stack([g[inside], np.full(inside.sum(), h)]))
        t = np.arange(0, 1, 0.02)
        edge = np.concatenate([np.column_stack([x0 + (x1 - x0) * t, np.full(len(t), y)])
                               for y in (y0, y1)]
                              + [np.column_stack([np.full(len(t), x), y0 + (y1 - y0) * t])
                                 for x in (x0, x1)])  # fmt: skip
        zs = np.arange(0.5, h, 0.5)
        parts.append(np.column_stack([np.repeat(edge, len(zs), axis=0), np.tile(zs, len(edge))]))
        polys.append(shapely.box(x0 + X0, y0 + Y0, x1 + X0, y1 + Y0))
    ground = np.column_stack([g[keep], 0.02 * g[keep, 0] + rng.normal(0, 0.02, keep.sum())])
    xyz = np.concatenate([ground, *parts]) + [X0, Y0, 0.0]
    return xyz, gpd.GeoDataFrame({"name": [f"b{k}" for k in range(9)]}, geometry=polys, crs=RD)


def _write(path: Path, xyz: np.ndarray, crs: str | None = RD) -> Path:
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.scales = [0.001, 0.001, 0.001]
    header.offsets = [X0, Y0, 0.0]
    if crs is not None:
        header.add_crs(CRS.from_user_input(crs))
    las = laspy.LasData(header)
    las.x, las.y, las.z = xyz[:, 0], xyz[:, 1], xyz[:, 2]
    las.intensity = np.arange(len(xyz)) % 60000
    las.write(path)
    return path


@pytest.fixture(scope="module")
def city(tmp_path_factory: pytest.TempPathFactory) -> dict:
    root = tmp_path_factory.mktemp("resume")
    xyz, layer = _scene(np.random.default_rng(11))
    tiles = split_las(_write(root / "whole.laz", xyz), root / "in", 3, 3)
    layer.to_file(root / "b.gpkg", engine="pyogrio")
    return {"root": root, "tiles": tiles, "layer": layer, "gpkg": root / "b.gpkg"}


def _outputs(out: Path) -> dict:
    """Every output a user reads, as comparable values (no timings)."""
    got: dict = {}
    for folder in sorted((out / "tiles").iterdir()):
        las = laspy.read(folder / "segmented.laz")
        dims = las.point_format.dimension_names
        got[folder.name] = {d: np.asarray(las[d]).tolist() for d in dims}
        if (folder / "objects.gpkg").is_file():
            t = pyogrio.read_dataframe(folder / "objects.gpkg")
            got[folder.name + "/objects"] = t.to_wkb().to_dict("list")
    objects = pyogrio.read_dataframe(out / "objects.gpkg")
    got["objects"] = objects.to_wkb().to_dict("list")
    index = pyogrio.read_dataframe(out / "tiles.gpkg", read_geometry=False)
    got["index"] = index[["name", "n_points", "output"]].to_dict("list")
    return got


def _cli(args: list[str]) -> subprocess.Popen:
    code = "import sys; from pyheracles.cli import main; sys.exit(main(sys.argv[1:]))"
    return subprocess.Popen(
        [sys.executable, "-c", code, *args], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
        text=True, start_new_session=True,
    )  # fmt: skip


def _wait_for_first_tile(proc: subprocess.Popen, work: Path, timeout: float = 300) -> None:
    t0 = time.monotonic()
    while not [p for p in work.glob("*.pkl") if p.name != "parameters.pkl"]:  # a tile's
        assert proc.poll() is None, proc.stdout.read() if proc.stdout else ""
        assert time.monotonic() - t0 < timeout, "no tile finished"
        time.sleep(0.05)


@pytest.mark.slow
def test_killed_worker_then_killed_run_resume_to_identical_outputs(
    city: dict, tmp_path: Path
) -> None:
    import psutil

    layers = {"building": gpd.read_file(city["gpkg"])}
    ref = tmp_path / "ref"
    assert set(run_tiles(city["root"] / "in", layers, ref).status.values()) == {"done"}
    expected = _outputs(ref)
    args = ["complex", str(city["root"] / "in"), "-l", f"building={city['gpkg']}"]

    # 1. one Dask worker process killed mid-run: Dask retries its task elsewhere
    out = tmp_path / "killed_worker"
    proc = _cli([*args, "-o", str(out), "--workers", "2"])
    _wait_for_first_tile(proc, out / ".work")
    assert not (out / "tiles.gpkg").exists()  # mid-way
    workers = [
        p
        for p in psutil.Process(proc.pid).children(recursive=True)
        if "spawn_main" in " ".join(p.cmdline()) or "forkserver" in " ".join(p.cmdline())
    ]
    assert workers, "no worker process found"  # fmt: skip
    os.kill(workers[0].pid, signal.SIGKILL)
    log = proc.communicate(timeout=600)[0]
    if proc.returncode != 0:  # the task failed for good: the same command resumes
        assert proc.returncode == 2, log
        assert main([*args, "-o", str(out)]) == 0
    assert _outputs(out) == expected

    # 2. the whole run killed mid-way (scheduler, workers, all): rerun resumes
    out = tmp_path / "killed_run"
    proc = _cli([*args, "-o", str(out), "--workers", "2"])
    _wait_for_first_tile(proc, out / ".work")
    os.killpg(proc.pid, signal.SIGKILL)  # its own session: only what this test started
    proc.communicate(timeout=60)
    assert not (out / "tiles.gpkg").exists()
    assert main([*args, "-o", str(out)]) == 0
    assert _outputs(out) == expected


# ----------------------------------------------------------------------------- bad input
def test_cli_tiles_in_different_crs_exit_2_naming_them(
    city: dict, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    xyz, _ = _scene(np.random.default_rng(2), side=40.0)
    _write(tmp_path / "a.laz", xyz[xyz[:, 0] < X0 + 20])
    _write(tmp_path / "b.laz", xyz[xyz[:, 0] >= X0 + 20], crs="EPSG:32631")
    code = main(["complex", str(tmp_path / "*.laz"), "-l", f"building={city['gpkg']}",
                 "-o", str(tmp_path / "o")])  # fmt: skip
    text = capsys.readouterr()
    msg = text.out + text.err
    assert code == 2
    assert "different CRSs" in msg and "a.laz" in msg and "b.laz" in msg
    assert "Traceback" not in msg


def test_cli_overlapping_duplicate_tile_exit_2(
    city: dict, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    for p in city["tiles"][:2]:
        (tmp_path / p.name).write_bytes(p.read_bytes())
    (tmp_path / "zz_copy.laz").write_bytes(city["tiles"][0].read_bytes())
    code = main(["ground", str(tmp_path), "-o", str(tmp_path / "o")])
    text = capsys.readouterr()
    assert code == 2
    assert "duplicates" in text.out + text.err and "zz_copy.laz" in text.out + text.err


@pytest.mark.parametrize("address", ["", "tcp://127.0.0.1:9"])
def test_cli_scheduler_missing_or_unreachable_exit_2(
    city: dict, tmp_path: Path, capsys: pytest.CaptureFixture[str], address: str
) -> None:
    code = main(["complex", str(city["root"] / "in"), "-l", f"building={city['gpkg']}",
                 "-o", str(tmp_path / "o"), "--scheduler", address])  # fmt: skip
    text = capsys.readouterr()
    msg = text.out + text.err
    assert code == 2
    assert ("needs the address" if not address else "cannot connect to the Dask scheduler") in msg
    assert "Traceback" not in msg


@pytest.mark.slow
def test_ground_unreadable_tile_named_others_finish_exit_2(
    city: dict, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    folder = tmp_path / "in"
    folder.mkdir()
    for p in city["tiles"][:3]:
        (folder / p.name).write_bytes(p.read_bytes())
    (folder / "broken.laz").write_bytes(b"LASF" + b"\0" * 50)
    out = tmp_path / "o"
    code = main(["ground", str(folder), "-o", str(out), "--method", "smrf"])
    text = capsys.readouterr().out
    assert code == 2 and "broken.laz" in text
    assert len(list((out / "tiles").glob("*/ground.laz"))) == 3
    index = gpd.read_file(out / "tiles.gpkg")
    assert (index["status"] == "done").sum() == 3
    assert index.loc[index["name"] == "broken", "status"].str.startswith("failed").all()
