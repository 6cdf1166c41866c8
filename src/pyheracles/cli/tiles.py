"""``heracles complex`` and ``heracles ground`` on many tiles (:mod:`pyheracles.tiles`)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import typer

from pyheracles.cli.common import console, print_objects
from pyheracles.errors import InputError


def _check_out(out: Path, marker: str = ".work") -> None:
    """OUT must be empty, new, or an earlier tiled run's folder (then it is resumed)."""
    if out.exists() and not out.is_dir():
        raise InputError("the output path is a file", path=out, hint="give a folder")
    if out.is_dir() and any(out.iterdir()) and not (out / marker).is_dir():
        raise InputError(
            "the output folder is not empty and holds no earlier tiled run to resume",
            path=out,
            hint="give a new or empty folder",
        )


def complex_tiles(
    source: str,
    layer_specs: list[str],
    out: Path,
    *,
    params: Any,
    workers: int | None,
    scheduler: str | None,
    buffer_m: float | None,
    reproject: bool,
    fix_invalid: bool,
    cloud_crs: str | None,
    per_object: str | None,
    cityjson: bool,
) -> None:
    """Run step 1 over tiles, print progress and a summary; exit 2 if a tile failed."""
    from pyheracles.io import read_layer
    from pyheracles.pipeline import parse_layer_spec
    from pyheracles.tiles import read_catalog, run_tiles

    if per_object is not None or cityjson:
        raise InputError(
            "--per-object and --cityjson are not available on tiles yet",
            hint="run them on one tile's folder (tiles/<tile>/), or drop the option",
        )
    _check_workers(workers, scheduler)
    _check_out(out)
    catalog = read_catalog(source, crs=cloud_crs)
    for path, reason in catalog.unreadable:
        console.print(f"[red]unreadable tile[/] {path}: {reason}", highlight=False)
    for note in catalog.notes:
        console.print(f"[yellow]note:[/] {note}", highlight=False)
    layers = {}
    for spec in layer_specs:
        name, path, lay = parse_layer_spec(spec)
        if name in layers:
            raise InputError(f"layer name {name!r} given twice", hint="give each its own NAME")
        layers[name] = read_layer(path, lay)
    console.print(
        f"{len(catalog.tiles)} tiles, {catalog.n_points:,} points"
        + (f"; Dask scheduler {scheduler}" if scheduler else "")
        + (f"; {workers} local workers" if workers else "")
    )
    result = run_tiles(
        catalog, layers, out, params=params, buffer_m=buffer_m, workers=workers,
        scheduler=scheduler, reproject=reproject, fix_invalid=fix_invalid,
        progress=_progress_printer(),
    )  # fmt: skip
    if len(result.objects):
        print_objects(result.objects, ["instance", "class", "source_fid", "n_points", "tile"])
    console.print(
        f"time {result.timings['total']:.1f} s, {result.points_per_s / 1e3:,.0f} k points/s, "
        f"peak memory per worker {result.peak_rss_mb:,.0f} MB"
    )
    for key, path in result.paths.items():
        console.print(f"[green]wrote[/] {key}: {path}")
    _report_failures(result.failed, len(result.status) + len(catalog.unreadable))


def _check_workers(workers: int | None, scheduler: str | None) -> None:
    if workers is not None and workers < 1:
        raise InputError(f"--workers must be >= 1, got {workers}")
    if scheduler is not None and not scheduler.strip():
        raise InputError(
            "--scheduler needs the address of a running Dask scheduler",
            hint="e.g. --scheduler tcp://HOST:8786, or --workers N for a cluster on this machine",
        )
    if workers is not None and scheduler is not None:
        raise InputError(
            "--workers and --scheduler exclude each other",
            hint="--workers N starts a cluster here; --scheduler uses a running one",
        )


def _progress_printer() -> Any:
    """A progress callback printing tiles done / total, points/s and the dashboard once."""
    shown = {"dashboard": False}

    def progress(event: dict[str, Any]) -> None:
        if event["dashboard"] and not shown["dashboard"]:
            console.print(f"Dask dashboard: {event['dashboard']}", highlight=False)
            shown["dashboard"] = True
        rate = event["points"] / event["seconds"] if event["seconds"] > 0 else 0.0
        if event["done"]:
            console.print(
                f"{event['phase']}: {event['done']}/{event['total']} tiles, "
                f"{rate / 1e3:,.0f} k points/s",
                highlight=False,
            )

    return progress


def _report_failures(failed: dict[str, str], total: int) -> None:
    """Name every failed tile; exit 2 if there is one (after the others finished)."""
    for name, why in failed.items():
        console.print(f"[red]tile {name}[/] {why}", highlight=False)
    if failed:
        console.print(
            f"[red]{len(failed)} of {total} tiles failed[/]; fix them and run the same "
            "command again to resume"
        )
        raise typer.Exit(2)


def ground_tiles(
    source: str,
    out: Path,
    *,
    method: str,
    max_object_size_m: float | None,
    dtm_cell_m: float | None,
    cloud_crs: str | None,
    workers: int | None,
    scheduler: str | None,
    buffer_m: float | None,
) -> None:
    """The ground of many tiles and the DTM mosaic; exit 2 if a tile failed."""
    from pyheracles.tiles import read_catalog, run_ground_tiles

    _check_workers(workers, scheduler)
    _check_out(out, "tiles")
    catalog = read_catalog(source, crs=cloud_crs)
    for path, reason in catalog.unreadable:
        console.print(f"[red]unreadable tile[/] {path}: {reason}", highlight=False)
    for note in catalog.notes:
        console.print(f"[yellow]note:[/] {note}", highlight=False)
    console.print(f"{len(catalog.tiles)} tiles, {catalog.n_points:,} points")
    result = run_ground_tiles(
        catalog, out, method=method, max_object_size_m=max_object_size_m, dtm_cell_m=dtm_cell_m,
        buffer_m=buffer_m, workers=workers, scheduler=scheduler, progress=_progress_printer(),
    )  # fmt: skip
    console.print(
        f"time {result.timings['total']:.1f} s, {result.points_per_s / 1e3:,.0f} k points/s, "
        f"peak memory per worker {result.peak_rss_mb:,.0f} MB"
    )
    for key, path in result.paths.items():
        console.print(f"[green]wrote[/] {key}: {path}")
    _report_failures(result.failed, len(result.status) + len(catalog.unreadable))
