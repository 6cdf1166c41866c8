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
    with pytest.raises(InputError, match=r"unknown key 'buffer' in complex \(did you mean 'buf"):
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


def test_config_typos_and_types_are_reported_together_before_any_work(tmp_path: Path) -> None:
    """Issue 15, defect 6: typos and wrong types in the YAML, all in one message."""
    bad = tmp_path / "run.yml"
    bad.write_text(
        "cloud: site.laz\n"
        "layers: {building: fp.gpkg}\n"
        "output: out\n"
        "complx: {ground: auto}\n"
        'complex: {buffer_m: "two", ground: csf}\n'
        "step2:\n"
        "  - select: {class: building, min_hieght_m: 4}\n"
        "    step: supports\n"
        "  - select: {min_height_m: tall, names: [Pendopo, 12]}\n"
        "    step: beams\n"
    )
    with pytest.raises(InputError) as err:
        load_config(bad)
    text = str(err.value)
    assert text.startswith(f"{bad}: 4 problems in the configuration")
    assert "unknown key 'complx' at the top level (did you mean 'complex'?)" in text
    assert "complex.buffer_m: expected a number" in text and "got 'two'" in text
    assert "unknown key 'min_hieght_m' in step2[0].select (did you mean 'min_height_m'?)" in text
    assert "step2[1].select.min_height_m: expected a number, got 'tall'" in text
    # step2 written as a mapping, a step that does not exist, a bad CRS: no traceback
    bad.write_text(
        "cloud: site.laz\nlayers: {building: fp.gpkg}\noutput: out\ncloud_crs: EPSG:99999\n"
        "reproject: yes please\nstep2:\n  select: {class: building}\n  step: supports\n"
    )
    with pytest.raises(InputError) as err:
        load_config(bad)
    text = str(err.value)
    assert "step2: expected a list of entries" in text and "got a mapping" in text
    assert "cloud_crs: 'EPSG:99999' is not a CRS" in text
    assert "reproject: expected true or false, got 'yes please'" in text
    assert main(["pipeline", str(bad)]) == 2
    bad.write_text(
        "cloud: site.laz\nlayers: {building: fp.gpkg}\noutput: out\n"
        "step2:\n  - {select: {class: building}, step: walls}\n  - 3\n"
    )
    with pytest.raises(InputError, match=r"step2\[0\]\.step: expected one of supports, beams"):
        load_config(bad)
    # good values are converted: whole numbers, lists -> tuples, one name -> a list
    bad.write_text(
        "cloud: site.laz\nlayers: {building: fp.gpkg}\noutput: out\n"
        "complex: {min_cluster_points: 20.0, layer_order: [building], buffer_m: 2}\n"
        "per_object: name\nstep2:\n  - select: {names: Pendopo, min_height_m: 2}\n"
    )
    cfg = load_config(bad)
    assert cfg.complex.min_cluster_points == 20 and cfg.complex.layer_order == ("building",)
    assert cfg.complex.buffer_m == 2.0
    assert cfg.step2[0].names == ("Pendopo",) and cfg.step2[0].name_field == "name"


def test_names_matching_nothing_warn_and_nothing_selected_is_an_error() -> None:
    from pyheracles.pipeline import _selections

    objects = pd.DataFrame(
        {"instance": [1, 2, 3], "class": ["building", "building", "wall"],
         "height": [6.0, 2.0, 3.0], "name": ["Pendopo", "Langgar", "Kelir"]}
    )  # fmt: skip
    specs = [Step2Spec("supports", "building", 0.0, ("Pendopo", "Pendapa"), "name")]
    chosen, warnings = _selections(objects, specs)
    assert chosen[0]["name"].tolist() == ["Pendopo"]
    assert len(warnings) == 1 and "['Pendapa'] match no building" in warnings[0]
    with pytest.raises(InputError, match="step 2 selects no object of the 3") as err:
        _selections(objects, [Step2Spec("supports", "building", 10.0, ("Pendopo",), "name")])
    assert "Kelir" in str(err.value) and "classes are building, wall" in str(err.value)
    assert _selections(objects, []) == ([], [])


def test_pipeline_warns_about_unmatched_names_and_refuses_an_empty_selection(
    pavilion_site: Path,
) -> None:
    import json

    text = pavilion_site.read_text().replace("names: [Pendopo]", "names: [Pendapa]")
    pavilion_site.write_text(text)
    assert main(["pipeline", str(pavilion_site)]) == 2  # nothing at all selected
    assert not (pavilion_site.parent / "out").exists()
    pavilion_site.write_text(
        text.replace("- select: {class: building, min_height_m: 2, names: [Pendapa]",
                     "- select: {class: building, min_height_m: 200}\n"
                     "    step: supports\n"
                     "  - select: {class: building, min_height_m: 2, names: [Pendopo, Pendapa]")
    )  # fmt: skip
    from pyheracles.pipeline import run_pipeline

    run = run_pipeline(load_config(pavilion_site))
    assert [r["name"] for r in run["step2"]] == ["Pendopo"]
    assert any("['Pendapa'] match no building" in w for w in run["warnings"])
    record = json.loads((pavilion_site.parent / "out" / "run.json").read_text())
    assert any("Pendapa" in w for w in record["warnings"])


def test_cloud_and_layers_without_crs_get_a_note(tmp_path: Path) -> None:
    import json

    from pyheracles.pipeline import complex_from_files

    rng = np.random.default_rng(0)
    g = np.c_[rng.uniform(0, 60, 30000), rng.uniform(0, 60, 30000), rng.normal(0, 0.01, 30000)]
    b = np.c_[rng.uniform(20, 30, 6000), rng.uniform(20, 30, 6000), np.full(6000, 5.0)]
    write_cloud(PointCloud.from_world(np.vstack([g, b])), tmp_path / "site.laz")
    layer = gpd.GeoDataFrame({"name": ["A"]}, geometry=[shapely.box(20, 20, 30, 30)])
    with pytest.warns(UserWarning, match="crs"):  # a layer without CRS, on purpose
        layer.to_file(tmp_path / "fp.gpkg", driver="GPKG")
    _, paths, _, _ = complex_from_files(
        tmp_path / "site.laz", [f"building={tmp_path / 'fp.gpkg'}"], tmp_path / "out"
    )
    notes = json.loads(paths["run"].read_text())["notes"]
    assert any("neither the cloud nor the layers have a CRS" in n for n in notes)


def test_pipeline_ifc_puts_each_element_in_its_building(pavilion_site: Path) -> None:
    pytest.importorskip("ifcopenshell")
    import ifcopenshell
    import ifcopenshell.util.element
    import ifcopenshell.validate

    assert main(["pipeline", str(pavilion_site), "--ifc"]) == 0
    out = pavilion_site.parent / "out"
    ifc = ifcopenshell.open(str(out / "model.ifc"))
    logger = ifcopenshell.validate.json_logger()
    ifcopenshell.validate.validate(ifc, logger)
    assert not [s for s in logger.statements if s.get("level", "error") == "error"]
    buildings = {b.Name: b for b in ifc.by_type("IfcBuilding")}
    assert "Pendopo" in buildings
    folder = out / "step2" / "supports" / "Pendopo"
    table = (gpd.read_file(folder / "objects.gpkg") if (folder / "objects.gpkg").exists()
             else pd.read_csv(folder / "objects.csv"))  # fmt: skip
    n_supports = int(table["class"].isin(["column", "pier", "engaged_column"]).sum())
    inside = [e for e in ifcopenshell.util.element.get_decomposition(buildings["Pendopo"])
              if e.is_a("IfcColumn")]  # fmt: skip
    assert len(inside) == n_supports == len(ifc.by_type("IfcColumn")) > 0
    run = __import__("json").loads((out / "run.json").read_text())
    assert run["ifc"]["elements"]["IfcColumn"] == n_supports
