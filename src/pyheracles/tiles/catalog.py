"""The tile catalogue: tiles from a glob, a folder or a tile index; reading by chunks.

:func:`read_catalog` takes a glob (``tiles/*.laz``), a folder, or a tile index GeoPackage
(one row per file, the path in a ``location`` / ``path`` / ``filename`` field, as
``gdaltindex``, PDAL ``tindex`` and lidR catalogs write).  Each tile's bounds come from
its LAS header (no point is read); the CRS is checked across tiles; duplicate tiles
(same bounds and point count, or boxes overlapping by more than half) are refused by
name; unreadable tiles are reported by name and the others are processed.

:func:`read_points` reads the points of a tile inside a box by chunks (memory holds the
kept points, not the file); COPC files are read the same way (a COPC query by bounds
returns points in octree order and would lose the file order the outputs keep).
:func:`split_las` cuts one huge file into tiles, by chunks.
"""

from __future__ import annotations

import glob as _glob
import os
import resource
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pyheracles.errors import InputError

__all__ = [
    "CHUNK_POINTS",
    "Tile",
    "TileCatalog",
    "in_box",
    "is_tile_source",
    "peak_rss_mb",
    "read_catalog",
    "read_points",
    "read_points_in",
    "split_las",
    "tile_name",
]

_LAS_SUFFIXES = (".las", ".laz")
_INDEX_FIELDS = ("location", "path", "filename", "file", "tile", "url")
#: Two tile boxes overlapping by more than this share of the smaller are duplicates.
_DUPLICATE_OVERLAP = 0.5
#: Points per chunk when reading a tile or a buffer.
CHUNK_POINTS = 1_000_000


# ----------------------------------------------------------------------------- catalogue
@dataclass(frozen=True)
class Tile:
    """One tile file: name, path and its header's bounds (world coordinates, metres)."""

    name: str
    path: Path
    bounds: tuple[float, float, float, float]  # xmin, ymin, xmax, ymax
    n_points: int
    crs: Any = None

    def box(self, buffer_m: float = 0.0) -> tuple[float, float, float, float]:
        """The tile's box grown by ``buffer_m`` on every side."""
        x0, y0, x1, y1 = self.bounds
        return (x0 - buffer_m, y0 - buffer_m, x1 + buffer_m, y1 + buffer_m)


@dataclass(frozen=True)
class TileCatalog:
    """The readable tiles (sorted by name), the shared CRS and the unreadable files."""

    tiles: tuple[Tile, ...]
    crs: Any
    unreadable: tuple[tuple[str, str], ...] = ()  # (path, reason)
    notes: tuple[str, ...] = ()

    @property
    def n_points(self) -> int:
        return sum(t.n_points for t in self.tiles)

    def neighbours(
        self, tile: Tile, buffer_m: float = 0.0, box: Sequence[float] | None = None
    ) -> list[Tile]:
        """The other tiles whose box meets ``box`` (default: ``tile``'s box + ``buffer_m``)."""
        x0, y0, x1, y1 = tile.box(buffer_m) if box is None else box
        return [
            t
            for t in self.tiles
            if t.name != tile.name
            and t.bounds[0] <= x1
            and t.bounds[2] >= x0
            and t.bounds[1] <= y1
            and t.bounds[3] >= y0
        ]


def is_tile_source(source: str | os.PathLike[str]) -> bool:
    """True if ``source`` names many tiles: a glob pattern, a folder or a tile index .gpkg."""
    text = str(source)
    return any(c in text for c in "*?[") or Path(text).is_dir() or text.lower().endswith(".gpkg")


def tile_name(path: Path) -> str:
    """A tile's name: its file name without ``.laz`` / ``.las`` / ``.copc.laz``."""
    name = path.name
    for suffix in (".copc.laz", ".laz", ".las"):
        if name.lower().endswith(suffix):
            return name[: -len(suffix)]
    return path.stem


def _index_paths(index: Path) -> list[Path]:
    """Tile files listed in a tile index GeoPackage (paths relative to its folder)."""
    import pyogrio

    try:
        table = pyogrio.read_dataframe(index, read_geometry=False)
    except Exception as exc:
        raise InputError(
            f"cannot read the tile index ({type(exc).__name__}: {exc})",
            path=index,
            hint="give a GeoPackage with one row per tile file, or a glob / folder of tiles",
        ) from exc
    column = next((c for c in table.columns if str(c).lower() in _INDEX_FIELDS), None)
    if column is None:
        raise InputError(
            "the tile index has no field naming the files "
            f"(looked for {', '.join(_INDEX_FIELDS)}; fields are {', '.join(table.columns)})",
            path=index,
            hint="write it with gdaltindex / pdal tindex, or add a 'location' field",
        )
    out = []
    for value in table[column].astype(str):
        p = Path(value)
        out.append(p if p.is_absolute() else index.parent / p)
    return out


def _source_paths(source: str | os.PathLike[str]) -> list[Path]:
    text = str(source)
    p = Path(text)
    if text.lower().endswith(".gpkg"):
        if not p.is_file():
            raise InputError("tile index not found", path=p, hint="check the path")
        return _index_paths(p)
    if p.is_dir():
        paths = sorted(c for c in p.iterdir() if c.name.lower().endswith(_LAS_SUFFIXES))
        if not paths:
            raise InputError(
                "the folder holds no LAS/LAZ tiles", path=p, hint="give a folder of .laz files"
            )
        return paths
    if any(c in text for c in "*?["):
        paths = sorted(Path(m) for m in _glob.glob(text) if m.lower().endswith(_LAS_SUFFIXES))
        if not paths:
            raise InputError(
                f"no LAS/LAZ file matches {text!r}",
                hint="quote the pattern ('tiles/*.laz') and check the folder",
            )
        return paths
    if p.is_file():
        return [p]
    raise InputError("file not found", path=p, hint="check the path")


def _read_header(path: Path) -> tuple[Tile | None, str]:
    import laspy

    if not path.is_file():
        return None, "file not found"
    try:
        with laspy.open(path) as reader:
            h = reader.header
            n = int(h.point_count)
            try:
                crs = h.parse_crs()
            except Exception:  # unparseable CRS VLR
                crs = None
    except Exception as exc:  # laspy raises many types for damaged files
        return None, f"cannot read the LAS header ({type(exc).__name__}: {exc})"
    if n == 0:
        return None, "the tile has no points"
    mins, maxs = np.asarray(h.mins, dtype=float), np.asarray(h.maxs, dtype=float)
    if not (np.isfinite(mins).all() and np.isfinite(maxs).all()):
        return None, "the header bounds are not finite"
    bounds = (float(mins[0]), float(mins[1]), float(maxs[0]), float(maxs[1]))
    return Tile(tile_name(path), path, bounds, n, crs), ""


def _check_duplicates(tiles: Sequence[Tile]) -> None:
    b = np.array([t.bounds for t in tiles], dtype=float).reshape(-1, 4)
    area = np.maximum(b[:, 2] - b[:, 0], 1e-9) * np.maximum(b[:, 3] - b[:, 1], 1e-9)
    for i in range(len(tiles)):
        w = np.minimum(b[i, 2], b[i + 1 :, 2]) - np.maximum(b[i, 0], b[i + 1 :, 0])
        h = np.minimum(b[i, 3], b[i + 1 :, 3]) - np.maximum(b[i, 1], b[i + 1 :, 1])
        share = np.clip(w, 0, None) * np.clip(h, 0, None) / np.minimum(area[i], area[i + 1 :])
        for j in np.flatnonzero(share > _DUPLICATE_OVERLAP) + i + 1:
            a, c = tiles[i], tiles[int(j)]
            same = a.bounds == c.bounds and a.n_points == c.n_points
            what = (
                "are duplicates (same bounds and point count)"
                if same
                else (f"overlap by {100 * share[int(j) - i - 1]:.0f} % of the smaller one")
            )
            raise InputError(
                f"tiles {a.path.name} and {c.path.name} {what}",
                path=c.path,
                hint="remove one of them: each point must be in exactly one tile",
            )


def read_catalog(source: str | os.PathLike[str], *, crs: Any = None) -> TileCatalog:
    """The tile catalogue of a glob, a folder or a tile index GeoPackage.

    Parameters
    ----------
    source
        ``"tiles/*.laz"``, a folder of LAS/LAZ/COPC files, or a tile index ``.gpkg``.
    crs
        CRS of tiles whose header has none (``None``: taken from the other tiles).

    Raises
    ------
    InputError
        No tile found, no readable tile, tiles in different CRSs (the tiles of each CRS
        named), two tiles with the same name, duplicate or largely overlapping tiles.
    """
    from pyproj import CRS

    tiles: list[Tile] = []
    unreadable: list[tuple[str, str]] = []
    for path in _source_paths(source):
        tile, reason = _read_header(path)
        if tile is None:
            unreadable.append((str(path), reason))
        else:
            tiles.append(tile)
    if not tiles:
        detail = "; ".join(f"{Path(p).name}: {r}" for p, r in unreadable[:5])
        raise InputError(f"no readable tile ({detail})", path=str(source))
    names: dict[str, Path] = {}
    for t in tiles:
        if t.name in names:
            raise InputError(
                f"two tiles are named {t.name!r}: {names[t.name]} and {t.path}",
                hint="tile names (file names without extension) must be unique",
            )
        names[t.name] = t.path
    by_crs: dict[str, list[str]] = {}
    for t in tiles:
        if t.crs is not None:
            by_crs.setdefault(t.crs.to_string(), []).append(t.path.name)
    groups = list(by_crs.items())
    distinct = []
    for key, members in groups:
        c = CRS.from_user_input(key)
        if not any(c.equals(d[0], ignore_axis_order=True) for d in distinct):
            distinct.append((c, members))
    notes: list[str] = []
    if len(distinct) > 1:
        detail = "; ".join(
            f"{c.to_string()}: {', '.join(m[:3])}{' ...' if len(m) > 3 else ''}"
            for c, m in distinct
        )
        raise InputError(
            f"the tiles are in different CRSs ({detail})",
            path=str(source),
            hint="reproject the tiles into one CRS (e.g. pdal translate / las2las)",
        )
    shared = distinct[0][0] if distinct else None
    if crs is not None:
        given = CRS.from_user_input(crs)
        if shared is not None and not given.equals(shared, ignore_axis_order=True):
            raise InputError(
                f"--cloud-crs {given.to_string()} differs from the tiles' {shared.to_string()}",
                hint="drop --cloud-crs: the tiles carry their CRS",
            )
        shared = given
    without = [t.path.name for t in tiles if t.crs is None]
    if without and shared is not None and distinct:
        notes.append(
            f"{len(without)} tiles have no CRS ({', '.join(without[:3])}); "
            f"taken to be {shared.to_string()}"
        )
    tiles.sort(key=lambda t: t.name)
    _check_duplicates(tiles)
    return TileCatalog(tuple(tiles), shared, tuple(unreadable), tuple(notes))


# ----------------------------------------------------------------------------- reading
def read_points(
    path: Path, box: tuple[float, float, float, float] | None, dims: Sequence[str]
) -> tuple[NDArray[np.float64], NDArray[np.int64], dict[str, NDArray[Any]]]:
    """World xyz, file indices and ``dims`` of the points of ``path`` inside ``box``
    (edges included; ``None``: every point).

    Read by chunks of a million points: memory holds the kept points, not the file.
    """
    return read_points_in(path, None if box is None else [box], dims)


def read_points_in(
    path: Path, boxes: Sequence[Sequence[float]] | None, dims: Sequence[str]
) -> tuple[NDArray[np.float64], NDArray[np.int64], dict[str, NDArray[Any]]]:
    """:func:`read_points` for the points inside ANY of ``boxes`` (in file order)."""
    import laspy

    xyz_parts, idx_parts = [], []
    attr_parts: dict[str, list[NDArray[Any]]] = {d: [] for d in dims}
    start = 0
    with laspy.open(path) as reader:
        have = set(reader.header.point_format.dimension_names)
        for chunk in reader.chunk_iterator(CHUNK_POINTS):
            x, y, z = np.asarray(chunk.x), np.asarray(chunk.y), np.asarray(chunk.z)
            if boxes is None:
                keep = np.ones(len(x), dtype=bool)
            else:
                keep = np.zeros(len(x), dtype=bool)
                for box in boxes:
                    keep |= in_box(x, y, box)
            idx = np.flatnonzero(keep)
            xyz_parts.append(np.column_stack([x[idx], y[idx], z[idx]]))
            idx_parts.append(idx + start)
            for d in dims:
                if d in have:
                    attr_parts[d].append(np.asarray(chunk[d])[idx])
            start += len(x)
    xyz = np.concatenate(xyz_parts) if xyz_parts else np.zeros((0, 3))
    index = np.concatenate(idx_parts) if idx_parts else np.zeros(0, dtype=np.int64)
    attrs = {d: np.concatenate(v) for d, v in attr_parts.items() if v}
    return xyz, index.astype(np.int64), attrs


def in_box(
    x: NDArray[np.float64], y: NDArray[np.float64], box: Sequence[float]
) -> NDArray[np.bool_]:
    """Points inside ``box`` (``xmin, ymin, xmax, ymax``, edges included): the one test
    every read of a buffer uses, so a point is kept or not alike wherever it is read."""
    return (x >= box[0]) & (x <= box[2]) & (y >= box[1]) & (y <= box[3])


def peak_rss_mb() -> float:
    """Peak resident memory of this process so far, MB (``getrusage`` ``ru_maxrss``)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def split_las(
    path: str | os.PathLike[str],
    outdir: str | os.PathLike[str],
    nx: int,
    ny: int,
    *,
    chunk_points: int = CHUNK_POINTS,
) -> list[Path]:
    """Cut one (huge) LAS/LAZ file into ``nx`` x ``ny`` tiles, read and written by chunks.

    Every point goes to exactly one tile (half-open cells of equal size over the
    header's box), in file order, with every dimension and VLR of the source (the
    header is copied).  Tiles are named ``<stem>_<col>_<row>.laz``; empty cells give
    no file.

    Raises
    ------
    InputError
        ``nx`` or ``ny`` below 1; an unreadable file.
    """
    import laspy

    if nx < 1 or ny < 1:
        raise InputError(f"nx and ny must be >= 1, got {nx} x {ny}")
    src = Path(path)
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    stem = tile_name(src)
    writers: dict[tuple[int, int], Any] = {}
    paths: dict[tuple[int, int], Path] = {}
    try:
        with laspy.open(src) as reader:
            h = reader.header
            x0, y0 = float(h.mins[0]), float(h.mins[1])
            w = (float(h.maxs[0]) - x0) / nx or 1.0
            d = (float(h.maxs[1]) - y0) / ny or 1.0
            for chunk in reader.chunk_iterator(chunk_points):
                col = np.clip(((np.asarray(chunk.x) - x0) // w).astype(int), 0, nx - 1)
                row = np.clip(((np.asarray(chunk.y) - y0) // d).astype(int), 0, ny - 1)
                cell = col * ny + row
                for c in np.unique(cell):
                    key = (int(c) // ny, int(c) % ny)
                    if key not in writers:
                        paths[key] = out / f"{stem}_{key[0]}_{key[1]}.laz"
                        writers[key] = laspy.open(paths[key], mode="w", header=h)
                    writers[key].write_points(chunk[cell == c])
    except (OSError, laspy.errors.LaspyException) as exc:
        raise InputError(f"cannot split ({type(exc).__name__}: {exc})", path=src) from exc
    finally:
        for writer in writers.values():
            writer.close()
    return [paths[k] for k in sorted(paths)]
