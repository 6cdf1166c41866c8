"""Progress bars for long work, shown only when the CLI asks for them.

Library code wraps its long loops in :func:`track`; by default that is a plain
pass-through (library code never prints).  The CLI enables rich progress bars
for the duration of a command with :func:`enabled`.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from typing import Any, TypeVar

__all__ = ["enabled", "track"]

T = TypeVar("T")
_PROGRESS: ContextVar[Any] = ContextVar("pyheracles_progress", default=None)


@contextmanager
def enabled(console: Any = None) -> Iterator[None]:
    """Show progress bars (rich) for every :func:`track` inside this block."""
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    progress = Progress(
        TextColumn("[bold blue]{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        TimeRemainingColumn(),
        console=console,
        transient=True,
    )
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
