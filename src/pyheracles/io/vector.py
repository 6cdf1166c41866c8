"""Polygon layers (Shapefile, GeoPackage, SpatiaLite, GeoJSON) with all their attributes.

Read through pyogrio into a GeoDataFrame.  The layer is checked before any
work: polygons only, valid, not empty, and in the cloud's CRS (or reprojected
when asked) -- the checks geopandas' ``clip`` does first.
"""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Any

import geopandas as gpd
import numpy as np
import pyogrio
import shapely
from pyproj import CRS

from pyheracles.errors import CRSMismatchError, DegenerateGeometryError, InputError

__all__ = ["GPKG_VERSION", "align_crs", "read_layer", "validate_polygons", "write_gpkg"]

_POLYGONAL = {"Polygon", "MultiPolygon"}

GPKG_VERSION = "1.2"
"""GeoPackage version written: 1.2 is read by every GDAL >= 2.2 without a warning (GDAL
3.6 warns about the 1.4 files newer GDAL writes by default)."""


def read_layer(path: str | Path, layer: str | int | None = None) -> gpd.GeoDataFrame:
    """Read one polygon layer with every attribute.

    Parameters
    ----------
    path
        Shapefile, GeoPackage, SpatiaLite/SQLite, GeoJSON ... (anything GDAL reads).
    layer
        Layer name or index inside a multi-layer source; required when the
        source holds more than one layer.

    Returns
    -------
    GeoDataFrame
        Attributes plus ``geometry``; the index is the feature's position in
        the layer, and the column ``source_fid`` keeps it for the outputs.

    Raises
    ------
    InputError
        Missing/unreadable file, unknown or ambiguous layer.
    """
    p = Path(path)
    if not p.exists():
        raise InputError("file not found", path=p, hint="check the path")
    try:
        layers = pyogrio.list_layers(p)
    except Exception as exc:
        raise InputError(
            f"cannot open as a vector layer ({exc})",
            path=p,
            hint="use a Shapefile, GeoPackage, SpatiaLite or GeoJSON file",
        ) from exc
    names = [str(n) for n in layers[:, 0]]
    if layer is None and len(names) > 1:
        raise InputError(
            f"the file holds {len(names)} layers ({', '.join(names)}); say which one",
            path=p,
            hint=f"append ':{names[0]}' to the path (PATH:LAYERNAME)",
        )
    if isinstance(layer, str) and layer not in names:
        raise InputError(
            f"no layer named {layer!r}; layers are: {', '.join(names)}",
            path=p,
            hint="give one of the listed layer names",
        )
    try:
        gdf = gpd.read_file(p, layer=layer, engine="pyogrio")
    except Exception as exc:
        raise InputError(f"cannot read the layer ({exc})", path=p) from exc
    gdf = gdf.reset_index(drop=True)
    gdf["source_fid"] = np.arange(len(gdf), dtype=np.int64)
    gdf.attrs["source"] = str(p)
    return gdf


def validate_polygons(
    gdf: gpd.GeoDataFrame, *, fix_invalid: bool = False, source: str | None = None
) -> gpd.GeoDataFrame:
    """Check that every feature is a non-empty valid (multi)polygon.

    Parameters
    ----------
    gdf
        The layer.
    fix_invalid
        Repair invalid polygons with ``shapely.make_valid`` (keeping the
        polygonal part) instead of raising.
    source
        File name for messages (defaults to ``gdf.attrs['source']``).

    Raises
    ------
    InputError
        Non-polygon or null geometries, or invalid ones when ``fix_invalid`` is off.
    DegenerateGeometryError
        A layer with no features or polygons of zero area.
    """
    src = source or gdf.attrs.get("source")
    if len(gdf) == 0:
        raise DegenerateGeometryError("the layer has no features", path=src)
    geoms = gdf.geometry.to_numpy()
    null = shapely.is_missing(geoms) | shapely.is_empty(geoms)
    if null.any():
        raise InputError(
            f"{int(null.sum())} features have no geometry "
            f"(rows {np.flatnonzero(null)[:10].tolist()})",
            path=src,
            hint="delete them or draw their outline",
        )
    kinds = shapely.get_type_id(geoms)
    polygonal = (kinds == 3) | (kinds == 6)
    if not polygonal.all():
        bad = np.flatnonzero(~polygonal)
        raise InputError(
            f"{len(bad)} features are not polygons (rows {bad[:10].tolist()}, "
            f"types {sorted(set(shapely.get_type_id(geoms[bad]).tolist()))})",
            path=src,
            hint="use a polygon layer (footprints), not lines or points",
        )
    invalid = ~shapely.is_valid(geoms)
    if invalid.any():
        if not fix_invalid:
            reasons = shapely.is_valid_reason(geoms[invalid])[:3]
            raise InputError(
                f"{int(invalid.sum())} invalid polygons (rows "
                f"{np.flatnonzero(invalid)[:10].tolist()}: {'; '.join(reasons)})",
                path=src,
                hint="repair them in your GIS or pass --fix-invalid (shapely.make_valid)",
            )
        fixed = shapely.make_valid(geoms[invalid])
        polys = [_polygonal_part(g) for g in fixed]
        geoms = geoms.copy()
        geoms[invalid] = polys
        gdf = gdf.set_geometry(gpd.GeoSeries(geoms, index=gdf.index, crs=gdf.crs))
    area = shapely.area(geoms)
    if (area <= 0).any():
        raise DegenerateGeometryError(
            f"{int((area <= 0).sum())} polygons have zero area "
            f"(rows {np.flatnonzero(area <= 0)[:10].tolist()})",
            path=src,
            hint="delete or redraw them",
        )
    return gdf


def _polygonal_part(geom: Any) -> Any:
    if geom.geom_type in _POLYGONAL:
        return geom
    parts = [g for g in getattr(geom, "geoms", []) if g.geom_type in _POLYGONAL]
    return shapely.union_all(parts) if parts else shapely.Polygon()


def align_crs(
    gdf: gpd.GeoDataFrame,
    cloud_crs: CRS | None,
    *,
    reproject: bool = False,
    cloud_source: str | None = None,
) -> gpd.GeoDataFrame:
    """Bring a layer into the cloud's CRS, or fail clearly on a mismatch.

    A cloud without CRS (many LAS files carry none) is taken to be in the
    layer's CRS; the caller records that assumption in the run summary.
    """
    src = gdf.attrs.get("source")
    if cloud_crs is None or gdf.crs is None:
        return gdf
    cloud = CRS.from_user_input(cloud_crs)
    if cloud.equals(gdf.crs, ignore_axis_order=True):
        return gdf
    if not reproject:
        raise CRSMismatchError(
            f"layer CRS {gdf.crs.to_string()} differs from the cloud's "
            f"{cloud.to_string()} ({cloud_source or 'cloud'})",
            path=src,
            hint="reproject the layer in your GIS, or pass --reproject",
        )
    out = gdf.to_crs(cloud)
    out.attrs.update(gdf.attrs)
    return out


def write_gpkg(gdf: gpd.GeoDataFrame, path: str | Path, layer: str) -> Path:
    """Write one layer as a GeoPackage 1.2 file, atomically.

    Columns of Python objects become text (GeoPackage has no mixed-type field);
    pandas' nullable integer / boolean columns stay integer / boolean fields.  The
    primary key is called ``ogc_fid`` because GIS layers often carry an attribute
    named ``fid`` (GeoPackage's default key name).
    """
    from pyheracles.io.atomic import atomic_path

    table = gdf.copy()
    for col in table.columns:
        if col != table.geometry.name and table[col].dtype == object:
            table[col] = table[col].astype("string")
    p = Path(path)
    with atomic_path(p) as tmp, warnings.catch_warnings():
        # a layer without CRS (a scan's local frame) is written with GeoPackage's
        # undefined Cartesian SRS on purpose; the caller says so in run.json
        warnings.filterwarnings("ignore", message="'crs' was not provided", category=UserWarning)
        table.to_file(
            tmp, driver="GPKG", layer=layer, engine="pyogrio",
            layer_options={"FID": "ogc_fid"}, dataset_options={"VERSION": GPKG_VERSION},
        )  # fmt: skip
    return p
