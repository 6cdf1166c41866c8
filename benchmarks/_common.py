"""Helpers shared by the benchmark scripts: JSON output and timing."""

from __future__ import annotations

import json
import os
import resource
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

SHARED_DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"


def emit(**record: Any) -> dict[str, Any]:
    """Print one JSON line (dataset, metric, value, time_s, points_per_s, ...)."""

    def plain(v: Any) -> Any:
        if hasattr(v, "item"):
            return v.item()
        return v

    record = {k: plain(v) for k, v in record.items()}
    print(json.dumps(record), flush=True)
    return record


class Timer:
    """Elapsed wall-clock seconds of a ``with`` block (``.s``)."""

    s: float = 0.0


@contextmanager
def timer() -> Iterator[Timer]:
    t = Timer()
    start = time.perf_counter()
    try:
        yield t
    finally:
        t.s = time.perf_counter() - start


def cpu_s() -> float:
    """CPU seconds of this process and of its ended children so far: the supports step
    measures some supports and slabs in a forked child (:mod:`pyheracles.forks`), whose
    CPU time ``time.process_time`` does not count."""
    own = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def peak_rss_gb() -> float:
    """Peak resident memory of this process so far, GB."""
    kb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return kb / 1e6 if sys.platform != "darwin" else kb / 1e9


def run_cli(args: list[str]) -> dict[str, Any]:
    """Run ``heracles ARGS`` in a fresh process, as a user would: its wall-clock and CPU
    seconds, its own peak resident memory (GB) and its exit code.

    Wall time includes the interpreter's start, the imports, reading and writing.
    """
    import os
    import subprocess
    import tempfile

    # stderr into a file, not a pipe: a child writing more than a pipe holds would block
    # while this process waits for it to end
    with tempfile.TemporaryFile() as err:
        start = time.perf_counter()
        proc = subprocess.Popen(
            [sys.executable, "-m", "pyheracles", *args], stdout=subprocess.DEVNULL, stderr=err
        )
        _, status, usage = os.wait4(proc.pid, 0)  # its own resource usage, not the sum
        wall = time.perf_counter() - start
        proc.returncode = os.waitstatus_to_exitcode(status)  # reaped here, not by Popen
        err.seek(0)
        stderr = err.read().decode(errors="replace")
    scale = 1e6 if sys.platform != "darwin" else 1e9
    return {
        "wall_s": wall,
        "cpu_s": usage.ru_utime + usage.ru_stime,
        "peak_rss_gb": usage.ru_maxrss / scale,
        "exit_code": proc.returncode,
        "stderr_tail": stderr[-500:],
    }


INTERRUPTED = "interrupted (Ctrl-C): the output ends at its last complete line"


def interruptible(main: Any) -> None:
    """Run a benchmark's ``main()``; Ctrl-C ends it with one line and exit code 130
    (what was printed before stays whole), not a traceback. An integer that ``main``
    returns is the exit code."""
    try:
        code = main()
    except KeyboardInterrupt:
        print(INTERRUPTED, file=sys.stderr)
        sys.exit(130)
    if code:
        sys.exit(code)


def ctrl_c_at_import(kind: type[BaseException], value: BaseException, tb: Any) -> None:
    """``sys.excepthook`` for a Ctrl-C outside ``main()``: while a benchmark still
    imports its libraries (Open3D, Dask: seconds on a loaded machine), where
    `interruptible` cannot catch it. One line and exit code 130; any other error is
    printed as Python would."""
    if not issubclass(kind, KeyboardInterrupt):
        sys.__excepthook__(kind, value, tb)
        return
    sys.stdout.flush()
    print(INTERRUPTED, file=sys.stderr, flush=True)
    os._exit(130)  # sys.exit inside an excepthook is reported as the hook's own error


# Only when a benchmark script is the program (not when a test imports a benchmark).
if Path(sys.argv[0]).resolve().parent == Path(__file__).resolve().parent:
    sys.excepthook = ctrl_c_at_import
