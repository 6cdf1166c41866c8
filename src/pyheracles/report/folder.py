"""What a report is made from: the files of one output folder, read once."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from pyheracles.errors import InputError

__all__ = ["CloudSample", "RunFolder", "read_run_folder", "sample_cloud"]

#: Clouds a report shows, in order of preference.
CLOUD_NAMES = ("segmented.laz", "ground.laz")
#: Tables shown as they are.
TABLE_NAMES = ("evaluation.csv", "checkpoints.csv", "tiepoints.csv")
#: JSON documents summarised in the report.
JSON_NAMES = (
    "report.json",
    "transform.json",
    "georef.json",
    "checkpoints.json",
    "evaluation.json",
    "frame.json",
)
#: 3D geometry drawn in the 3D view: GeoPackages of 3D polygons and CityJSON files.
LAYER_NAMES = ("walls.gpkg", "openings.gpkg", "buildings.city.json")


@dataclass(frozen=True)
class RunFolder:
    """The readable content of an output folder.

    Attributes
    ----------
    path
        The folder.
    run
        ``run.json`` (provenance, parameters, counts, warnings).
    objects
        The objects table (``objects.gpkg`` without its geometry, or
        ``objects.csv``), None when the step writes none.
    footprints
        The objects' polygons (world coordinates) when ``objects.gpkg`` has them.
    cloud
        The labelled cloud to show, or None.
    images
        PNG figures written by the step.
    tables, documents
        Other CSV tables and JSON documents by file name.
    layers
        3D geometry by file name: GeoDataFrames (``walls.gpkg``, ``openings.gpkg``)
        and CityJSON documents (``buildings.city.json``).
    """

    path: Path
    run: dict[str, Any]
    objects: pd.DataFrame | None = None
    footprints: Any = None
    cloud: Path | None = None
    images: list[Path] = field(default_factory=list)
    tables: dict[str, pd.DataFrame] = field(default_factory=dict)
    documents: dict[str, Any] = field(default_factory=dict)
    layers: dict[str, Any] = field(default_factory=dict)

    @property
    def step(self) -> str:
        """The step that wrote the folder (``complex``, ``supports`` ...)."""
        return str(self.run.get("step", "unknown"))


def read_run_folder(path: str | Path) -> RunFolder:
    """Read an output folder written by a ``heracles`` command.

    Raises
    ------
    InputError
        When ``path`` is not a folder or holds no ``run.json``.
    """
    p = Path(path)
    if not p.is_dir():
        raise InputError(
            "is not an output folder",
            path=p,
            hint="give the folder a heracles command wrote with -o",
        )
    run_file = p / "run.json"
    if not run_file.is_file():
        raise InputError(
            "has no run.json, so it was not written by a heracles command",
            path=p,
            hint="give the folder a heracles command wrote with -o",
        )
    try:
        run = json.loads(run_file.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise InputError(f"run.json is not readable JSON ({exc})", path=run_file) from exc
    objects, footprints = _objects(p)
    cloud = next((p / n for n in CLOUD_NAMES if (p / n).is_file()), None)
    if cloud is None:
        moved = sorted(p.glob("*_registered.laz")) + sorted(p.glob("*_georef.laz"))
        cloud = moved[0] if moved else None
    tables = {}
    for n in TABLE_NAMES:
        if (p / n).is_file():
            try:
                tables[n] = pd.read_csv(p / n)
            except (OSError, ValueError, pd.errors.ParserError):
                continue
    docs = {}
    for n in JSON_NAMES:
        if (p / n).is_file():
            try:
                docs[n] = json.loads((p / n).read_text(encoding="utf-8"))
            except (OSError, ValueError):
                continue
    images = sorted(x for x in p.glob("*.png"))
    return RunFolder(p, run, objects, footprints, cloud, images, tables, docs, _layers(p))


def _layers(p: Path) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for n in LAYER_NAMES:
        f = p / n
        if not f.is_file():
            continue
        try:
            if n.endswith(".json"):
                out[n] = json.loads(f.read_text(encoding="utf-8"))
            else:
                import pyogrio

                out[n] = pyogrio.read_dataframe(f)
        except (OSError, ValueError, RuntimeError):
            continue  # an unreadable layer is left out of the view, not fatal
    return out


def _objects(p: Path) -> tuple[pd.DataFrame | None, Any]:
    gpkg, csv = p / "objects.gpkg", p / "objects.csv"
    if gpkg.is_file():
        import pyogrio

        gdf = pyogrio.read_dataframe(gpkg)
        table = pd.DataFrame(gdf.drop(columns="geometry", errors="ignore"))
        return table, gdf if "geometry" in gdf else None
    if csv.is_file():
        return pd.read_csv(csv), None
    return None, None


@dataclass(frozen=True)
class CloudSample:
    """A subsample of a labelled cloud for pictures and the 3D view.

    ``xyz`` is in world coordinates minus ``origin`` (float32 keeps millimetres
    there); ``instance`` 0 = no object, ``ground`` True for ground points.
    """

    xyz: NDArray[np.float32]
    origin: NDArray[np.float64]
    instance: NDArray[np.int64]
    ground: NDArray[np.bool_]
    n_total: int
    crs: str | None


def sample_cloud(path: Path, max_points: int = 300_000, seed: int = 0) -> CloudSample:
    """Read a labelled cloud and keep at most ``max_points``, every object represented.

    Each object keeps at least ``min(its points, 300)`` points so that small
    objects stay visible; the rest of the budget is spread evenly.  When this
    process has just written ``path`` and still holds what it wrote
    (:func:`pyheracles.io.results.written_labels`), the sample is taken from
    memory; otherwise from the file.
    """
    from pyheracles.io.results import written_labels

    rng = np.random.default_rng(seed)
    held = written_labels(path)
    if held is not None:
        from pyheracles.labels import ASPRS_GROUND, asprs_classification

        cloud, seg = held
        inst = np.asarray(seg.instance, np.int64)
        idx = _sample_index(inst, max_points, rng)
        xyz = cloud.xyz[idx] + cloud.offset
        ground = asprs_classification(seg)[idx] == ASPRS_GROUND
        crs_name = None if cloud.crs is None else cloud.crs.name
        return _sample(xyz, inst[idx], ground, len(inst), crs_name)
    import laspy

    las = laspy.read(path)
    n = len(las.points)
    dims = set(las.point_format.dimension_names)
    inst = np.asarray(las["instance"], np.int64) if "instance" in dims else np.zeros(n, np.int64)
    idx = _sample_index(inst, max_points, rng)
    xyz = np.column_stack([np.asarray(las.x)[idx], np.asarray(las.y)[idx], np.asarray(las.z)[idx]])
    ground = np.asarray(las.classification)[idx] == 2
    crs = las.header.parse_crs()
    return _sample(xyz, inst[idx], ground, n, None if crs is None else crs.name)


def _sample_index(inst: NDArray[np.int64], max_points: int, rng: np.random.Generator):
    """Indices of at most about ``max_points`` points, each object keeping
    ``min(its points, 300)`` (see :func:`sample_cloud`)."""
    n = len(inst)
    if n <= max_points:
        return np.arange(n)
    keep = rng.random(n) < max_points / n
    # only the objects the random share leaves under their quota need their points
    # listed; sorting all labels instead cost 1 s on 10 M points
    labelled = inst > 0
    if labelled.any():
        total = np.bincount(inst[labelled])
        kept = np.bincount(inst[labelled & keep], minlength=len(total))
        short = np.flatnonzero((total > 0) & (kept < np.minimum(total, 300)))
        rows = np.flatnonzero(np.isin(inst, short))
        order = rows[np.argsort(inst[rows], kind="stable")]
        starts = np.searchsorted(inst[order], short)
        ends = np.searchsorted(inst[order], short, side="right")
        for s, e in zip(starts, ends, strict=True):
            take = order[s:e]
            keep[rng.choice(take, min(len(take), 300), replace=False)] = True
    return np.flatnonzero(keep)


def _sample(
    xyz: NDArray[np.float64],
    inst: NDArray[np.int64],
    ground: NDArray[np.bool_],
    n_total: int,
    crs: str | None,
) -> CloudSample:
    origin = np.floor(xyz.min(0)) if len(xyz) else np.zeros(3)
    return CloudSample((xyz - origin).astype(np.float32), origin, inst, ground, n_total, crs)
