"""``heracles walls``: wall planes, thickness and outlines with openings of a building cloud."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Annotated, Any

import typer

__all__ = ["register", "write_walls_layers"]

_HELP = "\n\n".join(
    [
        "Find the walls of a building cloud (TLS inside or outside, or a step-1 object; "
        "M_HERACLES wallSeg): vertical planar faces, paired into walls with their thickness "
        "where both faces are seen, each with its outline on its plane and the openings "
        "(windows, doors) as holes; walls that meet are joined at their plane intersection "
        "(least squares, as intersectMultPlanes / meshSnap).",
        "Writes into OUTDIR: segmented.laz (every input point in input order; instance = "
        "wall, class_id 1 = wall), objects.csv (one row per wall: plane normal, d, "
        "thickness, length, height, openings, fit RMS), walls.json and walls.gpkg (3D "
        "outlines and openings), run.json.  A wall seen on one face has no measured "
        "thickness (said in run.json); a cloud without vertical planes gives no walls and "
        "a note.",
        "Examples:",
        "  heracles walls nave_tls.laz -o out/walls",
        "  heracles walls chapel.laz --distance 0.02 --min-height 2 -o out/walls",
        "  heracles walls choir.laz --max-mullion 0.15 -o out/walls   # mullioned windows whole",
    ]
)


def write_walls_layers(result: Any, cloud: Any, folder: Path) -> list[Path]:
    """``walls.json`` and ``walls.gpkg`` (layers ``walls`` and ``openings``, 3D, world)."""
    import geopandas as gpd
    import numpy as np
    import shapely

    from pyheracles.io.atomic import atomic_write_json
    from pyheracles.io.vector import write_gpkg

    off = np.asarray(cloud.offset, dtype=np.float64)
    doc = result.to_json(off)
    paths = [atomic_write_json(folder / "walls.json", doc)]
    if not result.walls:
        return paths
    rows, geoms, orows, ogeoms = [], [], [], []
    for w, j in zip(result.walls, doc["walls"], strict=True):
        holes = [w.to_3d(o.polygon) + off for o in w.openings if o.kind == "window"]
        geoms.append(shapely.Polygon(w.to_3d(w.outline) + off, holes))
        rows.append({k: j[k] for k in ("instance", "thickness_m", "length_m", "height_m",
                                        "fit_rms_m", "n_points")})  # fmt: skip
        rows[-1]["n_openings"] = len(w.openings)
        for k, o in enumerate(w.openings, start=1):
            ogeoms.append(shapely.Polygon(w.to_3d(o.polygon) + off))
            orows.append({"wall": w.instance, "opening": k, "kind": o.kind,
                          "width_m": o.width_m, "height_m": o.height_m,
                          "n_lights": o.n_lights})  # fmt: skip
    crs = cloud.crs
    write_gpkg(gpd.GeoDataFrame(rows, geometry=geoms, crs=crs), folder / "walls.gpkg", "walls")
    if orows:
        write_gpkg(gpd.GeoDataFrame(orows, geometry=ogeoms, crs=crs),
                   folder / "openings.gpkg", "openings")  # fmt: skip
        paths.append(folder / "openings.gpkg")
    paths.append(folder / "walls.gpkg")
    return paths


def register(app: typer.Typer) -> None:
    """Add the ``walls`` subcommand to ``app``."""

    @app.command("walls", help=_HELP)
    def walls_command(
        cloud_path: Annotated[Path, typer.Argument(metavar="CLOUD", help="Building cloud file.")],
        outdir: Annotated[Path, typer.Option("-o", "--out", "--outdir", help="Output folder.")],
        distance_m: Annotated[
            float, typer.Option("--distance", help="Largest point-plane distance, metres.")
        ] = 0.03,
        min_height_m: Annotated[
            float, typer.Option("--min-height", help="Smallest wall height, metres.")
        ] = 1.5,
        min_length_m: Annotated[
            float, typer.Option("--min-length", help="Smallest wall length, metres.")
        ] = 1.0,
        voxel_m: Annotated[
            float, typer.Option("--voxel", help="Detection sample cube, metres.")
        ] = 0.06,
        door_step_m: Annotated[
            float,
            typer.Option(
                "--door-step",
                help="An opening whose foot lies within this height of "
                "a face's foot is a door, metres.",
            ),
        ] = 0.2,
        max_mullion_m: Annotated[
            float,
            typer.Option(
                "--max-mullion",
                help="Lights of one window separated by mullions up "
                "to this width are one opening, metres (0: each light apart).",
            ),
        ] = 0.0,
        ifc: Annotated[
            bool, typer.Option("--ifc", help="Also write model.ifc (IFC 4; needs the bim extra).")
        ] = False,
        force: Annotated[bool, typer.Option("--force", help="Write into a non-empty folder.")] = (
            False
        ),
    ) -> None:
        from dataclasses import asdict

        from rich.table import Table

        from pyheracles import progress
        from pyheracles.cli.common import (
            console,
            output_dir,
            print_objects,
            print_run_warnings,
            write_model_ifc,
        )
        from pyheracles.errors import InputError
        from pyheracles.io import read_cloud
        from pyheracles.io.results import write_segmentation
        from pyheracles.walls import WallParams, segment_walls

        try:
            params = WallParams(distance_m=distance_m, min_height_m=min_height_m,
                                min_length_m=min_length_m, voxel_m=voxel_m,
                                door_step_m=door_step_m, max_mullion_m=max_mullion_m)  # fmt: skip
        except ValueError as exc:
            raise InputError(str(exc)) from exc
        timings: dict[str, float] = {}
        with output_dir(outdir, force=force) as stage, progress.enabled(console):
            t = time.perf_counter()
            with progress.stage(f"reading {cloud_path.name}"):
                cloud = read_cloud(cloud_path).validate(what=f"point cloud {cloud_path}")
            timings["read"] = time.perf_counter() - t
            t = time.perf_counter()
            with progress.stage("walls: planes, faces, outlines, openings"):
                result = segment_walls(cloud.xyz, params)
            timings["walls"] = time.perf_counter() - t
            t = time.perf_counter()
            seg = result.to_segmentation(cloud.offset)
            write_segmentation(
                cloud, seg, stage, step="walls", parameters={"walls": asdict(params)},
                inputs=[cloud_path], timings=timings,
                extra={"n_walls": len(result.walls), "notes": list(result.notes),
                       "stage_timings": result.timings},
            )  # fmt: skip
            write_walls_layers(result, cloud, stage)
            if ifc:
                with progress.stage("IFC model"):
                    write_model_ifc(stage)
            timings["write"] = time.perf_counter() - t
            print_run_warnings(stage)
        cols = ["instance", "n_faces", "thickness_m", "length_m", "height_m", "n_windows",
                "n_doors", "fit_rms_m"]  # fmt: skip
        print_objects(seg.objects, cols)
        table = Table(title=f"heracles walls: {cloud_path.name}", show_header=False)
        table.add_row("walls", str(len(result.walls)))
        table.add_row("openings", str(sum(len(w.openings) for w in result.walls)))
        for note in result.notes:
            table.add_row("note", note)
        table.add_row("output", str(outdir))
        table.add_row("time", ", ".join(f"{k} {v:.1f} s" for k, v in timings.items()))
        console.print(table)
