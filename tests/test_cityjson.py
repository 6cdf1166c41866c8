"""CityJSON 2.0 export and its validation (pyheracles.export.cityjson)."""

from __future__ import annotations

import json

import numpy as np
import pytest
import shapely

from pyheracles.export.cityjson import CityBuilding, validate_cityjson, write_cityjson
from pyheracles.roofs.solid import extrude_partition, flat_solid, partition_footprint

OFFSET = np.array([84800.0, 447400.0, -0.5])


def _buildings() -> list[CityBuilding]:
    fp = shapely.box(0, 0, 10, 6)
    lod12 = flat_solid(fp, 0.0, 6.5)
    cells = partition_footprint(fp, [shapely.LineString([(-1, 3), (11, 3)])])
    labels = [0 if c.centroid.y < 3 else 1 for c in cells]
    lod22 = extrude_partition(cells, labels, np.array([[0, 2 / 3, 5.0], [0, -2 / 3, 9.0]]), 0.0)
    solids = {
        "1.2": (lod12.vertices + OFFSET, lod12.faces, lod12.semantics),
        "2.2": (lod22.vertices + OFFSET, lod22.faces, lod22.semantics),
    }
    attrs = {"name": "house", "storeys": np.int64(2), "height": float("nan"),
             "built": np.datetime64("2001-02-03")}  # fmt: skip
    return [CityBuilding("b1", attrs, solids)]


def test_write_and_validate(tmp_path) -> None:
    path = tmp_path / "city.json"
    report = write_cityjson(path, _buildings(), crs="EPSG:28992")
    assert report.invalid == [] and report.n_solids == {"1.2": 1, "2.2": 1}
    doc = json.loads(path.read_text())
    assert doc["version"] == "2.0" and doc["type"] == "CityJSON"
    assert doc["metadata"]["referenceSystem"].endswith("/EPSG/0/28992")
    assert validate_cityjson(doc) == []
    b = doc["CityObjects"]["b1"]
    assert [g["lod"] for g in b["geometry"]] == ["1.2", "2.2"]
    assert b["attributes"]["storeys"] == 2 and b["attributes"]["height"] is None
    types = {s["type"] for s in b["geometry"][1]["semantics"]["surfaces"]}
    assert types == {"RoofSurface", "WallSurface", "GroundSurface"}
    # vertices exact to 1 mm in world coordinates
    v = np.asarray(doc["vertices"]) * doc["transform"]["scale"] + doc["transform"]["translate"]
    assert np.isclose(v[:, 0].min(), OFFSET[0]) and np.isclose(v[:, 2].max(), 6.5)


def test_invalid_solid_left_out_and_listed(tmp_path) -> None:
    b = _buildings()[0]
    v, faces, sem = b.solids["2.2"]
    broken = CityBuilding("b2", {}, {"2.2": (v, faces[1:], sem[1:])})
    report = write_cityjson(tmp_path / "c.json", [b, broken], crs="EPSG:28992")
    assert len(report.invalid) == 1 and "b2" in report.invalid[0]
    doc = json.loads((tmp_path / "c.json").read_text())
    assert doc["CityObjects"]["b2"]["geometry"] == []
    assert validate_cityjson(doc) == []


def test_validator_catches_errors(tmp_path) -> None:
    write_cityjson(tmp_path / "c.json", _buildings(), crs="EPSG:28992")
    doc = json.loads((tmp_path / "c.json").read_text())
    bad = json.loads(json.dumps(doc))
    bad["CityObjects"]["b1"]["geometry"][0]["lod"] = "7"
    assert any("LoD" in e for e in validate_cityjson(bad))
    bad = json.loads(json.dumps(doc))
    bad["CityObjects"]["b1"]["geometry"][1]["boundaries"][0][0][0].reverse()
    assert validate_cityjson(bad)
    bad = json.loads(json.dumps(doc))
    bad["CityObjects"]["b1"]["geometry"][0]["boundaries"][0][0][0][0] = 10**6
    assert any("range" in e for e in validate_cityjson(bad))


def test_cjio_reads(tmp_path) -> None:
    import subprocess
    import sys

    pytest.importorskip("cjio")
    path = tmp_path / "city.json"
    write_cityjson(path, _buildings(), crs="EPSG:28992")
    # in a child process: importing cjio replaces the json module's float encoder for the
    # whole interpreter (json.encoder.c_make_encoder = None), which would round every
    # later JSON file of the test session to 6 decimals
    code = (
        "import sys, cjio.cityjson as c; cm = c.reader(open(sys.argv[1]), "
        "ignore_duplicate_keys=False); print(len(cm.j['CityObjects']), cm.get_epsg())"
    )
    out = subprocess.run([sys.executable, "-c", code, str(path)], capture_output=True,
                         text=True, check=True, timeout=120)  # fmt: skip
    assert out.stdout.split() == ["1", "28992"]


def test_cli_roofs_and_export(tmp_path, shared_data) -> None:
    from typer.testing import CliRunner

    from pyheracles.cli import app

    pytest.importorskip("pyheracles.cli.roofs")
    base = shared_data / "delft_ahn3"
    out = tmp_path / "roofs"
    r = CliRunner().invoke(app, ["--no-report", "--quiet", "roofs", str(base / "ahn3_tile1.laz"),
                                 "--footprints", str(base / "bgt" / "bgt_pand.sqlite"),
                                 "-o", str(out)])  # fmt: skip
    if r.exit_code == 2 and "No such command" in r.output:
        pytest.skip("roofs not registered in COMMAND_MODULES")
    assert r.exit_code == 0, r.output
    run = json.loads((out / "run.json").read_text())
    assert run["buildings"]["skipped"] == len(run["skipped"]) > 0
    r = CliRunner().invoke(app, ["export", "cityjson", str(out), "-o", str(tmp_path / "c.json")])
    assert r.exit_code == 0, r.output
    assert validate_cityjson(json.loads((tmp_path / "c.json").read_text())) == []


test_cli_roofs_and_export = pytest.mark.slow(test_cli_roofs_and_export)
