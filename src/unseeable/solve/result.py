"""Solver outcomes as values."""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, field

from unseeable.domain.structure import Structure

__all__ = ["SolveStatus", "SolveResult"]


class SolveStatus(enum.StrEnum):
    """How a solve ended.

    OPTIMAL
        ``structure`` maximises the log-probability (proven).
    FEASIBLE
        The time limit stopped the search; ``structure`` is the best found,
        ``bound`` what is proven about the optimum.
    INFEASIBLE
        No structure satisfies the grammar and the constraints (proven).
    TIMEOUT
        The time limit stopped the search before any structure was found.
    """

    OPTIMAL = "optimal"
    FEASIBLE = "feasible"
    INFEASIBLE = "infeasible"
    TIMEOUT = "timeout"


@dataclass(frozen=True, eq=False)
class SolveResult:
    """The outcome of one MAP estimate.

    Attributes
    ----------
    status : SolveStatus
    structure : Structure or None
        None when INFEASIBLE or TIMEOUT.
    log_probability : float
        Of ``structure``, recomputed in float64 from the evidence terms
        (never the solver's scaled integer objective); ``-inf`` without a
        structure.
    bound : float
        Proven upper bound on the optimal log-probability (``-inf`` when
        INFEASIBLE, ``inf`` when nothing is proven).
    backend : str
    timings : dict
        ``build_s`` (model construction — on a reused model only for its
        first solve — plus installing this objective) and ``solve_s`` (the
        search).
    wall_s : float
        Wall time of the whole call.
    resolves : int
        How many solves the same kept model did before this one.
    choices : dict name -> bool
        Values of the ``Choice`` variables of the constraints (empty when none).
    """

    status: SolveStatus
    structure: Structure | None
    log_probability: float
    bound: float
    backend: str
    timings: dict = field(default_factory=dict)
    wall_s: float = 0.0
    resolves: int = 0
    choices: dict = field(default_factory=dict)

    @property
    def proven(self) -> bool:
        """Whether the status is proven (OPTIMAL or INFEASIBLE)."""
        return self.status in (SolveStatus.OPTIMAL, SolveStatus.INFEASIBLE)

    @property
    def gap(self) -> float:
        """``bound - log_probability`` (about 0 when optimal; ``inf`` without a structure)."""
        if self.structure is None:
            return math.inf
        return max(0.0, self.bound - self.log_probability)

    def __repr__(self) -> str:
        return (f"SolveResult(status={self.status.value}, structure={self.structure!r}, "
                f"log_probability={self.log_probability:.6f}, bound={self.bound:.6f}, "
                f"backend={self.backend!r}, wall_s={self.wall_s:.3f})")
