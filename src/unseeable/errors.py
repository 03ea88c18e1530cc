"""The project's exceptions: one root, a few kinds.

Every error a user can cause (bad files, bad options) is an
:class:`InputError`, whose message names the file, the field and the value
received, so that the command line can print it as one line.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterator
from contextlib import contextmanager
from numbers import Integral, Real
from typing import Any

__all__ = [
    "UnseeableError",
    "InputError",
    "SolverError",
    "RenderError",
    "VisionError",
    "TimeLimitReached",
    "check_seconds",
    "check_whole_number",
    "vision_errors_name",
]

_MISSING = object()


class UnseeableError(Exception):
    """Root of every error raised on purpose by :mod:`unseeable`."""


class InputError(UnseeableError, ValueError):
    """Bad input: a file, a field of it or an argument holds an unusable value.

    Parameters
    ----------
    message : str
        What is wrong, e.g. ``"must be in (0, 1)"``.
    file : str or path, optional
        The file the value came from.
    field : str, optional
        Where in the file or which argument, e.g. ``"features[3].p"``.
    value : any, optional
        The value received; shown with ``repr``.

    Examples
    --------
    >>> str(InputError("must be in (0, 1)", file="e.json", field="features[0].p", value=1.5))
    'e.json: features[0].p: must be in (0, 1) (got 1.5)'
    """

    def __init__(
        self,
        message: str,
        *,
        file: Any = None,
        field: str | None = None,
        value: Any = _MISSING,
    ) -> None:
        self.message = message
        self.file = None if file is None else str(file)
        self.field = field
        self.value = value
        super().__init__(self._format())

    def _format(self) -> str:
        parts = []
        if self.file is not None:
            parts.append(self.file)
        if self.field is not None:
            parts.append(self.field)
        text = self.message
        if self.value is not _MISSING:
            shown = repr(self.value)
            # Arrays and long lists are cut to a line; a path is the file the user must
            # find, so it is shown whole (up to a paragraph).
            limit = 400 if isinstance(self.value, (str, os.PathLike)) else 80
            if len(shown) > limit:
                shown = shown[:limit - 3] + "..."
            text = f"{text} (got {shown})"
        parts.append(text)
        return ": ".join(parts)

    def in_file(self, file: Any) -> InputError:
        """Return the same error attributed to ``file`` (when it names none yet)."""
        if self.file is not None:
            return self
        return InputError(self.message, file=file, field=self.field, value=self.value)


class SolverError(UnseeableError):
    """A solver backend is unavailable or failed unexpectedly."""


class RenderError(UnseeableError):
    """The renderer could not produce an image."""


class VisionError(UnseeableError):
    """The vision front end could not produce a trustworthy answer (e.g. a poor pose fit)."""


class TimeLimitReached(UnseeableError):
    """The work stopped at its time limit without an answer (the command line's exit
    code 3)."""


@contextmanager
def vision_errors_name(path: Any) -> Iterator[None]:
    """A :class:`VisionError` raised inside says which file it is about, as an
    :class:`InputError` does (the command line prints it as one line).

    Examples
    --------
    >>> with vision_errors_name("view.json"):
    ...     raise VisionError("poor pose fit")
    Traceback (most recent call last):
    ...
    unseeable.errors.VisionError: view.json: poor pose fit
    """
    try:
        yield
    except VisionError as err:
        raise VisionError(f"{path}: {err}") from None


def check_whole_number(value: Any, *, field: str, minimum: int) -> int:
    """``value`` as an ``int`` when it is a whole number (Python's or numpy's, not a
    bool) at least ``minimum``; else an :class:`InputError` naming ``field``.

    Examples
    --------
    >>> check_whole_number(3, field="n", minimum=1)
    3
    >>> check_whole_number(0, field="n", minimum=1)
    Traceback (most recent call last):
    ...
    unseeable.errors.InputError: n: must be a whole number >= 1 (got 0)
    """
    if isinstance(value, bool) or not isinstance(value, Integral) or value < minimum:
        raise InputError(f"must be a whole number >= {minimum}", field=field, value=value)
    return int(value)


def check_seconds(value: Any, *, field: str) -> float:
    """``value`` as a ``float`` when it is a positive finite number (not a bool); else an
    :class:`InputError` naming ``field``. For time limits and budgets.

    Examples
    --------
    >>> check_seconds(30, field="time_limit")
    30.0
    >>> check_seconds(0.0, field="time_limit")
    Traceback (most recent call last):
    ...
    unseeable.errors.InputError: time_limit: must be a positive number of seconds (got 0.0)
    """
    if isinstance(value, bool) or not isinstance(value, Real) or not value > 0 \
            or not math.isfinite(value):
        raise InputError("must be a positive number of seconds", field=field, value=value)
    return float(value)
