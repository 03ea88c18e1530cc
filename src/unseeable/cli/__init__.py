"""The ``unseeable`` command line: a thin typer layer over the library.

Each stage's commands live in their own module here and only call library
functions. :func:`main` is the one place where an :class:`UnseeableError`
becomes a one-line message on stderr and exit code 1.
"""

from __future__ import annotations

import logging
import sys

import typer

from unseeable.errors import UnseeableError

app = typer.Typer(
    name="unseeable",
    help="Estimate Lincoln Log assemblies from photographs, including the logs no camera sees.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)


#: Command modules, imported for their side effect of adding commands to ``app``.
COMMAND_MODULES = ("core", "grammar", "render", "vision", "corpus", "experiment")


def _register() -> None:
    import importlib

    for name in COMMAND_MODULES:
        importlib.import_module(f"unseeable.cli.{name}")


@app.callback()
def _root() -> None:
    """Estimate Lincoln Log assemblies from photographs, including the logs no camera sees."""


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``unseeable`` console script.

    Usage errors are reported by typer (exit code 2); an :class:`UnseeableError`
    from the library becomes ``error: <message>`` on one line and exit code 1.
    """
    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    _register()
    try:
        app(args=argv, prog_name="unseeable")
    except SystemExit as done:  # typer's standalone mode always exits
        code = done.code
        return code if isinstance(code, int) else (0 if code is None else 1)
    except UnseeableError as err:
        typer.echo(f"error: {err}", err=True)
        return 1
    except KeyboardInterrupt:
        typer.echo("error: interrupted", err=True)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
