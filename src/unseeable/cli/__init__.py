"""The ``unseeable`` command line: a thin typer layer over the library.

Each stage's commands live in their own module here and only call library
functions. :func:`main` is the one place where an error becomes a one-line
message on stderr and an exit code:

====  ==========================================================================
code  meaning
====  ==========================================================================
0     done
1     an error: a bad input file or option, an output that cannot be written
      (:class:`~unseeable.errors.UnseeableError`), or an interrupt
2     bad usage: an unknown option, a missing argument (typer's own)
3     no answer within the time limit (:class:`TimeLimitReached`): ``estimate``
      found no structure, ``grammar count`` did not finish
====  ==========================================================================
"""

from __future__ import annotations

import logging
import sys
import warnings
from pathlib import Path

import typer
from typer.core import TyperCommand, TyperGroup

from unseeable.errors import TimeLimitReached, UnseeableError

__all__ = ["app", "main", "TimeLimitReached", "EXIT_ERROR", "EXIT_USAGE", "EXIT_TIME_LIMIT"]

app = typer.Typer(
    name="unseeable",
    help="Estimate Lincoln Log assemblies from photographs, including the logs no camera sees.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)

#: Exit code of an error (bad input, an output that cannot be written).
EXIT_ERROR = 1
#: Exit code of a usage error (typer's).
EXIT_USAGE = 2
#: Exit code of a run that found no answer within its time limit.
EXIT_TIME_LIMIT = 3

#: The one-line format of every message the library logs (and of Python's warnings).
LOG_FORMAT = "%(levelname)s %(name)s: %(message)s"


#: Command modules, imported for their side effect of adding commands to ``app``.
COMMAND_MODULES = ("core", "grammar", "render", "vision", "camera", "report", "language", "corpus",
                   "active", "experiment", "reproduce")


class QuietHelpCommand(TyperCommand):
    """A command whose ``--help`` is listed without a type (typer shows ``<bool>``)."""

    def get_help_option(self, ctx):
        option = super().get_help_option(ctx)
        if option is not None:
            option.metavar = ""
        return option


class QuietHelpGroup(TyperGroup):
    """A command group whose ``--help`` is listed without a type."""

    def get_help_option(self, ctx):
        option = super().get_help_option(ctx)
        if option is not None:
            option.metavar = ""
        return option


def _quiet_help(typer_app: typer.Typer) -> None:
    """Give every command and group of ``typer_app`` (and below) a ``--help`` without a type,
    unless it chose its own class."""
    from typer.models import DefaultPlaceholder

    cls = typer_app.info.cls
    if cls is None or isinstance(cls, DefaultPlaceholder) or cls is TyperGroup:
        typer_app.info.cls = QuietHelpGroup
    for command in typer_app.registered_commands:
        if command.cls is None or command.cls is TyperCommand:
            command.cls = QuietHelpCommand
    for group in typer_app.registered_groups:
        _quiet_help(group.typer_instance)


def _register() -> None:
    import importlib

    for name in COMMAND_MODULES:
        importlib.import_module(f"unseeable.cli.{name}")
    _quiet_help(app)


@app.callback()
def _root() -> None:
    """Estimate Lincoln Log assemblies from photographs, including the logs no camera sees."""


def _warning_to_log(message, category, filename, lineno, file=None, line=None) -> None:
    """``warnings.showwarning`` that logs a library's warning (a numpy RuntimeWarning, say)
    on one line, where it came from in brackets, instead of a dump with its source line."""
    logging.getLogger("py.warnings").warning("%s: %s (%s:%s)", category.__name__,
                                             str(message).strip().replace("\n", " "),
                                             Path(filename).name, lineno)


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``unseeable`` console script: runs a command and returns its exit
    code (see the module's table).

    An :class:`UnseeableError` becomes ``error: <message>`` on one line; Python's
    warnings are logged on one line each, in the format of the library's messages.
    """
    logging.basicConfig(level=logging.WARNING, format=LOG_FORMAT)
    # Python's warnings go to the "py.warnings" logger, as logging.captureWarnings sends
    # them, but on one line.
    shown = warnings.showwarning
    warnings.showwarning = _warning_to_log
    try:
        _register()
        app(args=argv, prog_name="unseeable")
    except SystemExit as done:  # typer's standalone mode always exits
        code = done.code
        return code if isinstance(code, int) else (0 if code is None else EXIT_ERROR)
    except TimeLimitReached as err:
        typer.echo(f"error: {err}", err=True)
        return EXIT_TIME_LIMIT
    except UnseeableError as err:
        typer.echo(f"error: {err}", err=True)
        return EXIT_ERROR
    except KeyboardInterrupt:
        typer.echo("error: interrupted", err=True)
        return EXIT_ERROR
    finally:
        warnings.showwarning = shown
    return 0


if __name__ == "__main__":
    sys.exit(main())
