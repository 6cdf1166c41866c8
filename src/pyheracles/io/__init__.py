"""File formats at the edges: point clouds, polygon layers, results.

``read_cloud`` / ``write_cloud`` choose the format from the file extension.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from numpy.typing import NDArray

from pyheracles.cloud import PointCloud
from pyheracles.errors import InputError
from pyheracles.io.atomic import atomic_path, atomic_write_json, atomic_write_text
from pyheracles.io.vector import align_crs, read_layer, validate_polygons

__all__ = [
    "CLOUD_SUFFIXES",
    "align_crs",
    "atomic_path",
    "atomic_write_json",
    "atomic_write_text",
    "check_cloud_path",
    "read_cloud",
    "read_layer",
    "validate_polygons",
    "write_cloud",
]

#: Point cloud file extensions understood by :func:`read_cloud`.
CLOUD_SUFFIXES = (".las", ".laz", ".copc.laz", ".ply", ".xyz", ".txt", ".csv", ".pts", ".e57")


def _suffix(path: Path) -> str:
    return path.suffix.lower()


def check_cloud_path(path: str | Path) -> Path:
    """The path as a :class:`~pathlib.Path` if it names an existing file.

    Raises
    ------
    InputError
        ``file not found``, or ``is a folder, not a point cloud file`` (with the
        point cloud files found inside it as a hint).
    """
    p = Path(path)
    if p.is_dir():
        inside = sorted(
            c.name for c in p.iterdir() if c.is_file() and c.name.lower().endswith(CLOUD_SUFFIXES)
        )
        hint = (
            f"give one file inside it, e.g. {p / inside[0]} "
            f"({len(inside)} point cloud file{'s' if len(inside) > 1 else ''} there)"
            if inside
            else "give the path of a point cloud file (" + ", ".join(CLOUD_SUFFIXES) + ")"
        )
        raise InputError("is a folder, not a point cloud file", path=p, hint=hint)
    if not p.is_file():
        raise InputError("file not found", path=p, hint="check the path")
    return p


def read_cloud(path: str | Path) -> PointCloud:
    """Read a point cloud, the format chosen from the extension.

    Supported: LAS/LAZ/COPC (laspy + lazrs), PLY, XYZ/TXT/CSV/PTS text, E57
    (with the ``e57`` extra).

    Raises
    ------
    InputError
        Unknown extension, missing, unreadable or truncated file, a folder, NaN or
        infinite coordinates (one error naming the file and counting the points).
    """
    p = Path(path)
    if p.is_dir():
        check_cloud_path(p)
    suffix = _suffix(p)
    if suffix in (".las", ".laz"):
        from pyheracles.io.las import read_las

        return read_las(p)
    if suffix == ".ply":
        from pyheracles.io.ply import read_ply

        return read_ply(p)
    if suffix in (".xyz", ".txt", ".csv", ".pts"):
        from pyheracles.io.text import read_text

        return read_text(p)
    if suffix == ".e57":
        from pyheracles.io.e57 import read_e57

        return read_e57(p)
    raise InputError(
        f"unknown point cloud extension {suffix!r}",
        path=p,
        hint=f"use one of {', '.join(CLOUD_SUFFIXES)}",
    )


def write_cloud(
    cloud: PointCloud,
    path: str | Path,
    extra_dims: Mapping[str, NDArray[Any]] | None = None,
    *,
    notes: list[str] | None = None,
) -> Path:
    """Write a cloud atomically, the format chosen from the extension (LAS/LAZ, PLY, text).

    LAS/LAZ keep every dimension of the source file (see
    :func:`pyheracles.io.las.write_las`); what the writer had to change (a point
    format upgrade, COPC written as plain LAZ) is appended to ``notes``.
    """
    p = Path(path)
    suffix = _suffix(p)
    if suffix in (".las", ".laz"):
        from pyheracles.io.las import write_las

        return write_las(cloud, p, extra_dims, notes=notes)
    if suffix == ".ply":
        from pyheracles.io.ply import write_ply

        return write_ply(cloud, p, dict(extra_dims or {}))
    if suffix in (".xyz", ".txt", ".csv"):
        from pyheracles.io.text import write_text

        return write_text(cloud, p, dict(extra_dims or {}))
    raise InputError(
        f"cannot write point clouds with extension {suffix!r}",
        path=p,
        hint="use .laz, .las, .ply or .csv",
    )
