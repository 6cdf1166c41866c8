"""The multi-scalar run: step 1 on a complex, then step 2 on chosen objects, from one config file.

A configuration (YAML) names the complex cloud, its GIS layers and the output
folder, the step-1 parameters, and which objects go on to step 2 (supports,
beams) -- each step-2 result annotated with its GIS feature's attributes.

.. code-block:: yaml

    cloud: site.laz
    layers:
      building: footprints.gpkg:buildings     # NAME: PATH[:LAYERNAME]
      wall: walls.shp
    output: out/
    complex:                                  # ComplexParams fields (optional)
      ground: auto
    per_object: name                          # also one LAZ per object (optional)
    step2:                                    # optional
      - select: {class: building, min_height_m: 4, names: ["Pendopo"], name_field: name}
        step: supports                        # supports | beams
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pyheracles.cloud import PointCloud
from pyheracles.errors import InputError
from pyheracles.labels import Segmentation

__all__ = [
    "STEP2_KINDS",
    "PipelineConfig",
    "Step2Spec",
    "complex_from_files",
    "load_config",
    "parse_layer_spec",
    "run_pipeline",
]

#: Step-2 analyses a pipeline can run on selected objects.
STEP2_KINDS = ("supports", "beams")


@dataclass(frozen=True)
class Step2Spec:
    """Which step-1 objects go on to which step-2 analysis.

    Attributes
    ----------
    step
        ``supports`` (attic/body split and structural supports) or ``beams``.
    layer
        Class (layer name) of the objects to take; ``None`` for all.
    min_height_m
        Only objects at least this high above the ground, metres.
    names
        Only objects whose ``name_field`` attribute is in this list.
    name_field
        Attribute used by ``names`` and to name the output folders.
    """

    step: str
    layer: str | None = None
    min_height_m: float = 0.0
    names: tuple[str, ...] | None = None
    name_field: str = "instance"

    def __post_init__(self) -> None:
        if self.step not in STEP2_KINDS:
            raise InputError(
                f"unknown step-2 analysis {self.step!r}; choose one of {', '.join(STEP2_KINDS)}"
            )


@dataclass(frozen=True)
class PipelineConfig:
    """A whole run, as read from the YAML configuration."""

    cloud: Path
    layers: tuple[str, ...]
    output: Path
    complex: Any = None
    per_object: str | None = None
    step2: tuple[Step2Spec, ...] = field(default_factory=tuple)
    reproject: bool = False
    cloud_crs: str | None = None


def parse_layer_spec(spec: str) -> tuple[str, Path, str | None]:
    """``NAME=PATH[:LAYERNAME]`` -> (name, path, layer name or None)."""
    if "=" not in spec:
        raise InputError(
            f"--layer {spec!r} is not NAME=PATH[:LAYERNAME]",
            hint="write e.g. --layer building=footprints.gpkg:buildings",
        )
    name, rest = spec.split("=", 1)
    name = name.strip()
    if not name:
        raise InputError(f"--layer {spec!r} has no class name before '='")
    layer: str | None = None
    path = Path(rest)
    if not path.exists() and ":" in rest:
        head, tail = rest.rsplit(":", 1)
        if Path(head).exists():
            path, layer = Path(head), tail
    return name, path, layer


def load_config(path: str | Path) -> PipelineConfig:
    """Read and check a pipeline configuration; relative paths are relative to the file."""
    import yaml

    from pyheracles.complex import ComplexParams

    p = Path(path)
    if not p.is_file():
        raise InputError("configuration file not found", path=p)
    try:
        raw = yaml.safe_load(p.read_text(encoding="utf-8"))
    except yaml.YAMLError as exc:
        raise InputError(f"not valid YAML ({exc})", path=p) from exc
    if not isinstance(raw, dict):
        raise InputError("the configuration must be a mapping", path=p)
    missing = [k for k in ("cloud", "layers", "output") if k not in raw]
    if missing:
        raise InputError(f"missing keys: {', '.join(missing)}", path=p,
                         hint="see the example in the README")  # fmt: skip
    base = p.parent

    def resolve(value: str) -> str:
        return str(value) if Path(value).is_absolute() else str(base / value)

    if not isinstance(raw["layers"], dict) or not raw["layers"]:
        raise InputError("'layers' must map class names to PATH[:LAYERNAME]", path=p)
    layers = tuple(f"{name}={resolve(str(spec))}" for name, spec in raw["layers"].items())
    known = {f.name for f in fields(ComplexParams)}
    cparams = dict(raw.get("complex") or {})
    unknown = sorted(set(cparams) - known)
    if unknown:
        raise InputError(f"unknown complex parameters {unknown}; known: {sorted(known)}", path=p)
    if "layer_order" in cparams and cparams["layer_order"] is not None:
        cparams["layer_order"] = tuple(cparams["layer_order"])
    steps = []
    for item in raw.get("step2") or []:
        sel = dict(item.get("select") or {})
        names = sel.get("names")
        steps.append(
            Step2Spec(
                step=str(item.get("step", "supports")),
                layer=sel.get("class"),
                min_height_m=float(sel.get("min_height_m", 0.0)),
                names=tuple(map(str, names)) if names else None,
                name_field=str(sel.get("name_field", raw.get("per_object") or "instance")),
            )
        )
    return PipelineConfig(
        cloud=Path(resolve(raw["cloud"])),
        layers=layers,
        output=Path(resolve(raw["output"])),
        complex=ComplexParams(**cparams),
        per_object=raw.get("per_object"),
        step2=tuple(steps),
        reproject=bool(raw.get("reproject", False)),
        cloud_crs=raw.get("cloud_crs"),
    )


def complex_from_files(
    cloud_path: Path,
    layer_specs: Sequence[str],
    outdir: Path,
    *,
    params: Any = None,
    reproject: bool = False,
    fix_invalid: bool = False,
    cloud_crs: str | None = None,
    per_object: str | None = None,
) -> tuple[Any, dict[str, Path], dict[str, float], PointCloud]:
    """Step 1 from files to files: read, segment, write (``heracles complex``)."""
    from pyproj import CRS

    from pyheracles.complex import prepare_layers, segment_complex
    from pyheracles.io import read_cloud, read_layer
    from pyheracles.io.results import write_segmentation

    timings: dict[str, float] = {}
    t = time.perf_counter()
    cloud = read_cloud(cloud_path)
    notes: list[str] = []
    if cloud_crs is not None:
        try:
            cloud = replace(cloud, crs=CRS.from_user_input(cloud_crs))
        except Exception as exc:
            raise InputError(f"--cloud-crs {cloud_crs!r} is not a CRS ({exc})") from exc
    layers = {}
    for spec in layer_specs:
        name, path, layer = parse_layer_spec(spec)
        if name in layers:
            raise InputError(
                f"layer name {name!r} given twice", hint="give each layer its own NAME"
            )
        layers[name] = read_layer(path, layer)
    if cloud.crs is None:
        crs = next((g.crs for g in layers.values() if g.crs is not None), None)
        if crs is not None:
            notes.append(f"the cloud has no CRS; taken to be the layers' {crs.to_string()}")
            cloud = replace(cloud, crs=crs)
    layers = prepare_layers(layers, cloud, reproject=reproject, fix_invalid=fix_invalid)
    timings["read"] = time.perf_counter() - t
    result = segment_complex(cloud, layers, params)
    timings.update(result.timings)
    t = time.perf_counter()
    inputs = [cloud_path, *[parse_layer_spec(s)[1] for s in layer_specs]]
    paths = write_segmentation(
        cloud, result.segmentation, outdir, step="complex", parameters=result.params,
        inputs=inputs, timings=timings, per_object=per_object,
        extra={"spacing_m": result.spacing_m, "layer_order": list(result.layer_order),
               "notes": notes},
    )  # fmt: skip
    timings["write"] = time.perf_counter() - t
    return result, paths, timings, cloud


def select_objects(objects: pd.DataFrame, spec: Step2Spec) -> pd.DataFrame:
    """Rows of the step-1 objects table chosen by a :class:`Step2Spec`."""
    rows = objects
    if spec.layer is not None:
        rows = rows[rows["class"] == spec.layer]
    if spec.min_height_m > 0:
        rows = rows[rows["height"] >= spec.min_height_m]
    if spec.names is not None:
        if spec.name_field not in rows.columns:
            raise InputError(
                f"cannot select by {spec.name_field!r}: no such attribute",
                hint=f"attributes are {', '.join(map(str, objects.columns))}",
            )
        rows = rows[rows[spec.name_field].astype(str).isin(spec.names)]
    return rows


def _step2(kind: str, cloud: PointCloud) -> tuple[Segmentation, Any]:
    """Run one step-2 analysis on one object's cloud."""
    if kind == "supports":
        from pyheracles.building import objects_in_world, segment_building

        seg, _found, split, _ = segment_building(cloud.xyz, source=cloud.source)
        seg = replace(seg, objects=objects_in_world(seg.objects, cloud))
        return seg, {"attic_limit_z_levelled_m": split.limit_z}
    from pyheracles.framework import segment_beams

    result = segment_beams(cloud)
    return result.to_segmentation(cloud.offset), {"beams": len(result.beams)}


def _annotate(objects: pd.DataFrame, feature: Mapping[str, Any]) -> pd.DataFrame:
    """Add the GIS feature's attributes (prefixed ``gis_``) to every step-2 object."""
    out = objects.copy()
    for key, value in feature.items():
        if key == "geometry":
            continue
        out[f"gis_{key}"] = value if np.ndim(value) == 0 else str(value)
    return out


def run_pipeline(config: PipelineConfig, outdir: Path | None = None) -> dict[str, Any]:
    """Run step 1, then each step-2 analysis on its selected objects.

    Parameters
    ----------
    config
        The run (see :func:`load_config`).
    outdir
        Where to write (default ``config.output``): step 1 at the top level,
        step 2 in ``step2/<step>/<object name>/``.

    Returns
    -------
    dict
        ``complex`` (the step-1 result), ``step2`` (one summary row per object
        analysed), ``timings``.
    """
    from pyheracles.io.results import write_segmentation
    from pyheracles.progress import track

    out = Path(outdir or config.output)
    # Step 1: the complex -> one object per GIS feature
    result, paths, timings, cloud = complex_from_files(
        config.cloud, config.layers, out, params=config.complex, reproject=config.reproject,
        cloud_crs=config.cloud_crs, per_object=config.per_object,
    )  # fmt: skip
    seg = result.segmentation
    order = np.argsort(seg.instance, kind="stable")
    starts = np.searchsorted(seg.instance[order], np.arange(int(seg.instance.max()) + 2))
    summary: list[dict[str, Any]] = []
    # Step 2: each chosen object on its own, annotated with its feature's attributes
    for spec in config.step2:
        chosen = select_objects(seg.objects, spec)
        for _, row in track(list(chosen.iterrows()), f"step 2: {spec.step}"):
            inst = int(row["instance"])
            idx = order[starts[inst] : starts[inst + 1]]
            part = cloud.subset(idx)
            name = str(row.get(spec.name_field, inst))
            t = time.perf_counter()
            try:
                sub, info = _step2(spec.step, part)
            except InputError as exc:  # one object that cannot be analysed does not stop the run
                summary.append({"instance": inst, "name": name, "step": spec.step,
                                "status": f"skipped: {exc}"})  # fmt: skip
                continue
            sub = replace(sub, objects=_annotate(sub.objects, row.to_dict()))
            folder = out / "step2" / spec.step / _safe(name)
            write_segmentation(part, sub, folder, step=spec.step, inputs=[config.cloud],
                               timings={"step2": time.perf_counter() - t},
                               extra={"gis_feature": {k: v for k, v in row.to_dict().items()
                                                      if k != "geometry"}, **info})  # fmt: skip
            counts = sub.counts()
            summary.append({"instance": inst, "name": name, "step": spec.step, "status": "ok",
                            "n_points": counts["total"], "n_objects": counts["n_objects"],
                            "classes": sub.objects["class"].value_counts().to_dict()
                            if len(sub.objects) else {}})  # fmt: skip
    return {"complex": result, "paths": paths, "step2": summary, "timings": timings}


def _safe(name: str) -> str:
    import re

    return re.sub(r"[^A-Za-z0-9._-]+", "_", name).strip("._") or "object"
