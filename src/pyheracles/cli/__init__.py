"""The ``heracles`` command: one subcommand per step, clear errors, exit code 2 on bad input.

Each step registers its subcommands from its own module ``pyheracles.cli.<name>``
(listed in :data:`COMMAND_MODULES`), which keeps this file small and lets the
heavy step modules load only when their command runs.

Exit codes of :func:`main`: 0 success, 2 bad input or usage (a short message,
never a traceback), 1 a failure that is not the input's fault, 130 interrupted
(Ctrl-C; no output is left behind).
"""

from __future__ import annotations

import errno
import os
import signal
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager, suppress
from importlib import import_module
from typing import Annotated, Any

import typer

from pyheracles.cli.common import err_console
from pyheracles.errors import HeraclesError, InputError

__all__ = ["COMMAND_MODULES", "app", "main", "run"]

#: Modules of ``pyheracles.cli`` that add subcommands through ``register(app)``.
COMMAND_MODULES: list[str] = [
    "building",
    "bundle",
    "complex",
    "demo",
    "evaluate",
    "beams",
    "ground",
    "registration",
    "pipeline",
    "report",
    "simulate",
    "walls",
    "roofs",
    "export",
]

app = typer.Typer(
    name="heracles",
    help="pyheracles: segment heritage point clouds across scales and check data quality.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    rich_markup_mode="rich",
)

#: Options of the root callback that :func:`main` reads back after the command.
_STATE: dict[str, bool] = {"debug": False}


def _exception_classes(*names: str) -> tuple[type[BaseException], ...]:
    """The classes called ``names`` in every click flavour present.

    typer >= 0.20 bundles its own click (``typer._click``) whose exceptions are
    not the ``click`` package's; older typer uses ``click`` itself.  Both are
    caught, whichever is installed.
    """
    found: list[type[BaseException]] = []
    for module in ("typer.exceptions", "typer._click.exceptions", "click.exceptions"):
        try:
            mod = import_module(module)
        except ImportError:
            continue
        for name in names:
            cls = getattr(mod, name, None)
            if isinstance(cls, type) and issubclass(cls, BaseException) and cls not in found:
                found.append(cls)
    for name in names:  # typer.Exit / typer.Abort, whatever module they live in
        cls = getattr(typer, name, None)
        if isinstance(cls, type) and issubclass(cls, BaseException) and cls not in found:
            found.append(cls)
    return tuple(found)


_CLICK_ERRORS = _exception_classes("ClickException")
_EXIT = _exception_classes("Exit")
_ABORT = _exception_classes("Abort")

#: OSError numbers the user can fix (exit code 2), with what to do.
_OS_HINTS: dict[int, str] = {
    errno.ENOENT: "check the path",
    errno.ENOTDIR: "a part of the path is a file, not a folder; check the path",
    errno.EISDIR: "give a file, not a folder",
    errno.EEXIST: "choose another output folder with -o",
    errno.EACCES: "choose a location you can read/write, or fix its permissions",
    errno.EPERM: "choose a location you can read/write, or fix its permissions",
    errno.EROFS: "the file system is read-only; choose another output folder with -o",
    errno.ENOSPC: "free some space or choose another output folder with -o",
    errno.EDQUOT: "free some space (disk quota) or choose another output folder with -o",
    errno.ENAMETOOLONG: "use a shorter path",
    errno.ELOOP: "check the symbolic links of the path",
    errno.EFBIG: "the file is too large for this file system; choose another with -o",
}


def _version_callback(value: bool) -> None:
    if value:
        from pyheracles import __version__

        typer.echo(f"pyheracles {__version__}")
        raise typer.Exit(0)


@app.callback()
def _root(
    version: Annotated[
        bool,
        typer.Option(
            "--version",
            callback=_version_callback,
            is_eager=True,
            help="Print the version and exit.",
        ),
    ] = False,
    quiet: Annotated[
        bool, typer.Option("--quiet", "-q", help="No progress bars or spinners.")
    ] = False,
    debug: Annotated[
        bool,
        typer.Option("--debug", help="Show the traceback of an unexpected error (developers)."),
    ] = False,
    no_report: Annotated[
        bool,
        typer.Option("--no-report", help="Do not write report.html into output folders."),
    ] = False,
) -> None:
    """pyheracles command line."""
    from pyheracles.cli.common import set_reports
    from pyheracles.progress import set_quiet

    _STATE["debug"] = _STATE["debug"] or debug
    set_quiet(quiet)
    set_reports(not no_report)


for _name in COMMAND_MODULES:
    import_module(f"pyheracles.cli.{_name}").register(app)


@contextmanager
def watch_interrupts() -> Iterator[Callable[[], bool]]:
    """Note a Ctrl-C even when a library turns the KeyboardInterrupt into its own error.

    Installed only over Python's default SIGINT handler, in the main thread.  A Ctrl-C
    that lands inside a callback from C (llvmlite's object-cache notifier while numba
    compiles, a ctypes or pybind11 callback) cannot leave that callback: the library
    prints it as an "ignored" exception with its traceback and carries on.  While the
    watch is on, such a KeyboardInterrupt is not printed but delivered again to the
    main thread (``_thread.interrupt_main`` from a timer thread), where it stops the run as usual.
    """
    import _thread
    import threading

    hit = [False]
    in_hook = [False]

    def handler(signum: int, frame: Any) -> None:
        hit[0] = True
        if in_hook[0]:  # raising here would only print another "ignored" traceback
            later()
            return
        raise KeyboardInterrupt

    timers: list[threading.Timer] = []

    def later() -> None:
        # From a second thread, once the hook has returned: the main thread's next
        # bytecode outside the callback runs the handler, which raises there.  Cancelled
        # when the watch ends (a run that ended meanwhile is not interrupted after it).
        timer = threading.Timer(0.02, _thread.interrupt_main)
        timer.daemon = True
        timers.append(timer)
        timer.start()

    def redeliver(exc_type: type[BaseException] | None) -> bool:
        if exc_type is None or not issubclass(exc_type, KeyboardInterrupt):
            return False
        hit[0] = True
        later()
        return True

    def unraisable(info: Any) -> None:
        in_hook[0] = True
        try:
            if not redeliver(info.exc_type):
                previous_unraisable(info)
        finally:
            in_hook[0] = False

    def excepthook(exc_type: Any, exc: Any, tb: Any) -> None:
        in_hook[0] = True
        try:
            if not redeliver(exc_type):
                previous_excepthook(exc_type, exc, tb)
        finally:
            in_hook[0] = False

    previous = None
    previous_unraisable, previous_excepthook = sys.unraisablehook, sys.excepthook
    try:
        if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
            previous = signal.signal(signal.SIGINT, handler)
    except (ValueError, OSError):  # pragma: no cover - not the main thread
        previous = None
    if previous is not None:
        sys.unraisablehook, sys.excepthook = unraisable, excepthook
    try:
        yield lambda: hit[0]
    finally:
        for timer in timers:
            timer.cancel()
        if previous is not None:
            signal.signal(signal.SIGINT, previous)
            sys.unraisablehook, sys.excepthook = previous_unraisable, previous_excepthook


def _caused_by_interrupt(exc: BaseException) -> bool:
    seen: set[int] = set()
    e: BaseException | None = exc
    while e is not None and id(e) not in seen:
        if isinstance(e, KeyboardInterrupt):
            return True
        seen.add(id(e))
        e = e.__cause__ or e.__context__
    return False


def _say(kind: str, message: str) -> None:
    from rich.markup import escape

    err_console.print(f"[bold red]{kind}:[/] {escape(message)}", highlight=False)


def _one_line(exc: BaseException, limit: int = 300) -> str:
    text = " ".join(str(exc).split())
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _os_error(exc: OSError) -> int:
    """Report an OSError in one line naming its file; 2 when the user can fix it."""
    where = exc.filename if exc.filename is not None else None
    reason = exc.strerror or _one_line(exc) or type(exc).__name__
    text = f"{where}: {reason}" if where is not None else reason
    if exc.filename2 is not None:
        text += f" (and {exc.filename2})"
    hint = _OS_HINTS.get(exc.errno) if exc.errno is not None else None
    if hint is None:
        _say("failed", text)
        return 1
    _say("error", f"{text}. Fix: {hint}")
    return 2


def _report(exc: BaseException) -> int:
    """One line for an exception that reached the top; the exit code."""
    if isinstance(exc, InputError):
        _say("error", _one_line(exc, 2000))
        return 2
    if isinstance(exc, HeraclesError):
        _say("failed", _one_line(exc, 2000))
        return 1
    if isinstance(exc, OSError):
        return _os_error(exc)
    if isinstance(exc, MemoryError):
        _say("failed", "not enough memory; try a smaller or thinned cloud, or a larger machine")
        return 1
    _say(
        "internal error",
        f"{type(exc).__name__}: {_one_line(exc)} "
        "(please report; rerun with --debug for the traceback)",
    )
    return 1


def _interrupted() -> int:
    err_console.print("[yellow]interrupted:[/] no output written", highlight=False)
    return 130


def _exit_code(code: Any) -> int:
    if code is None:
        return 0
    if isinstance(code, int):
        return code
    _say("error", str(code))
    return 1


def main(argv: list[str] | None = None) -> int:
    """Run the CLI and return its exit code; never shows a traceback (unless ``--debug``).

    Bad input or usage: a short message, exit code 2; other failures: one
    line, exit code 1; Ctrl-C: one line, exit code 130, no output written.
    """
    from pyheracles.progress import set_quiet

    args = list(sys.argv[1:] if argv is None else argv)
    _STATE["debug"] = os.environ.get("HERACLES_DEBUG", "") not in ("", "0")
    set_quiet(False)
    with watch_interrupts() as interrupted:
        try:
            rv = app(args=args, prog_name="heracles", standalone_mode=False)
        except BaseException as exc:
            if isinstance(exc, KeyboardInterrupt) or interrupted() or _caused_by_interrupt(exc):
                return _interrupted()
            if isinstance(exc, _CLICK_ERRORS):
                exc.show()  # type: ignore[attr-defined]  # usage line + error
                return int(getattr(exc, "exit_code", 2))
            if isinstance(exc, _EXIT):
                return _exit_code(getattr(exc, "exit_code", 0))
            if isinstance(exc, _ABORT):
                _say("aborted", "no output written")
                return 1
            if isinstance(exc, SystemExit):
                return _exit_code(exc.code)
            if _STATE["debug"] or not isinstance(exc, Exception):
                raise
            return _report(exc)
        finally:
            set_quiet(False)
    code = rv if isinstance(rv, int) else 0
    if code == 130 or (code != 0 and interrupted()):
        return _interrupted()  # typer turns a KeyboardInterrupt into exit code 130
    return code


def run() -> None:
    """Console-script entry point (also ``python -m pyheracles``)."""
    code = main()
    if code == 130:
        # Interrupted: the outputs are already cleaned up.  Leave now, with exit code 130:
        # CPython would otherwise exit by SIGINT when the interrupt hit a C extension
        # (an import, a writer), and print the errors of half-closed writers at shutdown.
        import atexit

        with suppress(BaseException):
            atexit._run_exitfuncs()
        for stream in (sys.stdout, sys.stderr):
            with suppress(BaseException):
                stream.flush()
        os._exit(130)
    sys.exit(code)


if __name__ == "__main__":  # pragma: no cover
    run()
