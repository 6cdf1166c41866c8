"""``--ifc`` on the step commands: model.ifc in the output folder, valid, one element each."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

pytest.importorskip("ifcopenshell")
import ifcopenshell
import ifcopenshell.validate

from pyheracles.cli import main
from pyheracles.cloud import PointCloud
from pyheracles.io import write_cloud


def _valid(path: Path):
    ifc = ifcopenshell.open(str(path))
    logger = ifcopenshell.validate.json_logger()
    ifcopenshell.validate.validate(ifc, logger)
    assert not [s for s in logger.statements if s.get("level", "error") == "error"]
    return ifc


def test_supports_ifc(tmp_path: Path) -> None:
    from pyheracles.synthetic.buildings import building_scene

    scene = building_scene("pavilion", spacing_m=0.08, rng=7)
    src = tmp_path / "pavilion.laz"
    write_cloud(PointCloud.from_world(scene.xyz + [651000.0, 6862000.0, 50.0],
                                      crs="EPSG:2154"), src)  # fmt: skip
    assert main(["supports", str(src), "-o", str(tmp_path / "sup"), "--ifc"]) == 0
    ifc = _valid(tmp_path / "sup" / "model.ifc")
    import geopandas as gpd

    sup = tmp_path / "sup"
    table = (gpd.read_file(sup / "objects.gpkg") if (sup / "objects.gpkg").exists()
             else pd.read_csv(sup / "objects.csv"))  # fmt: skip
    n = int(table["class"].isin(["column", "pier", "engaged_column"]).sum())
    assert len(ifc.by_type("IfcColumn")) == n == 14
    assert ifc.by_type("IfcProjectedCRS")[0].Name == "EPSG:2154"
    run = json.loads((tmp_path / "sup" / "run.json").read_text())
    assert run["ifc"] == {"path": "model.ifc", "elements": {"IfcColumn": 14}}


def test_walls_ifc_without_crs_says_so(tmp_path: Path, capsys) -> None:
    rng = np.random.default_rng(2)
    faces = []
    for x0, x1, y0, y1 in ((0, 10, 0, 0), (0, 10, 6, 6), (0, 0, 0, 6), (10, 10, 0, 6)):
        for off in (-0.2, 0.2):  # both faces of a 0.4 m wall
            n = 15000
            s, z = rng.random(n), rng.uniform(0, 4, n)
            x = x0 + s * (x1 - x0) + (off if x0 == x1 else 0)
            y = y0 + s * (y1 - y0) + (off if y0 == y1 else 0)
            faces.append(np.c_[x, y, z])
    xyz = np.vstack(faces) + rng.normal(0, 0.002, (len(faces) * 15000, 3))
    src = tmp_path / "room.laz"
    write_cloud(PointCloud.from_world(xyz), src)
    assert main(["walls", str(src), "-o", str(tmp_path / "w"), "--ifc"]) == 0
    ifc = _valid(tmp_path / "w" / "model.ifc")
    assert len(ifc.by_type("IfcWall")) == len(pd.read_csv(tmp_path / "w" / "objects.csv")) == 4
    assert "IFC: the cloud has no CRS" in capsys.readouterr().err  # the note reaches the screen
