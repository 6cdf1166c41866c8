"""Pieces shared by the subcommands: output folders and summary tables."""

from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from rich.console import Console
from rich.table import Table

from pyheracles.errors import InputError

console = Console()

__all__ = ["console", "output_dir", "print_counts", "print_objects"]


@contextmanager
def output_dir(path: Path, *, force: bool = False) -> Iterator[Path]:
    """A staging folder that becomes ``path`` only when the command succeeds.

    Outputs are written into a hidden sibling folder; on success its files are
    moved into ``path`` (created if needed), on any error the staging folder is
    deleted, so a failed run leaves no partial output behind.  A non-empty
    ``path`` is refused unless ``force``.
    """
    if path.exists() and not path.is_dir():
        raise InputError("output path exists and is not a folder", path=path)
    if path.is_dir() and any(path.iterdir()) and not force:
        raise InputError(
            "output folder is not empty", path=path, hint="choose a new folder or pass --force"
        )
    path.parent.mkdir(parents=True, exist_ok=True)
    stage = Path(tempfile.mkdtemp(prefix=f".{path.name}.", suffix=".partial", dir=path.parent))
    try:
        yield stage
        path.mkdir(exist_ok=True)
        for item in stage.iterdir():
            target = path / item.name
            if target.is_dir() and not target.is_symlink():
                shutil.rmtree(target)
            os.replace(item, target)
    finally:
        shutil.rmtree(stage, ignore_errors=True)


def print_objects(objects: Any, columns: Sequence[str], *, limit: int = 40) -> None:
    """Print the first rows of an objects table."""
    cols = [c for c in columns if c in objects.columns]
    table = Table(title=f"{len(objects)} objects", show_lines=False)
    for c in cols:
        table.add_column(c, justify="right" if objects[c].dtype.kind in "iuf" else "left")
    for _, row in objects.head(limit).iterrows():
        table.add_row(
            *[f"{row[c]:.2f}" if isinstance(row[c], float) else str(row[c]) for c in cols]
        )
    console.print(table)
    if len(objects) > limit:
        console.print(f"... {len(objects) - limit} more rows in the objects table")


def print_counts(
    counts: Mapping[str, int], timings: Mapping[str, float], paths: Mapping[str, Path]
) -> None:
    """Print the conservation balance, timings and written files."""
    table = Table(title="points", show_header=False)
    for key in ("objects", "ground", "remainder", "total"):
        if key in counts:
            table.add_row(key, f"{counts[key]:,}")
    console.print(table)
    console.print(
        "time: "
        + ", ".join(f"{k} {v:.1f} s" for k, v in timings.items())
        + f" (total {sum(timings.values()):.1f} s)"
    )
    for key, path in paths.items():
        console.print(f"[green]wrote[/] {key}: {path}")
