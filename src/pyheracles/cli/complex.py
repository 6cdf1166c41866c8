"""``heracles complex``: step 1, GIS-aided segmentation of a heritage complex."""

from __future__ import annotations

from pathlib import Path

import typer

from pyheracles.cli.common import (
    console,
    output_dir,
    print_counts,
    print_objects,
    print_run_warnings,
)


def register(app: typer.Typer) -> None:
    """Add ``heracles complex``."""

    @app.command("complex")
    def complex_cmd(
        cloud: Path = typer.Argument(
            ..., metavar="CLOUD", help="Point cloud of the complex (LAS/LAZ/PLY/E57/XYZ)."
        ),
        layer: list[str] = typer.Option(
            ...,
            "--layer",
            "-l",
            help="GIS layer as NAME=PATH[:LAYERNAME]; NAME becomes the class. Repeat per layer.",
        ),
        out: Path = typer.Option(..., "-o", "--out", "--outdir", help="Output folder."),
        ground: str = typer.Option("auto", help="Ground: auto|csf|smrf|class|none."),
        buffer: float = typer.Option(None, help="Cookie-cutter buffer, m (auto: 1 m)."),
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
        cityjson: bool = typer.Option(
            False, "--cityjson", help="Also write buildings.city.json (CityJSON 2.0, LoD1.2)."
        ),
        workers: int = typer.Option(
            None, help="Tiles: run on a local Dask cluster of N processes (1 thread each)."
        ),
        scheduler: str = typer.Option(
            None, help="Tiles: address of a running Dask scheduler (tcp://HOST:8786)."
        ),
        tile_buffer: float = typer.Option(
            None, help="Tiles: buffer around each tile, m (auto: the ground window)."
        ),
    ) -> None:
        """Split a complex into one object per GIS feature, plus ground and remainder.

        Writes into OUT: segmented.laz (every input point in input order, extra
        dimensions instance and class_id, ground as class 2), objects.gpkg (one row
        per object with its GIS attributes), run.json, report.html; with --per-object
        one LAZ per object in objects/; with --cityjson buildings.city.json (every object
        with a footprint as a LoD1.2 Building carrying its GIS attributes).

        Example:

            heracles complex ahn3.laz -l building=bgt_pand.sqlite
            -l wall=bgt_scheiding.sqlite -o out/

        CLOUD may also be many tiles: a quoted glob ('tiles/*.laz'), a folder or a tile
        index .gpkg; then OUT gets tiles/<tile>/segmented.laz, objects.gpkg and tiles.gpkg
        (see the README, "City scale"), on Dask with --workers N or --scheduler ADDRESS.
        """
        from pyheracles.complex import ComplexParams
        from pyheracles.pipeline import complex_from_files
        from pyheracles.progress import enabled, stage
        from pyheracles.tiles import is_tile_source

        params = ComplexParams(
            buffer_m=buffer, cluster_distance_m=distance, min_cluster_points=min_points,
            ground=ground,
            layer_order=tuple(s.strip() for s in order.split(",")) if order else None,
        )  # fmt: skip
        if is_tile_source(cloud):
            from pyheracles.cli.tiles import complex_tiles

            complex_tiles(
                str(cloud), layer, out, params=params, workers=workers, scheduler=scheduler,
                buffer_m=tile_buffer, reproject=reproject, fix_invalid=fix_invalid,
                cloud_crs=cloud_crs, per_object=per_object, cityjson=cityjson,
            )  # fmt: skip
            return
        with output_dir(out, force=force) as staging, enabled(console):
            with stage("step 1: complex -> objects"):
                result, paths, timings, _ = complex_from_files(
                    cloud, layer, staging, params=params, reproject=reproject,
                    fix_invalid=fix_invalid, cloud_crs=cloud_crs, per_object=per_object,
                )  # fmt: skip
            if cityjson:
                from pyheracles.cli.export import export_cityjson

                with stage("CityJSON LoD1.2"):
                    _, problems = export_cityjson(staging, staging / "buildings.city.json")
                paths["cityjson"] = staging / "buildings.city.json"
                for problem in problems:
                    console.print(f"[yellow]warning:[/] CityJSON: {problem}", highlight=False)
            print_run_warnings(staging)
        paths = {k: out / v.relative_to(staging) for k, v in paths.items()}
        seg = result.segmentation
        print_objects(seg.objects, ["instance", "class", "source_fid", "n_points", "height"])
        print_counts(seg.counts(), timings, paths)
