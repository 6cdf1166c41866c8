"""Polygon layers: reading with attributes, validation, CRS alignment."""

from __future__ import annotations

from pathlib import Path

import geopandas as gpd
import numpy as np
import pytest
import shapely
from pyproj import CRS

from pyheracles import CRSMismatchError, DegenerateGeometryError, InputError
from pyheracles.io import align_crs, read_layer, validate_polygons


def _layer(geoms: list, crs: str = "EPSG:28992") -> gpd.GeoDataFrame:
    return gpd.GeoDataFrame({"name": [f"f{i}" for i in range(len(geoms))]}, geometry=geoms, crs=crs)


def test_real_bgt_layers_keep_every_attribute(shared_data: Path) -> None:
    pand = read_layer(shared_data / "delft_ahn3" / "bgt" / "bgt_pand.sqlite")
    assert len(pand) == 160
    assert {"gml_id", "identificatiebagpnd", "creationdate", "source_fid"} <= set(pand.columns)
    assert pand.crs.to_epsg() == 28992
    walls = read_layer(shared_data / "delft_ahn3" / "bgt" / "bgt_scheiding.sqlite", "scheiding")
    assert len(walls) == 57 and "bgt_type" in walls.columns


def test_shapefile_in_wgs84_is_reprojected_only_on_request(shared_data: Path) -> None:
    shp = read_layer(shared_data / "autzen" / "attributes.shp")
    assert shp.crs.to_epsg() == 4326 and "cls" in shp.columns
    utm = CRS.from_epsg(32610)
    with pytest.raises(CRSMismatchError, match=r"attributes\.shp: layer CRS EPSG:4326 differs"):
        align_crs(shp, utm)
    moved = align_crs(shp, utm, reproject=True)
    assert moved.crs.equals(utm)
    assert 400_000 < moved.total_bounds[0] < 700_000


def test_missing_layer_name_lists_the_layers(tmp_path: Path) -> None:
    path = tmp_path / "two.gpkg"
    _layer([shapely.box(0, 0, 1, 1)]).to_file(path, layer="a", driver="GPKG")
    _layer([shapely.box(0, 0, 2, 2)]).to_file(path, layer="b", driver="GPKG")
    with pytest.raises(InputError, match=r"holds 2 layers \(a, b\)"):
        read_layer(path)
    with pytest.raises(InputError, match="no layer named 'c'"):
        read_layer(path, "c")
    assert len(read_layer(path, "b")) == 1


def test_unreadable_vector_file(tmp_path: Path) -> None:
    bad = tmp_path / "bad.gpkg"
    bad.write_bytes(b"not a geopackage")
    with pytest.raises(InputError, match=r"bad\.gpkg"):
        read_layer(bad)


def test_invalid_polygon_is_an_error_unless_fixed() -> None:
    bowtie = shapely.Polygon([(0, 0), (2, 2), (2, 0), (0, 2)])
    gdf = _layer([shapely.box(0, 0, 1, 1), bowtie])
    with pytest.raises(InputError, match=r"1 invalid polygons \(rows \[1\]"):
        validate_polygons(gdf)
    fixed = validate_polygons(gdf, fix_invalid=True)
    assert fixed.is_valid.all() and fixed.geometry.iloc[1].area > 0


def test_lines_and_empty_layers_are_rejected() -> None:
    with pytest.raises(InputError, match="not polygons"):
        validate_polygons(_layer([shapely.LineString([(0, 0), (1, 1)])]))
    with pytest.raises(DegenerateGeometryError, match="no features"):
        validate_polygons(_layer([]))


# ----------------------------------------------------------------------------- issue 15
def _gpkg_version(path: Path) -> tuple[int, int]:
    import sqlite3
    from contextlib import closing

    with closing(sqlite3.connect(path)) as db:
        return db.execute("pragma application_id").fetchone()[0], db.execute(
            "pragma user_version"
        ).fetchone()[0]


def test_objects_gpkg_is_geopackage_1_2(tmp_path: Path) -> None:
    """Defect 15: GeoPackage 1.2 (GDAL 3.6 warns about 1.4)."""
    from pyheracles.io.results import write_objects_table
    from pyheracles.io.vector import write_gpkg

    table = _layer([shapely.box(0, 0, 1, 1)])
    path = write_objects_table(table, tmp_path, table.crs)
    assert path.name == "objects.gpkg"
    assert _gpkg_version(path) == (0x47504B47, 10200)  # "GPKG", version 1.2.0
    other = write_gpkg(table, tmp_path / "layer.gpkg", "footprints")
    assert _gpkg_version(other) == (0x47504B47, 10200)


def _two_layer_site(rng) -> tuple:
    """Flat ground, two buildings and a wall; only the building layer has an integer id."""
    from pyheracles import PointCloud

    e0, n0 = 85000.0, 447000.0
    ground = np.column_stack([rng.uniform(0, 60, 20000), rng.uniform(0, 40, 20000),
                              rng.normal(0, 0.01, 20000)])  # fmt: skip
    parts = [ground]
    for x0 in (10.0, 30.0):  # flat roofs at 6 m
        top = np.column_stack([rng.uniform(x0, x0 + 8, 4000), rng.uniform(10, 20, 4000)])
        parts.append(np.column_stack([top, np.full(4000, 6.0)]))
    wall = np.column_stack([rng.uniform(5, 50, 3000), rng.uniform(30, 30.3, 3000),
                            rng.uniform(0, 2, 3000)])  # fmt: skip
    parts.append(wall)
    world = np.vstack(parts) + [e0, n0, 0.0]
    cloud = PointCloud.from_world(np.round(world, 3), crs="EPSG:28992", scale=np.full(3, 1e-3))
    buildings = gpd.GeoDataFrame(
        {
            "identificatiebagpnd": np.array([503100000000035, 9007199254740993], np.int64),
            "inonderzoek": [False, True],
            "relatievehoogteligging": np.array([0, 1], np.int32),
        },
        geometry=[shapely.box(e0 + x0, n0 + 10, e0 + x0 + 8, n0 + 20) for x0 in (10.0, 30.0)],
        crs="EPSG:28992",
    )
    walls = gpd.GeoDataFrame(
        {"bgt_type": ["muur"]},
        geometry=[shapely.box(e0 + 5, n0 + 29.9, e0 + 50, n0 + 30.4)],
        crs="EPSG:28992",
    )
    return cloud, {"building": buildings, "wall": walls}


def test_integer_attributes_stay_integer_and_name_per_object_files(tmp_path: Path) -> None:
    """Defect 9: no ``503100000000035.0.laz`` and ``nan.laz``; Integer64 stays Integer64."""
    import json

    import laspy
    import pyogrio

    from pyheracles.complex import ComplexParams, prepare_layers, segment_complex
    from pyheracles.io.results import write_segmentation

    cloud, layers = _two_layer_site(np.random.default_rng(5))
    layers = prepare_layers(layers, cloud)
    result = segment_complex(cloud, layers, ComplexParams(ground="smrf"))
    objects = result.segmentation.objects
    assert str(objects["identificatiebagpnd"].dtype) == "Int64"
    assert str(objects["inonderzoek"].dtype) == "boolean"
    assert str(objects["relatievehoogteligging"].dtype) == "Int32"
    paths = write_segmentation(
        cloud, result.segmentation, tmp_path / "out", step="complex",
        per_object="identificatiebagpnd",
    )  # fmt: skip
    names = sorted(p.name for p in paths["objects_dir"].iterdir())
    wall_id = int(objects.loc[objects["class"] == "wall", "instance"].iloc[0])
    assert names == sorted(["503100000000035.laz", "9007199254740993.laz", f"wall_{wall_id}.laz"])
    info = pyogrio.read_info(paths["objects"])
    types = dict(zip(info["fields"], info["dtypes"], strict=True))
    assert types["identificatiebagpnd"] == "int64" and types["relatievehoogteligging"] == "int32"
    assert types["inonderzoek"] == "bool"
    import sqlite3
    from contextlib import closing

    with closing(sqlite3.connect(paths["objects"])) as db:
        got = db.execute("select identificatiebagpnd from objects").fetchall()
    assert sorted(v for (v,) in got if v is not None) == [503100000000035, 9007199254740993]
    # ASPRS classes: building 6, wall 64 (user definable), ground 2, rest 1
    las = laspy.read(paths["cloud"])
    inst = np.asarray(las["instance"])
    cls = np.asarray(las.classification)
    by_class = dict(zip(objects["instance"], objects["class"], strict=True))
    for instance, name in by_class.items():
        assert set(np.unique(cls[inst == instance])) == {6 if name == "building" else 64}
    assert set(np.unique(cls[inst == 0])) <= {1, 2}
    run = json.loads(paths["run"].read_text())
    assert run["asprs_classes"]["building"] == 6 and run["asprs_classes"]["wall"] == 64


@pytest.mark.realdata
@pytest.mark.slow
def test_delft_per_object_files_are_named_by_bag_id(shared_data: Path, tmp_path: Path) -> None:
    """The issue's command: BGT buildings and walls, ``--per-object identificatiebagpnd``."""
    import pyogrio

    from pyheracles.pipeline import complex_from_files

    d = shared_data / "delft_ahn3"
    _, paths, _, _ = complex_from_files(
        d / "ahn3_tile1.laz",
        [f"building={d / 'bgt' / 'bgt_pand.sqlite'}",
         f"wall={d / 'bgt' / 'bgt_scheiding.sqlite'}:scheiding"],
        tmp_path / "out", per_object="identificatiebagpnd",
    )  # fmt: skip
    names = [p.stem for p in paths["objects_dir"].iterdir()]
    assert not [n for n in names if n.startswith("nan") or n.endswith(".0")]
    assert any(n.startswith("5031") and n.isdigit() for n in names)
    assert any(n.startswith("wall_") for n in names)
    info = pyogrio.read_info(paths["objects"])
    assert dict(zip(info["fields"], info["dtypes"], strict=True))["identificatiebagpnd"] == "int64"
