"""``heracles pipeline``: step 1 then step 2 on chosen objects, from one YAML file."""

from __future__ import annotations

from pathlib import Path

import typer

from pyheracles.cli.common import console, output_dir, print_counts


def register(app: typer.Typer) -> None:
    """Add ``heracles pipeline``."""

    @app.command("pipeline")
    def pipeline_cmd(
        config: Path = typer.Argument(..., help="YAML configuration (see the README)."),
        force: bool = typer.Option(False, help="Write into a non-empty output folder."),
    ) -> None:
        """Run the multi-scalar pipeline: complex -> objects -> supports / beams.

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
        from pyheracles.progress import enabled

        cfg = load_config(config)
        with output_dir(cfg.output, force=force) as stage, enabled(console):
            run = run_pipeline(cfg, stage)
        table = Table(title="step 2")
        columns = ("instance", "name", "step", "status", "n_objects", "classes")
        for col in columns:
            table.add_column(col)
        for row in run["step2"]:
            table.add_row(*[str(row.get(c, "")) for c in columns])
        console.print(table)
        seg = run["complex"].segmentation
        paths = {k: cfg.output / v.relative_to(stage) for k, v in run["paths"].items()}
        print_counts(seg.counts(), run["timings"], paths)
