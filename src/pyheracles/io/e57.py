"""E57 (ASTM E2807) reading through ``pye57`` (libE57Format), an optional extra.

All scans of the file are merged into one cloud in the file's common frame
(each scan's pose applied), with a ``scan_index`` attribute; intensity and
colour are kept when present.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pyheracles.cloud import PointCloud
from pyheracles.errors import InputError

__all__ = ["read_e57"]


def read_e57(path: str | Path) -> PointCloud:
    """Read every scan of an E57 file, transformed into the file's frame.

    Raises :class:`InputError` on a folder, a missing or damaged file, or NaN /
    infinite points (one error naming the file and counting them).
    """
    from pyheracles.io import check_cloud_path

    p = check_cloud_path(path)
    try:
        import pye57
    except ImportError as exc:  # optional dependency
        raise InputError(
            "reading E57 needs the optional package pye57",
            path=p,
            hint="pip install 'pyheracles[e57]'",
        ) from exc
    try:
        e57 = pye57.E57(str(p))
        parts, scan_ids, extra = [], [], {"intensity": [], "red": [], "green": [], "blue": []}
        for i in range(e57.scan_count):
            data = e57.read_scan(i, ignore_missing_fields=True, intensity=True, colors=True,
                                 transform=True)  # fmt: skip
            xyz = np.column_stack(
                [data["cartesianX"], data["cartesianY"], data["cartesianZ"]]
            ).astype(np.float64)
            parts.append(xyz)
            scan_ids.append(np.full(len(xyz), i, dtype=np.uint16))
            for key, field in (("intensity", "intensity"), ("red", "colorRed"),
                               ("green", "colorGreen"), ("blue", "colorBlue")):  # fmt: skip
                extra[key].append(data.get(field))
    except Exception as exc:
        raise InputError(
            f"cannot read as E57 ({type(exc).__name__}: {exc})",
            path=p,
            hint="the file may be truncated or not an E57 file; export it again",
        ) from exc
    world = np.vstack(parts) if parts else np.empty((0, 3))
    attrs = {"scan_index": np.concatenate(scan_ids) if scan_ids else np.empty(0, np.uint16)}
    for key, chunks in extra.items():
        if chunks and all(c is not None for c in chunks):
            attrs[key] = np.concatenate([np.asarray(c) for c in chunks])
    return PointCloud.from_world(world, attributes=attrs, source=str(p))
