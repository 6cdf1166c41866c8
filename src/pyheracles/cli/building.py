"""``heracles attic`` and ``heracles supports``: step 2a on one building cloud."""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Annotated, Any

import typer

__all__ = ["register"]

_ATTIC_HELP = "\n\n".join(
    [
        "Split one building cloud into attic and body (thesis ch. 6.2, MATLAB atticsegment).",
        "Horizontal slices every --interval metres, --thickness thick; the attic starts where "
        "the convex hull area of consecutive slices changes by more than --area-change "
        "(thesis: 0.2 m, 5 cm, 10 %). 'No attic' when there is none. Millimetre clouds are "
        "rescaled and tilted clouds levelled (reported as notes).",
        "Writes into OUTDIR: segmented.laz (every input point in input order, extra "
        "dimensions instance and class_id: 1 body, 2 attic), objects.csv / objects.gpkg and "
        "run.json.",
        "Examples:",
        "  heracles attic pavilion.laz -o out/attic",
        "  heracles attic chapel.ply --area-change 0.15 -o out/attic",
    ]
)

_SUPPORTS_HELP = "\n\n".join(
    [
        "Find the structural supports of one building cloud: columns, piers and engaged "
        "columns (thesis ch. 6.2, MATLAB supportdetect), after removing the attic.",
        "The cross-section height is chosen automatically where support islands are most "
        "numerous and stable (below capitals, away from fences); --section-height forces it "
        "(metres above the lowest body point). Columns vs piers by hull circularity "
        "(thesis: 1.12) and a circle-versus-rectangle fit test; each support gets a fitted "
        "cylinder (radius, axis, height, RMS) or oriented box (length, width, height, RMS).",
        "Writes into OUTDIR: segmented.laz (instance + class_id: 1 body, 2 attic, 3 column, "
        "4 pier, 5 engaged_column), objects.gpkg (with a CRS; support axes as points) or "
        "objects.csv, run.json; with --per-object one LAZ per support.",
        "Examples:",
        "  heracles supports hall.laz -o out/supports",
        "  heracles supports choir.laz --section-height 4.2 -o out/supports",
        "  heracles supports scan_mm.e57 --units mm --no-attic -o out/supports",
    ]
)


def _input_height(z_levelled: float | None, prepared: Any, z_offset: float) -> float | None:
    """A height of the prepared (levelled, metre) frame as z of the input frame (world,
    input units) at the cloud's centre; None for None / NaN."""
    import numpy as np

    from pyheracles.building import to_input_frame

    if z_levelled is None or not np.isfinite(z_levelled):
        return None
    q = np.r_[prepared.centre[:2], float(z_levelled)]
    return float(to_input_frame(q, prepared)[0, 2]) + z_offset


def _height_text(z_levelled: float | None, prepared: Any, z_offset: float) -> str | None:
    """``z = 102.18 m (input frame), 2.18 m above the lowest point``; None without one.

    One convention for every height the step-2 commands print: z in the input file's
    frame and units, and the height above the lowest point (the same in the levelled
    frame of the computation and in the input frame; the frame of ``--section-height``
    and of the notes).
    """
    z_in = _input_height(z_levelled, prepared, z_offset)
    if z_in is None or z_levelled is None:
        return None
    unit = "m" if prepared.scale_to_m == 1.0 else "mm" if prepared.scale_to_m == 1e-3 else ""
    above = float(z_levelled) - float(prepared.xyz[:, 2].min())
    return f"z = {z_in:.2f} {unit} (input frame), {above:.2f} m above the lowest point"


def _summary(title: str, seg: Any, extra_rows: list[tuple[str, str]], timings: dict) -> None:
    from rich.table import Table

    from pyheracles.cli.common import console, print_objects

    cols = ["instance", "class", "n_points", "x", "y", "height_m", "radius_m", "box_length_m",
            "box_width_m", "fit_rms_m"]  # fmt: skip
    print_objects(seg.objects, cols)
    table = Table(title=title, show_header=False)
    for k, v in extra_rows:
        table.add_row(k, v)
    c = seg.counts()
    table.add_row("points", f"{c['total']:,} (objects {c['objects']:,}, rest {c['remainder']:,})")
    table.add_row("time", ", ".join(f"{k} {v:.1f} s" for k, v in timings.items()))
    console.print(table)


def register(app: typer.Typer) -> None:
    """Add the ``attic`` and ``supports`` subcommands to ``app``."""

    @app.command("attic", help=_ATTIC_HELP)
    def attic_command(
        cloud_path: Annotated[Path, typer.Argument(metavar="CLOUD", help="Building cloud file.")],
        outdir: Annotated[Path, typer.Option("-o", "--out", "--outdir", help="Output folder.")],
        interval_m: Annotated[
            float, typer.Option("--interval", help="Slice interval, metres (thesis 0.2).")
        ] = 0.2,
        thickness_m: Annotated[
            float, typer.Option("--thickness", help="Slice thickness, metres (thesis 0.05).")
        ] = 0.05,
        area_change: Annotated[
            float, typer.Option("--area-change", help="Relative hull area change (thesis 0.1).")
        ] = 0.10,
        units: Annotated[str, typer.Option("--units", help="auto, m or mm.")] = "auto",
        force: Annotated[bool, typer.Option("--force", help="Write into a non-empty folder.")] = (
            False
        ),
    ) -> None:
        from dataclasses import asdict, replace

        from pyheracles import progress
        from pyheracles.building import (
            AtticParams,
            BuildingParams,
            objects_in_world,
            segment_attic,
        )
        from pyheracles.cli.common import console, output_dir, print_run_warnings
        from pyheracles.errors import InputError
        from pyheracles.io import read_cloud
        from pyheracles.io.results import write_segmentation

        prep = BuildingParams(units=units)  # checks --units before any work
        try:
            params = AtticParams(interval_m=interval_m, thickness_m=thickness_m,
                                 area_change=area_change)  # fmt: skip
            params.slices()
        except ValueError as exc:
            raise InputError(str(exc)) from exc
        timings: dict[str, float] = {}
        with output_dir(outdir, force=force) as stage, progress.enabled(console):
            t = time.perf_counter()
            with progress.stage(f"reading {cloud_path.name}"):
                cloud = read_cloud(cloud_path).validate(what=f"point cloud {cloud_path}")
            timings["read"] = time.perf_counter() - t
            t = time.perf_counter()
            with progress.stage("attic / body split"):
                seg, split, prepared = segment_attic(
                    cloud.xyz, params, prep, source=str(cloud_path)
                )
            timings["attic"] = time.perf_counter() - t
            t = time.perf_counter()
            seg = replace(seg, objects=objects_in_world(seg.objects, cloud))
            z_offset = float(cloud.offset[2])
            write_segmentation(
                cloud, seg, stage, step="attic",
                parameters={"attic": asdict(params), "units": units},
                inputs=[cloud_path], timings=timings,
                extra={"limit_z_levelled_m": split.limit_z,
                       "limit_z_input": _input_height(split.limit_z, prepared, z_offset),
                       "tilt_deg": prepared.tilt_deg,
                       "scale_to_m": prepared.scale_to_m,
                       "slice_heights_m": split.profile.heights.tolist(),
                       "slice_areas_m2": split.profile.areas.tolist()},
            )  # fmt: skip
            timings["write"] = time.perf_counter() - t
            print_run_warnings(stage)
        limit = _height_text(split.limit_z, prepared, z_offset) or "no attic"
        _summary(f"heracles attic: {cloud_path.name}", seg,
                 [("attic limit", limit), ("output", str(outdir))], timings)  # fmt: skip

    @app.command("supports", help=_SUPPORTS_HELP)
    def supports_command(
        cloud_path: Annotated[Path, typer.Argument(metavar="CLOUD", help="Building cloud file.")],
        outdir: Annotated[Path, typer.Option("-o", "--out", "--outdir", help="Output folder.")],
        section_height_m: Annotated[
            float | None,
            typer.Option("--section-height", help="Section height above the body bottom, m."),
        ] = None,
        circularity_max: Annotated[
            float, typer.Option("--circularity", help="Largest column circularity (thesis 1.12).")
        ] = 1.12,
        no_attic: Annotated[
            bool, typer.Option("--no-attic", help="Do not remove an attic first.")
        ] = False,
        no_engaged: Annotated[
            bool, typer.Option("--no-engaged", help="Do not look for engaged columns.")
        ] = False,
        units: Annotated[str, typer.Option("--units", help="auto, m or mm.")] = "auto",
        per_object: Annotated[
            bool, typer.Option("--per-object", help="Also write one LAZ per object.")
        ] = False,
        ifc: Annotated[
            bool, typer.Option("--ifc", help="Also write model.ifc (IFC 4; needs the bim extra).")
        ] = False,
        force: Annotated[bool, typer.Option("--force", help="Write into a non-empty folder.")] = (
            False
        ),
    ) -> None:
        from dataclasses import asdict, replace

        from pyheracles import progress
        from pyheracles.building import BuildingParams, objects_in_world, segment_building
        from pyheracles.cli.common import (
            console,
            output_dir,
            print_run_warnings,
            write_model_ifc,
        )
        from pyheracles.errors import InputError
        from pyheracles.io import read_cloud
        from pyheracles.io.results import write_segmentation
        from pyheracles.supports import SupportParams

        prep = BuildingParams(units=units)  # checks --units before any work
        try:
            params = SupportParams(
                section_height_m=section_height_m,
                circularity_max=circularity_max,
                engaged=not no_engaged,
            )
        except ValueError as exc:
            raise InputError(str(exc)) from exc
        timings: dict[str, float] = {}
        with output_dir(outdir, force=force) as stage, progress.enabled(console):
            t = time.perf_counter()
            with progress.stage(f"reading {cloud_path.name}"):
                cloud = read_cloud(cloud_path).validate(what=f"point cloud {cloud_path}")
            timings["read"] = time.perf_counter() - t
            t = time.perf_counter()
            with progress.stage("structural supports"):
                seg, found, split, prepared = segment_building(
                    cloud.xyz, params, prep=prep,
                    split_attic=not no_attic, source=str(cloud_path),
                )  # fmt: skip
            timings["supports"] = time.perf_counter() - t
            t = time.perf_counter()
            seg = replace(seg, objects=objects_in_world(seg.objects, cloud))
            z_offset = float(cloud.offset[2])
            section = None if math.isnan(found.section_height) else found.section_height
            write_segmentation(
                cloud, seg, stage, step="supports",
                parameters={"supports": asdict(params), "units": units,
                            "split_attic": not no_attic},
                inputs=[cloud_path], timings=timings,
                per_object="instance" if per_object else None,
                extra={"section_height_levelled_m": section,
                       "section_height_input_z": _input_height(section, prepared, z_offset),
                       "spacing_m": found.spacing_m, "tilt_deg": prepared.tilt_deg,
                       "scale_to_m": prepared.scale_to_m,
                       "attic_limit_levelled_m": split.limit_z,
                       "attic_limit_input_z": _input_height(split.limit_z, prepared, z_offset),
                       "height_scores": found.height_scores},
            )  # fmt: skip
            if ifc:
                with progress.stage("IFC model"):
                    write_model_ifc(stage)
            timings["write"] = time.perf_counter() - t
            print_run_warnings(stage)
        n_by = seg.objects["class"].value_counts().to_dict() if len(seg.objects) else {}
        rows = [
            ("section height", _height_text(section, prepared, z_offset) or "none (see notes)"),
            ("columns", str(n_by.get("column", 0))),
            ("piers", str(n_by.get("pier", 0))),
            ("engaged columns", str(n_by.get("engaged_column", 0))),
            ("attic", _height_text(split.limit_z, prepared, z_offset) or "no attic"),
            ("output", str(outdir)),
        ]
        _summary(f"heracles supports: {cloud_path.name}", seg, rows, timings)
