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


def _register() -> None:
    # Import command modules for their side effect of adding commands to ``app``.
    from unseeable.cli import core  # noqa: F401


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``unseeable`` console script."""
    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    _register()
    try:
        app(args=argv, standalone_mode=False)
    except UnseeableError as err:
        typer.echo(f"error: {err}", err=True)
        return 1
    except (typer.Abort, KeyboardInterrupt):
        typer.echo("error: interrupted", err=True)
        return 1
    except Exception as err:  # click usage errors
        import click

        if isinstance(err, click.exceptions.UsageError):
            typer.echo(f"error: {err.format_message()}", err=True)
            return 2
        if isinstance(err, click.exceptions.Exit):
            return err.exit_code
        raise
    return 0


if __name__ == "__main__":
    sys.exit(main())
