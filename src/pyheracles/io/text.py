"""Plain-text point clouds: XYZ / TXT / CSV / PTS, space, comma or semicolon separated.

The first three columns are X, Y, Z.  A header line, when present, names the
columns (``x,y,z,intensity``); without one, further columns are ``col3``,
``col4`` ... .  pandas' C parser reads tens of millions of rows per minute.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from pyheracles.cloud import PointCloud
from pyheracles.errors import InputError
from pyheracles.io.atomic import atomic_path

__all__ = ["read_text", "write_text"]


def _sniff(p: Path) -> tuple[str, bool]:
    with open(p, encoding="utf-8", errors="replace") as fh:
        first = fh.readline()
    sep = "," if "," in first else (";" if ";" in first else r"\s+")
    tokens = [t for t in first.replace(",", " ").replace(";", " ").split() if t]
    try:
        [float(t) for t in tokens]
        has_header = False
    except ValueError:
        has_header = True
    return sep, has_header


def read_text(path: str | Path) -> PointCloud:
    """Read an ASCII point list (X Y Z [more columns]) into a :class:`PointCloud`."""
    p = Path(path)
    if not p.is_file():
        raise InputError("file not found", path=p, hint="check the path")
    sep, has_header = _sniff(p)
    try:
        df = pd.read_csv(p, sep=sep, header=0 if has_header else None, engine="c",
                         comment="#", skip_blank_lines=True)  # fmt: skip
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        raise InputError(f"cannot parse as a point list ({exc})", path=p) from exc
    if df.shape[1] < 3:
        raise InputError(
            f"needs at least 3 columns (X Y Z), found {df.shape[1]}",
            path=p,
            hint="write one point per line as 'X Y Z [attributes]'",
        )
    if not has_header:
        df.columns = ["x", "y", "z", *[f"col{i}" for i in range(3, df.shape[1])]]
    cols = list(df.columns)
    try:
        world = df[cols[:3]].to_numpy(dtype=np.float64)
    except ValueError as exc:
        raise InputError(f"non-numeric coordinates ({exc})", path=p) from exc
    attrs: dict[str, NDArray[Any]] = {}
    for c in cols[3:]:
        if pd.api.types.is_numeric_dtype(df[c]):
            attrs[str(c).strip().lower()] = df[c].to_numpy()
    return PointCloud.from_world(world, attributes=attrs, source=str(p))


def write_text(
    cloud: PointCloud, path: str | Path, extra_dims: dict[str, NDArray[Any]] | None = None
) -> Path:
    """Write world X, Y, Z (mm precision) and numeric attributes as CSV with a header."""
    attrs = dict(cloud.attributes)
    attrs.update(extra_dims or {})
    world = cloud.world_xyz()
    df = pd.DataFrame({"x": world[:, 0], "y": world[:, 1], "z": world[:, 2]})
    for name, values in attrs.items():
        arr = np.asarray(values)
        if arr.ndim == 1 and arr.dtype.kind in "iufb":
            df[name] = arr
    with atomic_path(path) as tmp:
        df.to_csv(tmp, index=False, float_format="%.4f")
    return Path(path)
