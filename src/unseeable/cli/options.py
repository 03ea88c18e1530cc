"""Command-line options and parsers of their values shared by several commands."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING, Any

import typer

from unseeable.errors import InputError

if TYPE_CHECKING:
    from rich.progress import Progress

__all__ = ["CALIBRATION", "JOINT_COST", "STACKED_JOINT_COST", "UNSUPPORTED_NOTCH_COST",
           "THREADS", "TIES",
           "parse_angles", "parse_pose", "parse_size", "progress_bar", "bar_from_first_report"]

#: ``--threads`` of the commands that estimate a pose from one photograph.
THREADS = typer.Option(2, help="Threads for the pose search (the machine's two cores); the "
                               "result is the same for any number.")
#: ``--ties`` of the commands that estimate structures. The default is the pipeline's
#: ``TIE_POLICY``, written out so that the command line starts without importing it.
TIES = typer.Option("fewest", "--ties",
                    help="Which of equally probable structures (hidden parts) to keep: "
                         "fewest (the fewest logs, then the longest), emptiest (the fewest "
                         "positions plus logs) or any (whichever the solver finds: the "
                         "paper's plain MAP).")

#: ``--joint-cost`` of the commands that estimate structures (the pipeline's
#: ``JOINT_COST``, written out as ``TIES`` is).
JOINT_COST = typer.Option(1.0, "--joint-cost",
                          help="Nats each joint (two logs end to end on a line) costs under the "
                               "structure prior: the estimate divides walls into fewer, longer "
                               "logs unless the evidence says otherwise. 0: the paper's "
                               "uniform prior.")

#: ``--stacked-joint-cost`` of the commands that estimate structures (the pipeline's
#: ``STACKED_JOINT_COST``, written out as ``TIES`` is).
STACKED_JOINT_COST = typer.Option(1.0, "--stacked-joint-cost",
                                  help="Nats a joint straight above another on the same wall "
                                       "(two layers up) costs under the structure prior: "
                                       "builders stagger joints, and hidden walls are guessed "
                                       "so. 0: none (with --joint-cost 0, the paper's uniform "
                                       "prior).")

#: ``--unsupported-notch-cost`` of the commands that estimate structures (the pipeline's
#: ``UNSUPPORTED_NOTCH_COST``, written out as ``TIES`` is).
UNSUPPORTED_NOTCH_COST = typer.Option(1.0, "--unsupported-notch-cost",
                                      help="Nats a notch with nothing below it costs under "
                                           "the structure prior: logs rest on every notch "
                                           "they can, and hidden courses are filled under "
                                           "the logs above. 0: none.")

#: ``--calibration`` of the commands that run the detectors on photographs.
CALIBRATION = typer.Option(None, "--calibration",
                           help="Detector calibration file (made by `unseeable calibrate` or "
                                "`unseeable merge-calibrations`; default: the shipped one).")


def parse_angles(text: str) -> list[float]:
    try:
        angles = [float(a) for a in text.split(",") if a.strip()]
    except ValueError:
        raise InputError("must be angles in degrees separated by commas", field="--angles",
                         value=text) from None
    if not angles:
        raise InputError("must name at least one angle", field="--angles", value=text)
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

    return Progress(*columns, console=Console(stderr=True), transient=transient)


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
