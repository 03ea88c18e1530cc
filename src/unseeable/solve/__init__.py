"""MAP structure estimation under the grammar: backends behind one interface.

* :func:`estimate_structure` — one solve.
* :class:`StructureSolver` — keep the model of Φ + constraints, swap objectives.
* :class:`SolveStatus`, :class:`SolveResult` — outcomes as values.
* :data:`TIES` — which member of an exact tie to keep (:mod:`unseeable.solve.ties`).

Backends: ``"cpsat"`` (OR-Tools CP-SAT, the default), ``"bnb"`` (the paper's
arc consistency + depth-first branch and bound, pure Python; small grids),
``"toulbar2"`` (pytoulbar2, optional).
"""

from unseeable.solve.api import (
    BACKENDS,
    TIES,
    StructureSolver,
    available_backends,
    check_tie_policy,
    estimate_structure,
)
from unseeable.solve.result import SolveResult, SolveStatus

__all__ = ["SolveStatus", "SolveResult", "StructureSolver", "estimate_structure", "BACKENDS",
           "TIES", "available_backends", "check_tie_policy"]
