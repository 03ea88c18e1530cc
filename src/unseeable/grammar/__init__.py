"""The stochastic CSP of Lincoln Log structure estimation, solver-neutral.

* :mod:`~unseeable.grammar.expr` — expressions (``Occ``, ``Choice``, ``And``, …).
* :mod:`~unseeable.grammar.rules` — the grammar Φ and the feature definitions g_f.
* :mod:`~unseeable.grammar.objective` — evidence terms, factors, the compiled objective.
* :mod:`~unseeable.grammar.priors` — the prior over structures (``builder``, ``uniform``).
* :mod:`~unseeable.grammar.shapes` — wall, door and window as shape predicates.
* :func:`count_valid` — exact number of valid structures of an extent.
* :func:`random_structure` — random valid structures.

Backends that maximise the objective under Φ live in :mod:`unseeable.solve`.
"""

from unseeable.grammar.count import count_line_tilings, count_valid
from unseeable.grammar.expr import (
    ALL_CODES,
    FALSE,
    FIRST_NOTCH_CODES,
    LAST_NOTCH_CODES,
    NONEMPTY,
    SPAN_CODES,
    TRUE,
    And,
    AtLeast,
    AtMost,
    Choice,
    Const,
    Exactly,
    Expr,
    Iff,
    Implies,
    Not,
    Occ,
    Or,
    as_expr,
    empty,
    evaluate,
    negate,
    occupied,
    scope,
    simplify,
    truth_table,
)
from unseeable.grammar.objective import (
    EvidenceTerm,
    Factor,
    Objective,
    Term,
    as_terms,
    check_prior_cost,
    compile_objective,
    joint_prior,
    log_probability,
    seen_joints,
    stacked_joint_prior,
    terms_extent,
    unsupported_notch_prior,
)
from unseeable.grammar.priors import PRIOR_NAMES, TIE_POLICY, StructurePrior
from unseeable.grammar.rules import (
    feature_expressions,
    feature_table,
    grammar_constraints,
    line_positions,
)
from unseeable.grammar.sampling import full_structure, random_structure
from unseeable.grammar.shapes import (
    SHAPE_KINDS,
    WALL_MIN_HEIGHT,
    WALL_MIN_WIDTH,
    Condition,
    Placement,
    check_placement,
    conditions,
    find_shapes,
    holds,
    placements,
    shape_expr,
    span_logs,
)

__all__ = [
    "Expr", "Const", "TRUE", "FALSE", "Occ", "Choice", "Not", "And", "Or", "Implies", "Iff",
    "AtLeast", "AtMost", "Exactly", "occupied", "empty", "as_expr", "simplify", "negate",
    "evaluate", "truth_table", "scope", "ALL_CODES", "NONEMPTY", "FIRST_NOTCH_CODES",
    "LAST_NOTCH_CODES", "SPAN_CODES", "grammar_constraints", "feature_expressions",
    "feature_table", "line_positions", "EvidenceTerm", "Factor", "Term", "Objective",
    "compile_objective", "as_terms", "log_probability", "terms_extent", "joint_prior",
    "seen_joints", "check_prior_cost", "count_valid", "stacked_joint_prior",
    "unsupported_notch_prior",
    "count_line_tilings", "random_structure", "full_structure", "StructurePrior",
    "PRIOR_NAMES", "TIE_POLICY", "SHAPE_KINDS", "WALL_MIN_WIDTH", "WALL_MIN_HEIGHT",
    "Placement", "Condition", "conditions", "check_placement", "placements", "holds",
    "find_shapes", "shape_expr", "span_logs",
]
