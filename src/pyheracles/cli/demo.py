"""``heracles demo``: generate the built-in heritage complex, run step 1, score it, draw it."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pandas as pd
import typer

from pyheracles.cli.common import console, output_dir, print_counts, print_run_warnings


def register(app: typer.Typer) -> None:
    """Add ``heracles demo``."""

    @app.command("demo")
    def demo_cmd(
        out: Path = typer.Option(
            Path("demo_out"), "-o", "--out", "--outdir", help="Output folder."
        ),
        points: int = typer.Option(400_000, help="Points in the generated complex."),
        seed: int = typer.Option(0, help="Seed of the generated scene."),
        force: bool = typer.Option(False, help="Write into a non-empty output folder."),
        open_report: bool = typer.Option(
            False, "--open", help="Open report.html in the web browser when done."
        ),
    ) -> None:
        """Run step 1 on a generated walled complex (like the thesis's Kasepuhan) and score it.

        Writes into OUT: scene/ (the generated inputs: cloud.laz, building/wall/gate
        GeoPackages, reference), result/ (segmented.laz, objects.gpkg, per-object LAZ,
        run.json naming the scene/ inputs and the scene's seed, evaluation.csv/.json,
        report.html: the page to open first) and overview.png.

        Example:

            heracles demo -o demo_out --points 400000
        """
        with output_dir(out, force=force) as stage:
            table, gscore, seg, paths, timings = _run_demo(stage, points, seed)
            print_run_warnings(stage)
        paths = {k: out / v.relative_to(stage) for k, v in paths.items()}
        _print_scores(table)
        console.print(f"ground: precision {gscore['precision']:.3f}, recall {gscore['recall']:.3f}")
        print_counts(seg.counts(), timings, paths)
        report = out / "result" / "report.html"
        if report.exists():
            console.print(f"[bold]report:[/] {report} (open it in a web browser)")
            if open_report:
                import webbrowser

                webbrowser.open(report.resolve().as_uri())


def _run_demo(outdir: Path, points: int, seed: int) -> tuple[Any, ...]:
    """Generate, write, segment, evaluate and draw; returns what the summary prints."""
    from pyheracles.complex import ComplexParams
    from pyheracles.evaluate import evaluate_by_feature, ground_scores
    from pyheracles.io.atomic import atomic_path, atomic_write_json
    from pyheracles.pipeline import complex_from_files
    from pyheracles.progress import enabled, stage
    from pyheracles.report.overview import plot_complex_overview
    from pyheracles.synthetic.complex_scene import (
        ComplexSceneParams,
        kasepuhan_scene,
        write_scene,
    )

    with enabled(console):
        with stage("generating the complex"):
            scene_params = ComplexSceneParams(n_points=points, seed=seed)
            scene = kasepuhan_scene(scene_params)
            files = write_scene(scene, outdir / "scene")
        specs = [f"{name}={files[name]}" for name in scene.layers]
        with stage("step 1: complex -> objects"):
            result, paths, timings, _ = complex_from_files(
                files["cloud"], specs, outdir / "result", params=ComplexParams(), per_object="fid"
            )
    _record_scene(paths["run"], scene_params)
    seg = result.segmentation
    ref = scene.reference_objects
    ev = evaluate_by_feature(seg.instance, seg.objects, scene.reference_instance, ref)
    table = ev.table()
    with atomic_path(outdir / "result" / "evaluation.csv") as tmp:
        table.to_csv(tmp, index=False)
    gscore = ground_scores(seg.ground, scene.ground)
    atomic_write_json(
        outdir / "result" / "evaluation.json", {"objects": ev.to_dict(), "ground": gscore}
    )
    png = plot_complex_overview(
        scene.cloud, seg, scene.layers, outdir / "overview.png", scores=table.iloc[:-2]
    )
    return table, gscore, seg, {**paths, "overview": png}, timings


def _record_scene(run_json: Path, scene_params: Any) -> None:
    """Name the built-in scene (generator and parameters, seed included) in run.json.

    Its input paths point into the staging folder while the demo runs;
    :func:`~pyheracles.cli.common.output_dir` turns them into the final scene/ paths.
    """
    import json
    from dataclasses import asdict

    from pyheracles.io.atomic import atomic_write_json

    record = json.loads(run_json.read_text(encoding="utf-8"))
    record["demo_scene"] = {
        "generator": "pyheracles.synthetic.complex_scene.kasepuhan_scene",
        "parameters": asdict(scene_params),
        "inputs_folder": "scene/",
    }
    atomic_write_json(run_json, record)


def _print_scores(table: pd.DataFrame) -> None:
    from rich.table import Table

    t = Table(title="per-object scores against the reference (thesis tables 5.1/5.2)")
    headers = {"n_reference": "points", "unclassified_pct": "uncl. %"}
    for col in ("object", "name", "n_reference", "precision", "recall", "f1", "unclassified_pct"):
        t.add_column(
            headers.get(col, col), justify="left" if col in ("object", "name") else "right"
        )
    for _, row in table.iterrows():

        def fmt(v: object, pct: bool = False) -> str:
            if v is None or bool(pd.isna(v)):
                return "-"
            return f"{v:.1f}" if pct else (f"{v:.3f}" if isinstance(v, float) else str(v))

        t.add_row(
            str(row["object"]), fmt(row.get("name")), fmt(row["n_reference"]),
            fmt(row["precision"]), fmt(row["recall"]), fmt(row["f1"]),
            fmt(row["unclassified_pct"], pct=True),
        )  # fmt: skip
    console.print(t)
