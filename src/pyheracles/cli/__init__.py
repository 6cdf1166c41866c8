"""The ``heracles`` command: one subcommand per step, clear errors, exit code 2 on bad input.

Each step registers its subcommands from its own module ``pyheracles.cli.<name>``
(listed in :data:`COMMAND_MODULES`), which keeps this file small and lets the
heavy step modules load only when their command runs.
"""

from __future__ import annotations

import sys
from importlib import import_module

import click
import typer
from rich.console import Console

from pyheracles.errors import HeraclesError, InputError

__all__ = ["COMMAND_MODULES", "app", "main", "run"]

#: Modules of ``pyheracles.cli`` that add subcommands through ``register(app)``.
COMMAND_MODULES: list[str] = [
    "building",
    "bundle",
    "complex",
    "demo",
    "evaluate",
    "framework",
    "ground",
    "registration",
    "pipeline",
]

app = typer.Typer(
    name="heracles",
    help="pyheracles: segment heritage point clouds across scales and check data quality.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    rich_markup_mode="rich",
)
err_console = Console(stderr=True, soft_wrap=True)


@app.callback()
def _root(
    version: bool = typer.Option(False, "--version", help="Print the version and exit."),
) -> None:
    """pyheracles command line."""
    if version:
        from pyheracles import __version__

        typer.echo(f"pyheracles {__version__}")
        raise typer.Exit(0)


for _name in COMMAND_MODULES:
    import_module(f"pyheracles.cli.{_name}").register(app)


def main(argv: list[str] | None = None) -> int:
    """Run the CLI; bad input gives a one-paragraph message and exit code 2."""
    try:
        app(args=argv, standalone_mode=False)
    except InputError as exc:
        err_console.print(f"[bold red]error:[/] {exc}", highlight=False)
        return 2
    except click.exceptions.Abort:
        err_console.print("[red]aborted[/]")
        return 130
    except click.exceptions.Exit as exc:
        return int(exc.exit_code or 0)
    except click.ClickException as exc:
        exc.show()
        return 2
    except HeraclesError as exc:
        err_console.print(f"[bold red]failed:[/] {exc}", highlight=False)
        return 1
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())


def run() -> None:
    """Console-script entry point."""
    sys.exit(main())
