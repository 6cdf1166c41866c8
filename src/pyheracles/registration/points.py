"""Point lists (tie, control and check points) in CSV and their pairing by id.

A point list is a CSV file with a header naming at least an id column and the
three coordinates, optionally their standard deviations::

    id,X,Y,Z,sX,sY,sZ
    GCP01,1049817.412,6842301.118,148.305,0.005,0.005,0.008

Accepted header spellings (case-insensitive): ``id``/``name``/``point``; ``x``/``e``/
``easting``; ``y``/``n``/``northing``; ``z``/``h``/``height``/``elevation``; sigmas
``sx``/``sigma_x``/``std_x`` (same for y, z) or a single ``sigma``.  The separator
(comma, semicolon, tab, spaces) is detected.  Coordinates are kept as float64, ids as
strings (leading zeros survive).
"""

from __future__ import annotations

import csv
import io
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from pyheracles.errors import InputError

__all__ = [
    "PointList",
    "PointPairs",
    "pair_points",
    "read_point_groups",
    "read_points",
    "write_points",
]

_ALIASES = {
    "id": ("id", "name", "point", "point_id", "pointid", "label"),
    "x": ("x", "e", "easting", "east"),
    "y": ("y", "n", "northing", "north"),
    "z": ("z", "h", "height", "elevation", "alt", "altitude"),
    "sx": ("sx", "sigma_x", "std_x", "sdx", "s_x"),
    "sy": ("sy", "sigma_y", "std_y", "sdy", "s_y"),
    "sz": ("sz", "sigma_z", "std_z", "sdz", "s_z"),
    "sigma": ("sigma", "std", "sd", "s"),
}


@dataclass(frozen=True, eq=False)
class PointList:
    """Named 3D points, e.g. control points in a national grid or targets in a scan.

    Attributes
    ----------
    ids
        Point names, unique.
    xyz
        ``(N, 3)`` float64 coordinates, metres.
    sigma
        ``(N, 3)`` standard deviations, metres, or ``None`` when the file has none.
    source
        File the list was read from (for messages).
    """

    ids: tuple[str, ...]
    xyz: NDArray[np.float64]
    sigma: NDArray[np.float64] | None = None
    source: str | None = None

    def __post_init__(self) -> None:
        xyz = np.asarray(self.xyz, dtype=np.float64).reshape(-1, 3)
        object.__setattr__(self, "xyz", xyz)
        object.__setattr__(self, "ids", tuple(str(i) for i in self.ids))
        if len(self.ids) != len(xyz):
            raise InputError(f"{len(self.ids)} ids for {len(xyz)} points", path=self.source)
        if self.sigma is not None:
            raw = np.asarray(self.sigma, dtype=np.float64)
            if raw.ndim == 1 and raw.size == len(xyz) and raw.size != 3:
                raw = raw[:, None]
            try:
                sig = np.broadcast_to(raw, (len(xyz), 3)).copy()
            except ValueError as exc:
                raise InputError(
                    f"sigmas of shape {raw.shape} do not fit {len(xyz)} points", path=self.source
                ) from exc
            object.__setattr__(self, "sigma", sig)
        _check_unique(self.ids, self.source)

    def __len__(self) -> int:
        return len(self.ids)

    def select(self, ids: Sequence[str]) -> PointList:
        """The points with these ids, in this order (``InputError`` if one is missing)."""
        index = {k: i for i, k in enumerate(self.ids)}
        missing = [i for i in ids if i not in index]
        if missing:
            raise InputError(f"point ids not in the list: {_short(missing)}", path=self.source)
        idx = np.array([index[i] for i in ids], dtype=int)
        return PointList(
            ids=tuple(ids),
            xyz=self.xyz[idx],
            sigma=None if self.sigma is None else self.sigma[idx],
            source=self.source,
        )


@dataclass(frozen=True, eq=False)
class PointPairs:
    """Points common to two lists, in the same order (``a`` and ``b`` frames)."""

    ids: tuple[str, ...]
    a: NDArray[np.float64]
    b: NDArray[np.float64]
    sigma_a: NDArray[np.float64] | None
    sigma_b: NDArray[np.float64] | None
    only_in_a: tuple[str, ...]
    only_in_b: tuple[str, ...]

    def __len__(self) -> int:
        return len(self.ids)


def _short(items: Sequence[str], limit: int = 8) -> str:
    shown = ", ".join(repr(i) for i in list(items)[:limit])
    return shown + (f" and {len(items) - limit} more" if len(items) > limit else "")


def _check_unique(ids: Sequence[str], source: str | None) -> None:
    if len(set(ids)) == len(ids):  # fast path: point lists are built in loops (propagation)
        return
    s = pd.Series(list(ids), dtype=object)
    dup = s[s.duplicated()].unique().tolist()
    if dup:
        raise InputError(
            f"duplicated point ids: {_short(dup)}",
            path=source,
            hint="give every point a unique id (one row per point)",
        )


def _find(columns: list[str], key: str) -> str | None:
    low = {c.strip().lower(): c for c in columns}
    for alias in _ALIASES[key]:
        if alias in low:
            return low[alias]
    return None


def _read_table(path: str | Path) -> tuple[Path, pd.DataFrame]:
    p = Path(path)
    if not p.is_file():
        raise InputError("point list not found", path=p, hint="check the path")
    text = p.read_text(encoding="utf-8-sig", errors="replace")
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        raise InputError("the point list is empty", path=p)
    try:
        sep = csv.Sniffer().sniff(lines[0], delimiters=",;\t ").delimiter
    except csv.Error:
        sep = ","
    try:
        df = pd.read_csv(
            io.StringIO("\n".join(lines)),
            sep=r"\s+" if sep == " " else sep,
            dtype=str,
            skipinitialspace=True,
        )
    except (pd.errors.ParserError, ValueError) as exc:
        raise InputError(f"cannot parse the point list: {exc}", path=p) from exc
    return p, df


def _to_points(df: pd.DataFrame, p: Path) -> PointList:
    cols = [str(c) for c in df.columns]
    names = {k: _find(cols, k) for k in _ALIASES}
    missing = [k for k in ("id", "x", "y", "z") if names[k] is None]
    if missing:
        raise InputError(
            f"missing column(s) {', '.join(missing)}; found {', '.join(cols)}",
            path=p,
            hint="the first line must be a header such as 'id,X,Y,Z' (optional sX,sY,sZ)",
        )
    if df.empty:
        raise InputError("the point list has a header but no points", path=p)
    ids = df[names["id"]].astype(str).str.strip().tolist()
    if any(i in ("", "nan") for i in ids):
        raise InputError("some rows have no point id", path=p)
    coords = df[[names["x"], names["y"], names["z"]]].apply(pd.to_numeric, errors="coerce")
    xyz = coords.to_numpy(dtype=np.float64)
    bad = ~np.isfinite(xyz).all(axis=1)
    if bad.any():
        row = int(np.flatnonzero(bad)[0])
        raise InputError(
            f"{int(bad.sum())} point(s) with missing or non-numeric coordinates "
            f"(first: id {ids[row]!r}, data row {row + 1})",
            path=p,
        )
    sigma = None
    if all(names[k] is not None for k in ("sx", "sy", "sz")):
        sigma = (
            df[[names["sx"], names["sy"], names["sz"]]]
            .apply(pd.to_numeric, errors="coerce")
            .to_numpy(dtype=np.float64)
        )
    elif names["sigma"] is not None:
        s1 = pd.to_numeric(df[names["sigma"]], errors="coerce").to_numpy(dtype=np.float64)
        sigma = np.repeat(s1[:, None], 3, axis=1)
    if sigma is not None and (~np.isfinite(sigma) | (sigma < 0)).any():
        raise InputError(
            "standard deviations must be numbers >= 0", path=p, hint="fix or drop the sigma columns"
        )
    return PointList(ids=tuple(ids), xyz=xyz, sigma=sigma, source=str(p))


def read_points(path: str | Path) -> PointList:
    """Read a point list CSV (id, X, Y, Z, optional sigmas).

    Raises
    ------
    InputError
        Missing file or columns, non-numeric or NaN coordinates, duplicated ids,
        negative sigmas, empty list.
    """
    p, df = _read_table(path)
    return _to_points(df, p)


def read_point_groups(path: str | Path, column: str = "cloud") -> dict[str, PointList]:
    """Read a point list whose ``column`` says in which cloud/frame each row is measured.

    E.g. tie points ``id,cloud,X,Y,Z`` with ``cloud`` = ``source``/``target`` (or the
    cloud file names); ids must be unique within each group.
    """
    p, df = _read_table(path)
    low = {str(c).strip().lower(): c for c in df.columns}
    if column not in low:
        raise InputError(
            f"no {column!r} column telling in which cloud each point is measured",
            path=p,
            hint=f"add a '{column}' column (e.g. source/target), or give one file per cloud",
        )
    key = low[column]
    groups = {}
    for name, sub in df.groupby(df[key].astype(str).str.strip(), sort=False):
        groups[str(name)] = _to_points(sub.drop(columns=[key]).reset_index(drop=True), p)
    return groups


def write_points(path: str | Path, points: PointList) -> Path:
    """Write a point list as CSV (atomically) with ``id,X,Y,Z[,sX,sY,sZ]``, 0.1 mm."""
    from pyheracles.io.atomic import atomic_write_text

    df = pd.DataFrame({"id": points.ids})
    for k, name in enumerate("XYZ"):
        df[name] = points.xyz[:, k]
    if points.sigma is not None:
        for k, name in enumerate(("sX", "sY", "sZ")):
            df[name] = points.sigma[:, k]
    return atomic_write_text(path, df.to_csv(index=False, float_format="%.4f"))


def pair_points(
    a: PointList,
    b: PointList,
    *,
    unmatched: str = "error",
    min_pairs: int = 3,
) -> PointPairs:
    """Pair two point lists by id.

    Parameters
    ----------
    a, b
        Point lists (e.g. measured in the source cloud, and in the target frame).
    unmatched
        ``"error"``: every id must be in both lists; ``"ignore"``: keep the common ids
        and report the others in ``only_in_a``/``only_in_b``.
    min_pairs
        Minimum number of common points.

    Raises
    ------
    InputError
        Unmatched ids (with ``unmatched="error"``) or too few common points.
    """
    if unmatched not in ("error", "ignore"):
        raise InputError(f"unmatched must be 'error' or 'ignore', got {unmatched!r}")
    in_b = set(b.ids)
    in_a = set(a.ids)
    common = [i for i in a.ids if i in in_b]
    only_a = tuple(i for i in a.ids if i not in in_b)
    only_b = tuple(i for i in b.ids if i not in in_a)
    if unmatched == "error" and (only_a or only_b):
        parts = []
        if only_a:
            parts.append(f"{_short(only_a)} only in {a.source or 'the first list'}")
        if only_b:
            parts.append(f"{_short(only_b)} only in {b.source or 'the second list'}")
        raise InputError(
            "unmatched point ids: " + "; ".join(parts),
            hint="use the same ids in both lists, or remove the points measured only once",
        )
    if len(common) < min_pairs:
        raise InputError(
            f"only {len(common)} point id(s) common to {a.source or 'the first list'} and "
            f"{b.source or 'the second list'}; at least {min_pairs} are needed",
            hint="check that both lists use the same point names",
        )
    pa = a.select(common)
    pb = b.select(common)
    return PointPairs(
        ids=tuple(common),
        a=pa.xyz,
        b=pb.xyz,
        sigma_a=pa.sigma,
        sigma_b=pb.sigma,
        only_in_a=only_a,
        only_in_b=only_b,
    )


def points_from_arrays(
    ids: Sequence[str], xyz: ArrayLike, sigma: ArrayLike | None = None
) -> PointList:
    """Convenience constructor from arrays."""
    return PointList(ids=tuple(ids), xyz=np.asarray(xyz, float), sigma=sigma)
