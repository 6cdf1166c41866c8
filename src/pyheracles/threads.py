"""Independent pieces of numpy work on the machine's cores, with threads.

Why threads and not processes: numpy's copies, arithmetic and sorts release the
interpreter lock on large arrays (so do scipy's tree queries and lazrs), so pieces of
work that share nothing but their inputs (the fields of a LAS record, the cookies of the
supports) run on both cores of a two-core machine without copying a 10 M point cloud
into other processes.  :func:`map_threads` returns what the same calls in a loop return,
in the same order: each piece runs the same code on the same inputs, so the results do
not depend on the number of threads.

``HERACLES_THREADS`` (an integer) sets the number of threads; 1 runs every piece in the
calling thread (to compare, or on a machine whose other cores are taken).

Examples
--------
>>> map_threads(lambda k: k * k, range(5), workers=2)
[0, 1, 4, 9, 16]
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable
from concurrent.futures import ThreadPoolExecutor
from typing import TypeVar

__all__ = ["map_threads", "n_workers"]

T = TypeVar("T")
R = TypeVar("R")

#: At most this many threads: the pieces are memory-bound beyond a few cores.
MAX_WORKERS = 4


def n_workers() -> int:
    """Threads to use: ``HERACLES_THREADS`` if set, else the cores this process may run
    on, at most :data:`MAX_WORKERS`."""
    env = os.environ.get("HERACLES_THREADS", "").strip()
    if env:
        try:
            return max(1, int(env))
        except ValueError:
            pass
    try:
        cores = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        cores = os.cpu_count() or 1
    return max(1, min(cores, MAX_WORKERS))


def map_threads(fn: Callable[[T], R], items: Iterable[T], *, workers: int | None = None) -> list[R]:
    """``[fn(x) for x in items]``, the calls spread over up to ``workers`` threads
    (default :func:`n_workers`).

    The pieces must not write to the same memory (each its own output array, or its own
    columns of one).  An exception of a piece is raised here, as in the loop.  A new
    pool per call: a piece may call :func:`map_threads` itself without waiting for a
    thread of a pool it holds.
    """
    todo = list(items)
    k = n_workers() if workers is None else max(1, workers)
    if k == 1 or len(todo) < 2:
        return [fn(x) for x in todo]
    with ThreadPoolExecutor(max_workers=min(k, len(todo))) as pool:
        return list(pool.map(fn, todo))
