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
    "safe_folder_name",
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


#: Keys of a configuration file and of its ``step2`` entries.
CONFIG_KEYS = ("cloud", "layers", "output", "complex", "per_object", "step2", "reproject",
               "cloud_crs")  # fmt: skip
STEP2_KEYS = ("select", "step")
#: ``select:`` keys and the :class:`Step2Spec` field each one sets.
SELECT_KEYS = {"class": "layer", "min_height_m": "min_height_m", "names": "names",
               "name_field": "name_field"}  # fmt: skip


def _unknown(key: object, known: Sequence[str], where: str) -> str:
    """``unknown key 'complx' at the top level (did you mean 'complex'?)``."""
    import difflib

    close = difflib.get_close_matches(str(key), list(known), n=1)
    guess = f"did you mean {close[0]!r}?" if close else f"known keys: {', '.join(known)}"
    return f"unknown key {str(key)!r} {where} ({guess})"


def _describe(hint: Any) -> str:
    """A type annotation in words: ``a number``, ``text or null`` ..."""
    import types
    import typing

    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if origin in (typing.Union, types.UnionType):
        parts = [_describe(a) for a in args if a is not type(None)]
        return " or ".join(parts) + (" or null" if type(None) in args else "")
    if origin is tuple:
        return f"a list of {_describe(args[0]).removeprefix('a ')}s" if args else "a list"
    return {float: "a number", int: "a whole number", bool: "true or false",
            str: "text"}.get(hint, getattr(hint, "__name__", str(hint)))  # fmt: skip


def check_value(value: Any, hint: Any, where: str) -> tuple[Any, str | None]:
    """``value`` read from YAML, converted to the annotation ``hint``, or a problem.

    Returns ``(converted, None)`` or ``(value, "where: expected a number, got 'two'")``.
    Numbers must be finite, booleans are not numbers, whole floats are accepted as ints.
    """
    import types
    import typing

    origin, args = typing.get_origin(hint), typing.get_args(hint)
    bad = f"{where}: expected {_describe(hint)}, got {value!r}"
    if hint is Any:
        return value, None
    if origin in (typing.Union, types.UnionType):
        if value is None and type(None) in args:
            return None, None
        for arg in (a for a in args if a is not type(None)):
            out, problem = check_value(value, arg, where)
            if problem is None:
                return out, None
        return value, bad
    if origin is tuple:
        if not isinstance(value, list | tuple):
            return value, bad
        elem = args[0] if args else Any
        items = [check_value(v, elem, f"{where}[{i}]") for i, v in enumerate(value)]
        problems = [p for _, p in items if p]
        return (tuple(v for v, _ in items), None) if not problems else (value, problems[0])
    if hint is bool:
        return (value, None) if isinstance(value, bool) else (value, bad)
    if hint in (float, int):
        if isinstance(value, bool) or not isinstance(value, int | float):
            return value, bad
        if not np.isfinite(value):
            return value, f"{where}: expected a finite number, got {value!r}"
        if hint is int:
            if float(value) != int(value):
                return value, bad
            return int(value), None
        return float(value), None
    if hint is str:
        return (value, None) if isinstance(value, str) else (value, bad)
    return value, None


def _check_fields(cls: type, values: Mapping[str, Any], where: str, problems: list[str]) -> Any:
    """Type-check ``values`` against the dataclass ``cls`` and build it (None on problems)."""
    import typing

    hints = typing.get_type_hints(cls)
    known = [f.name for f in fields(cls)]
    kwargs: dict[str, Any] = {}
    ok = True
    for key, value in values.items():
        if key not in known:
            problems.append(_unknown(key, known, f"in {where}"))
            ok = False
            continue
        out, problem = check_value(value, hints[key], f"{where}.{key}")
        if problem:
            problems.append(problem)
            ok = False
        kwargs[key] = out
    if not ok:
        return None
    try:
        return cls(**kwargs)
    except (InputError, ValueError, TypeError) as exc:  # the dataclass's own range checks
        problems.append(f"{where}: {exc}")
        return None


def _check_step2(raw: Any, per_object: Any, problems: list[str]) -> list[Step2Spec]:
    """The ``step2:`` list, every entry and ``select:`` key checked."""
    import typing

    if raw is None:
        return []
    if not isinstance(raw, list):
        problems.append(
            f"step2: expected a list of entries ('- select: {{...}}' then 'step: supports'), "
            f"got {type(raw).__name__ if not isinstance(raw, dict) else 'a mapping'}"
        )
        return []
    hints = typing.get_type_hints(Step2Spec)
    steps: list[Step2Spec] = []
    for i, item in enumerate(raw):
        where = f"step2[{i}]"
        if not isinstance(item, dict):
            problems.append(f"{where}: expected a mapping with 'select' and 'step', got {item!r}")
            continue
        ok = True
        for key in item:
            if key not in STEP2_KEYS:
                problems.append(_unknown(key, STEP2_KEYS, f"in {where}"))
                ok = False
        step = item.get("step", "supports")
        if not isinstance(step, str) or step not in STEP2_KINDS:
            problems.append(f"{where}.step: expected one of {', '.join(STEP2_KINDS)}, got {step!r}")
            ok = False
        sel = item.get("select") or {}
        if not isinstance(sel, dict):
            problems.append(f"{where}.select: expected a mapping of {', '.join(SELECT_KEYS)}, "
                            f"got {sel!r}")  # fmt: skip
            continue
        kwargs: dict[str, Any] = {"step": step}
        for key, value in sel.items():
            if key not in SELECT_KEYS:
                problems.append(_unknown(key, list(SELECT_KEYS), f"in {where}.select"))
                ok = False
                continue
            name = SELECT_KEYS[key]
            if name == "names" and isinstance(value, str | int) and not isinstance(value, bool):
                value = [value]  # one name
            if name == "names" and isinstance(value, list):  # numeric ids are names too
                value = [str(v) if isinstance(v, int) and not isinstance(v, bool) else v
                         for v in value]  # fmt: skip
            out, problem = check_value(value, hints[name], f"{where}.select.{key}")
            if problem:
                problems.append(problem)
                ok = False
            kwargs[name] = out
        if isinstance(kwargs.get("min_height_m"), float) and kwargs["min_height_m"] < 0:
            problems.append(f"{where}.select.min_height_m: must be >= 0 metres, "
                            f"got {kwargs['min_height_m']}")  # fmt: skip
            ok = False
        if kwargs.get("names") == ():
            problems.append(f"{where}.select.names: the list is empty (leave it out for all)")
            ok = False
        kwargs.setdefault("name_field", str(per_object or "instance"))
        if ok:
            steps.append(Step2Spec(**kwargs))
    return steps


def load_config(path: str | Path) -> PipelineConfig:
    """Read and check a pipeline configuration; relative paths are relative to the file.

    The whole file is checked before any work: unknown keys (with the closest valid
    one), value types against the parameter dataclasses (the key path named), the
    ``step2`` entries, the cloud CRS; all problems are reported in one
    :class:`InputError`.
    """
    import yaml

    from pyheracles.complex import ComplexParams

    p = Path(path)
    if not p.is_file():
        raise InputError("configuration file not found", path=p)
    try:
        raw = yaml.safe_load(p.read_text(encoding="utf-8"))
    except yaml.YAMLError as exc:
        raise InputError(f"not valid YAML ({exc})", path=p) from exc
    except UnicodeDecodeError as exc:
        raise InputError(f"not a text file ({exc.reason})", path=p) from exc
    if not isinstance(raw, dict):
        raise InputError("the configuration must be a mapping", path=p,
                         hint="see the example in the README")  # fmt: skip
    problems: list[str] = []
    for key in raw:
        if key not in CONFIG_KEYS:
            problems.append(_unknown(key, CONFIG_KEYS, "at the top level"))
    missing = [k for k in ("cloud", "layers", "output") if k not in raw]
    if missing:
        problems.append(f"missing keys: {', '.join(missing)}")
    base = p.parent

    def resolve(value: str) -> str:
        return str(value) if Path(value).is_absolute() else str(base / value)

    for key in ("cloud", "output", "per_object", "cloud_crs"):
        if key in raw and raw[key] is not None and not isinstance(raw[key], str):
            problems.append(f"{key}: expected text, got {raw[key]!r}")
    for key in ("cloud", "output"):
        if key in raw and raw[key] is None:
            problems.append(f"{key}: no value given")
    if "reproject" in raw and not isinstance(raw["reproject"], bool):
        problems.append(f"reproject: expected true or false, got {raw['reproject']!r}")
    layers: tuple[str, ...] = ()
    if "layers" in raw:
        if not isinstance(raw["layers"], dict) or not raw["layers"]:
            problems.append("layers: must map class names to PATH[:LAYERNAME]")
        else:
            for name, spec in raw["layers"].items():
                if not isinstance(spec, str):
                    problems.append(f"layers.{name}: expected PATH[:LAYERNAME], got {spec!r}")
            layers = tuple(f"{name}={resolve(str(spec))}" for name, spec in raw["layers"].items())
    if isinstance(raw.get("cloud_crs"), str):
        from pyproj import CRS
        from pyproj.exceptions import CRSError

        try:
            CRS.from_user_input(raw["cloud_crs"])
        except CRSError as exc:
            problems.append(f"cloud_crs: {raw['cloud_crs']!r} is not a CRS ({exc})")
    cparams = raw.get("complex") or {}
    complex_params = None
    if not isinstance(cparams, dict):
        problems.append(f"complex: expected a mapping of ComplexParams fields, got {cparams!r}")
    else:
        complex_params = _check_fields(ComplexParams, cparams, "complex", problems)
    steps = _check_step2(raw.get("step2"), raw.get("per_object"), problems)
    if problems:
        head = "1 problem" if len(problems) == 1 else f"{len(problems)} problems"
        raise InputError(f"{head} in the configuration: {'; '.join(problems)}", path=p,
                         hint="see the example in the README")  # fmt: skip
    return PipelineConfig(
        cloud=Path(resolve(raw["cloud"])),
        layers=layers,
        output=Path(resolve(raw["output"])),
        complex=complex_params,
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
        else:
            notes.append(
                "neither the cloud nor the layers have a CRS: they are taken to be in the "
                "same coordinates (give --cloud-crs, or a CRS to the layers, to check it)"
            )
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
    from pyheracles.beams import segment_beams

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
    # which objects each step-2 entry takes; names that match nothing are reported
    chosen_by, warnings = _selections(seg.objects, config.step2)
    if warnings:
        _add_warnings(paths.get("run", out / "run.json"), warnings)
    # Step 2: each chosen object on its own, annotated with its feature's attributes
    for spec, chosen in zip(config.step2, chosen_by, strict=True):
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
            folder = out / "step2" / spec.step / safe_folder_name(name)
            write_segmentation(part, sub, folder, step=spec.step, inputs=[config.cloud],
                               timings={"step2": time.perf_counter() - t},
                               extra={"gis_feature": {k: v for k, v in row.to_dict().items()
                                                      if k != "geometry"}, **info})  # fmt: skip
            counts = sub.counts()
            summary.append({"instance": inst, "name": name, "step": spec.step, "status": "ok",
                            "n_points": counts["total"], "n_objects": counts["n_objects"],
                            "classes": sub.objects["class"].value_counts().to_dict()
                            if len(sub.objects) else {}})  # fmt: skip
    return {"complex": result, "paths": paths, "step2": summary, "timings": timings,
            "warnings": warnings}  # fmt: skip


def _selections(
    objects: pd.DataFrame, specs: Sequence[Step2Spec]
) -> tuple[list[pd.DataFrame], list[str]]:
    """The objects each step-2 entry selects, and warnings for names that match nothing.

    Raises
    ------
    InputError
        There are step-2 entries but none selects any object.
    """
    chosen_by = [select_objects(objects, spec) for spec in specs]
    warnings: list[str] = []
    for i, (spec, chosen) in enumerate(zip(specs, chosen_by, strict=True)):
        if spec.names is None:
            continue
        found = set(chosen[spec.name_field].astype(str)) if len(chosen) else set()
        missing = [n for n in spec.names if n not in found]
        if missing:
            tall = f" at least {spec.min_height_m:g} m high" if spec.min_height_m else ""
            warnings.append(
                f"step2[{i}]: names {missing} match no {spec.layer or 'object'}{tall} "
                f"(by {spec.name_field!r}); they are skipped"
            )
    if specs and not any(len(c) for c in chosen_by):
        what = "; ".join(
            f"step2[{i}]: class {s.layer or 'any'}, min_height_m {s.min_height_m:g}"
            + (f", names {list(s.names)}" if s.names else "")
            for i, s in enumerate(specs)
        )
        field_ = specs[0].name_field
        known = (
            sorted(map(str, objects[field_].dropna().unique()))[:20]
            if field_ in objects.columns else []
        )  # fmt: skip
        classes = sorted(map(str, objects["class"].unique())) if len(objects) else []
        raise InputError(
            f"step 2 selects no object of the {len(objects)} found by step 1 ({what})",
            hint=f"check the selection: classes are {', '.join(classes) or 'none'}"
            + (f"; {field_!r} values include {', '.join(known)}" if known else ""),
        )
    return chosen_by, warnings


def _add_warnings(run_json: Path, warnings: Sequence[str]) -> None:
    """Append warnings found after step 1 to its ``run.json`` (shown by the CLI)."""
    from pyheracles.provenance import add_to_run_json

    add_to_run_json(run_json, "warnings", warnings)


def safe_folder_name(name: str) -> str:
    import re

    return re.sub(r"[^A-Za-z0-9._-]+", "_", name).strip("._") or "object"
