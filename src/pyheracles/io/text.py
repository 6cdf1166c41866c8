"""Plain-text point clouds: XYZ / TXT / CSV / PTS, space, comma or semicolon separated.

The first three columns are X, Y, Z.  A header line, when present, names the
columns (``x,y,z,intensity``); without one, further columns are ``col3``,
``col4`` ... .  pandas' C parser reads tens of millions of rows per minute.

The number of decimals of the coordinates is the cloud's ``scale`` (0.01 m for
``85000.12``) when every coordinate lies on that lattice: the local frame is
then snapped to it (:meth:`PointCloud.from_world`), so a file whose coordinates
are shifted by 10^9 m gives the same local coordinates, and the same results.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from pyheracles.cloud import PointCloud, reject_non_finite
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


def _decimals_scale(
    p: Path, sep: str, has_header: bool, world: NDArray[np.float64]
) -> NDArray[np.float64] | None:
    """Quantisation step of the coordinates from their decimals, if all points are on it."""
    if len(world) == 0:
        return None
    try:
        sample = pd.read_csv(p, sep=sep, header=0 if has_header else None, engine="c",
                             comment="#", skip_blank_lines=True, usecols=[0, 1, 2],
                             dtype=str, nrows=2000)  # fmt: skip
    except (pd.errors.ParserError, ValueError, UnicodeDecodeError):
        return None
    steps = []
    for col in sample.columns[:3]:
        tokens = sample[col].dropna().str.strip()
        if tokens.str.contains("[eE]", regex=True).any():
            return None  # exponent notation: no fixed number of decimals
        decimals = tokens.str.partition(".")[2].str.len().max()
        decimals = 0 if pd.isna(decimals) else int(decimals)
        if decimals > 9:
            return None
        steps.append(10.0**-decimals)
    scale = np.array(steps)
    # every point, not only the sample, must lie on the lattice (to a thousandth of a step)
    k = (world - world.min(axis=0)) / scale
    if np.abs(k - np.round(k)).max() > 1e-3:
        return None
    return scale


def read_text(path: str | Path) -> PointCloud:
    """Read an ASCII point list (X Y Z [more columns]) into a :class:`PointCloud`.

    Raises
    ------
    InputError
        A folder, a missing or unparsable file, fewer than 3 columns, non-numeric or
        NaN coordinates (one error naming the file and counting the bad rows).
    """
    from pyheracles.io import check_cloud_path

    p = check_cloud_path(path)
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
    if not np.isfinite(world).all():  # one clear error before the lattice check
        return PointCloud.from_world(world, attributes=attrs, source=str(p))
    scale = _decimals_scale(p, sep, has_header, world)
    return PointCloud.from_world(world, attributes=attrs, scale=scale, source=str(p))


def write_text(
    cloud: PointCloud, path: str | Path, extra_dims: dict[str, NDArray[Any]] | None = None
) -> Path:
    """Write world X, Y, Z (mm precision) and numeric attributes as CSV with a header."""
    reject_non_finite(cloud.xyz, cloud.source)
    attrs = dict(cloud.attributes)
    attrs.update(extra_dims or {})
    world = cloud.world_xyz()
    df = pd.DataFrame({"x": world[:, 0], "y": world[:, 1], "z": world[:, 2]})
    for name, values in attrs.items():
        arr = np.asarray(values)
        if arr.dtype.kind not in "iufb":
            continue
        if arr.ndim == 1:
            df[name] = arr
        elif arr.ndim == 2:  # several values per point (LAS array extra bytes)
            for i in range(arr.shape[1]):
                df[f"{name}_{i}"] = arr[:, i]
    with atomic_path(path) as tmp:
        df.to_csv(tmp, index=False, float_format="%.4f")
    return Path(path)
