"""Pieces shared by the subcommands: output folders, warnings and summary tables."""

from __future__ import annotations

import errno
import json
import os
import shutil
import tempfile
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager, suppress
from pathlib import Path
from typing import Any

from rich.console import Console
from rich.markup import escape
from rich.table import Table

from pyheracles.errors import InputError

console = Console()
#: Errors, warnings and notes: stderr, so that they survive ``> log.txt``.
err_console = Console(stderr=True, soft_wrap=True)

__all__ = [
    "STAGING_PREFIX",
    "console",
    "err_console",
    "output_dir",
    "print_counts",
    "print_objects",
    "print_run_warnings",
    "run_warnings",
    "set_reports",
    "write_model_ifc",
    "write_reports",
]

#: Name prefix of the hidden staging folder of :func:`output_dir`.
STAGING_PREFIX = ".heracles-partial-"


def _unwritable(path: Path, exc: OSError, what: str) -> InputError:
    reason = exc.strerror or str(exc)
    if exc.errno == errno.ENOSPC:
        hint = "free some space or choose another folder with -o"
    elif exc.errno == errno.EROFS:
        hint = "the file system is read-only; choose another folder with -o"
    else:
        hint = "choose a folder you can write to with -o, or fix its permissions"
    return InputError(f"cannot {what} ({reason})", path=path, hint=hint)


def _make_parents(folder: Path, output: Path) -> list[Path]:
    """Create ``folder`` and its missing parents; return the folders created (deepest last)."""
    missing: list[Path] = []
    p = folder
    while not p.exists():
        missing.append(p)
        if p.parent == p:
            break
        p = p.parent
    if p.exists() and not p.is_dir():
        raise InputError(
            f"cannot create the output folder: {p} is a file",
            path=output,
            hint="choose an output folder that is not inside a file, with -o",
        )
    created: list[Path] = []
    for d in reversed(missing):
        try:
            d.mkdir()
        except FileExistsError:
            continue
        except OSError as exc:
            _remove_empty(created)
            raise _unwritable(output, exc, "create the output folder") from exc
        created.append(d)
    return created


def _remove_empty(folders: list[Path]) -> None:
    for d in reversed(folders):
        with suppress(OSError):
            d.rmdir()


def _move(src: Path, dst: Path) -> None:
    """Rename ``src`` onto ``dst`` (replacing it); copy when they are on different devices."""
    if dst.is_dir() and not dst.is_symlink():
        shutil.rmtree(dst)
    try:
        os.replace(src, dst)
    except OSError as exc:
        if exc.errno != errno.EXDEV:
            raise
        shutil.move(str(src), str(dst))


def _relocate(value: Any, old: str, new: str) -> Any:
    if isinstance(value, str):
        return new + value[len(old) :] if value.startswith(old) else value
    if isinstance(value, list):
        return [_relocate(v, old, new) for v in value]
    if isinstance(value, dict):
        return {k: _relocate(v, old, new) for k, v in value.items()}
    return value


def _relocate_run_json(stage: Path, final: Path) -> None:
    """Make run.json paths that point into the staging folder point to the final folder."""
    from pyheracles.io.atomic import atomic_write_json

    old = str(stage.resolve())
    for run in stage.rglob("run.json"):
        text = run.read_text(encoding="utf-8")
        if old not in text:
            continue
        atomic_write_json(run, _relocate(json.loads(text), old, str(final.resolve())))


@contextmanager
def output_dir(path: Path, *, force: bool = False) -> Iterator[Path]:
    """A staging folder that becomes ``path`` only when the command succeeds.

    Outputs are written into a hidden staging folder on the file system of
    ``path`` (so that the final moves are renames, also when ``path`` is a
    mount point such as a USB drive or a container volume): inside ``path``
    when it exists, beside it when it does not.  On success the staged files
    become ``path``'s; on any error or interrupt the staging folder (and any
    folder created for it) is deleted, so a failed run leaves no partial
    output behind.  A non-empty ``path`` is refused unless ``force``.
    Unwritable, read-only or full locations raise :class:`InputError`.
    """
    path = Path(path)
    try:
        if path.exists() and not path.is_dir():
            raise InputError(
                "output path exists and is not a folder", path=path, hint="choose a folder with -o"
            )
        exists = path.is_dir()
        ignored = (".DS_Store", "Thumbs.db")
        content = [p for p in path.iterdir() if p.name not in ignored] if exists else []
    except OSError as exc:
        raise _unwritable(path, exc, "use the output folder") from exc
    if any(not p.name.startswith(STAGING_PREFIX) for p in content) and not force:
        raise InputError(
            "output folder is not empty", path=path, hint="choose a new folder or pass --force"
        )
    created = [] if exists else _make_parents(path.parent, path)
    where = path if exists else path.parent
    try:
        stage = Path(tempfile.mkdtemp(prefix=STAGING_PREFIX, dir=where))
    except OSError as exc:
        _remove_empty(created)
        what = "write into the output folder" if exists else "create the output folder"
        raise _unwritable(path, exc, what) from exc
    moved: list[Path] = []
    done = False
    try:
        try:
            yield stage
        except OSError as exc:  # name the file as the user will look for it, not the staged one
            renamed = _unstaged(exc, stage, path)
            if renamed is exc:
                raise
            raise renamed from exc
        try:
            _relocate_run_json(stage, path)
            write_reports(stage, path)
            if not (not exists and _rename_into_place(stage, path)):
                path.mkdir(exist_ok=True)
                for item in sorted(stage.iterdir()):
                    target = path / item.name
                    _move(item, target)
                    moved.append(target)
        except OSError as exc:
            raise _unwritable(Path(exc.filename or path), exc, "write the output") from exc
        done = True
    finally:
        if not done:
            for target in moved:  # a failure while moving up: take back what was moved
                with suppress(OSError):
                    shutil.rmtree(target) if target.is_dir() else target.unlink()
        shutil.rmtree(stage, ignore_errors=True)
        if not done:
            if not exists:
                with suppress(OSError):
                    path.rmdir()
            _remove_empty(created)


#: Whether commands write report.html (the root option ``--no-report`` turns it off; so
#: does the environment variable ``HERACLES_NO_REPORT=1``).
_REPORTS = {"enabled": True}


def set_reports(enabled: bool) -> None:
    """Turn the writing of ``report.html`` into output folders on or off."""
    _REPORTS["enabled"] = bool(enabled)


def write_reports(stage: Path, final: Path) -> list[Path]:
    """Write ``report.html`` beside every ``run.json`` of a staged output folder.

    A report that cannot be built does not cost the run its results: the
    reason is printed as a warning and the other outputs are kept.
    """
    if not _REPORTS["enabled"] or os.environ.get("HERACLES_NO_REPORT", "") not in ("", "0"):
        return []
    from pyheracles.progress import stage as spinner
    from pyheracles.report.html import build_report

    written = []
    for run in sorted(stage.rglob("run.json")):
        rel = run.parent.relative_to(stage)
        try:
            with spinner(f"report {(final / rel).as_posix()}/report.html"):
                written.append(build_report(run.parent))
        except (KeyboardInterrupt, SystemExit):
            raise
        except Exception as exc:  # the results stand without their report; say why
            err_console.print(
                f"[yellow]warning:[/] report.html not written in {escape(str(final / rel))}: "
                f"{escape(type(exc).__name__)}: {escape(str(exc))}",
                highlight=False,
            )
    return written


def _unstaged(exc: OSError, stage: Path, path: Path) -> OSError:
    """``exc`` with its file names moved from the staging folder to the output folder."""
    names = []
    for name in (exc.filename, exc.filename2):
        try:
            names.append(str(path / Path(name).relative_to(stage)) if name else name)
        except (TypeError, ValueError):
            names.append(name)
    if exc.errno is None or names == [exc.filename, exc.filename2]:
        return exc
    return OSError(exc.errno, exc.strerror or str(exc), names[0], None, names[1])


def _rename_into_place(stage: Path, path: Path) -> bool:
    """Rename the staging folder to the (absent) output folder; False when that fails."""
    if path.exists():
        return False
    mask = os.umask(0)
    os.umask(mask)
    os.chmod(stage, 0o777 & ~mask)  # mkdtemp makes it private (0700)
    try:
        os.rename(stage, path)
    except OSError:
        return False
    return True


def write_model_ifc(
    stage: Path,
    parts: Sequence[tuple[Path, int | None]] | None = None,
    *,
    step1_dir: Path | None = None,
) -> Path:
    """``model.ifc`` of an output folder (the ``--ifc`` option of supports, beams, walls, pipeline).

    ``parts`` are the step-2 result folders and their step-1 instances (a pipeline
    run); by default ``stage`` itself.  The exporter's notes are added to the
    ``notes`` of ``stage/run.json`` (so :func:`print_run_warnings` shows them) with
    the elements written under ``ifc``.
    """
    from pyheracles.export.ifc import export_ifc_folders
    from pyheracles.provenance import add_to_run_json

    path = stage / "model.ifc"
    rep = export_ifc_folders(list(parts or [(stage, None)]), path, step1_dir=step1_dir,
                             name=f"pyheracles: {stage.name}")  # fmt: skip
    add_to_run_json(stage / "run.json", "notes", [f"IFC: {n}" for n in rep.notes],
                    ifc={"path": "model.ifc", "elements": dict(rep.elements)})  # fmt: skip
    return path


def run_warnings(folder: Path) -> list[str]:
    """Warnings and notes recorded in the ``run.json`` files of ``folder`` (recursively).

    Nested records (``step2/supports/hall/run.json``) are prefixed with their
    folder relative to ``folder``; a message recorded under two keys is listed once.
    """
    found: list[str] = []
    runs = sorted(Path(folder).rglob("run.json"), key=lambda p: (len(p.parts), str(p)))
    for run in runs:
        try:
            record = json.loads(run.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            continue
        if not isinstance(record, Mapping):
            continue
        rel = run.parent.relative_to(folder).as_posix()
        prefix = "" if rel == "." else f"{rel}: "
        for key in ("warnings", "notes", "note"):
            value = record.get(key)
            items = [value] if isinstance(value, str) else value
            if isinstance(items, list):
                found.extend(f"{prefix}{item}" for item in items if item)
    return list(dict.fromkeys(found))  # a message kept as a warning and as a note: once


def print_run_warnings(folder: Path) -> list[str]:
    """Print every warning and note that went to ``run.json`` (stderr, yellow ``warning:``).

    Every command calls this once its outputs are written (``folder`` is the
    staging folder or the final output folder), so that what the provenance
    record says is also seen on the screen.  Returns the messages printed.
    """
    found = run_warnings(folder)
    for message in found:
        err_console.print(f"[yellow]warning:[/] {escape(message)}", highlight=False)
    return found


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
