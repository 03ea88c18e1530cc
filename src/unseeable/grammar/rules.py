"""The grammar Φ of Lincoln Logs and the feature definitions g_f, as expressions.

DESIGN.md §2: constraints (a)–(d) restrict the occupancy Z; (e)–(g) define
each image feature as a function of Z. Positions outside the grid are EMPTY,
which is what makes a 2-notch log impossible at the last position of a line,
and support (c)–(d) applies above layer 0 only.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from unseeable.domain.features import FeatureKind, feature_index
from unseeable.domain.grid import Extent
from unseeable.grammar.expr import (
    FIRST_NOTCH_CODES,
    LAST_NOTCH_CODES,
    SPAN_CODES,
    AtLeast,
    Const,
    Expr,
    Iff,
    Implies,
    Occ,
    Or,
    occupied,
    simplify,
)

__all__ = ["grammar_constraints", "feature_expressions", "FeatureTable", "feature_table",
           "line_positions"]


def line_positions(extent: Extent) -> list[list[tuple[int, int, int]]]:
    """Every line of the grid: the positions of one layer along its axis, in order.

    Layers in order; within an even layer lines are ordered by k (positions
    along i), within an odd layer by i (positions along k).
    """
    I, J, K = extent.shape
    lines = []
    for j in range(J):
        if j % 2 == 0:
            lines.extend([[(i, j, k) for i in range(I)] for k in range(K)])
        else:
            lines.extend([[(i, j, k) for k in range(K)] for i in range(I)])
    return lines


@lru_cache(maxsize=32)
def grammar_constraints(extent: Extent) -> tuple[Expr, ...]:
    """Φ (constraints (a)–(d)) as simplified expressions that must all hold.

    (a) ``Z_q = (2,0) ⇔ Z_n(q) = (2,1)``; (b) ``Z_q = (3,0) ⇔ Z_n(q) = (3,1)``,
    ``Z_q = (3,1) ⇔ Z_n(q) = (3,2)`` — for every q of a line and the position
    just before its start, so the boundary forbids logs that leave the grid;
    (c) above layer 0 a notch of a 1- or 2-notch log has a log below it;
    (d) above layer 0 a 3-notch log has logs below at least 2 of its notches.

    Examples
    --------
    >>> from unseeable.domain import Extent
    >>> grammar_constraints(Extent(1, 1, 1))  # a lone position: only EMPTY or (1,0)
    (Occ([0, 0, 0], [0, 1]),)
    """
    raw: list[Expr] = []
    for line in line_positions(extent):
        j = line[0][1]
        first = line[0]
        step = np.subtract(Extent.next(first), first)  # unit step along the layer's axis
        before = tuple(int(c) for c in np.subtract(first, step))
        chain = [before, *line]
        for q in chain:
            nq = Extent.next(q)
            raw.append(Iff(Occ(q, {2}), Occ(nq, {3})))
            raw.append(Iff(Occ(q, {4}), Occ(nq, {5})))
            raw.append(Iff(Occ(q, {5}), Occ(nq, {6})))
        if j == 0:
            continue
        for q in line:
            nq = Extent.next(q)
            nnq = Extent.next(nq)
            raw.append(Implies(Occ(q, {1, 2, 3}), occupied(Extent.below(q))))
            raw.append(Implies(Occ(q, {4}), AtLeast(2, [occupied(Extent.below(q)),
                                                        occupied(Extent.below(nq)),
                                                        occupied(Extent.below(nnq))])))
    # Unary restrictions (boundary cases) on one position merge into one literal.
    allowed: dict[tuple[int, int, int], frozenset] = {}
    out: list[Expr] = []
    seen: set[Expr] = set()
    for c in raw:
        s = simplify(c, extent)
        if isinstance(s, Occ):
            allowed[s.q] = allowed.get(s.q, s.values) & s.values
        elif not (isinstance(s, Const) and s.value) and s not in seen:
            seen.add(s)
            out.append(s)
    unary = [Occ(q, v) for q, v in sorted(allowed.items())]
    return tuple(unary + out)


def _feature_expression(kind: int, q: tuple[int, int, int]) -> Expr:
    if kind == FeatureKind.END_MINUS:
        return Occ(q, FIRST_NOTCH_CODES)
    if kind == FeatureKind.END_PLUS:
        return Occ(q, LAST_NOTCH_CODES)
    bb = Extent.below(q, 2)
    if kind in (FeatureKind.U, FeatureKind.V):
        return Or(occupied(q), occupied(bb))
    return Or(Occ(q, SPAN_CODES), Occ(bb, SPAN_CODES))


@lru_cache(maxsize=64)
def feature_expressions(extent: Extent, removed_from_layer: int | None = None
                        ) -> tuple[Expr, ...]:
    """g_f(Z) for every feature, in :func:`unseeable.domain.feature_index` order.

    Constraints (e)–(g): ``end-`` ⇔ first notch, ``end+`` ⇔ last notch,
    ``u``/``v`` ⇔ ``Z_q ≠ EMPTY ∨ Z_b(b(q)) ≠ EMPTY``, ``w`` ⇔
    ``span(q) ∨ span(b(b(q)))``. With ``removed_from_layer=L`` the features
    are those of the assembly after removing every log on layers ``>= L``.

    Returns
    -------
    tuple of Expr, length N (simplified; some are constants)
    """
    idx = feature_index(extent)
    return tuple(
        simplify(_feature_expression(int(kind), tuple(int(a) for a in at)), extent,
                 removed_from_layer=removed_from_layer)
        for kind, at in zip(idx.kind, idx.at)
    )


class FeatureTable:
    """Features of an extent grouped by distinct expression (for building objectives fast).

    Attributes
    ----------
    exprs : tuple of Expr
        The distinct non-constant feature expressions (``u`` and ``v`` at the
        same position share one).
    expr_of_feature : (N,) int
        Index into ``exprs`` of each feature, or -1 when the feature is a
        constant.
    constant_value : (N,) bool
        The value of constant features (False elsewhere).
    """

    def __init__(self, exprs: tuple[Expr, ...], expr_of_feature: np.ndarray,
                 constant_value: np.ndarray) -> None:
        self.exprs = exprs
        self.expr_of_feature = expr_of_feature
        self.constant_value = constant_value


@lru_cache(maxsize=64)
def feature_table(extent: Extent, removed_from_layer: int | None = None) -> FeatureTable:
    """Distinct feature expressions of ``extent`` (cached)."""
    features = feature_expressions(extent, removed_from_layer)
    ids: dict[Expr, int] = {}
    which = np.full(len(features), -1, dtype=np.int64)
    const = np.zeros(len(features), dtype=bool)
    for f, e in enumerate(features):
        if isinstance(e, Const):
            const[f] = e.value
            continue
        which[f] = ids.setdefault(e, len(ids))
    which.setflags(write=False)
    const.setflags(write=False)
    return FeatureTable(tuple(ids), which, const)
