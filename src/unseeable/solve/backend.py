"""What every backend adapter implements (internal)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from unseeable.domain.grid import Extent
from unseeable.grammar.expr import Expr
from unseeable.grammar.objective import Objective
from unseeable.solve.result import SolveStatus

__all__ = ["RawSolution", "Backend", "SCALE"]

#: Integer backends multiply log-probabilities by this before rounding; ×1000
#: was measured to return structures 5e-4 below the optimum now and then.
SCALE = 1e6


@dataclass
class RawSolution:
    """A backend's answer in objective units (constant included)."""

    status: SolveStatus
    occupancy: np.ndarray | None
    bound: float
    solve_s: float
    install_s: float = 0.0
    choices: dict = field(default_factory=dict)


class Backend(Protocol):
    """A MAP backend for one extent and one set of hard constraints.

    The constructor builds whatever can be kept across solves; :meth:`solve`
    maximises one objective under the grammar Φ and the constraints.

    Optional, found by name (the CP-SAT backend has both):
    ``improve(objective, *, hint, hint_choices, time_limit) -> RawSolution``
    answers "does a structure beat ``hint``?" (FEASIBLE with one, INFEASIBLE
    when none does, TIMEOUT) faster than solving to optimality, for the
    confidence tests (:meth:`~unseeable.solve.StructureSolver.find_better`);
    ``lexicographic(objective, secondary, *, hint, hint_choices,
    deterministic_limit) -> RawSolution`` searches a tie for the best
    ``secondary`` value (the tie policies).
    """

    name: str

    def __init__(self, extent: Extent, constraints: Sequence[Expr], *,
                 workers: int = 1) -> None: ...

    def solve(self, objective: Objective, *, hint: np.ndarray | None,
              hint_choices: Mapping[str, bool] | None, time_limit: float,
              work_limit: float | None = None) -> RawSolution:
        """``work_limit``: a budget of deterministic work (CP-SAT's deterministic time,
        about seconds), so that where a search stops does not depend on the machine's
        speed or load; a backend without one ignores it (and answers exactly)."""
        ...
