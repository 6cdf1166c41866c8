"""``heracles ground``: classify the ground of a cloud and write it with its DTM."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Annotated, Any

import numpy as np
import typer

__all__ = ["DTM_NODATA", "parse_crs_option", "register", "write_dtm_geotiff"]

#: Nodata value of band 1 of dtm.tif (the DTM is gap-free; GIS tools need the tag).
DTM_NODATA = -9999.0

_HELP = "\n\n".join(
    [
        "Classify the ground of a point cloud and write it with its terrain model.",
        "Methods: auto (measured parameters, SMRF seeds refined against the measured ground "
        "roughness; the default), csf (Cloth Simulation Filter, package defaults), smrf "
        "(Simple Morphological Filter, PDAL defaults).",
        "Writes into OUTDIR: ground.laz (all points in input order; class 2 = ground, former "
        "ground points now off-ground become 1, other classes kept; extra dimension "
        "height_above_ground in metres), dtm.tif (float32 GeoTIFF in the cloud's CRS: band 1 "
        "ground height, nodata -9999, band 2 = 1 where the cell held ground points, 0 where "
        "inpainted) and run.json (parameters, measured scene, inputs, timings, counts). "
        "--crs gives the CRS when the file has none (it is written into both outputs).",
        "Examples:",
        "  heracles ground ahn3_tile1.laz -o out/ground",
        "  heracles ground site.laz --method smrf --dtm-cell 0.5 -o out/ground_smrf",
        "  heracles ground site.laz --max-object-size 60 -o out/ground",
        "  heracles ground scan.ply --crs EPSG:2154 -o out/ground",
        "CLOUD may also be many tiles (a quoted glob, a folder, a tile index .gpkg): then "
        "OUTDIR gets tiles/<tile>/ground.laz and dtm.tif per tile, dtm.vrt (the seamless "
        "DTM mosaic) and tiles.gpkg, on Dask with --workers N or --scheduler ADDRESS.",
    ]
)


def parse_crs_option(value: str | None, option: str = "--crs") -> Any:
    """``pyproj.CRS`` of a ``--crs`` value (EPSG code, WKT, PROJ string), None for None.

    Raises
    ------
    InputError
        The value is not a CRS pyproj knows.
    """
    if value is None:
        return None
    from pyproj import CRS
    from pyproj.exceptions import CRSError

    from pyheracles.errors import InputError

    try:
        return CRS.from_user_input(value)
    except (CRSError, TypeError, ValueError) as exc:
        raise InputError(
            f"{option} {value!r} is not a coordinate reference system ({exc})",
            hint=f"give an EPSG code such as {option} EPSG:2154, a WKT or a PROJ string",
        ) from exc


def write_dtm_geotiff(dtm: Any, path: Path, *, offset: np.ndarray, crs: Any) -> Path:
    """Write a :class:`~pyheracles.ground.DTM` as a two-band float32 GeoTIFF, atomically.

    Band 1 is the height in the world frame (``offset`` added; nodata :data:`DTM_NODATA`
    for any non-finite cell), band 2 is 1 where the cell held ground points and 0 where
    it was inpainted.
    """
    import rasterio

    from pyheracles.io.atomic import atomic_path

    rows, cols = dtm.shape
    height = dtm.z_m + float(offset[2])
    bands = np.stack([np.where(np.isfinite(height), height, DTM_NODATA),
                      dtm.observed.astype(np.float64)])  # fmt: skip
    profile = {
        "driver": "GTiff",
        "height": rows,
        "width": cols,
        "count": 2,
        "dtype": "float32",
        "transform": dtm.transform(offset),
        "crs": None if crs is None else crs.to_wkt(),
        "nodata": DTM_NODATA,
        "compress": "deflate",
    }
    with atomic_path(path) as tmp, rasterio.open(tmp, "w", **profile) as dst:
        dst.write(bands.astype(np.float32))
        dst.set_band_description(1, "ground height (m)")
        dst.set_band_description(2, "observed (1) or inpainted (0)")
    return path


def register(app: typer.Typer) -> None:
    """Add the ``ground`` subcommand to ``app``."""

    @app.command("ground", help=_HELP)
    def ground_command(
        cloud_path: Annotated[Path, typer.Argument(metavar="CLOUD", help="Point cloud file.")],
        outdir: Annotated[Path, typer.Option("-o", "--out", "--outdir", help="Output folder.")],
        method: Annotated[
            str, typer.Option("--method", "-m", help="Ground filter: auto, csf, smrf.")
        ] = "auto",
        max_object_size_m: Annotated[
            float | None,
            typer.Option(
                "--max-object-size", help="Largest building size in metres (auto; default 34)."
            ),
        ] = None,
        dtm_cell_m: Annotated[
            float | None,
            typer.Option("--dtm-cell", help="DTM cell size in metres (default: filter's cell)."),
        ] = None,
        crs: Annotated[
            str | None,
            typer.Option(
                "--crs", help="CRS of the cloud when its file has none (EPSG:2154, WKT ...)."
            ),
        ] = None,
        force: Annotated[
            bool, typer.Option("--force", help="Write into a non-empty output folder.")
        ] = False,
        workers: Annotated[
            int | None, typer.Option("--workers", help="Tiles: local Dask worker processes.")
        ] = None,
        scheduler: Annotated[
            str | None,
            typer.Option("--scheduler", help="Tiles: address of a running Dask scheduler."),
        ] = None,
        tile_buffer: Annotated[
            float | None,
            typer.Option("--tile-buffer", help="Tiles: buffer in metres (auto: ground window)."),
        ] = None,
    ) -> None:
        from pyheracles.tiles import is_tile_source

        if is_tile_source(cloud_path):  # many tiles: README "City scale"
            from pyheracles.cli.tiles import ground_tiles

            ground_tiles(
                str(cloud_path), outdir, method=method, max_object_size_m=max_object_size_m,
                dtm_cell_m=dtm_cell_m, cloud_crs=crs, workers=workers, scheduler=scheduler,
                buffer_m=tile_buffer,
            )  # fmt: skip
            return
        from dataclasses import replace

        from rich.table import Table

        from pyheracles.cli.common import console, output_dir, print_run_warnings
        from pyheracles.errors import InputError
        from pyheracles.ground import extract_ground, height_above_ground, pass_through_of
        from pyheracles.io import read_cloud, write_cloud
        from pyheracles.progress import enabled, stage
        from pyheracles.provenance import write_run_json

        if method not in ("auto", "csf", "smrf"):
            raise InputError(f"unknown --method {method!r}; expected one of auto, csf, smrf")
        given_crs = parse_crs_option(crs)  # checked before any work
        notes: list[str] = []
        with output_dir(outdir, force=force) as staging, enabled(console):
            timings: dict[str, float] = {}
            t = time.perf_counter()
            with stage(f"reading {cloud_path.name}"):
                cloud = read_cloud(cloud_path).validate(what=f"point cloud {cloud_path}")
            timings["read"] = time.perf_counter() - t
            if given_crs is not None:
                if cloud.crs is not None and not given_crs.equals(cloud.crs):
                    notes.append(
                        f"--crs {given_crs.to_string()} replaces the file's CRS "
                        f"{cloud.crs.to_string()} (a label only: nothing is reprojected)"
                    )
                cloud = replace(cloud, crs=given_crs)
            elif cloud.crs is None:
                notes.append("the cloud has no CRS: ground.laz and dtm.tif have none (use --crs)")

            t = time.perf_counter()
            with stage(f"ground filter ({method})"):
                through = pass_through_of(cloud.attributes)
                result = extract_ground(
                    cloud.xyz, method, max_object_size_m=max_object_size_m,
                    dtm_cell_m=dtm_cell_m, source=str(cloud_path), pass_through=through,
                )  # fmt: skip
            if through is not None and through.any() and method != "none":
                notes.append(
                    f"{int(through.sum())} returns that are not the last of their pulse were "
                    "kept out of the filter (ground only where they lie on the terrain model)"
                )
            timings["ground"] = time.perf_counter() - t

            t = time.perf_counter()
            with stage("writing ground.laz and dtm.tif"):
                old = cloud.attributes.get("classification")
                classification = (
                    np.ones(len(cloud), np.uint8)
                    if old is None
                    else np.asarray(old, np.uint8).copy()
                )
                classification[classification == 2] = 1
                classification[result.mask] = 2
                extra: dict[str, np.ndarray] = {"classification": classification}
                if result.dtm is not None:
                    extra["height_above_ground"] = height_above_ground(
                        cloud.xyz, result.dtm
                    ).astype(np.float32)
                cloud_out = write_cloud(cloud, staging / "ground.laz", extra_dims=extra)
                outputs = {"cloud": str(outdir / cloud_out.name)}
                if result.dtm is not None:
                    dtm_out = write_dtm_geotiff(
                        result.dtm, staging / "dtm.tif", offset=cloud.offset, crs=cloud.crs
                    )
                    outputs["dtm"] = str(outdir / dtm_out.name)
            timings["write"] = time.perf_counter() - t
            counts = result.counts()
            write_run_json(
                staging,
                step="ground",
                parameters={"method": method, "params": result.params},
                inputs=[cloud_path],
                timings=timings,
                counts=counts,
                extra={
                    "scene": result.scene,
                    "note": result.note,
                    "notes": notes,
                    "crs": None if cloud.crs is None else cloud.crs.to_string(),
                    "outputs": outputs,
                    "dtm_cell_m": None if result.dtm is None else result.dtm.cell_m,
                },
            )
            print_run_warnings(staging)

        table = Table(title=f"heracles ground: {cloud_path.name}")
        table.add_column("item")
        table.add_column("value", justify="right")
        table.add_row("method", result.method)
        table.add_row("points", f"{counts['total']:,}")
        table.add_row(
            "ground", f"{counts['ground']:,} ({100 * counts['ground'] / counts['total']:.1f} %)"
        )
        if result.scene is not None:
            table.add_row("point spacing", f"{result.scene.spacing_m:.2f} m")
            table.add_row("terrain slope (p90)", f"{result.scene.slope:.2f}")
        if result.dtm is not None:
            table.add_row(
                "DTM",
                f"{result.dtm.shape[1]} x {result.dtm.shape[0]} cells of {result.dtm.cell_m:.2f} m",
            )
        table.add_row("time", f"{timings['ground']:.2f} s")
        table.add_row("output", str(outdir))
        console.print(table)
