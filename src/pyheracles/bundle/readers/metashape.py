"""Reader of Agisoft Metashape / PhotoScan camera exports (File > Export > Export Cameras, XML).

The export is the ``<chunk>`` of the project without its tie points: sensors
with their calibration (``f``, ``cx``, ``cy`` from the image centre, ``b1``,
``b2``, ``k1..k3``, ``p1``, ``p2``; or PhotoScan 1.x's ``fx``, ``fy``, ``cx``,
``cy``), the cameras' ``transform`` (camera-to-chunk 4x4, through their
component's transform when there is one), the chunk's transform to the world
frame, the markers with their ``reference`` coordinates and accuracies and
their image ``location`` s.  The marker measurements are the image
observations: a network of markers seen in several cameras is re-adjusted with
the markers that have a reference as control points (check points when the
reference is disabled).  Conventions and the lens model conversion are those of
:mod:`pyheracles.bundle.readers.photoscan`.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

from pyheracles.bundle.project import Project
from pyheracles.bundle.readers.photoscan import project_from_chunk
from pyheracles.errors import InputError

__all__ = ["is_metashape_xml", "read_metashape_xml"]


def _chunk(root: ET.Element) -> ET.Element | None:
    if root.tag == "chunk":
        return root
    chunk = root.find("chunk")
    return chunk if chunk is not None else root.find("chunks/chunk")


def is_metashape_xml(path: str | Path) -> bool:
    """True when ``path`` parses as XML holding an Agisoft ``<chunk>`` with sensors."""
    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, OSError):
        return False
    if "dbat_script_version" in root.attrib:
        return False
    chunk = _chunk(root)
    return chunk is not None and chunk.find("sensors") is not None


def read_metashape_xml(path: str | Path) -> Project:
    """Read a Metashape/PhotoScan camera export (XML).

    Returns
    -------
    Project
        World coordinates (the chunk transform applied); cameras fixed (no
        interior parameter estimated unless asked); markers with an enabled
        reference as weighted control points, with a disabled one as check
        points, the others as tie points.

    Raises
    ------
    InputError
        Unreadable XML, no sensor, no aligned camera, or no marker measurement
        (the export then has nothing to adjust; the hint names the fix).
    """
    path = Path(path)
    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, OSError) as exc:
        raise InputError(
            f"unreadable Metashape camera export ({exc})",
            path=path,
            hint="export the cameras again (File > Export > Export Cameras, Agisoft XML)",
        ) from None
    chunk = _chunk(root)
    if chunk is None:
        raise InputError("no <chunk> in the camera export", path=path)
    return project_from_chunk(chunk, path, read_member=None, fmt="metashape-xml")
