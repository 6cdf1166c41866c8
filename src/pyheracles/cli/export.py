"""``heracles export ...``: results to other tools' formats.

One sub-command per format, each in its own function below:

* ``heracles export cityjson RESULT_DIR -o city.json`` (3D GIS, CityJSON 2.0);
* ``heracles export ifc ...`` (BIM; added by the IFC module);
* ``heracles export training RESULT_DIR -o DIR --format ply|npz|s3dis`` (deep learning).

Every command reads a result folder written by another ``heracles`` command.
"""

from __future__ import annotations

from pathlib import Path

import typer

__all__ = ["export_app", "register"]

export_app = typer.Typer(
    name="export",
    help="Export results to other tools' formats. Writes what -o names: CityJSON 2.0 for "
    "3D GIS (export cityjson), IFC 4 for BIM (export ifc), or a folder of labelled blocks "
    "for deep learning (export training).",
    no_args_is_help=True,
)


# --------------------------------------------------------------------------- cityjson
def export_cityjson(result_dir: Path, out: Path) -> tuple[int, list[str]]:
    """Write the buildings of a result folder as CityJSON 2.0; (buildings, problems).

    A ``heracles roofs`` folder: its ``buildings.city.json`` (LoD1.2 + LoD2.2),
    validated again.  A ``heracles complex`` folder (``segmented.laz`` +
    ``objects.gpkg``): LoD1.2 of every object with a footprint, from its points.
    """
    import json

    from pyheracles.errors import InputError
    from pyheracles.export.cityjson import validate_cityjson, write_cityjson
    from pyheracles.io.atomic import atomic_write_json

    result_dir = Path(result_dir)
    if not result_dir.is_dir():
        raise InputError("not a result folder", path=result_dir, hint="give an output folder")
    city = result_dir / "buildings.city.json"
    if city.exists():
        doc = json.loads(city.read_text(encoding="utf-8"))
        errors = validate_cityjson(doc)
        if errors:
            raise InputError(
                f"{len(errors)} problems in the CityJSON, first: {errors[0]}",
                path=city,
                hint="rerun heracles roofs",
            )
        atomic_write_json(out, doc)
        return len(doc.get("CityObjects", {})), []
    cloud_path, objects_path = result_dir / "segmented.laz", result_dir / "objects.gpkg"
    if not (cloud_path.exists() and objects_path.exists()):
        raise InputError(
            "no buildings.city.json, nor segmented.laz + objects.gpkg",
            path=result_dir,
            hint="give the folder of heracles roofs or heracles complex",
        )
    from pyheracles.io import read_cloud
    from pyheracles.io.vector import read_layer
    from pyheracles.roofs import city_buildings, model_roofs

    cloud = read_cloud(cloud_path)
    objects = read_layer(objects_path, "objects")
    objects = objects[objects.geom_type.isin(["Polygon", "MultiPolygon"])].reset_index(drop=True)
    cls = cloud.attributes.get("classification")
    result = model_roofs(cloud.xyz, objects, offset=cloud.offset, classification=cls, lod22=False)
    report = write_cityjson(out, city_buildings(result, cloud.offset), crs=objects.crs)
    return report.n_buildings, result.skipped + report.invalid


def _cityjson_cmd(
    result_dir: Path = typer.Argument(..., metavar="RESULT_DIR", help="Output folder of a step."),
    out: Path = typer.Option(..., "-o", "--out", help="CityJSON file to write (.city.json)."),
) -> None:
    """Buildings of a result folder as CityJSON 2.0 (LoD1.2, and LoD2.2 where modelled).

    Example:

        heracles export cityjson out/roofs -o city.json
    """
    from pyheracles.cli.common import console, err_console

    n, problems = export_cityjson(result_dir, out)
    for p in problems:
        err_console.print(f"[yellow]warning:[/] {p}", highlight=False)
    console.print(f"[green]wrote[/] {n} buildings: {out}")


export_app.command("cityjson")(_cityjson_cmd)


# -------------------------------------------------------------------------------- ifc
def _ifc_cmd(
    result_dir: Path = typer.Argument(
        ..., metavar="RESULT_DIR", help="Output folder of heracles supports, beams or walls."
    ),
    out: Path = typer.Option(..., "-o", "--out", help="IFC file to write (.ifc)."),
    buildings: Path | None = typer.Option(
        None, "--buildings", help="heracles complex folder: one IfcBuilding per object."
    ),
) -> None:
    """Elements of a step-2 result folder as an IFC 4 model (needs the bim extra).

    IfcColumn (COLUMN, PILASTER for engaged columns, piers as rectangles), IfcBeam /
    IfcMember, IfcWall with IfcOpeningElement voids; a provenance property set on each;
    the site georeferenced from the cloud's CRS.

    Example:

        heracles export ifc out/supports -o model.ifc
    """
    from pyheracles.cli.common import console, err_console
    from pyheracles.export.ifc import export_ifc

    rep = export_ifc(result_dir, out, step1_dir=buildings)
    for p in rep.notes:
        err_console.print(f"[yellow]note:[/] {p}", highlight=False)
    what = ", ".join(f"{n} {k}" for k, n in rep.elements.items()) or "no elements"
    console.print(f"[green]wrote[/] {what}: {out}")


export_app.command("ifc")(_ifc_cmd)


# --------------------------------------------------------------------------- training
def _training_cmd(
    result_dir: Path = typer.Argument(
        ..., metavar="RESULT_DIR", help="Output folder of a heracles step (segmented.laz)."
    ),
    out: Path = typer.Option(..., "-o", "--out", help="Folder to write."),
    fmt: str = typer.Option("ply", "--format", help="ply, npz or s3dis."),
    block_m: float = typer.Option(10.0, "--block", help="Side of the plan blocks, m (0 = one)."),
    per_object: bool = typer.Option(True, "--objects/--no-objects", help="One file per object."),
    class_map: Path | None = typer.Option(
        None, "--class-map", help='JSON file of extra class names, e.g. {"gate": "wall"}.'
    ),
) -> None:
    """Labelled clouds for deep learning, in blocks, with the ArCH heritage class map.

    Writes DIR/scene/ (or DIR/Area_1/ for s3dis), DIR/objects/, blocks.csv and
    classes.json (the class map, with the pyheracles classes that went to "other").

    Example:

        heracles export training out/supports -o train/ --format s3dis --block 8
    """
    import json

    from pyheracles.cli.common import console, err_console
    from pyheracles.errors import InputError
    from pyheracles.export.training import TrainingParams, export_training

    extra: dict[str, str] = {}
    if class_map is not None:
        try:
            extra = json.loads(Path(class_map).read_text(encoding="utf-8"))
        except (OSError, ValueError) as exc:
            raise InputError(
                f"unreadable class map: {exc}",
                path=class_map,
                hint='give a JSON object of names, e.g. {"gate": "wall"}',
            ) from exc
        if not isinstance(extra, dict):
            raise InputError("the class map is not a JSON object", path=class_map,
                             hint='e.g. {"gate": "wall"}')  # fmt: skip
    rep = export_training(
        result_dir, out,
        TrainingParams(format=fmt, block_m=block_m, per_object=per_object, class_map=extra),
    )  # fmt: skip
    if rep.unmapped:
        err_console.print(
            f"[yellow]note:[/] classes {', '.join(rep.unmapped)} went to 'other' "
            "(map them with --class-map)", highlight=False,
        )  # fmt: skip
    shown = ", ".join(f"{k} {v}" for k, v in rep.class_counts.items() if v)
    console.print(
        f"[green]wrote[/] {rep.n_points} points in {rep.n_blocks} blocks and "
        f"{rep.n_objects} object files ({shown}): {out}"
    )


export_app.command("training")(_training_cmd)


# ------------------------------------------------------------------------------- app
def register(app: typer.Typer) -> None:
    """Add ``heracles export``."""
    app.add_typer(export_app, name="export")
