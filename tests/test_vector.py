"""Polygon layers: reading with attributes, validation, CRS alignment."""

from __future__ import annotations

from pathlib import Path

import geopandas as gpd
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
