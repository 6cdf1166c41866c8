"""The three tasks of a tiled run, one per tile, run by Dask workers (or here, one by one).

0. :func:`strip_tile`: read the tile once and keep, uncompressed, the points inside its
   neighbours' read boxes in ``.work/strips/<tile>.npz`` (each neighbour's buffer then
   costs a load, not the decompression of a whole file) and the tile's own points in
   ``.work/own/<tile>.npz`` (phase 1 loads them instead of decompressing the file again,
   and deletes them once its record is saved);
1. :func:`segment_tile`: read the tile and its buffer, ground and step 1, and save the
   owned objects with their members as (tile, index in that tile's file) plus the ground
   mask of the tile's own points in ``.work/<tile>.pkl``;
2. :func:`write_tile`: the tile's own points (read again with every dimension), labelled
   by the owners of the objects touching it, written to ``tiles/<tile>/segmented.laz``
   (exactly the tile's points, in file order, every input dimension kept) with its
   ``objects.gpkg`` and ``run.json``; the folder is built beside and renamed into place,
   so a finished tile is whole or absent.

Conflicts between runs (rare, at the edges of buffers): a point claimed by objects of two
owners goes to the first owner in catalogue order; a point one tile's ground filter calls
ground but the owning run put in an object stays in the object.

Every task skips a tile whose output exists (``.work/strips/<tile>.npz``,
``.work/<tile>.pkl``, ``tiles/<tile>/run.json``):
a rerun resumes, and since every task is deterministic the files are the same.
"""

from __future__ import annotations

import os
import pickle
import shutil
import tempfile
import time
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pyheracles.tiles.catalog import Tile, in_box, peak_rss_mb, read_points

__all__ = [
    "BUFFER_DIMS",
    "SegmentJob",
    "StripJob",
    "WriteJob",
    "load_record",
    "own_path",
    "own_points",
    "save_record",
    "segment_tile",
    "strip_path",
    "strip_tile",
    "write_tile",
]

#: The dimensions phase 1 reads besides x, y, z (the ground filter's and step 1's).
BUFFER_DIMS = ("return_number", "number_of_returns", "classification")


# ----------------------------------------------------------------------------- phase 0
@dataclass(frozen=True)
class StripJob:
    """What one phase-0 task needs: its tile and the read boxes of the tiles it buffers."""

    tile: Tile
    boxes: tuple[tuple[float, float, float, float], ...]  # the neighbours' read boxes
    work: Path
    keep_own: bool = True  # also keep the tile's own points for its phase 1


def strip_path(work: Path, name: str) -> Path:
    """The phase-0 file of tile ``name``: its points inside its neighbours' read boxes."""
    return work / "strips" / f"{name}.npz"


def own_path(work: Path, name: str) -> Path:
    """The phase-0 copy of tile ``name``'s own points (deleted by phase 1)."""
    return work / "own" / f"{name}.npz"


def strip_tile(job: StripJob) -> dict[str, Any]:
    """Read a tile once: the points its neighbours need for their buffers, and its own.

    Without it each tile's task would decompress every neighbour's whole file for a
    strip along its edge: nine files per tile on a grid.  The strip holds the points
    inside any neighbour's read box (file order, :data:`BUFFER_DIMS`), uncompressed;
    phase 1 selects its own box from it with the same test (:func:`in_box`), so the
    points are those a direct read of the neighbour's file would give.  The tile's own
    points (every point, :data:`BUFFER_DIMS`) are kept beside, uncompressed, for the
    tile's phase 1; they are written before the strip, so a strip on disk means both
    are whole.
    """
    target = strip_path(job.work, job.tile.name)
    if target.is_file() or not job.boxes:
        return skipped(job.tile)
    from pyheracles.io.atomic import atomic_path

    xyz, index, attrs = read_points(job.tile.path, None, BUFFER_DIMS)
    dims = {f"dim_{k}": v for k, v in attrs.items()}
    if job.keep_own:
        with atomic_path(own_path(job.work, job.tile.name)) as tmp, open(tmp, "wb") as fh:
            np.savez(fh, xyz=xyz, **dims)
    keep = np.zeros(len(xyz), dtype=bool)
    for box in job.boxes:
        keep |= in_box(xyz[:, 0], xyz[:, 1], box)
    keep = np.flatnonzero(keep)
    with atomic_path(target) as tmp, open(tmp, "wb") as fh:
        np.savez(fh, xyz=xyz[keep], index=index[keep], boxes=np.asarray(job.boxes, dtype=float),
                 **{k: v[keep] for k, v in dims.items()})  # fmt: skip
    return {"tile": job.tile.name, "skipped": False, "n_strip": len(keep),
            "peak_rss_mb": peak_rss_mb()}  # fmt: skip


def own_points(
    tile: Tile, work: Path
) -> tuple[NDArray[np.float64], NDArray[np.int64], dict[str, NDArray[Any]]]:
    """Every point of ``tile`` (file order, :data:`BUFFER_DIMS`): phase 0's copy if it
    is there, else read from the file."""
    path = own_path(work, tile.name)
    if path.is_file():
        with np.load(path) as data:
            xyz = data["xyz"]
            attrs = {k[4:]: data[k] for k in data.files if k.startswith("dim_")}
        return xyz, np.arange(len(xyz), dtype=np.int64), attrs
    return read_points(tile.path, None, BUFFER_DIMS)


def buffer_points(
    tile: Tile, box: tuple[float, float, float, float], work: Path
) -> tuple[NDArray[np.float64], NDArray[np.int64], dict[str, NDArray[Any]]]:
    """A neighbour's points inside ``box``: from its strip (phase 0) if the strip was cut
    for this box, else from its file."""
    path = strip_path(work, tile.name)
    if path.is_file():
        with np.load(path) as data:
            if (data["boxes"] == np.asarray(box, dtype=float)).all(axis=1).any():
                xyz = data["xyz"]
                keep = np.flatnonzero(in_box(xyz[:, 0], xyz[:, 1], box))
                attrs = {k[4:]: data[k][keep] for k in data.files if k.startswith("dim_")}
                return xyz[keep], data["index"][keep], attrs
    return read_points(tile.path, box, BUFFER_DIMS)


def skipped(tile: Tile) -> dict[str, Any]:
    """A task's result for a tile whose output was already there (a resumed run)."""
    return {"tile": tile.name, "skipped": True, "peak_rss_mb": peak_rss_mb()}


def read_tile_cloud(tile: Tile, crs: Any) -> Any:
    """The tile's own points as a :class:`~pyheracles.cloud.PointCloud`, every dimension
    kept, with the catalogue's CRS where the file names none."""
    from pyheracles.io import read_cloud

    cloud = read_cloud(tile.path)
    return cloud if cloud.crs is not None or crs is None else replace(cloud, crs=crs)


def neighbour_buffers(
    neighbours: tuple[Tile, ...],
    box: tuple[float, float, float, float],
    work: Path,
    warnings: list[str],
) -> list[tuple[Tile, NDArray[np.float64], NDArray[np.int64], dict[str, NDArray[Any]]]]:
    """Each neighbour's points inside ``box`` (:func:`buffer_points`); an unreadable
    neighbour adds a line to ``warnings`` and its points are missing from the buffer."""
    out = []
    for other in neighbours:
        try:
            out.append((other, *buffer_points(other, box, work)))
        except Exception as exc:  # an unreadable neighbour: its points are missing
            warnings.append(f"buffer: cannot read {other.path.name} ({exc})")
    return out


# ----------------------------------------------------------------------------- phase 1
@dataclass(frozen=True)
class SegmentJob:
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
    ground_params: Any = None  # AutoParams measured once for the city ("auto" ground)
    #: name -> global object id of each feature in ``layers`` (stable across runs)
    feature_ids: Mapping[str, NDArray[np.int64]] = field(default_factory=dict)
    spacing_m: float = float("nan")  # the city's point spacing (step 1's automatic values)


def segment_tile(job: SegmentJob) -> dict[str, Any]:
    """Ground and step 1 on one tile with its buffer; the owned objects saved to ``work``."""
    from pyheracles.cloud import PointCloud
    from pyheracles.complex import raised_ground_points, segment_complex
    from pyheracles.ground import extract_ground, pass_through_of

    t0 = time.perf_counter()
    target = job.work / f"{job.tile.name}.pkl"
    if target.is_file():
        own_path(job.work, job.tile.name).unlink(missing_ok=True)
        return skipped(job.tile)
    dims = BUFFER_DIMS
    parts = [(job.tile_index[job.tile.name], *own_points(job.tile, job.work))]
    warnings: list[str] = []
    box = job.box
    for other, *points in neighbour_buffers(job.neighbours, box, job.work, warnings):
        parts.append((job.tile_index[other.name], *points))
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
    released = None
    if params.ground in ("auto", "csf", "smrf"):
        # the city's parameters and world-aligned cells: the single-cloud run's rasters
        ground = extract_ground(
            cloud.xyz, params.ground, job.ground_params if params.ground == "auto" else None,
            max_object_size_m=job.max_object_size_m, source=str(job.tile.path),
            origin_m=cloud.offset[:2], pass_through=pass_through_of(cloud.attributes),
        ).mask  # fmt: skip
        near = {k: v for k, v in job.layers.items() if len(v)}
        if params.raised_ground_m is not None and ground.any() and near:
            # as segment_complex does after its own ground filter (skipped for "class");
            # passed on, so that the clutter rule spares them as it does there
            released = raised_ground_points(near, cloud, ground, params, job.spacing_m)
            ground &= ~released
        attrs = dict(cloud.attributes)
        attrs["classification"] = np.where(ground, 2, 1).astype(np.uint8)
        cloud = replace(cloud, attributes=attrs)
        params = replace(params, ground="class")
    layers = {k: v for k, v in job.layers.items() if len(v)}
    rows = None
    members: list[NDArray[np.int64]] = []
    order: tuple[str, ...] = ()
    if layers:
        if params.layer_order is not None:  # a layer with no feature near this tile is absent
            present = tuple(c for c in params.layer_order if c in layers)
            params = replace(params, layer_order=present)
        result = segment_complex(cloud, layers, params, released=released)
        seg = result.segmentation
        ground_mask = seg.ground if seg.ground is not None else np.zeros(len(cloud), bool)
        order = result.layer_order
        objects = seg.objects
        keep, ids = [], []
        for k in range(len(objects)):
            name, fid = objects["class"].iloc[k], objects["source_fid"].iloc[k]
            gdf = layers[name]
            pos = np.flatnonzero(gdf["source_fid"].to_numpy() == fid)
            if len(pos) and job.owned[name][pos[0]]:
                keep.append(k)
                ids.append(int(job.feature_ids[name][pos[0]]))
        rows = objects.iloc[keep].reset_index(drop=True)
        if len(rows):
            inst = seg.instance
            by = np.argsort(inst, kind="stable")
            starts = np.searchsorted(inst[by], rows["instance"].to_numpy())
            # the city's id of the object: its feature's, whichever tiles ran before
            rows["instance"] = np.asarray(ids, dtype=np.int32)
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
    save_record(record, target)
    own_path(job.work, job.tile.name).unlink(missing_ok=True)
    return {"tile": job.tile.name, "skipped": False, "n_points": n_own, "n_read": len(cloud),
            "seconds": record["seconds"], "peak_rss_mb": peak_rss_mb()}  # fmt: skip


def save_record(obj: Any, path: Path) -> None:
    """Pickle ``obj`` to ``path`` atomically (written beside, then renamed)."""
    from pyheracles.io.atomic import atomic_path

    with atomic_path(path) as tmp, open(tmp, "wb") as fh:
        pickle.dump(obj, fh, protocol=pickle.HIGHEST_PROTOCOL)


def load_record(path: Path) -> dict[str, Any]:
    """A phase-1 record written by :func:`save_record`."""
    with open(path, "rb") as fh:
        return pickle.load(fh)  # our own file in our own output folder


# ----------------------------------------------------------------------------- phase 2
@dataclass(frozen=True)
class WriteJob:
    """What one phase-2 task needs: its tile and the phase-1 records of its owners."""

    tile: Tile
    tile_number: int
    sources: tuple[tuple[int, Path], ...]  # (tile number, phase-1 file) of the owners
    classes: Mapping[str, int]
    crs: Any
    outdir: Path
    parameters: Any


def write_tile(job: WriteJob) -> dict[str, Any]:
    """Label one tile's own points from the owners' results and write ``tiles/<tile>/``."""
    import geopandas as gpd

    from pyheracles.io.results import write_segmentation
    from pyheracles.labels import Segmentation

    t0 = time.perf_counter()
    final = job.outdir / "tiles" / job.tile.name
    if (final / "run.json").is_file():
        return skipped(job.tile)
    cloud = read_tile_cloud(job.tile, job.crs)
    n = len(cloud)
    own = load_record(job.outdir / ".work" / f"{job.tile.name}.pkl")
    ground = np.asarray(own["ground_own"], dtype=bool).copy()
    instance = np.zeros(n, dtype=np.int32)
    class_id = np.zeros(n, dtype=np.uint8)
    conflicts = 0
    tables = []
    warnings = list(own["warnings"]) if own["tile"] == job.tile.name else []
    for _, path in job.sources:
        record = own if path.stem == job.tile.name else load_record(path)
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
            instance[free] = rows["instance"].iloc[k]
            class_id[free] = job.classes[rows["class"].iloc[k]]
            touched.append(k)
        if touched:
            part = rows.iloc[touched].copy()
            part["instance"] = part["instance"].astype(np.int32)
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
        "peak_rss_mb": peak_rss_mb(),
    }
