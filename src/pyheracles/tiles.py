"""City scale: step 1 and ground over many tiles with a buffer, out of core, on Dask.

A city does not fit one file nor one machine's memory (step 1 needs about
140 bytes per point).  This module runs step 1 (:func:`pyheracles.complex.segment_complex`)
and the ground filter tile by tile, each tile with a buffer of its neighbours' points,
and merges the results so that an object crossing a tile edge comes out whole and once.

Catalogue
    :func:`read_catalog` takes a glob (``tiles/*.laz``), a folder, or a tile index
    GeoPackage (one row per file, the path in a ``location`` / ``path`` / ``filename``
    field, as ``gdaltindex``, PDAL ``tindex`` and lidR catalogs write).  Each tile's
    bounds come from its LAS header (no point is read); the CRS is checked across
    tiles; duplicate tiles (same bounds and point count, or boxes overlapping by more
    than half) are refused by name; unreadable tiles are reported by name and the
    others are processed.

Buffer
    A tile is processed with the points of the other tiles inside its read box: the
    tile's box grown by ``buffer_m``, widened to hold every feature the tile owns grown
    by twice the cookie-cutter buffer (so an owned object is always whole, however
    large).  The automatic ``buffer_m`` is half the largest object plus 5 m, at least
    20 m: the ground filter's window (half the largest object plus a cell) around the
    tile, so the DTM has no seam.  Points are read by chunks with laspy, so memory stays
    bounded by the tile plus its buffer; COPC files are read the same way (a COPC query
    by bounds returns points in octree order and would lose the file order the outputs
    keep).

Ownership rule
    Each GIS feature belongs to exactly ONE tile: the tile whose box contains the
    feature's representative point (``shapely.point_on_surface``, always inside the
    polygon, unlike the centroid of an L-shaped building); on a shared edge, or where
    boxes overlap, the tile whose centre is nearest; a point in no box goes to the
    nearest box.  The owning tile's run (with its buffer) gives the object's points in
    every tile; other tiles' runs use the feature only so that it competes for points
    as in a single run.

Two phases
    1. per tile (a Dask task): read the tile and its buffer, ground and step 1, and
       save the owned objects with their members as (tile, index in that tile's file)
       plus the ground mask of the tile's own points in ``.work/<tile>.pkl``;
    2. per tile: the tile's own points (read again with every dimension), labelled by
       the owners of the objects touching it, written to ``tiles/<tile>/segmented.laz``
       (exactly the tile's points, in file order, every input dimension kept) with its
       ``objects.gpkg`` and ``run.json``; the folder is built beside and renamed into
       place, so a finished tile is whole or absent.  Finally ``objects.gpkg`` (all
       objects, global ``instance`` ids, ``n_points`` over all tiles, the owning
       ``tile``) and ``tiles.gpkg`` (the tile index with each tile's status).

    Conflicts between runs (rare, at the edges of buffers): a point claimed by objects
    of two owners goes to the first owner in catalogue order; a point one tile's ground
    filter calls ground but the owning run put in an object stays in the object.

Resume
    A tile whose phase-1 file or ``tiles/<tile>/`` folder exists is not computed again;
    outputs are deterministic, so a resumed run gives the same files.
"""

from __future__ import annotations

import glob as _glob
import os
import pickle
import resource
import shutil
import tempfile
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pyheracles.errors import InputError

__all__ = [
    "Tile",
    "TileCatalog",
    "TiledResult",
    "assign_owners",
    "is_tile_source",
    "read_catalog",
    "run_tiles",
    "split_las",
]

_LAS_SUFFIXES = (".las", ".laz")
_INDEX_FIELDS = ("location", "path", "filename", "file", "tile", "url")
#: Two tile boxes overlapping by more than this share of the smaller are duplicates.
_DUPLICATE_OVERLAP = 0.5
_CHUNK = 1_000_000  # points per chunk when reading a buffer


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


def _tile_name(path: Path) -> str:
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
    return Tile(_tile_name(path), path, bounds, n, crs), ""


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


def assign_owners(points_xy: NDArray[np.float64], bounds: NDArray[np.float64]) -> NDArray[np.int64]:
    """Index of the tile owning each point (see the module's ownership rule).

    Parameters
    ----------
    points_xy
        ``(M, 2)`` representative points of the features, world coordinates.
    bounds
        ``(T, 4)`` tile boxes ``xmin, ymin, xmax, ymax``.

    Examples
    --------
    >>> b = np.array([[0, 0, 10, 10], [10, 0, 20, 10]], dtype=float)
    >>> assign_owners(np.array([[2.0, 5.0], [10.0, 5.0], [10.5, 5.0], [30.0, 5.0]]), b).tolist()
    [0, 0, 1, 1]
    """
    p = np.asarray(points_xy, dtype=float).reshape(-1, 1, 2)
    b = np.asarray(bounds, dtype=float).reshape(1, -1, 4)
    dx = np.maximum(np.maximum(b[..., 0] - p[..., 0], p[..., 0] - b[..., 2]), 0.0)
    dy = np.maximum(np.maximum(b[..., 1] - p[..., 1], p[..., 1] - b[..., 3]), 0.0)
    outside = np.hypot(dx, dy)
    cx, cy = (b[..., 0] + b[..., 2]) / 2, (b[..., 1] + b[..., 3]) / 2
    centre = np.hypot(p[..., 0] - cx, p[..., 1] - cy)
    # nearest box first, then the nearest centre among the boxes at that distance
    rank = np.where(outside == outside.min(axis=1, keepdims=True), centre, np.inf)
    return np.argmin(rank, axis=1).astype(np.int64)


# ----------------------------------------------------------------------------- reading
def _read_points(
    path: Path, box: tuple[float, float, float, float] | None, dims: Sequence[str]
) -> tuple[NDArray[np.float64], NDArray[np.int64], dict[str, NDArray[Any]]]:
    """World xyz, file indices and ``dims`` of the points of ``path`` inside ``box``.

    Read by chunks of a million points: memory holds the kept points, not the file.
    """
    import laspy

    xyz_parts, idx_parts = [], []
    attr_parts: dict[str, list[NDArray[Any]]] = {d: [] for d in dims}
    start = 0
    with laspy.open(path) as reader:
        have = set(reader.header.point_format.dimension_names)
        for chunk in reader.chunk_iterator(_CHUNK):
            x, y, z = np.asarray(chunk.x), np.asarray(chunk.y), np.asarray(chunk.z)
            if box is None:
                keep = np.ones(len(x), dtype=bool)
            else:
                keep = (x >= box[0]) & (x <= box[2]) & (y >= box[1]) & (y <= box[3])
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


def _peak_rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def split_las(
    path: str | os.PathLike[str],
    outdir: str | os.PathLike[str],
    nx: int,
    ny: int,
    *,
    chunk_points: int = _CHUNK,
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
    stem = _tile_name(src)
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


# ----------------------------------------------------------------------------- phase 1
@dataclass(frozen=True)
class _Job:
    """What one phase-1 task needs: its tile, the neighbours and the features near it."""

    tile: Tile
    neighbours: tuple[Tile, ...]
    tile_index: Mapping[str, int]
    layers: Mapping[str, Any]  # name -> GeoDataFrame of the features meeting the buffered box
    owned: Mapping[str, NDArray[np.bool_]]  # name -> feature owned by this tile
    params: Any
    box: tuple[float, float, float, float]  # the read box: tile, buffer, owned features
    max_object_size_m: float
    crs: Any
    work: Path


def _phase1(job: _Job) -> dict[str, Any]:
    """Ground and step 1 on one tile with its buffer; the owned objects saved to ``work``."""
    from pyheracles.cloud import PointCloud
    from pyheracles.complex import segment_complex
    from pyheracles.ground import extract_ground

    t0 = time.perf_counter()
    target = job.work / f"{job.tile.name}.pkl"
    if target.is_file():
        return {"tile": job.tile.name, "skipped": True, "peak_rss_mb": _peak_rss_mb()}
    dims = ("number_of_returns", "classification")
    parts = [(job.tile_index[job.tile.name], *_read_points(job.tile.path, None, dims))]
    warnings: list[str] = []
    box = job.box
    for other in job.neighbours:
        try:
            parts.append((job.tile_index[other.name], *_read_points(other.path, box, dims)))
        except Exception as exc:  # an unreadable neighbour: its points are missing
            warnings.append(f"buffer: cannot read {other.path.name} ({exc})")
    n_own = len(parts[0][1])
    world = np.concatenate([p[1] for p in parts])
    src_tile = np.concatenate([np.full(len(p[1]), p[0], dtype=np.int32) for p in parts])
    src_index = np.concatenate([p[2] for p in parts])
    attrs = {}
    for d in dims:
        if all(d in p[3] for p in parts):
            attrs[d] = np.concatenate([p[3][d] for p in parts])
    cloud = PointCloud.from_world(world, attributes=attrs, crs=job.crs, source=str(job.tile.path))
    del world
    params = job.params
    if params.ground in ("auto", "csf", "smrf"):
        ground = extract_ground(
            cloud.xyz, params.ground, max_object_size_m=job.max_object_size_m,
            source=str(job.tile.path),
        ).mask  # fmt: skip
        attrs = dict(cloud.attributes)
        attrs["classification"] = np.where(ground, 2, 1).astype(np.uint8)
        cloud = replace(cloud, attributes=attrs)
        params = replace(params, ground="class")
    layers = {k: v for k, v in job.layers.items() if len(v)}
    rows = None
    members: list[NDArray[np.int64]] = []
    order: tuple[str, ...] = ()
    if layers:
        result = segment_complex(cloud, layers, params)
        seg = result.segmentation
        ground_mask = seg.ground if seg.ground is not None else np.zeros(len(cloud), bool)
        order = result.layer_order
        objects = seg.objects
        keep = []
        for k in range(len(objects)):
            name, fid = objects["class"].iloc[k], objects["source_fid"].iloc[k]
            gdf = layers[name]
            pos = np.flatnonzero(gdf["source_fid"].to_numpy() == fid)
            if len(pos) and job.owned[name][pos[0]]:
                keep.append(k)
        rows = objects.iloc[keep].reset_index(drop=True)
        if len(rows):
            inst = seg.instance
            by = np.argsort(inst, kind="stable")
            starts = np.searchsorted(inst[by], rows["instance"].to_numpy())
            for start, count in zip(starts, rows["n_points"].to_numpy(), strict=True):
                members.append(by[start : start + int(count)])
        warnings.extend(seg.warnings)
        spacing = result.spacing_m
        used = result.params
    else:
        ground_mask = np.asarray(cloud.attributes.get("classification", 0)) == 2
        if ground_mask.shape != (len(cloud),):
            ground_mask = np.zeros(len(cloud), bool)
        spacing, used = float("nan"), params
    record = {
        "tile": job.tile.name,
        "n_own": n_own,
        "n_read": len(cloud),
        "ground_own": ground_mask[:n_own].copy(),
        "objects": rows,
        "member_tile": [src_tile[m] for m in members],
        "member_index": [src_index[m] for m in members],
        "layer_order": order,
        "spacing_m": spacing,
        "params": used,
        "warnings": warnings,
        "seconds": time.perf_counter() - t0,
    }
    _atomic_pickle(record, target)
    return {"tile": job.tile.name, "skipped": False, "n_points": n_own, "n_read": len(cloud),
            "seconds": record["seconds"], "peak_rss_mb": _peak_rss_mb()}  # fmt: skip


def _atomic_pickle(obj: Any, path: Path) -> None:
    from pyheracles.io.atomic import atomic_path

    with atomic_path(path) as tmp, open(tmp, "wb") as fh:
        pickle.dump(obj, fh, protocol=pickle.HIGHEST_PROTOCOL)


def _load(path: Path) -> dict[str, Any]:
    with open(path, "rb") as fh:
        return pickle.load(fh)  # our own file in our own output folder


# ----------------------------------------------------------------------------- phase 2
@dataclass(frozen=True)
class _Job2:
    tile: Tile
    tile_number: int
    sources: tuple[tuple[int, Path, int], ...]  # (tile number, phase-1 file, first global id)
    classes: Mapping[str, int]
    crs: Any
    outdir: Path
    parameters: Any


def _phase2(job: _Job2) -> dict[str, Any]:
    """Label one tile's own points from the owners' results and write ``tiles/<tile>/``."""
    import geopandas as gpd

    from pyheracles.io import read_cloud
    from pyheracles.io.results import write_segmentation
    from pyheracles.labels import Segmentation

    t0 = time.perf_counter()
    final = job.outdir / "tiles" / job.tile.name
    if (final / "run.json").is_file():
        return {"tile": job.tile.name, "skipped": True, "peak_rss_mb": _peak_rss_mb()}
    cloud = read_cloud(job.tile.path)
    if cloud.crs is None and job.crs is not None:
        cloud = replace(cloud, crs=job.crs)
    n = len(cloud)
    own = _load(job.outdir / ".work" / f"{job.tile.name}.pkl")
    ground = np.asarray(own["ground_own"], dtype=bool).copy()
    instance = np.zeros(n, dtype=np.int32)
    class_id = np.zeros(n, dtype=np.uint8)
    conflicts = 0
    tables = []
    warnings = list(own["warnings"]) if own["tile"] == job.tile.name else []
    for _, path, first_id in job.sources:
        record = own if path.stem == job.tile.name else _load(path)
        rows = record["objects"]
        if rows is None or not len(rows):
            continue
        touched = []
        for k, (mt, mi) in enumerate(
            zip(record["member_tile"], record["member_index"], strict=True)
        ):
            idx = mi[mt == job.tile_number]
            if not len(idx):
                continue
            free = idx[instance[idx] == 0]
            conflicts += len(idx) - len(free)
            instance[free] = first_id + k
            class_id[free] = job.classes[rows["class"].iloc[k]]
            touched.append(k)
        if touched:
            part = rows.iloc[touched].copy()
            part["instance"] = (first_id + np.asarray(touched)).astype(np.int32)
            part["tile"] = record["tile"]
            tables.append(part)
    ground &= instance == 0
    if conflicts:
        warnings.append(f"{conflicts} points claimed by objects of two tiles: first owner kept")
    counts = np.bincount(instance, minlength=1)
    if tables:
        import pandas as pd

        objects = gpd.GeoDataFrame(pd.concat(tables, ignore_index=True), crs=job.crs)
        objects["class_id"] = [job.classes[c] for c in objects["class"]]
        objects["n_points"] = counts[objects["instance"].to_numpy()].astype(np.int64)
        objects = objects[objects["n_points"] > 0].reset_index(drop=True)
    else:
        objects = gpd.GeoDataFrame({"instance": np.zeros(0, np.int32), "class": [],
                                    "n_points": np.zeros(0, np.int64)},
                                   geometry=gpd.GeoSeries([], crs=job.crs))  # fmt: skip
    seg = Segmentation(
        instance=instance, class_id=class_id, classes={v: k for k, v in job.classes.items()},
        objects=objects, ground=ground, warnings=tuple(warnings),
    )  # fmt: skip
    staging = Path(tempfile.mkdtemp(prefix=f".{job.tile.name}.", suffix=".part",
                                    dir=final.parent))  # fmt: skip
    try:
        write_segmentation(
            cloud, seg, staging, step="complex-tile", parameters=job.parameters,
            inputs=[job.tile.path],
            extra={"tile": job.tile.name, "owner_tiles": sorted({t["tile"].iloc[0]
                                                                 for t in tables}),
                   "conflicts": conflicts},
        )  # fmt: skip
        if final.exists():  # a stale, unfinished folder (no run.json): replace it
            shutil.rmtree(final)
        os.replace(staging, final)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
    return {
        "tile": job.tile.name,
        "skipped": False,
        "n_points": n,
        "counts": {int(i): int(c) for i, c in enumerate(counts) if i and c},
        "seconds": time.perf_counter() - t0,
        "peak_rss_mb": _peak_rss_mb(),
    }


# ----------------------------------------------------------------------------- driver
@dataclass
class TiledResult:
    """Result of :func:`run_tiles`.

    Attributes
    ----------
    catalog
        The tiles.
    status
        Tile name -> ``done``, ``resumed`` (done by an earlier run) or ``failed: <why>``.
    objects
        The merged objects table (global ``instance``, ``n_points`` over all tiles).
    paths
        ``objects``, ``tiles`` (the index), ``run``.
    timings, peak_rss_mb
        Seconds per phase; the largest peak resident memory of a task's process, MB.
    """

    catalog: TileCatalog
    status: dict[str, str]
    objects: Any
    paths: dict[str, Path]
    timings: dict[str, float] = field(default_factory=dict)
    peak_rss_mb: float = 0.0
    points_per_s: float = 0.0
    dashboard: str | None = None

    @property
    def failed(self) -> dict[str, str]:
        """Tiles (and unreadable files) that did not finish, with the reason."""
        out = {k: v for k, v in self.status.items() if v.startswith("failed")}
        for path, reason in self.catalog.unreadable:
            out[Path(path).name] = f"failed: {reason}"
        return out


def _auto_buffer(layers: Mapping[str, Any]) -> tuple[float, float]:
    """(tile buffer, largest object size), metres: the ground window around a tile.

    The size is the ground filter's (``sqrt`` of the largest footprint area, at least
    20 m); the auto ground window is half of it plus a cell.
    """
    import shapely

    size = 20.0
    for gdf in layers.values():
        if len(gdf):
            size = max(size, float(np.sqrt(shapely.area(gdf.geometry.to_numpy())).max()))
    return max(size / 2.0 + 5.0, 20.0), size


def _resolve_once(params: Any, catalog: TileCatalog) -> Any:
    """Automatic step-1 parameters measured once (on the median tile), the same for all.

    Per-tile spacings differ a little, and with them the automatic buffer, distance
    and cluster size; one value keeps the tiles consistent with each other.
    """
    from pyheracles.complex import resolve_params
    from pyheracles.geometry.neighbours import point_spacing

    auto = ("buffer_m", "cluster_distance_m", "min_cluster_points", "attach_distance_m",
            "scatter_offset_m")  # fmt: skip
    if all(getattr(params, a) is not None for a in auto):
        return params
    tile = sorted(catalog.tiles, key=lambda t: t.n_points)[len(catalog.tiles) // 2]
    xyz, _, _ = _read_points(tile.path, None, ())
    xyz -= xyz.min(axis=0)
    return resolve_params(params, point_spacing(xyz, rng=params.seed))


def _read_box(
    tile: Tile, buffer_m: float, owned_bounds: NDArray[np.float64], margin_m: float
) -> tuple[float, float, float, float]:
    """The tile's box + ``buffer_m``, widened to the owned features' bounds + ``margin_m``."""
    x0, y0, x1, y1 = tile.box(buffer_m)
    if len(owned_bounds):
        x0 = min(x0, float(owned_bounds[:, 0].min()) - margin_m)
        y0 = min(y0, float(owned_bounds[:, 1].min()) - margin_m)
        x1 = max(x1, float(owned_bounds[:, 2].max()) + margin_m)
        y1 = max(y1, float(owned_bounds[:, 3].max()) + margin_m)
    return (x0, y0, x1, y1)


def _client(workers: int | None, scheduler: str | None) -> tuple[Any, Any]:
    """(client, cluster) for ``scheduler`` or a LocalCluster of ``workers`` processes."""
    try:
        from dask.distributed import Client, LocalCluster
    except ImportError as exc:  # pragma: no cover - the city extra is missing
        raise InputError(
            "running on tiles with --workers / --scheduler needs Dask",
            hint='pip install "pyheracles[city]"',
        ) from exc
    import logging

    if scheduler is not None:
        try:
            return Client(scheduler, timeout="5s", set_as_default=True), None
        except Exception as exc:
            raise InputError(
                f"cannot connect to the Dask scheduler at {scheduler!r} "
                f"({type(exc).__name__}: {exc})",
                hint="check the address (tcp://HOST:8786) and that the scheduler is running; "
                "or use --workers N for a cluster on this machine",
            ) from exc
    cluster = LocalCluster(
        n_workers=int(workers or 1), threads_per_worker=1, processes=True,
        dashboard_address=":0", silence_logs=logging.ERROR,
    )  # fmt: skip
    return Client(cluster, set_as_default=True), cluster


def _layers_near(
    layers: Mapping[str, Any], box: tuple[float, float, float, float]
) -> dict[str, Any]:
    import shapely

    out = {}
    region = shapely.box(*box)
    for name, gdf in layers.items():
        hit = np.sort(gdf.sindex.query(region, predicate="intersects"))
        part = gdf.iloc[hit]
        part.attrs.update(gdf.attrs)
        out[name] = (part, hit)
    return out


def run_tiles(
    source: str | os.PathLike[str] | TileCatalog,
    layers: Mapping[str, Any],
    outdir: str | os.PathLike[str],
    *,
    params: Any = None,
    buffer_m: float | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    retries: int = 2,
    cloud_crs: Any = None,
    reproject: bool = False,
    fix_invalid: bool = False,
    progress: Callable[[dict[str, Any]], None] | None = None,
) -> TiledResult:
    """Step 1 and ground over many tiles; see the module docstring for the rules.

    Parameters
    ----------
    source
        A glob, a folder, a tile index ``.gpkg`` or a :class:`TileCatalog`.
    layers
        Layer name -> GeoDataFrame (as for :func:`pyheracles.complex.segment_complex`).
    outdir
        Output folder; an earlier run's folder is resumed.
    params
        :class:`pyheracles.complex.ComplexParams`.
    buffer_m
        Tile buffer, metres (``None``: half the largest object + 5 m, at least 20 m, the
        ground window); each tile's read box is also widened to hold its owned features.
    workers, scheduler
        ``scheduler``: address of a running Dask scheduler; else ``workers`` processes of
        one thread in a LocalCluster; ``None`` / 0 runs the tasks here, one by one.
    retries
        Times a failed task is tried again (Dask ``retries=``).
    progress
        Called after every finished task with ``phase``, ``done``, ``total``, ``points``,
        ``seconds`` and ``dashboard``.

    Returns
    -------
    TiledResult
        Statuses per tile (a failing tile does not stop the others), merged objects.

    Raises
    ------
    InputError
        Bad catalogue (see :func:`read_catalog`), invalid layers, CRS mismatch, an
        unreachable scheduler.
    """
    import geopandas as gpd
    import pandas as pd
    import shapely

    from pyheracles.complex import ComplexParams
    from pyheracles.io.vector import align_crs, validate_polygons, write_gpkg
    from pyheracles.provenance import write_run_json

    t_start = time.perf_counter()
    p = params or ComplexParams()
    catalog = source if isinstance(source, TileCatalog) else read_catalog(source, crs=cloud_crs)
    if not layers:
        raise InputError("no GIS layer given", hint="add at least one --layer NAME=PATH")
    crs = catalog.crs
    if crs is None:
        crs = next((g.crs for g in layers.values() if g.crs is not None), None)
    checked: dict[str, Any] = {}
    for name, gdf in layers.items():
        src = gdf.attrs.get("source")
        g = validate_polygons(gdf, fix_invalid=fix_invalid, source=src)
        g = align_crs(g, crs, reproject=reproject, cloud_source=str(source))
        if "source_fid" not in g.columns:
            g = g.assign(source_fid=np.arange(len(g), dtype=np.int64))
        g = g.reset_index(drop=True)
        g.attrs.update(gdf.attrs)
        checked[name] = g
    auto_buffer, max_size = _auto_buffer(checked)
    p = _resolve_once(p, catalog)
    buffer = float(buffer_m) if buffer_m is not None else auto_buffer
    if not buffer >= 0:
        raise InputError(f"the tile buffer must be >= 0 m, got {buffer_m}")
    out = Path(outdir)
    work = out / ".work"
    work.mkdir(parents=True, exist_ok=True)
    (out / "tiles").mkdir(exist_ok=True)
    tiles = catalog.tiles
    numbers = {t.name: k for k, t in enumerate(tiles)}
    bounds = np.array([t.bounds for t in tiles], dtype=float)
    owners = {
        name: assign_owners(shapely.get_coordinates(shapely.point_on_surface(
            g.geometry.to_numpy())), bounds)
        for name, g in checked.items()
    }  # fmt: skip
    # an owned object is whole: its feature grown by twice the cookie-cutter buffer
    margin = 2.0 * (p.buffer_m if p.buffer_m is not None else 3.0) + 2.0
    feature_bounds = {n: shapely.bounds(g.geometry.to_numpy()) for n, g in checked.items()}
    jobs = []
    boxes = {}
    for k, tile in enumerate(tiles):
        mine = [feature_bounds[n][owners[n] == k] for n in checked]
        box = _read_box(tile, buffer, np.concatenate(mine) if mine else np.zeros((0, 4)), margin)
        boxes[tile.name] = box
        near = _layers_near(checked, box)
        jobs.append(_Job(
            tile=tile, neighbours=tuple(catalog.neighbours(tile, box=box)), tile_index=numbers,
            layers={n: v[0] for n, v in near.items()},
            owned={n: owners[n][v[1]] == k for n, v in near.items()},
            params=p, box=box, max_object_size_m=max_size, crs=crs, work=work,
        ))  # fmt: skip
    status: dict[str, str] = {}
    client = cluster = None
    dashboard = None
    peak = 0.0
    timings: dict[str, float] = {}
    try:
        if scheduler is not None or workers:
            client, cluster = _client(workers, scheduler)
            dashboard = getattr(client, "dashboard_link", None)
        t = time.perf_counter()
        first = _run_phase(client, _phase1, jobs, "segment", retries, progress, dashboard)
        timings["segment"] = time.perf_counter() - t
        for name, (ok, info) in first.items():
            if not ok:
                status[name] = f"failed: {info}"
            else:
                peak = max(peak, float(info.get("peak_rss_mb", 0.0)))
        # global ids: tiles in catalogue order, each tile's owned objects in its order
        records: dict[str, dict[str, Any]] = {}
        first_id: dict[str, int] = {}
        next_id = 1
        class_names: list[str] = list(p.layer_order or ())
        for tile in tiles:
            if tile.name in status:
                continue
            rec = _load(work / f"{tile.name}.pkl")
            records[tile.name] = rec
            first_id[tile.name] = next_id
            next_id += 0 if rec["objects"] is None else len(rec["objects"])
            for c in rec["layer_order"]:
                if c not in class_names:
                    class_names.append(c)
        for c in checked:
            if c not in class_names:
                class_names.append(c)
        classes = {c: k for k, c in enumerate(class_names, start=1)}
        jobs2 = []
        for tile in tiles:
            if tile.name in status:
                continue
            # the tiles whose read box meets this tile may own objects with points in it
            sources = tuple(
                (numbers[o.name], work / f"{o.name}.pkl", first_id[o.name])
                for o in tiles
                if o.name in records
                and (o.name == tile.name or tile in catalog.neighbours(o, box=boxes[o.name]))
            )
            jobs2.append(_Job2(tile, numbers[tile.name], sources, classes, crs, out, p))
        t = time.perf_counter()
        second = _run_phase(client, _phase2, jobs2, "write", retries, progress, dashboard)
        timings["write"] = time.perf_counter() - t
    finally:
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()
    totals: dict[int, int] = {}
    for name, (ok, info) in second.items():
        if not ok:
            status[name] = f"failed: {info}"
            continue
        peak = max(peak, float(info.get("peak_rss_mb", 0.0)))
        status[name] = (
            "resumed" if info.get("skipped") and first[name][1].get("skipped") else ("done")
        )
        counts = info.get("counts")
        if counts is None:  # a tile finished by an earlier run: its counts from its table
            counts = _tile_counts(out / "tiles" / name)
        for i, c in counts.items():
            totals[int(i)] = totals.get(int(i), 0) + int(c)
    # merged objects
    tables = []
    for name, rec in records.items():
        rows = rec["objects"]
        if rows is None or not len(rows):
            continue
        rows = rows.copy()
        rows["instance"] = (first_id[name] + np.arange(len(rows))).astype(np.int32)
        rows["class_id"] = [classes[c] for c in rows["class"]]
        rows["tile"] = name
        tables.append(rows)
    if tables:
        objects = gpd.GeoDataFrame(pd.concat(tables, ignore_index=True), crs=crs)
        objects["n_points"] = [totals.get(int(i), 0) for i in objects["instance"]]
        objects["n_points"] = objects["n_points"].astype(np.int64)
    else:
        objects = gpd.GeoDataFrame({"instance": np.zeros(0, np.int32)},
                                   geometry=gpd.GeoSeries([], crs=crs))  # fmt: skip
    paths: dict[str, Path] = {}
    if len(objects) and crs is not None:
        paths["objects"] = write_gpkg(objects, out / "objects.gpkg", "objects")
    index = gpd.GeoDataFrame(
        {
            "name": [t.name for t in tiles] + [Path(u).stem for u, _ in catalog.unreadable],
            "location": [str(t.path) for t in tiles] + [u for u, _ in catalog.unreadable],
            "n_points": [t.n_points for t in tiles] + [0] * len(catalog.unreadable),
            "status": [status.get(t.name, "failed") for t in tiles]
            + [f"failed: {r}" for _, r in catalog.unreadable],
            "output": [
                str(Path("tiles") / t.name / "segmented.laz")
                if not status.get(t.name, "failed").startswith("failed") else ""
                for t in tiles
            ] + [""] * len(catalog.unreadable),
        },
        geometry=[shapely.box(*t.bounds) for t in tiles] + [None] * len(catalog.unreadable),
        crs=crs,
    )  # fmt: skip
    paths["tiles"] = write_gpkg(index, out / "tiles.gpkg", "tiles")
    total_time = time.perf_counter() - t_start
    timings["total"] = total_time
    n_done = sum(t.n_points for t in tiles if not status[t.name].startswith("failed"))
    rate = n_done / total_time if total_time > 0 else 0.0
    paths["run"] = write_run_json(
        out, step="complex-tiles", parameters=p,
        inputs=[g.attrs["source"] for g in layers.values() if g.attrs.get("source")],
        timings=timings,
        counts={"tiles": len(tiles), "points": catalog.n_points, "objects": len(objects)},
        extra={"tile_buffer_m": buffer, "max_object_size_m": max_size, "status": status,
               "unreadable": [list(u) for u in catalog.unreadable], "notes": list(catalog.notes),
               "peak_rss_mb_per_worker": peak, "points_per_s": rate,
               "tiles": [str(t.path) for t in tiles], "classes": classes},
    )  # fmt: skip
    return TiledResult(catalog, status, objects, paths, timings, peak, rate, dashboard)


def _tile_counts(folder: Path) -> dict[int, int]:
    import pyogrio

    gpkg = folder / "objects.gpkg"
    if not gpkg.is_file():
        return {}
    table = pyogrio.read_dataframe(gpkg, read_geometry=False, columns=["instance", "n_points"])
    return dict(zip(table["instance"].astype(int), table["n_points"].astype(int), strict=True))


def _run_phase(
    client: Any,
    fn: Callable[[Any], dict[str, Any]],
    jobs: Sequence[Any],
    phase: str,
    retries: int,
    progress: Callable[[dict[str, Any]], None] | None,
    dashboard: str | None,
) -> dict[str, tuple[bool, Any]]:
    """Run ``fn`` on every job; tile name -> (ok, task info or the error message)."""
    results: dict[str, tuple[bool, Any]] = {}
    t0 = time.perf_counter()
    points = 0

    def report() -> None:
        if progress is not None:
            progress({"phase": phase, "done": len(results), "total": len(jobs),
                      "points": points, "seconds": time.perf_counter() - t0,
                      "dashboard": dashboard})  # fmt: skip

    report()
    if client is None:
        for job in jobs:
            try:
                info = fn(job)
                results[job.tile.name] = (True, info)
                points += int(info.get("n_points", 0))
            except Exception as exc:  # one tile's failure must not stop the others
                results[job.tile.name] = (False, _why(exc))
            report()
        return results
    from dask.distributed import as_completed

    futures = client.map(fn, jobs, retries=retries, pure=False,
                         key=[f"{phase}-{job.tile.name}" for job in jobs])  # fmt: skip
    names = {f.key: job.tile.name for f, job in zip(futures, jobs, strict=True)}
    for future in as_completed(futures):
        name = names[future.key]
        if future.status == "finished":
            info = future.result()
            results[name] = (True, info)
            points += int(info.get("n_points", 0))
        else:
            results[name] = (False, _why(future.exception()))
        report()
    return results


def _why(exc: BaseException | None) -> str:
    if exc is None:
        return "unknown error"
    return str(exc) if isinstance(exc, InputError) else f"{type(exc).__name__}: {exc}"
