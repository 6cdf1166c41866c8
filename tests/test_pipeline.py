"""``heracles pipeline``: step 1 on a site, then step 2 (supports) on the chosen building."""

from __future__ import annotations

from pathlib import Path

import geopandas as gpd
import numpy as np
import pandas as pd
import pytest
import shapely

from pyheracles import InputError, PointCloud
from pyheracles.cli import main
from pyheracles.io import write_cloud
from pyheracles.pipeline import Step2Spec, load_config


@pytest.fixture
def pavilion_site(tmp_path: Path, rng) -> Path:
    """A generated pavilion (piers and columns) standing on a flat site, with its footprint."""
    from pyheracles.synthetic.buildings import building_scene

    scene = building_scene("pavilion", spacing_m=0.08, rng=0)
    bxyz = scene.xyz - [*scene.xyz[:, :2].min(axis=0), scene.xyz[:, 2].min()] + [20, 20, 0]
    lo, hi = bxyz[:, :2].min(axis=0), bxyz[:, :2].max(axis=0)
    n = 60000
    g = np.column_stack([rng.uniform(0, hi[0] + 20, n), rng.uniform(0, hi[1] + 20, n),
                         rng.normal(0, 0.005, n)])  # fmt: skip
    g = g[~((g[:, :2] > lo).all(axis=1) & (g[:, :2] < hi).all(axis=1))]
    world = np.vstack([bxyz, g]) + [500000, 5400000, 100]
    cloud = PointCloud.from_world(world, crs="EPSG:32632")
    write_cloud(cloud, tmp_path / "site.laz")
    fp = shapely.box(*(lo + [500000, 5400000]), *(hi + [500000, 5400000]))
    gdf = gpd.GeoDataFrame({"name": ["Pendopo"], "period": ["XVI"]}, geometry=[fp], crs=32632)
    gdf.to_file(tmp_path / "fp.gpkg", driver="GPKG")
    (tmp_path / "run.yml").write_text(
        "cloud: site.laz\n"
        "layers: {building: fp.gpkg}\n"
        "output: out\n"
        "complex: {ground: auto}\n"
        "per_object: name\n"
        "step2:\n"
        "  - select: {class: building, min_height_m: 2, names: [Pendopo], name_field: name}\n"
        "    step: supports\n"
    )
    return tmp_path / "run.yml"


def test_pipeline_runs_step1_then_supports_with_gis_attributes(pavilion_site: Path) -> None:
    assert main(["pipeline", str(pavilion_site)]) == 0
    out = pavilion_site.parent / "out"
    assert (out / "segmented.laz").is_file() and (out / "objects" / "Pendopo.laz").is_file()
    folder = out / "step2" / "supports" / "Pendopo"
    table = (
        gpd.read_file(folder / "objects.gpkg")
        if (folder / "objects.gpkg").exists()
        else (pd.read_csv(folder / "objects.csv"))
    )
    classes = table["class"].value_counts().to_dict()
    assert classes.get("pier", 0) + classes.get("column", 0) >= 10, classes
    assert (table["gis_name"] == "Pendopo").all() and (table["gis_period"] == "XVI").all()


def test_config_errors(tmp_path: Path) -> None:
    bad = tmp_path / "bad.yml"
    bad.write_text("cloud: a.laz\n")
    with pytest.raises(InputError, match="missing keys: layers, output"):
        load_config(bad)
    bad.write_text("cloud: a.laz\nlayers: {b: x.gpkg}\noutput: o\ncomplex: {buffer: 2}\n")
    with pytest.raises(InputError, match=r"unknown complex parameters \['buffer'\]"):
        load_config(bad)
    with pytest.raises(InputError, match="unknown step-2 analysis 'walls'"):
        Step2Spec(step="walls")
    assert main(["pipeline", str(tmp_path / "none.yml")]) == 2


def test_step2_beams_on_a_roof_object() -> None:
    """The pipeline's beams analysis on one object's cloud, in a national grid frame."""
    from pyheracles.pipeline import _step2
    from pyheracles.synthetic.truss import make_truss_roof

    truss = make_truss_roof(rng=0)
    cloud = PointCloud.from_world(truss.xyz + [500000, 5400000, 100], crs="EPSG:32632")
    seg, info = _step2("beams", cloud)
    seg.check_balance()
    assert info["beams"] == len(seg.objects) >= len(truss.beams) - 1
    assert set(seg.objects["class"]) == {"beam"}
    # object positions are in the world frame
    assert seg.objects["centre_x"].between(499_990, 500_100).all()
