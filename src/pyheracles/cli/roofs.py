"""``heracles roofs``: roof planes and LoD1.2 / LoD2.2 building solids per footprint."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import typer

__all__ = ["register", "roofs_from_files", "write_roofs"]

_HELP = "\n\n".join(
    [
        "Model the buildings of an aerial or UAV cloud on their footprints: roof planes by "
        "region growing on normals (M_HERACLES detectRoof), a LoD1.2 block (footprint "
        "extruded from the ground to the 70th percentile of the roof heights, as 3dfier) "
        "and a closed LoD2.2 solid (footprint cut by the planes' intersection and step "
        "lines, walls from the ground to the roof edges, as roofer).",
        "Ground: the cloud's ASPRS class 2 when it has one, else extracted. Footprints "
        "without points, or without roof points, are listed and not modelled; an invalid "
        "LoD2.2 solid is listed and left out (the building keeps its LoD1.2).",
        "Writes into OUT: buildings.city.json (CityJSON 2.0), segmented.laz (every input "
        "point in input order; extra dimensions instance = building, roof_plane = plane "
        "id), objects.gpkg (one row per building with its GIS attributes and figures), "
        "roof_planes.csv, run.json.",
        "Example:",
        "  heracles roofs ahn3.laz --footprints bgt_pand.sqlite -o out/roofs",
    ]
)


def _layer(spec: str) -> tuple[Path, str | None]:
    path = Path(spec)
    if not path.exists() and ":" in spec:
        head, tail = spec.rsplit(":", 1)
        if Path(head).exists():
            return Path(head), tail
    return path, None


def roofs_from_files(
    cloud_path: Path,
    footprints: str,
    *,
    params: Any = None,
    cloud_crs: str | None = None,
    reproject: bool = False,
    lod22: bool = True,
) -> tuple[Any, Any, Any, list[str], dict[str, float]]:
    """Read a cloud and a footprint layer and model the roofs.

    Returns the cloud, the footprints (in the cloud's CRS), the
    :class:`~pyheracles.roofs.RoofsResult`, notes and timings.
    """
    from pyheracles.io import read_cloud
    from pyheracles.io.vector import align_crs, read_layer
    from pyheracles.roofs import model_roofs

    timings: dict[str, float] = {}
    notes: list[str] = []
    t = time.perf_counter()
    cloud = read_cloud(cloud_path).validate(what=f"point cloud {cloud_path}")
    path, layer = _layer(footprints)
    gdf = read_layer(path, layer)
    crs = cloud.crs or cloud_crs
    if crs is None:
        if gdf.crs is not None:
            notes.append(
                f"{cloud_path.name} has no CRS: taken to be the footprints' {gdf.crs.to_string()}"
            )
    else:
        gdf = align_crs(gdf, crs, reproject=reproject, cloud_source=str(cloud_path))
    timings["read"] = time.perf_counter() - t
    t = time.perf_counter()
    cls = cloud.attributes.get("classification")
    result = model_roofs(
        cloud.xyz, gdf, offset=cloud.offset, classification=cls, params=params, lod22=lod22
    )
    timings["roofs"] = time.perf_counter() - t
    return cloud, gdf, result, notes, timings


def write_roofs(
    cloud: Any,
    footprints: Any,
    result: Any,
    outdir: Path,
    *,
    parameters: Any,
    inputs: list[Path],
    timings: dict[str, float],
    notes: list[str],
) -> dict[str, Path]:
    """Write a roofs result (the files of ``heracles roofs``) into ``outdir``."""
    import numpy as np

    from pyheracles.export.cityjson import write_cityjson
    from pyheracles.io.atomic import atomic_path
    from pyheracles.io.results import write_segmentation
    from pyheracles.labels import Segmentation
    from pyheracles.roofs import city_buildings

    t = time.perf_counter()
    crs = cloud.crs or footprints.crs
    city = write_cityjson(
        outdir / "buildings.city.json", city_buildings(result, cloud.offset), crs=crs
    )
    seg = Segmentation(
        instance=result.instance,
        class_id=(result.instance > 0).astype(np.uint8),
        classes={1: "building"},
        objects=result.objects,
        ground=result.ground & (result.instance == 0),
    )
    out_cloud = cloud.with_attributes(roof_plane=result.roof_plane)
    planes_csv = outdir / "roof_planes.csv"
    with atomic_path(planes_csv) as tmp:
        result.planes.to_csv(tmp, index=False)
    objects = result.objects
    rms = objects["lod22_rms_m"].to_numpy(dtype=float) if len(objects) else np.zeros(0)
    timings["write"] = time.perf_counter() - t
    paths = write_segmentation(
        out_cloud, seg, outdir, step="roofs", parameters=parameters, inputs=inputs,
        timings=timings,
        extra={
            "notes": notes,
            "skipped": result.skipped,
            "warnings_roofs": result.warnings,
            "invalid_solids": city.invalid,
            "buildings": {
                "footprints": len(footprints), "modelled": len(objects),
                "lod22": int(objects["lod22"].sum()) if len(objects) else 0,
                "skipped": len(result.skipped), "invalid_solids": len(city.invalid),
                "lod22_rms_m_median": float(np.nanmedian(rms)) if np.isfinite(rms).any()
                else None,
            },
        },
    )  # fmt: skip
    # what the user must see goes to run.json's warnings too
    import json

    run = paths["run"]
    record = json.loads(run.read_text(encoding="utf-8"))
    record["warnings"] = list(record.get("warnings", [])) + result.skipped + result.warnings
    record["warnings"] += city.invalid
    from pyheracles.io.atomic import atomic_write_json

    atomic_write_json(run, record)
    paths["cityjson"] = outdir / "buildings.city.json"
    paths["planes"] = planes_csv
    return paths


def register(app: typer.Typer) -> None:
    """Add ``heracles roofs``."""

    @app.command("roofs", help=_HELP)
    def roofs_cmd(
        cloud: Path = typer.Argument(..., metavar="CLOUD", help="Aerial/UAV cloud (LAS/LAZ...)."),
        footprints: str = typer.Option(
            ..., "--footprints", "-f", help="Footprint layer PATH[:LAYERNAME]."
        ),
        out: Path = typer.Option(..., "-o", "--out", "--outdir", help="Output folder."),
        min_height: float = typer.Option(1.0, help="Roof points above the ground, m."),
        percentile: float = typer.Option(70.0, help="LoD1.2 roof height percentile."),
        cloud_crs: str = typer.Option(None, help="CRS of the cloud when its file has none."),
        reproject: bool = typer.Option(
            False, help="Reproject the footprints into the cloud's CRS."
        ),
        force: bool = typer.Option(False, help="Write into a non-empty output folder."),
    ) -> None:
        from dataclasses import asdict

        from rich.table import Table

        from pyheracles.cli.common import console, output_dir, print_run_warnings
        from pyheracles.errors import InputError
        from pyheracles.progress import enabled, stage
        from pyheracles.roofs import RoofParams

        try:
            params = RoofParams(min_height_m=min_height, lod12_percentile=percentile).validate()
        except ValueError as exc:
            raise InputError(str(exc)) from exc
        with output_dir(out, force=force) as staging, enabled(console):
            with stage(f"roofs: {cloud.name}"):
                c, gdf, result, notes, timings = roofs_from_files(
                    cloud, footprints, params=params, cloud_crs=cloud_crs, reproject=reproject
                )
            with stage("writing"):
                fp_path, _ = _layer(footprints)
                write_roofs(
                    c, gdf, result, staging, parameters={"roofs": asdict(params)},
                    inputs=[cloud, fp_path], timings=timings, notes=notes,
                )  # fmt: skip
            print_run_warnings(staging)
        o = result.objects
        table = Table(title=f"heracles roofs: {cloud.name}", show_header=False)
        table.add_row("footprints", str(len(gdf)))
        table.add_row("buildings modelled", str(len(o)))
        table.add_row("with LoD2.2", str(int(o["lod22"].sum()) if len(o) else 0))
        table.add_row("skipped", str(len(result.skipped)))
        if len(o) and o["lod22"].any():
            table.add_row("LoD2.2 RMS (median)", f"{o['lod22_rms_m'].median():.3f} m")
        table.add_row("output", str(out))
        console.print(table)
        console.print("time: " + ", ".join(f"{k} {v:.1f} s" for k, v in timings.items()))
