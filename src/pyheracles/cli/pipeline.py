"""``heracles pipeline``: step 1 then step 2 on chosen objects, from one YAML file."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import typer

from pyheracles.cli.common import console, output_dir, print_counts, print_run_warnings


def register(app: typer.Typer) -> None:
    """Add ``heracles pipeline``."""

    @app.command("pipeline")
    def pipeline_cmd(
        config: Path = typer.Argument(
            ..., metavar="CONFIG", help="YAML configuration (see the README)."
        ),
        force: bool = typer.Option(False, help="Write into a non-empty output folder."),
        ifc: bool = typer.Option(
            False, "--ifc", help="Also write model.ifc: every step-2 element in its building."
        ),
    ) -> None:
        """Run the multi-scalar pipeline: complex -> objects -> supports / beams.

        Writes into the configuration's output folder: step 1 (segmented.laz,
        objects.gpkg, run.json) at the top level and one folder per analysed object
        in step2/<step>/<name>/ (segmented.laz, objects table, run.json); with --ifc,
        model.ifc (IFC 4: one IfcBuilding per step-1 object, the step-2 elements in
        theirs).

        Example configuration:

            cloud: site.laz
            layers: {building: footprints.gpkg, wall: walls.shp}
            output: out/
            step2:
              - select: {class: building, min_height_m: 4}
                step: supports
        """
        from rich.table import Table

        from pyheracles.pipeline import load_config, run_pipeline
        from pyheracles.progress import enabled, stage

        cfg = load_config(config)
        with output_dir(cfg.output, force=force) as staging, enabled(console):
            with stage("pipeline: step 1, then step 2 per object"):
                run = run_pipeline(cfg, staging)
            if ifc:
                _write_ifc(staging, run["step2"])
            statuses = [_status(row, staging) for row in run["step2"]]
            print_run_warnings(staging)
        table = Table(title="step 2")
        columns = ("instance", "name", "step", "status", "n_objects", "classes")
        for col in columns:
            table.add_column(col)
        for row, status in zip(run["step2"], statuses, strict=True):
            table.add_row(*[status if c == "status" else str(row.get(c, "")) for c in columns])
        console.print(table)
        seg = run["complex"].segmentation
        paths = {k: cfg.output / v.relative_to(staging) for k, v in run["paths"].items()}
        print_counts(seg.counts(), run["timings"], paths)


def _write_ifc(staging: Path, rows: list[dict[str, Any]]) -> None:
    """``model.ifc`` of a pipeline run: its step-2 folders, each in its building."""
    from pyheracles.cli.common import write_model_ifc
    from pyheracles.pipeline import safe_folder_name
    from pyheracles.progress import stage

    parts = [(staging / "step2" / r["step"] / safe_folder_name(r["name"]), int(r["instance"]))
             for r in rows if r.get("status") == "ok"]  # fmt: skip
    if not parts:
        from pyheracles.cli.common import err_console

        err_console.print("[yellow]warning:[/] --ifc: no step-2 result, no model.ifc written")
        return
    step1 = staging if (staging / "objects.gpkg").exists() else None
    with stage("IFC model"):
        write_model_ifc(staging, parts, step1_dir=step1)


def _status(row: dict[str, Any], outdir: Path) -> str:
    """The real status of one step-2 object: its run.json warnings when it has any."""
    from pyheracles.cli.common import run_warnings
    from pyheracles.pipeline import safe_folder_name

    status = str(row.get("status", ""))
    if status != "ok":
        return status
    folder = (
        outdir / "step2" / str(row.get("step", "")) / safe_folder_name(str(row.get("name", "")))
    )
    found = run_warnings(folder) if (folder / "run.json").is_file() else []
    if not found:
        return status
    return "; ".join(found) if not row.get("n_objects") else "ok; " + "; ".join(found)
