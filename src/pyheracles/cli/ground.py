"""``heracles ground``: classify the ground of a cloud and write it with its DTM."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Annotated, Any

import numpy as np
import typer

__all__ = ["register", "write_dtm_geotiff"]

_HELP = "\n\n".join(
    [
        "Classify the ground of a point cloud and write it with its terrain model.",
        "Methods: auto (measured parameters, SMRF seeds refined against the measured ground "
        "roughness; the default), csf (Cloth Simulation Filter, package defaults), smrf "
        "(Simple Morphological Filter, PDAL defaults).",
        "Writes into OUTDIR: ground.laz (all points in input order; class 2 = ground, former "
        "ground points now off-ground become 1, other classes kept; extra dimension "
        "height_above_ground in metres), dtm.tif (float32 GeoTIFF in the cloud's CRS: band 1 "
        "ground height, band 2 = 1 where the cell held ground points, 0 where inpainted) and "
        "run.json (parameters, measured scene, inputs, timings, counts).",
        "Examples:",
        "  heracles ground ahn3_tile1.laz -o out/ground",
        "  heracles ground site.laz --method smrf --dtm-cell 0.5 -o out/ground_smrf",
        "  heracles ground site.laz --max-object-size 60 -o out/ground",
    ]
)


def write_dtm_geotiff(dtm: Any, path: Path, *, offset: np.ndarray, crs: Any) -> Path:
    """Write a :class:`~pyheracles.ground.DTM` as a two-band float32 GeoTIFF, atomically.

    Band 1 is the height in the world frame (``offset`` added), band 2 is 1 where the
    cell held ground points and 0 where it was inpainted.
    """
    import rasterio

    from pyheracles.io.atomic import atomic_path

    rows, cols = dtm.shape
    bands = np.stack([dtm.z_m + float(offset[2]), dtm.observed.astype(np.float64)])
    profile = {
        "driver": "GTiff",
        "height": rows,
        "width": cols,
        "count": 2,
        "dtype": "float32",
        "transform": dtm.transform(offset),
        "crs": None if crs is None else crs.to_wkt(),
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
        force: Annotated[
            bool, typer.Option("--force", help="Write into a non-empty output folder.")
        ] = False,
    ) -> None:
        from rich.table import Table

        from pyheracles.cli.common import console, output_dir
        from pyheracles.errors import InputError
        from pyheracles.ground import extract_ground, height_above_ground
        from pyheracles.io import read_cloud, write_cloud
        from pyheracles.provenance import write_run_json

        if method not in ("auto", "csf", "smrf"):
            raise InputError(f"unknown --method {method!r}; expected one of auto, csf, smrf")
        with output_dir(outdir, force=force) as stage:
            timings: dict[str, float] = {}
            t = time.perf_counter()
            cloud = read_cloud(cloud_path).validate(what=f"point cloud {cloud_path}")
            timings["read"] = time.perf_counter() - t

            t = time.perf_counter()
            result = extract_ground(
                cloud.xyz, method, max_object_size_m=max_object_size_m, dtm_cell_m=dtm_cell_m
            )
            timings["ground"] = time.perf_counter() - t

            t = time.perf_counter()
            old = cloud.attributes.get("classification")
            classification = (
                np.ones(len(cloud), np.uint8) if old is None else np.asarray(old, np.uint8).copy()
            )
            classification[classification == 2] = 1
            classification[result.mask] = 2
            extra: dict[str, np.ndarray] = {"classification": classification}
            if result.dtm is not None:
                extra["height_above_ground"] = height_above_ground(cloud.xyz, result.dtm).astype(
                    np.float32
                )
            cloud_out = write_cloud(cloud, stage / "ground.laz", extra_dims=extra)
            outputs = {"cloud": str(outdir / cloud_out.name)}
            if result.dtm is not None:
                dtm_out = write_dtm_geotiff(
                    result.dtm, stage / "dtm.tif", offset=cloud.offset, crs=cloud.crs
                )
                outputs["dtm"] = str(outdir / dtm_out.name)
            timings["write"] = time.perf_counter() - t
            counts = result.counts()
            write_run_json(
                stage,
                step="ground",
                parameters={"method": method, "params": result.params},
                inputs=[cloud_path],
                timings=timings,
                counts=counts,
                extra={
                    "scene": result.scene,
                    "note": result.note,
                    "outputs": outputs,
                    "dtm_cell_m": None if result.dtm is None else result.dtm.cell_m,
                },
            )

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
        if result.note:
            console.print(f"[yellow]note:[/] {result.note}", highlight=False)
