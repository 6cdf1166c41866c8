"""Project readers: DBAT XML scripts, PhotoModeler text exports, PhotoScan .psz, Metashape
camera exports (XML), COLMAP text models."""

from __future__ import annotations

from pathlib import Path

from pyheracles.bundle.project import Project
from pyheracles.bundle.readers.colmap import read_colmap
from pyheracles.bundle.readers.dbat_script import read_camera_xml, read_dbat_script
from pyheracles.bundle.readers.metashape import is_metashape_xml, read_metashape_xml
from pyheracles.bundle.readers.photomodeler import (
    read_camera_positions,
    read_control_points,
    read_photomodeler,
)
from pyheracles.bundle.readers.photoscan import read_photoscan
from pyheracles.errors import InputError

__all__ = [
    "read_camera_positions",
    "read_camera_xml",
    "read_colmap",
    "read_control_points",
    "read_dbat_script",
    "read_metashape_xml",
    "read_photomodeler",
    "read_photoscan",
    "read_project",
]


def read_project(path: str | Path) -> Project:
    """Read a project, choosing the reader from the file name and content.

    Supported: DBAT XML script (``*.xml`` with ``dbat_script_version``),
    PhotoModeler text export (``*.txt`` starting with a "Bundle Soln" title line),
    PhotoScan/Metashape archive (``*.psz``), Metashape camera export (``*.xml``
    holding a ``<chunk>`` with sensors), COLMAP text model (a folder with
    ``cameras.txt``, ``images.txt``, ``points3D.txt``).
    """
    path = Path(path)
    if not path.exists():
        raise InputError("project file not found", path=path)
    if path.is_dir():
        if (path / "images.txt").is_file() or (path / "cameras.txt").is_file():
            return read_colmap(path)
        if (path / "images.bin").is_file():
            raise InputError(
                "binary COLMAP model (images.bin): only the text format is read",
                path=path,
                hint=f"colmap model_converter --output_type TXT, with this folder ({path}) "
                "as input and output path",
            )
        raise InputError(
            "folder is not a COLMAP text model (no images.txt)",
            path=path,
            hint="export the model as text (colmap model_converter --output_type TXT)",
        )
    suffix = path.suffix.lower()
    if suffix == ".xml":
        if is_metashape_xml(path):
            return read_metashape_xml(path)
        return read_dbat_script(path)
    if suffix == ".txt":
        return read_photomodeler(path)
    if suffix == ".psz":
        return read_photoscan(path)
    raise InputError(
        "unknown project format",
        path=path,
        hint="give a DBAT XML script or a Metashape camera export (.xml), a PhotoModeler "
        "export (.txt), a PhotoScan .psz or a COLMAP text model folder",
    )
