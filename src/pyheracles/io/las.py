"""LAS / LAZ / COPC reading and writing with laspy (LAZ through lazrs).

Coordinates are read as integers and turned into local-frame float64 without
ever forming the large world values in float arithmetic first: ``local =
X * scale + (file_offset - cloud_offset)``.  Written files keep the source
scale (default 1 mm) and an offset near the data, so a round trip is exact to
the quantisation step (DESIGN.md rule 3).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import laspy
import numpy as np
from numpy.typing import NDArray

from pyheracles.cloud import PointCloud
from pyheracles.errors import InputError
from pyheracles.io.atomic import atomic_path

__all__ = ["read_las", "write_las"]

#: LAS standard dimensions copied into ``PointCloud.attributes`` when present.
_STANDARD_DIMS = (
    "intensity",
    "return_number",
    "number_of_returns",
    "classification",
    "scan_angle_rank",
    "scan_angle",
    "user_data",
    "point_source_id",
    "gps_time",
    "red",
    "green",
    "blue",
    "nir",
)
_DEFAULT_SCALE = 0.001  # metres; 1 mm, the resolution the design promises


def _laz_backend() -> laspy.LazBackend | None:
    """lazrs with one thread per core when available (LAZ chunks are independent)."""
    if laspy.LazBackend.LazrsParallel.is_available():
        return laspy.LazBackend.LazrsParallel
    return None


def read_las(path: str | Path) -> PointCloud:
    """Read a LAS, LAZ or COPC file into a :class:`PointCloud`.

    Standard dimensions (intensity, classification, RGB, GPS time ...) and all
    extra dimensions become attributes.  The CRS comes from the header's WKT
    or GeoTIFF keys (``None`` when absent).

    Raises
    ------
    InputError
        If the file is missing, truncated or not a LAS/LAZ file.
    """
    p = Path(path)
    if not p.is_file():
        raise InputError("file not found", path=p, hint="check the path")
    try:
        las = laspy.read(p, laz_backend=_laz_backend())
    except Exception as exc:  # laspy raises many types for damaged files
        raise InputError(
            f"cannot read as LAS/LAZ ({type(exc).__name__}: {exc})",
            path=p,
            hint="the file may be truncated or not a LAS/LAZ file; re-export it",
        ) from exc
    header = las.header
    n_declared = int(header.point_count)
    if len(las.points) != n_declared:
        raise InputError(
            f"header declares {n_declared} points but {len(las.points)} could be read",
            path=p,
            hint="the file is truncated; copy or export it again",
        )
    scale = np.asarray(header.scales, dtype=np.float64)
    file_offset = np.asarray(header.offsets, dtype=np.float64)
    ints = np.column_stack([np.asarray(las.X), np.asarray(las.Y), np.asarray(las.Z)])
    if len(ints):
        # Choose a whole-metre local offset near the minimum corner.
        world_min = ints.min(axis=0) * scale + file_offset
        offset = np.floor(world_min)
    else:
        offset = np.zeros(3)
    xyz = ints * scale + (file_offset - offset)
    names = set(las.point_format.dimension_names)
    attrs: dict[str, NDArray[Any]] = {}
    for name in _STANDARD_DIMS:
        if name in names:
            attrs[name] = np.asarray(las[name]).copy()
    for name in las.point_format.extra_dimension_names:
        attrs[name] = np.asarray(las[name]).copy()
    try:
        crs = header.parse_crs()
    except Exception:  # unparseable VLR: say so rather than guess
        crs = None
    return PointCloud(xyz=xyz, offset=offset, attributes=attrs, crs=crs, scale=scale, source=str(p))


def _point_format_for(attributes: Mapping[str, NDArray[Any]]) -> int:
    has_rgb = all(k in attributes for k in ("red", "green", "blue"))
    has_nir = "nir" in attributes
    if has_rgb and has_nir:
        return 8
    return 7 if has_rgb else 6


def write_las(
    cloud: PointCloud,
    path: str | Path,
    extra_dims: Mapping[str, NDArray[Any]] | None = None,
) -> Path:
    """Write a cloud as LAS 1.4 (``.las``) or LAZ (``.laz``), atomically.

    Parameters
    ----------
    cloud
        The cloud; standard attributes go to their LAS fields, other
        attributes become extra dimensions.
    path
        Output file; the extension chooses compression.
    extra_dims
        Further per-point arrays written as extra dimensions (e.g. ``instance``
        int32, ``class_id`` uint8); they override attributes of the same name.

    Returns
    -------
    Path
        The written file.
    """
    p = Path(path)
    attrs: dict[str, NDArray[Any]] = dict(cloud.attributes)
    attrs.update({k: np.asarray(v) for k, v in (extra_dims or {}).items()})
    for name, values in attrs.items():
        if len(values) != len(cloud):
            raise InputError(f"attribute {name!r} has {len(values)} values for {len(cloud)} points")
    header = laspy.LasHeader(point_format=_point_format_for(attrs), version="1.4")
    scale = cloud.scale if cloud.scale is not None else np.full(3, _DEFAULT_SCALE)
    header.scales = scale
    header.offsets = cloud.offset
    if cloud.crs is not None:
        header.add_crs(cloud.crs)
    std = set(header.point_format.dimension_names)
    extras = {k: v for k, v in attrs.items() if k not in std}
    for name, values in extras.items():
        dtype = np.asarray(values).dtype
        if dtype == np.bool_:
            dtype = np.dtype(np.uint8)
        header.add_extra_dim(laspy.ExtraBytesParams(name=name, type=dtype))
    las = laspy.LasData(header)
    # Integer coordinates computed from local values: exact for data read at this scale.
    ints = np.round(cloud.xyz / scale).astype(np.int64)
    las.X, las.Y, las.Z = ints[:, 0], ints[:, 1], ints[:, 2]
    for name, values in attrs.items():
        if name == "scan_angle_rank":
            if "scan_angle" not in attrs:
                las["scan_angle"] = np.round(np.asarray(values) / 0.006).astype(np.int16)
            continue
        arr = np.asarray(values)
        las[name] = arr.astype(np.uint8) if arr.dtype == np.bool_ else arr
    if len(cloud):
        las.update_header()
    with atomic_path(p) as tmp:
        las.write(tmp, laz_backend=_laz_backend() if p.suffix.lower() == ".laz" else None)
    return p
