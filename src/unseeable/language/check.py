"""Whether any structure satisfies a description: :func:`check_satisfiable`."""

from __future__ import annotations

import logging
from typing import Any

from unseeable.domain.grid import Extent
from unseeable.errors import SolverError
from unseeable.language.compile import compile_description
from unseeable.language.syntax import Description, UnsatisfiableError, parse

__all__ = ["check_satisfiable", "is_satisfiable"]

logger = logging.getLogger(__name__)


def is_satisfiable(description: Any, extent: Extent, *, viewpoint: Any = None,
                   time_limit: float = 30.0) -> bool:
    """Whether some valid structure on ``extent`` satisfies ``description``: the grammar Φ
    and the description's constraints, solved with no evidence (CP-SAT).

    Raises
    ------
    SolverError
        The solver decided nothing within ``time_limit`` seconds.
    """
    from unseeable.solve import StructureSolver
    from unseeable.solve.result import SolveStatus

    if not isinstance(extent, Extent):
        extent = Extent.parse(extent)
    psi = compile_description(description, extent, viewpoint=viewpoint)
    result = StructureSolver(extent, constraints=psi).solve([], time_limit=time_limit)
    if result.status == SolveStatus.TIMEOUT:
        raise SolverError(f"could not decide within {time_limit:g} s whether a structure on "
                          f"the grid satisfies the description")
    return result.status != SolveStatus.INFEASIBLE


def check_satisfiable(description: Description | str, extent: Extent, *,
                      viewpoint: Any = None, time_limit: float = 30.0) -> None:
    """Raise :class:`~unseeable.language.UnsatisfiableError` when no valid structure on
    ``extent`` satisfies ``description``.

    The message names the first sentence that no structure satisfies by itself, else
    the whole description: "no structure on a 2×2×2 grid satisfies: door".

    Parameters
    ----------
    description : Description or text
    extent : Extent or (I, J, K)
    viewpoint : optional
        Where left and right are seen from (:func:`~unseeable.language.compile_description`).
    time_limit : float
        Seconds per solve.

    Examples
    --------
    >>> check_satisfiable("window left of door", (5, 6, 5))
    >>> try:
    ...     check_satisfiable("door perpendicular to door", (5, 6, 5))
    ... except UnsatisfiableError as err:
    ...     print(err)
    no structure on a 5×6×5 grid satisfies: door perpendicular to door
    """
    description = parse(description)
    if not isinstance(extent, Extent):
        extent = Extent.parse(extent)
    kw = {"viewpoint": viewpoint, "time_limit": time_limit}
    if is_satisfiable(description, extent, **kw):
        return
    culprit = str(description).rstrip(".")
    if len(description.sentences) > 1:
        texts = description.sentence_texts()
        for sentence, text in zip(description.sentences, texts):
            if not is_satisfiable(Description((sentence,), text), extent, **kw):
                culprit = text
                break
    I, J, K = extent.shape
    raise UnsatisfiableError(f"no structure on a {I}×{J}×{K} grid satisfies: {culprit}")
