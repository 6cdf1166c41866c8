"""``heracles report``: (re)build ``report.html`` from an existing output folder."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

__all__ = ["register"]

_HELP = "\n\n".join(
    [
        "Build the HTML report of an output folder written by any heracles command.",
        "The page is self-contained (opens offline, from a USB stick): what ran with which "
        "parameters (automatic values marked), the point balance, warnings, the sortable "
        "objects table, the figures, an interactive 3D view (WebGL, written for the report) of "
        "the labelled cloud with the fitted primitives, walls and roofs, check and tie point "
        "residuals or a bundle adjustment's cameras, and the provenance.",
        "Writes: OUTDIR/report.html (replacing an older one).",
        "Examples:",
        "  heracles report demo_out/result",
        "  heracles report out/supports --max-points 100000",
    ]
)


def register(app: typer.Typer) -> None:
    """Add the ``report`` subcommand to ``app``."""

    @app.command("report", help=_HELP)
    def report_command(
        outdir: Annotated[
            Path, typer.Argument(metavar="OUTDIR", help="Output folder with a run.json.")
        ],
        max_points: Annotated[
            int, typer.Option("--max-points", min=1000, help="Points in the 3D view at most.")
        ] = 300_000,
    ) -> None:
        from pyheracles.cli.common import console
        from pyheracles.report.html import build_report

        path = build_report(outdir, max_points=max_points)
        console.print(f"wrote {path} ({path.stat().st_size / 1e6:.1f} MB)")
