"""``heracles bundle``: photogrammetric quality control by bundle adjustment (QC-1)."""

from __future__ import annotations

import time
import warnings
from pathlib import Path
from typing import Annotated

import typer

__all__ = ["register"]

_HELP = "\n\n".join(
    [
        "Re-process a photogrammetric project with a bundle adjustment with self-calibration "
        "and expose its statistics (thesis ch. 2; DBAT conventions): sigma0, posterior "
        "standard deviations of the cameras, images and points, correlations over 95 %, "
        "control and check point residuals, per-image statistics, data snooping.",
        "PROJECT: a DBAT XML script (.xml, its operations give the estimated parameters and "
        "the datum), a Metashape/PhotoScan camera export (.xml with a <chunk>: sensors, "
        "cameras, markers and their projections), a PhotoModeler text export (.txt), a "
        "PhotoScan/Metashape archive (.psz) or a COLMAP text model folder (cameras.txt, "
        "images.txt, points3D.txt).",
        "--control: control/check points, one per line: id, label, X, Y, Z, then s or "
        "sX sY sZ, then 'check' for a check point (label, standard deviations and role "
        "optional; no standard deviation = fixed point). A first line of column names "
        "(id,label,X,Y,Z,sX,sY,sZ,role) or --control-columns resolves ambiguous rows "
        "(a numeric label followed by X Y Z); anything ambiguous is an error naming the "
        "line. --image-size WIDTHxHEIGHT: for PhotoModeler exports without the image size "
        "on line 2. --snooping w (Baarda, a priori sigma) or tau (Pope, posterior sigma0). "
        "A run that fails still writes its diagnosis (report.txt, report.json) into OUTDIR. "
        "--estimate: interior parameters to estimate "
        "(cc,px,py,as,sk,K1,K2,K3,P1,P2; 'none' = fixed camera; default: the project's "
        "choice). --damping gna (Gauss-Newton-Armijo, DBAT default), lm or gn. "
        "--positions: prior camera positions 'image,X,Y,Z,s' used as weighted observations; "
        "--resect: initial orientations by resection from the control points (when the "
        "project's own orientations are in another frame).",
        "Writes into OUTDIR: report.txt (DBAT layout), report.json, radial_distortion.png, "
        "eo_std_hist.png, image_stats.png, run.json.",
        "Examples:",
        "  heracles bundle romabundledemo/romabundledemo.xml -o out/roma",
        "  heracles bundle camcal-pmexport.txt --control camcal-fixed.txt --model 3 "
        "--estimate cc,px,py,as,K1,K2,K3,P1,P2 -o out/camcal",
    ]
)


def register(app: typer.Typer) -> None:
    """Add the ``bundle`` subcommand."""

    @app.command("bundle", help=_HELP)
    def bundle_cmd(
        project: Annotated[
            Path,
            typer.Argument(
                metavar="PROJECT",
                help="Project: .xml (DBAT script, Metashape cameras), .txt (PM), .psz, "
                "COLMAP folder.",
            ),
        ],
        out: Annotated[Path, typer.Option("-o", "--out", "--outdir", help="Output folder.")],
        control: Annotated[
            Path | None, typer.Option("--control", help="Control/check point table.")
        ] = None,
        control_columns: Annotated[
            str | None,
            typer.Option(
                "--control-columns",
                help="Column names of the control table, e.g. id,label,X,Y,Z,sX,sY,sZ.",
            ),
        ] = None,
        image_size: Annotated[
            str | None,
            typer.Option("--image-size", help="Image size WIDTHxHEIGHT px (PhotoModeler)."),
        ] = None,
        snooping: Annotated[
            str, typer.Option("--snooping", help="Data snooping test: w (Baarda) or tau (Pope).")
        ] = "w",
        positions: Annotated[
            Path | None,
            typer.Option("--positions", help="Prior camera positions 'image,X,Y,Z,s' (GNSS)."),
        ] = None,
        resect: Annotated[
            bool,
            typer.Option("--resect", help="Re-initialise images by resection from control."),
        ] = False,
        estimate: Annotated[
            str | None, typer.Option("--estimate", help="IO parameters to estimate, comma list.")
        ] = None,
        damping: Annotated[str, typer.Option("--damping", help="gna, lm or gn.")] = "gna",
        model: Annotated[
            int | None, typer.Option("--model", help="Lens distortion model 1-5 (DBAT).")
        ] = None,
        datum: Annotated[str, typer.Option("--datum", help="auto, control or depend.")] = "auto",
        max_iterations: Annotated[int, typer.Option("--max-iterations")] = 20,
        default_io: Annotated[
            float | None,
            typer.Option("--default-io", help="Start from cc=VALUE mm, centred pp, no distortion."),
        ] = None,
        no_plots: Annotated[bool, typer.Option("--no-plots", help="Skip the PNG plots.")] = False,
        force: Annotated[bool, typer.Option("--force", help="Overwrite OUT.")] = False,
    ) -> None:
        from rich.table import Table

        from pyheracles import progress
        from pyheracles.bundle import BundleParameters, BundleWarning, bundle_adjust
        from pyheracles.bundle.readers import (
            read_camera_positions,
            read_control_points,
            read_project,
        )
        from pyheracles.bundle.readers.photomodeler import read_photomodeler
        from pyheracles.bundle.report import write_failure_report, write_reports
        from pyheracles.cli.common import console, output_dir, print_run_warnings
        from pyheracles.errors import HeraclesError, InputError
        from pyheracles.provenance import write_run_json

        t0 = time.perf_counter()
        est: tuple[str, ...] | None = None
        if estimate is not None:
            names = [s.strip() for s in estimate.split(",") if s.strip()]
            est = () if names in (["none"], []) else tuple(names)
        params = BundleParameters(
            damping=damping,
            estimate_io=est,
            datum=datum,
            max_iterations=max_iterations,
            snooping=snooping,
        )
        size = None
        if image_size is not None:
            try:
                w_px, h_px = (int(v) for v in image_size.lower().split("x"))
            except ValueError:
                raise InputError(
                    f"--image-size '{image_size}' is not WIDTHxHEIGHT (e.g. 6000x4000)"
                ) from None
            size = (w_px, h_px)
        # A COLMAP model is a folder: describe its files.
        model_files = sorted(p for p in project.glob("*.txt")) if project.is_dir() else [project]
        inputs = [*model_files, *(f for f in (control, positions) if f)]
        failed: Exception | None = None
        with warnings.catch_warnings(record=True) as caught, progress.enabled(console):
            warnings.simplefilter("always", BundleWarning)
            with progress.stage(f"reading {project.name}"):
                if size is not None:
                    if project.suffix.lower() != ".txt":
                        raise InputError(
                            "--image-size is for PhotoModeler text exports only", path=project
                        )
                    proj = read_photomodeler(project, image_size_px=size)
                else:
                    proj = read_project(project)
                if model is not None:
                    proj = proj.with_model(model)
                if control is not None:
                    proj = proj.with_control(read_control_points(control, control_columns))
                if default_io is not None:
                    proj = proj.with_default_io(default_io)
                if resect:
                    proj = proj.replace(needs_resection=True)
                if positions is not None:
                    proj = proj.with_prior_positions(read_camera_positions(positions))
            t_read = time.perf_counter() - t0
            with progress.stage("bundle adjustment"):
                try:
                    result = bundle_adjust(proj, params)
                except HeraclesError as exc:
                    if not hasattr(exc, "diagnosis"):
                        raise
                    failed = exc
        notes = [str(w.message) for w in caught if issubclass(w.category, BundleWarning)]
        if failed is not None:
            # A failed run still writes its diagnosis, then reports the error.
            with output_dir(out, force=force) as stage:
                write_failure_report(failed.diagnosis, stage, proj, str(failed))
                write_run_json(
                    stage,
                    step="bundle",
                    parameters=params,
                    inputs=inputs,
                    timings={"read": t_read},
                    counts={"images": proj.n_images, "points": proj.n_points},
                    extra={"failed": True, "error": str(failed), "warnings": notes},
                )
                print_run_warnings(stage)
            raise failed
        if not result.converged:  # pragma: no cover - bundle_adjust raises instead
            raise InputError("bundle adjustment did not converge", path=project)
        with output_dir(out, force=force) as stage, progress.enabled(console):
            with progress.stage("writing the reports and plots"):
                paths = write_reports(result, stage, plots=not no_plots)
            timings = {"read": t_read, **result.timings}
            write_run_json(
                stage,
                step="bundle",
                parameters=params,
                inputs=inputs,
                timings=timings,
                counts={
                    "images": result.project.n_images,
                    "points": result.project.n_points,
                    "image_observations": result.project.n_observations,
                },
                extra={
                    "sigma0": result.sigma0,
                    "redundancy": result.redundancy,
                    "warnings": notes,
                },
            )
            print_run_warnings(stage)
        table = Table(title=f"bundle: {project.name}", show_header=False)
        table.add_row("sigma0", f"{result.sigma0:.6g}")
        table.add_row("redundancy", f"{result.redundancy:,}")
        table.add_row(
            "parameters",
            f"{result.n_parameters:,} ({int(result.network.io_free.sum())} IO, "
            f"{int(result.network.eo_free.sum())} EO, {int(result.network.op_free.sum())} OP)",
        )
        table.add_row("observations", f"{result.n_observations:,}")
        table.add_row("iterations", f"{result.iterations} ({params.damping})")
        table.add_row("datum", result.network.datum)
        for ci, cam in enumerate(result.project.cameras):
            free = result.network.io_free[ci]
            for j in range(len(free)):
                if free[j]:
                    from pyheracles.bundle.camera import IO_NAMES

                    table.add_row(
                        f"camera {cam.id} {IO_NAMES[j]}",
                        f"{result.io[ci, j]:.6g} ± {result.io_std[ci, j]:.3g}",
                    )
        table.add_row("time", f"{time.perf_counter() - t0:.1f} s")
        table.add_row("outputs", ", ".join(p.name for p in paths.values()) + ", run.json")
        console.print(table)
