"""Progress bars and stage spinners for long work, shown only when the CLI asks for them.

Library code wraps its long loops in :func:`track` and its long single steps in
:func:`stage`; by default both are plain pass-throughs (library code never
prints).  The CLI enables rich progress for the duration of a command with
:func:`enabled`; ``heracles --quiet`` turns it off (:func:`set_quiet`), and
nothing is drawn when the console is not a terminal (logs, pipes, tests).
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from typing import Any, TypeVar

__all__ = ["enabled", "is_quiet", "set_quiet", "stage", "track"]

T = TypeVar("T")
_PROGRESS: ContextVar[Any] = ContextVar("pyheracles_progress", default=None)
_QUIET = False


def set_quiet(quiet: bool = True) -> None:
    """Turn progress display off (``True``) or back on for every later :func:`enabled`."""
    global _QUIET
    _QUIET = bool(quiet)


def is_quiet() -> bool:
    """Whether progress display is turned off (``heracles --quiet``)."""
    return _QUIET


def _columns() -> list[Any]:
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        SpinnerColumn,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    class _Counted(MofNCompleteColumn):
        def render(self, task: Any) -> Any:
            from rich.text import Text

            return Text("") if task.total is None else super().render(task)

    class _Remaining(TimeRemainingColumn):
        def render(self, task: Any) -> Any:
            from rich.text import Text

            return Text("") if task.total is None else super().render(task)

    return [
        SpinnerColumn(),
        TextColumn("[bold blue]{task.description}"),
        BarColumn(),
        _Counted(),
        TimeElapsedColumn(),
        _Remaining(),
    ]


@contextmanager
def enabled(console: Any = None) -> Iterator[None]:
    """Show progress bars and spinners (rich) for every :func:`track` / :func:`stage` inside.

    A no-op when progress is turned off (:func:`set_quiet`), when the console
    is not a terminal, or when progress is already enabled (nested blocks).
    """
    if _QUIET or _PROGRESS.get() is not None:
        yield
        return
    from rich.console import Console
    from rich.progress import Progress

    con = console if console is not None else Console(stderr=True)
    if not con.is_terminal:
        yield
        return
    progress = Progress(*_columns(), console=con, transient=True)
    token = _PROGRESS.set(progress)
    try:
        with progress:
            yield
    finally:
        _PROGRESS.reset(token)


def track(iterable: Iterable[T], description: str, total: int | None = None) -> Iterator[T]:
    """Iterate, advancing a progress bar when one is enabled."""
    progress = _PROGRESS.get()
    if progress is None:
        yield from iterable
        return
    if total is None and hasattr(iterable, "__len__"):
        total = len(iterable)  # type: ignore[arg-type]
    task = progress.add_task(description, total=total)
    try:
        for item in iterable:
            yield item
            progress.advance(task)
    finally:
        progress.remove_task(task)


@contextmanager
def stage(name: str) -> Iterator[None]:
    """Show a spinner named ``name`` while the block runs (when progress is enabled).

    Examples
    --------
    >>> with stage("fitting cuboids"):  # no-op outside ``enabled()``
    ...     pass
    """
    progress = _PROGRESS.get()
    if progress is None:
        yield
        return
    task = progress.add_task(name, total=None)
    try:
        yield
    finally:
        progress.remove_task(task)
