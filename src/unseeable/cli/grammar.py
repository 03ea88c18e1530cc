"""Commands about the grammar itself: ``unseeable grammar count``."""

from __future__ import annotations

import time

import typer

from unseeable.cli import TimeLimitReached, app
from unseeable.cli.options import MAX_TIME_LIMIT, bar_from_first_report, progress_bar
from unseeable.errors import InputError, check_seconds

__all__ = ["grammar_app", "count_command", "CountClock"]

grammar_app = typer.Typer(name="grammar", help="The grammar of Lincoln Log assemblies.",
                          no_args_is_help=True)
app.add_typer(grammar_app, name="grammar")

#: A count is stopped early when the positions swept so far say it would take this many
#: times the time limit (each position costs the same; the first few tell).
OVERRUN = 1.5
#: ... once it has run this long (seconds; or a quarter of the time limit if that is
#: shorter): shorter times are too noisy to project.
PROJECT_AFTER_S = 1.0


class CountClock:
    """The progress callback of a count: stops it at ``time_limit`` seconds, or as soon as
    the positions swept so far show it would take more than :data:`OVERRUN` times that.

    Parameters
    ----------
    time_limit : float
        Seconds.
    report : callable, optional
        ``report(done, total)`` after each position (a progress bar).
    """

    def __init__(self, time_limit: float, report=None) -> None:
        self.time_limit = time_limit
        self.report = report
        self.start = time.perf_counter()

    def __call__(self, done: int, total: int) -> None:
        if self.report is not None:
            self.report(done, total)
        elapsed = time.perf_counter() - self.start
        if done >= total:
            return
        if elapsed > self.time_limit:
            raise TimeLimitReached(f"stopped at the time limit ({self.time_limit:g} s) after "
                                   f"{done} of the {total} positions; raise --time-limit")
        if done and elapsed >= min(PROJECT_AFTER_S, self.time_limit / 4):
            projected = elapsed / done * total
            if projected > OVERRUN * self.time_limit:
                raise TimeLimitReached(
                    f"would take about {projected:.0f} s (from the first {done} of the "
                    f"{total} positions, {elapsed:.1f} s), more than --time-limit "
                    f"{self.time_limit:g} s; raise it or give a smaller extent")


@grammar_app.command("count")
def count_command(
    extent: str = typer.Option(..., "--extent", metavar="I,J,K",
                               help="Grid size I,J,K (layers are J)."),
    time_limit: float = typer.Option(60.0, "--time-limit", metavar="SECONDS",
                                     help="Stop the count after as long (exit code 3)."),
) -> None:
    """Print the exact number of valid structures of an extent (alone on the last line).

    The time grows as 2^(I*K) per position: I*K is at most 20 when J > 1. A count that
    would not finish within --time-limit stops as soon as that shows (exit code 3).
    """
    from rich.progress import BarColumn, TextColumn, TimeElapsedColumn, TimeRemainingColumn

    from unseeable.domain import Extent
    from unseeable.grammar import count_valid

    grid = Extent.parse(extent, field="--extent")
    limit = check_seconds(time_limit, field="--time-limit")
    if limit > MAX_TIME_LIMIT:
        raise InputError(f"must be at most {MAX_TIME_LIMIT:g} seconds (a day)",
                         field="--time-limit", value=time_limit)
    bar = progress_bar(TextColumn(f"counting {grid}"), BarColumn(),
                       TextColumn("{task.completed}/{task.total} positions"),
                       TimeElapsedColumn(), TimeRemainingColumn())
    with bar_from_first_report(bar, total=grid.positions) as update:
        clock = CountClock(limit, lambda done, total: update(completed=done, total=total))
        total = count_valid(grid, progress=clock)
    typer.echo(f"valid structures of a {grid} grid:")
    typer.echo(str(total))
