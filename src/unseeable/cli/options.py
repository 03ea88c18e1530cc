"""Command-line options and parsers of their values shared by several commands."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING, Any

import typer

from unseeable.cli import QuietHelpGroup
from unseeable.confidence.readings import READING_SHIFT as _READING_SHIFT
from unseeable.confidence.tolerance import DELTA_STAR as _DELTA_STAR
from unseeable.errors import InputError

if TYPE_CHECKING:
    from rich.progress import Progress

__all__ = ["GroupWithDefault", "CALIBRATION", "PRIOR", "BACKEND", "TIME_LIMIT", "JOINT_COST",
           "STACKED_JOINT_COST", "UNSUPPORTED_NOTCH_COST", "THREADS", "TIES", "DELTA_STAR",
           "READING_SHIFT", "ADVANCED", "PHOTOGRAPHS", "MAX_TIME_LIMIT", "MAX_THREADS",
           "SCHEDULER", "flag",
           "parse_angles", "parse_pose", "parse_size", "progress_bar", "working",
           "bar_from_first_report", "open_scheduler"]

class GroupWithDefault(QuietHelpGroup):
    """A command group whose first argument, when it names none of its commands, goes to
    its ``show`` command: ``unseeable view estimate.json`` is ``unseeable view show
    estimate.json``, beside ``unseeable view new``."""

    default_command = "show"

    def resolve_command(self, ctx, args):
        if args and args[0] not in self.commands and not args[0].startswith("-"):
            args = [self.default_command, *args]
        return super().resolve_command(ctx, args)


#: The help panel of the options most runs leave alone.
ADVANCED = "Advanced: the structure prior, the solver and the confidence test"
#: The help panel of the options about photographs: the pose, the detectors.
PHOTOGRAPHS = "Photographs: the pose and the detectors"

#: Longest time limit accepted (seconds): a day.
MAX_TIME_LIMIT = 86400.0
#: Most threads accepted for the pose search.
MAX_THREADS = 256


def flag(default: bool, decls: str, *, help: str, **options: Any) -> Any:
    """A ``--name/--no-name`` option, shown as such in the help (without a type)."""
    return typer.Option(default, decls, metavar="", help=help, **options)


def _at_most(maximum: float, field: str, unit: str) -> Callable[[Any], Any]:
    """An option callback refusing values above ``maximum`` (the settings check the
    lower bound and the type, each with its own message)."""

    def check(value: Any) -> Any:
        if isinstance(value, (int, float)) and not isinstance(value, bool) \
                and value > maximum:
            raise InputError(f"must be at most {maximum:g} {unit}", field=field, value=value)
        return value

    return check


# The options' help says its default itself where that is shorter than typer's own line.

#: ``--threads`` of the commands that estimate a pose from one photograph.
THREADS = typer.Option(2, "--threads", metavar="N", rich_help_panel=PHOTOGRAPHS,
                       show_default=False,
                       callback=_at_most(MAX_THREADS, "threads", "threads"),
                       help="Pose search threads (default 2; same result).")

#: ``--prior`` of the commands that estimate structures.
PRIOR = typer.Option("builder", "--prior", metavar="NAME", rich_help_panel=ADVANCED,
                     show_default=False,
                     help="builder (default) or uniform (the paper's).")

#: ``--backend`` of the commands that estimate structures.
BACKEND = typer.Option("cpsat", "--backend", metavar="NAME", rich_help_panel=ADVANCED,
                       show_default=False, help="cpsat (default), bnb or toulbar2.")

#: ``--time-limit`` of the commands that estimate structures.
TIME_LIMIT = typer.Option(60.0, "--time-limit", metavar="SECONDS", show_default=False,
                          callback=_at_most(MAX_TIME_LIMIT, "time_limit", "seconds (a day)"),
                          help="Seconds per solve (default 60), and for the visibility loop.")

# The options below override one field of the named prior or of the confidence test; None
# leaves it as --prior and the defaults set it.
TIES = typer.Option(None, "--ties", metavar="NAME", rich_help_panel=ADVANCED,
                    show_default=False,
                    help="Tie rule: fewest (default), emptiest, any.")
JOINT_COST = typer.Option(None, "--joint-cost", metavar="NATS", rich_help_panel=ADVANCED,
                          show_default=False,
                          help="Per joint seen (default 1; uniform 0).")
STACKED_JOINT_COST = typer.Option(None, "--stacked-joint-cost", metavar="NATS",
                                  rich_help_panel=ADVANCED, show_default=False,
                                  help="Per stacked joint (default 1; uniform 0).")
UNSUPPORTED_NOTCH_COST = typer.Option(None, "--unsupported-notch-cost", metavar="NATS",
                                      rich_help_panel=ADVANCED, show_default=False,
                                      help="Per notch on nothing (default 1; uniform 0).")
DELTA_STAR = typer.Option(_DELTA_STAR, "--delta-star", metavar="NATS",
                          rich_help_panel=ADVANCED, show_default=False,
                          help=f"Confidence threshold δ* (default {_DELTA_STAR:g}).")
READING_SHIFT = typer.Option(_READING_SHIFT, "--reading-shift", metavar="NATS",
                             rich_help_panel=ADVANCED, show_default=False,
                             help=f"Reading test shift (default {_READING_SHIFT:g}; 0: off).")

#: ``--scheduler`` of the commands that run corpus-wide jobs (see :func:`open_scheduler`).
SCHEDULER = typer.Option(None, "--scheduler", metavar="SPEC", show_default=False,
                         help="Run the jobs on a Dask cluster: tcp://HOST:PORT (a running "
                              "scheduler) or local:N (a LocalCluster of N workers started "
                              "here); default --workers local processes. Same results.")

#: ``--calibration`` of the commands that run the detectors on photographs.
CALIBRATION = typer.Option(None, "--calibration", metavar="FILE", rich_help_panel=PHOTOGRAPHS,
                           help="Detector calibration (default: the shipped one).")


def open_scheduler(scheduler: str | None, *, workers: int) -> Any:
    """The executor of ``--scheduler`` (``--workers`` local processes without one), open for
    a ``with`` block: a malformed value, or a scheduler that does not answer, is an
    :class:`InputError` naming ``--scheduler``, before any work."""
    from unseeable.executor import open_executor

    return open_executor(scheduler, workers=workers, field="--scheduler")


def parse_angles(text: str) -> list[float]:
    """Arm angles in degrees from ``"A,B,..."`` (each finite, within ±360)."""
    try:
        angles = [float(a) for a in text.split(",") if a.strip()]
    except ValueError:
        raise InputError("must be angles in degrees separated by commas", field="--angles",
                         value=text) from None
    if not angles:
        raise InputError("must name at least one angle", field="--angles", value=text)
    if not all(-360.0 <= a <= 360.0 for a in angles):  # also refuses nan
        raise InputError("must be angles in degrees from -360 to 360", field="--angles",
                         value=text)
    return angles


def parse_pose(text: str):
    from unseeable.domain import GridPose

    parts = text.split(",")
    try:
        x, z, yaw = (float(p) for p in parts)
    except ValueError:
        raise InputError("must be X,Z,YAW (mm, mm, degrees)", field="--pose", value=text) from None
    return GridPose(x, z, yaw)


def parse_size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(p) for p in text.lower().split("x"))
    except ValueError:
        raise InputError("must be WIDTHxHEIGHT in pixels, e.g. 640x480", field="--size",
                         value=text) from None
    if not (1 <= w <= 20000 and 1 <= h <= 20000):
        raise InputError("must be WIDTHxHEIGHT with sides in 1..20000", field="--size",
                         value=text)
    return w, h


def progress_bar(*columns: Any, transient: bool = True) -> Progress:
    """A rich ``Progress`` with ``columns``, drawn on stderr.

    Every command's bar goes to stderr, so that stdout holds only the command's
    results (and an error leaves nothing there, not even the blank line a
    transient bar leaves behind on a stream that is not a terminal).
    """
    from rich.console import Console
    from rich.progress import Progress

    console = Console(stderr=True)
    # A transient bar on a stream that is not a terminal would leave a blank line (before
    # an error's line, too): it is not drawn there at all.
    return Progress(*columns, console=console, transient=transient,
                    disable=transient and not console.is_terminal)


@contextmanager
def bar_from_first_report(bar: Any, *, total: int | None = None
                          ) -> Iterator[Callable[..., None]]:
    """An ``update(**fields)`` for a rich ``Progress`` ``bar`` that shows it from its first
    call on (one task; ``fields`` as ``Progress.update``), and stops it on leaving.

    Bad input (a missing corpus, a bad worker count) ends a command before its first
    report: its error line is then printed alone, with no bar (or blank line) before it.
    """
    tasks: list = []

    def update(**fields: Any) -> None:
        if not tasks:
            bar.start()
            tasks.append(bar.add_task("", total=fields.get("total", total)))
        bar.update(tasks[0], **fields)

    try:
        yield update
    finally:
        if tasks:
            bar.stop()


class _ToConsole:
    """A stream that prints through a rich console, above its live display."""

    def __init__(self, console: Any) -> None:
        self.console = console

    def write(self, text: str) -> int:
        self.console.print(text, end="", markup=False, highlight=False, soft_wrap=True)
        return len(text)

    def flush(self) -> None:
        pass


@contextmanager
def working(text: str) -> Iterator[None]:
    """A spinner with the time elapsed on stderr while a long step runs, when stderr is a
    terminal; nothing otherwise (an error line must stay alone on a stream that is not a
    terminal). Messages logged meanwhile are printed above it."""
    import logging

    from rich.console import Console
    from rich.progress import Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

    console = Console(stderr=True)
    if not console.is_terminal:
        yield
        return
    handlers = [h for h in logging.getLogger().handlers
                if type(h) is logging.StreamHandler]
    streams = [h.stream for h in handlers]
    with Progress(SpinnerColumn(), TextColumn(text, markup=False), TimeElapsedColumn(),
                  console=console, transient=True) as bar:
        bar.add_task("", total=None)
        for handler in handlers:
            handler.setStream(_ToConsole(console))
        try:
            yield
        finally:
            for handler, stream in zip(handlers, streams):
                handler.setStream(stream)
