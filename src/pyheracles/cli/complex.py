"""``heracles complex``: step 1, GIS-aided segmentation of a heritage complex."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import typer

from pyheracles.cli.common import console, output_dir, print_counts, print_objects
from pyheracles.errors import InputError


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


def run_complex(
    cloud_path: Path,
    layer_specs: list[str],
    outdir: Path,
    *,
    params: Any,
    reproject: bool = False,
    fix_invalid: bool = False,
    cloud_crs: str | None = None,
    per_object: str | None = None,
) -> tuple[Any, dict[str, Path], Any]:
    """Read inputs, segment, write outputs; shared by ``complex``, ``demo`` and ``pipeline``."""
    from dataclasses import replace

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
            crs = CRS.from_user_input(cloud_crs)
        except Exception as exc:
            raise InputError(f"--cloud-crs {cloud_crs!r} is not a CRS ({exc})") from exc
        cloud = replace(cloud, crs=crs)
    layers = {}
    for spec in layer_specs:
        name, path, layer = parse_layer_spec(spec)
        if name in layers:
            raise InputError(
                f"layer name {name!r} given twice", hint="give each --layer its own NAME"
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
    return result, paths, timings


def register(app: typer.Typer) -> None:
    """Add ``heracles complex``."""

    @app.command("complex")
    def complex_cmd(
        cloud: Path = typer.Argument(..., help="Point cloud of the complex (LAS/LAZ/PLY/E57/XYZ)."),
        layer: list[str] = typer.Option(
            ...,
            "--layer",
            "-l",
            help="GIS layer as NAME=PATH[:LAYERNAME]; NAME becomes the class. Repeat per layer.",
        ),
        out: Path = typer.Option(..., "-o", "--out", help="Output folder."),
        ground: str = typer.Option("auto", help="Ground: auto|csf|smrf|class|none."),
        buffer: float = typer.Option(None, help="Cookie-cutter buffer, m (auto: from spacing)."),
        distance: float = typer.Option(None, help="Clustering distance, m (auto)."),
        min_points: int = typer.Option(None, help="Minimum cluster size, points (auto)."),
        order: str = typer.Option(
            None, help="Layer order, comma separated (auto: lowest objects first)."
        ),
        per_object: str = typer.Option(
            None, help="Also write one LAZ per object, named after this attribute."
        ),
        reproject: bool = typer.Option(False, help="Reproject layers into the cloud's CRS."),
        fix_invalid: bool = typer.Option(False, help="Repair invalid polygons (make_valid)."),
        cloud_crs: str = typer.Option(None, help="CRS of the cloud when its file has none."),
        force: bool = typer.Option(False, help="Write into a non-empty output folder."),
    ) -> None:
        """Split a complex into one object per GIS feature, plus ground and remainder.

        Example:

            heracles complex ahn3.laz -l building=bgt_pand.sqlite
            -l wall=bgt_scheiding.sqlite -o out/
        """
        from pyheracles.complex import ComplexParams
        from pyheracles.progress import enabled

        params = ComplexParams(
            buffer_m=buffer, cluster_distance_m=distance, min_cluster_points=min_points,
            ground=ground,
            layer_order=tuple(s.strip() for s in order.split(",")) if order else None,
        )  # fmt: skip
        with output_dir(out, force=force) as stage, enabled(console):
            result, paths, timings = run_complex(
                cloud, layer, stage, params=params, reproject=reproject,
                fix_invalid=fix_invalid, cloud_crs=cloud_crs, per_object=per_object,
            )  # fmt: skip
        paths = {k: out / v.relative_to(stage) for k, v in paths.items()}
        seg = result.segmentation
        print_objects(seg.objects, ["instance", "class", "source_fid", "n_points", "height"])
        print_counts(seg.counts(), timings, paths)
        for w in seg.warnings:
            console.print(f"[yellow]warning:[/] {w}")
