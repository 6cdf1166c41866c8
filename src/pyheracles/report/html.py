"""``report.html``: one self-contained page per output folder (opens offline, prints well).

What ran with which parameters (automatic values marked), the point balance,
warnings, the sortable objects table, the figures (plan with every object
named, the step's own pictures, F1 per object when a reference was given, the
DTM as a hillshade), an interactive 3D view of the labelled cloud with its
fitted primitives, surfaces and check point residuals, and the provenance.
Built from a jinja2 template; the 3D viewer (a small hand-written WebGL
script, see :mod:`pyheracles.report.view3d`) and every picture are embedded,
so the file needs nothing else (no CDN).
"""

from __future__ import annotations

import base64
import dataclasses
import functools
import io
import json
import sys
import time
from importlib import import_module
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pyheracles.io.atomic import atomic_write_text
from pyheracles.report.colours import hex_colour, object_colours
from pyheracles.report.folder import RunFolder, read_run_folder, sample_cloud
from pyheracles.report.overview import name_column, object_name

__all__ = ["REPORT_HTML", "auto_fields_from_source", "build_report"]

REPORT_HTML = "report.html"

#: Parameter dataclass of each step: fields whose default is None are automatic.
PARAMS_OF_STEP = {
    "complex": "pyheracles.complex:ComplexParams",
    "supports": "pyheracles.supports:SupportParams",
    "beams": "pyheracles.beams:BeamParams",
    "framework": "pyheracles.beams:BeamParams",
}
#: Columns that name an object, in order of preference.


def _auto_fields(step: str) -> set[str]:
    """Fields of the step's parameter dataclass whose default is None (measured from the data).

    Read from the already imported class when the step ran in this process;
    otherwise from the module's source (``ast``), which spares ``heracles report``
    importing the whole step (scipy and all) only to mark its automatic values.
    """
    spec = PARAMS_OF_STEP.get(step)
    if spec is None:
        return set()
    mod, cls = spec.split(":")
    params = getattr(sys.modules.get(mod), cls, None)
    if params is None or not dataclasses.is_dataclass(params):
        found = auto_fields_from_source(mod, cls)
        if found is not None:
            return found
        try:
            params = getattr(import_module(mod), cls)
        except (ImportError, AttributeError):
            return set()
    return {f.name for f in dataclasses.fields(params) if f.default is None}


def _module_file(mod: str) -> Path | None:
    import pyheracles

    parts = mod.split(".")
    if parts[0] != "pyheracles":
        return None
    base = Path(pyheracles.__file__).parent.joinpath(*parts[1:])
    for f in (base.with_suffix(".py"), base / "__init__.py"):
        if f.is_file():
            return f
    return None


def auto_fields_from_source(mod: str, cls: str, depth: int = 3) -> set[str] | None:
    """Annotated fields of class ``cls`` defaulting to None, from source; None if not found."""
    import ast

    path = _module_file(mod)
    if path is None or depth < 0:
        return None
    try:
        tree = ast.parse(path.read_text(encoding="utf-8"))
    except (OSError, SyntaxError):
        return None
    for node in tree.body:
        if isinstance(node, ast.ClassDef) and node.name == cls:
            out = set()
            for st in node.body:
                if not (isinstance(st, ast.AnnAssign) and isinstance(st.target, ast.Name)):
                    continue
                v = st.value
                if (
                    isinstance(v, ast.Call)
                    and getattr(v.func, "id", getattr(v.func, "attr", "")) == "field"
                ):
                    v = next((k.value for k in v.keywords if k.arg == "default"), None)
                    if v is None:
                        continue
                if isinstance(v, ast.Constant) and v.value is None:
                    out.add(st.target.id)
            return out
    package = mod if path.name == "__init__.py" else mod.rsplit(".", 1)[0]
    for node in tree.body:
        if isinstance(node, ast.ImportFrom) and any(a.name == cls for a in node.names):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - node.level + 1]
                src = ".".join(base + ([node.module] if node.module else []))
            else:
                src = node.module or ""
            return auto_fields_from_source(src, cls, depth - 1)
    return None


def _flatten(d: dict[str, Any], prefix: str = "") -> list[tuple[str, Any]]:
    out: list[tuple[str, Any]] = []
    for k, v in d.items():
        key = f"{prefix}{k}"
        if isinstance(v, dict):
            out += _flatten(v, key + ".")
        else:
            out.append((key, v))
    return out


def _parameters(run: dict[str, Any], step: str) -> list[dict[str, Any]]:
    auto = _auto_fields(step)
    rows = []
    params = run.get("parameters") or {}
    for key, value in _flatten(params if isinstance(params, dict) else {"value": params}):
        leaf = key.split(".")[-1]
        rows.append({"name": key, "value": _fmt(value), "auto": leaf in auto})
    return rows


def _fmt(v: Any) -> str:
    if isinstance(v, float):
        return "NaN" if not np.isfinite(v) else f"{v:.4g}"
    if isinstance(v, list | tuple):
        return ", ".join(_fmt(x) for x in v[:12]) + (" ..." if len(v) > 12 else "")
    return "" if v is None else str(v)


def _labels(
    objects: pd.DataFrame | None,
) -> tuple[dict[int, str], dict[int, list[list[str]]], dict[int, str]]:
    """Instance -> display name, -> ``[[attribute, value], ...]``, -> class."""
    if objects is None or "instance" not in objects:
        return {}, {}, {}
    col = name_column(objects)
    names: dict[int, str] = {}
    attrs: dict[int, list[list[str]]] = {}
    classes: dict[int, str] = {}
    for row in objects.to_dict("records"):
        try:
            i = int(row["instance"])
        except (TypeError, ValueError):
            continue
        cls = row.get("class")
        cls = "object" if cls is None or str(cls) in ("", "nan") else str(cls)
        names[i] = object_name(row, col)
        classes[i] = cls
        pairs = [["instance", str(i)]]
        for k, v in list(row.items())[:24]:
            if (
                k in ("instance", "geometry")
                or v is None
                or (isinstance(v, float) and not np.isfinite(v))
            ):
                continue
            pairs.append([str(k), _fmt(v)])
        attrs[i] = pairs
    return names, attrs, classes


def _png_data_uri(path_or_bytes: Path | bytes) -> str:
    data = path_or_bytes.read_bytes() if isinstance(path_or_bytes, Path) else path_or_bytes
    return "data:image/png;base64," + base64.b64encode(data).decode("ascii")


def _fig_png(fig: Any) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    import matplotlib.pyplot as plt

    plt.close(fig)
    return buf.getvalue()


def _f1_svg(ev: pd.DataFrame) -> str | None:
    if "f1" not in ev or "object" not in ev:
        return None
    bars = ev[pd.to_numeric(ev["f1"], errors="coerce").notna()]
    bars = bars[~bars["object"].astype(str).isin(["mean", "median"])]
    if bars.empty:
        return None
    from pyheracles.report.charts import bar_chart_svg

    return bar_chart_svg(
        bars["object"].astype(str).tolist(),
        bars["f1"].astype(float).tolist(),
        target=0.95,
        target_label="target F1 = 0.95",
        xlabel="F1 per object against the reference (orange: below the target)",
    )


def _hillshade(path: Path) -> bytes | None:
    try:
        import rasterio
    except ImportError:  # pragma: no cover - rasterio is a dependency
        return None
    with rasterio.open(path) as src:
        z = src.read(1).astype(float)
        nodata = src.nodata
        res = src.res
    if nodata is not None:
        z[z == nodata] = np.nan
    gy, gx = np.gradient(z, res[1], res[0])
    az, alt = np.deg2rad(315), np.deg2rad(45)
    slope = np.arctan(np.hypot(gx, gy))
    aspect = np.arctan2(-gx, gy)
    shade = np.sin(alt) * np.cos(slope) + np.cos(alt) * np.sin(slope) * np.cos(az - aspect)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 6.5))
    ax.imshow(shade, cmap="gray", interpolation="nearest")
    im = ax.imshow(z, cmap="terrain", alpha=0.45, interpolation="nearest")
    fig.colorbar(im, ax=ax, label="ground height (m)", shrink=0.8)
    ax.set_title(f"DTM hillshade ({res[0]:.2f} m cells)")
    ax.set_axis_off()
    fig.tight_layout()
    return _fig_png(fig)


def _table(
    df: pd.DataFrame, colours: dict[int, str] | None = None, limit: int = 5000
) -> dict[str, Any]:
    cols = [c for c in df.columns if c != "geometry"]
    rows = []
    for rec in df.head(limit).to_dict("records"):
        cells = []
        for c in cols:
            v = rec[c]
            num = isinstance(v, int | float | np.number) and not isinstance(v, bool)
            cells.append(
                {
                    "text": _fmt(v)
                    if not isinstance(v, float) or not num
                    else ("NaN" if not np.isfinite(v) else f"{v:.3f}"),
                    "num": bool(num),
                }
            )
        swatch = None
        if colours is not None and "instance" in rec:
            try:
                swatch = colours.get(int(rec["instance"]))
            except (TypeError, ValueError):
                swatch = None
        rows.append({"cells": cells, "swatch": swatch})
    return {
        "columns": cols,
        "rows": rows,
        "truncated": max(0, len(df) - limit),
        "swatches": colours is not None,
    }


@functools.lru_cache(maxsize=1)
def _template() -> Any:
    """The page template, compiled once per process."""
    import jinja2

    env = jinja2.Environment(
        loader=jinja2.PackageLoader("pyheracles.report", "templates"),
        autoescape=jinja2.select_autoescape(["html", "j2"]),
    )
    return env.get_template("report.html.j2")


@functools.lru_cache(maxsize=1)
def _viewer_js() -> str:
    """The viewer's JavaScript (plain JS; named .j2 so that it is packaged with the templates)."""
    from importlib.resources import files

    return files("pyheracles.report").joinpath("templates", "view3d.js.j2").read_text("utf-8")


def build_report(outdir: str | Path, *, max_points: int = 300_000, seed: int = 0) -> Path:
    """Write ``report.html`` into an output folder of a ``heracles`` command and return it.

    Parameters
    ----------
    outdir
        A folder with a ``run.json`` (and whatever else the step wrote).
    max_points
        Points in the 3D view at most (every object keeps at least 300).
    seed
        Seed of the subsampling.

    Raises
    ------
    InputError
        When the folder is not an output folder.
    """
    t0 = time.perf_counter()
    folder: RunFolder = read_run_folder(outdir)
    run = folder.run
    names, attrs, classes = _labels(folder.objects)
    figures: list[dict[str, str]] = []
    crs = None
    warnings = [str(w) for w in (run.get("warnings") or [])]
    notes = [str(n) for n in (run.get("notes") or [])]
    if run.get("note"):
        notes.append(str(run["note"]))
    colours: dict[int, str] = {}
    sample = None
    if folder.cloud is not None:
        sample = sample_cloud(folder.cloud, max_points=max_points, seed=seed)
        crs = sample.crs
        ids = [int(i) for i in np.unique(sample.instance) if i > 0]
        if folder.objects is not None and "instance" in folder.objects:
            ids = sorted(set(ids) | {int(i) for i in folder.objects["instance"].dropna()})
        cols = object_colours(max(ids, default=0))
        colours = {i: hex_colour(cols[i - 1]) for i in ids}
        if ids:
            from pyheracles.report.plan import plan_svg

            missing = [w for w in warnings if "no points" in w]
            svg = plan_svg(
                sample,
                names,
                footprints=folder.footprints,
                missing=missing,
                title=f"{folder.step}: {folder.path.name}",
            )
            figures.append({"title": "Plan: every object in its own colour, named", "svg": svg})
    from pyheracles.report.view3d import folder_scene

    view = folder_scene(folder, sample, names, attrs, classes)
    view_points = 0 if sample is None else len(sample.xyz)
    view_total = 0 if sample is None else sample.n_total
    for img in folder.images:
        figures.append({"title": img.stem.replace("_", " "), "src": _png_data_uri(img)})
    ev = folder.tables.get("evaluation.csv")
    if ev is not None:
        svg = _f1_svg(ev)
        if svg:
            figures.append({"title": "F1 per object", "svg": svg})
    dtm = folder.path / "dtm.tif"
    if dtm.is_file():
        png = _hillshade(dtm)
        if png:
            figures.append({"title": "Terrain model (DTM)", "src": _png_data_uri(png)})
    counts = run.get("counts") or {}
    balance = None
    if {"objects", "ground", "remainder", "total"} <= set(counts):
        balance = counts["objects"] + counts["ground"] + counts["remainder"] == counts["total"]
    tables = [{"title": n, **_table(df)} for n, df in folder.tables.items()]
    objects = folder.objects
    images = (folder.documents.get("report.json") or {}).get("images")
    if objects is None and isinstance(images, list) and images:
        # a bundle adjustment's objects are its images
        objects = pd.DataFrame(
            [{k: v for k, v in im.items() if not isinstance(v, dict | list)} for im in images]
        )
    summary = {
        k: v
        for k, v in (folder.documents.get("report.json") or {}).items()
        if isinstance(v, int | float | str) and not isinstance(v, bool)
    }
    page = _template().render(
        title=f"heracles {folder.step}: {folder.path.name}",
        run=run,
        step=folder.step,
        command=" ".join(map(str, run.get("command") or [])),
        parameters=_parameters(run, folder.step),
        counts=counts,
        balance=balance,
        warnings=warnings,
        notes=notes,
        objects=None if objects is None else _table(objects, colours),
        objects_title="Images" if folder.objects is None and objects is not None else "Objects",
        view_what="camera stations" if sample is None else "points",
        figures=figures,
        tables=tables,
        summary=summary,
        # "</" escaped so that no name can close the script element
        view_json=None
        if view is None
        else json.dumps(view, separators=(",", ":")).replace("</", "<\\/"),
        view_js=_viewer_js() if view is not None else "",
        view_points=view_points,
        view_total=view_total,
        view_overlays=[]
        if view is None
        else [o["name"] for k in ("meshes", "lines", "markers") for o in view[k]],
        crs=crs,
        inputs=run.get("inputs") or [],
        timings=run.get("timings_s") or {},
        build_s=time.perf_counter() - t0,
    )
    return atomic_write_text(folder.path / REPORT_HTML, page)
