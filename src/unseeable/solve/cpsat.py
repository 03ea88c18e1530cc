"""OR-Tools CP-SAT backend.

Model: one Boolean per log placement (where a 1-, 2- or 3-notch log starts)
and one "empty" Boolean per position, exactly one of which covers each
position — the one-hot encoding of Z_q = v with the notches of one log
sharing one variable, so (a)–(b) hold by construction. ``Occ(q, V)`` is a
linear form over them (``Σ_{v∈V} x[q][v]`` or ``1 - Σ_{v∉V} x[q][v]``), so
grammar implications become linear inequalities whose LP relaxation is
tight; compound expressions get one reified Boolean each. The objective is
``Σ_e round(c_e·SCALE)·[e]``; the result's value is recomputed in float
elsewhere and the proven bound is corrected for the rounding.

Support (c)–(d) is the part of Φ whose plain linear form is weak: "a 3-notch
log has at least 2 of its 3 notches supported" as ``Σ_below ≥ 2·x`` lets the
LP mix tilings of a line so that half-logs rest on thirds of supports. The
default ``formulation="tight"`` writes it disjunctively: each 3-notch
placement above layer 0 has one *exemption* literal per notch (at most one of
them, only with the log, only over an empty position), and a position is
occupied only over an occupied position or at an exempt notch. An exempt
notch is then exactly an unsupported one, so the structure prior's
unsupported-notch factor is that linear form, with no literal of its own;
the column inequality ``[Z_q ≠ ∅ ∨ Z_b(b(q)) ≠ ∅] ≤ [Z_b(b(q)) ≠ ∅] + ex(q) +
ex(b(q))`` (a notch above an empty position two layers down rests on a notch
above an empty one, or is itself unsupported) cuts what the LP still mixes
along a column; a conjunction of joints (the stacked-joint factor) is the
conjunction of the joints' literals. Every optimum is the plain model's
(tests/solve/test_formulation.py), proven 2–4× faster under the uniform prior
and up to 8× under the shipped one (8×10×8 dense random structures: median
CPU 8.0 s → 0.92 s; ``benchmarks/solve.py --variants``, 2026-12-06).

Parameters (measured, DESIGN.md §8 and ``benchmarks/solve.py``): default
parameters fail to prove optimality from 8×8×8 up; ``linearization_level=2``
proves everything; with several workers the portfolio ignores that unless
the LP workers are named (``subsolvers``). One worker is deterministic, and
on the 2-core machine two never paid under the shipped prior: at 10×12×10
(dense) median wall 9.5 s with one, 15–23 s with two, whichever subsolver
pair or CP-SAT's portfolio (``benchmarks/solve.py --workers``, 2026-12-06,
load average 7). No other parameter paid on the shipped model (10×12×10 dense, 3
instances, medians of CPU time and deterministic time, ``--parameters``, 2026-12-06,
load 1.2–3.2): these settings 10.5 s / 4.35; lazy LP constraints 10.3 s / 2.43 (half the
deterministic work, not the time); presolve 10.2 s; symmetry off 8.8 s, the same search
(shipped since: over the lodge, hall and cabin-door estimates, pose known, CP-SAT's time
1.08 → 1.00 s, the same structures);
linearization 1 16 s; LP or pseudo-cost branching 22 / 10.9 s; LB tree search 29 s (2 of
3 proven); core-based search or cut level 0 prove at most 1 of 3 within 60 s.

What keeps dense 10×12×10 instances slow is the joint and the stacked-joint factors
together: with either cost at 0 the proof takes a fifth to a twentieth of the work (instance
0: deterministic time 0.33 and 0.39 against 2.55). Their root LP bound is the plain LP
relaxation's, 7.7 nats above the optimum (instance 0), and CP-SAT's cuts close none of
it; the optimum given as a hint does not shorten the proof (2.55 → 4.15). The gap sits
on the u/v features ``[Z_q ≠ ∅ ∨ Z_b(b(q)) ≠ ∅]`` (16 nats), the joints (7.9) and the
stacked joints (5.1), offset on the logs' end features: a tighter formulation must tie
those together across layers; one line's tilings with its joint costs are already
integral (the placements are a path flow, the joint's AND form its exact projection).
"""

from __future__ import annotations

import dataclasses
import itertools
import logging
import math
import threading
import time
from collections import OrderedDict
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from unseeable.domain.grid import NUM_VALUES, Extent
from unseeable.errors import SolverError
from unseeable.grammar.expr import (
    ALL_CODES,
    LAST_NOTCH_CODES,
    NONEMPTY,
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
    evaluate,
    leaf_table,
    negate,
)
from unseeable.grammar.objective import Objective
from unseeable.grammar.rules import grammar_constraints, line_positions
from unseeable.solve.backend import SCALE, RawSolution
from unseeable.solve.result import SolveStatus

logger = logging.getLogger(__name__)

__all__ = ["CpSatBackend", "MULTI_WORKER_SUBSOLVERS", "FORMULATIONS"]

#: Subsolvers for ``workers > 1`` (the LP-heavy ones prove this model's optimum).
MULTI_WORKER_SUBSOLVERS = ("max_lp", "default_lp")

_INT64_MAX = 2**63 - 1

#: Every MAP solve (:meth:`CpSatBackend.solve`, one worker, no work limit of its own) is
#: first tried without the SAT solver's inprocessing (clause vivification and probing
#: between restarts), stopping after this much deterministic work; only a model it does
#: not settle in that is solved again with the full settings. Measured at 10x12x10
#: (``benchmarks/solve.py --parameters``, docs/decisions.md): without inprocessing the
#: uniform-prior and sparse shipped-prior solves took a third to a half of the time and
#: settled within 0.03-0.27; the dense shipped-prior ones need the probing and took twice
#: as long without it, so they keep it and pay this much more. The attempt starts cold: a
#: solve's hint goes only to the full settings (following a whole hint with the LP at each
#: decision cost more than it saved on the corpus's models, docs/decisions.md), and an
#: optimum it proves that the hint ties is answered with the hint.
EASY_SOLVE_WORK = 0.3

#: :meth:`CpSatBackend.improve` first asks the whole model with the LP, for this share of
#: the deterministic work (CP-SAT's deterministic time, about seconds) of the model's last
#: solve and at least the floor. Proving "none" took 0.3-1.7 of the MAP's work at 8x10x8
#: and 10x12x10 (`benchmarks/solve.py`) and less than the floor on the corpus's grids
#: (docs/decisions.md), so the share settles nearly every "none" at once; a better
#: structure the LP does not reach in it is left to the neighbourhoods.
IMPROVE_LP_SHARE = 2.0
IMPROVE_LP_FLOOR = 0.01
#: Deterministic work of each neighbourhood's re-solve in :meth:`CpSatBackend.improve`
#: (measured at 10x12x10: a better structure in one took up to 0.14, a proof of none in
#: one 0.015).
NEIGHBOURHOOD_WORK = 0.25
#: The neighbourhoods :meth:`CpSatBackend.improve` re-solves around the estimate, in
#: rounds: (columns of this many positions a side, every layer; at most this many blocks).
#: Measured on the δ* tests of benchmarks/solve.py's instances (CPU time, medians):
#: blocks 2 a side found the better structure as often as 4 a side and in a third to a
#: half of the time (6x8x6 cabins 0.042 s against 0.120 s, 10x12x10 cabins 0.25 s
#: against 0.41 s); blocks 4 a side are the fallback for a change wider than that.
NEIGHBOURHOOD_ROUNDS = ((2, 4), (4, 2))

#: Model formulations: "tight" (disjunctive support, the default) and "plain" (Φ as the
#: grammar's expressions, for comparison).
FORMULATIONS = ("tight", "plain")
_SUPPORT_ANTECEDENTS = (frozenset({1, 2, 3}), frozenset({4}))
_EMPTY = frozenset({0})


#: Deterministic time within which :meth:`CpSatBackend.lexicographic` must find a
#: structure to search on (its ``probe``).
LEXICOGRAPHIC_PROBE = 0.2


@dataclass(frozen=True)
class _Template:
    """A built model of Φ + constraints (no objective) and where its variables are."""

    model: Any  # CpModel, copied for each backend
    x_index: np.ndarray  # (positions, NUM_VALUES) placement literal indices, -1: impossible
    false: int
    lits: dict  # Expr -> index of its reified literal
    choices: dict  # choice name -> index
    exempt: dict  # position index -> indices of the exemption literals of its notch
    exempt_table: np.ndarray  # (n, 3) int64: exemption literal, its log's start, position below
    halves: dict  # Expr -> (conjunction, indices of its ≤ rows, of its ≥ rows), both posted


@dataclass
class _Half:
    """A conjunction's or disjunction's literal reified for objectives only
    (:meth:`CpSatBackend._objective_literal`): its parts (0/1 linear forms) and, for each
    side of ``literal = [e]`` (True: ≤, False: ≥), its rows once posted and whether they
    are kept."""

    literal: Any
    parts: list | Callable[[], list]  # or what makes them, on first use
    conjunction: bool
    rows: dict = field(default_factory=lambda: {True: None, False: None})
    active: dict = field(default_factory=lambda: {True: False, False: False})


#: The domain of a row left out of a solve (:meth:`CpSatBackend._set_side`): wider than
#: any activity of a definition's rows (a few 0/1 terms).
_ANY_ACTIVITY = (-(1 << 40), 1 << 40)


#: Models built lately, by (extent, constraints): the pose choice, the visibility fixpoint
#: and the confidence tests build solvers for the same extent over and over; building a
#: 6x8x6 model in Python takes 16 ms, copying a kept one and making handles on its
#: variables 3 ms (the copy is the model built: tests/solve/test_cpsat.py).
_TEMPLATES: OrderedDict[tuple, _Template] = OrderedDict()
_TEMPLATES_KEPT = 8
_TEMPLATES_LOCK = threading.Lock()


def _template_key(extent: Extent, constraints: Sequence[Expr],
                  formulation: str = "tight") -> tuple | None:
    """The key of the model of ``extent`` under ``constraints`` (None: cannot be kept)."""
    key = (extent, tuple(constraints))
    if formulation != "tight":
        key = (*key, formulation)
    try:
        hash(key)
    except TypeError:  # a constraint that cannot be a key: built afresh each time
        return None
    return key


def _template(key: tuple | None) -> _Template | None:
    if key is None:
        return None
    with _TEMPLATES_LOCK:
        template = _TEMPLATES.get(key)
        if template is not None:
            _TEMPLATES.move_to_end(key)
        return template


def _keep_template(key: tuple | None, template: _Template) -> None:
    if key is None:
        return
    with _TEMPLATES_LOCK:
        _TEMPLATES[key] = template
        _TEMPLATES.move_to_end(key)
        while len(_TEMPLATES) > _TEMPLATES_KEPT:
            _TEMPLATES.popitem(last=False)


class CpSatBackend:
    """CP-SAT model of Φ + constraints, kept across solves; only the objective changes."""

    name = "cpsat"

    @staticmethod
    def available() -> bool:
        try:
            from ortools.sat.python import cp_model  # noqa: F401
        except ImportError:  # pragma: no cover
            return False
        return True

    def __init__(self, extent: Extent, constraints: Sequence[Expr], *, workers: int = 1,
                 formulation: str = "tight") -> None:
        if formulation not in FORMULATIONS:
            raise SolverError(f"unknown CP-SAT formulation {formulation!r}; "
                              f"expected one of {FORMULATIONS}")
        try:
            from ortools.sat.python import cp_model
        except ImportError as err:  # pragma: no cover - ortools is a hard dependency
            raise SolverError("OR-Tools is not installed: pip install ortools") from err
        from ortools.sat.python import cp_model_helper

        self._cp = cp_model
        self._helper = cp_model_helper
        self.extent = extent
        self.workers = int(workers)
        self.formulation = formulation
        # Each objective expression's 0/1 linear form, flattened (indices, coefficients,
        # offset) and kept: re-solves (the visibility fixpoint, the confidence tests, the
        # pose choice) change the weights, not the expressions, and building the forms was
        # a tenth of a known-pose estimate.
        # Kept as slots: each expression's slot number, and the forms as one table
        # (_slot_table) from which a solve gathers its objective with numpy.
        self._slots: dict[Expr, int] = {}
        self._slot_arrays: tuple | None = None
        # Conjunctions and disjunctions reified for an objective only, with the sides of
        # their definition posted so far (see _objective_literal).
        self._halves: dict[Expr, _Half] = {}
        self._half_vars: dict[int, _Half] = {}  # the same, by the literal's variable index
        self._hint_table: tuple | None = None
        self._literal_table: tuple | None = None
        self._position_table: tuple | None = None
        # Deterministic work of the last solve: what a decision's searches may spend.
        self._last_work: float | None = None
        key = _template_key(extent, constraints, formulation)
        template = _template(key)
        if template is not None:
            self._from_template(template)
            return
        self.model = cp_model.CpModel()
        self._build_placements()
        self._lits: dict[Expr, object] = {}
        self._choices: dict[str, object] = {}
        self._exempt: dict[int, list] = {}
        self._exempt_table = np.zeros((0, 3), np.int64)
        tight = formulation == "tight"
        if tight:
            self._build_support()
        for c in grammar_constraints(extent):
            if not (tight and self._is_support_rule(c)):
                self._post(c, ())
        if tight:
            self._build_column_cuts()
        for c in constraints:
            self._post(c, ())
        _keep_template(key, _Template(
            self.model.clone(), self._x_index, self._false.index,
            {e: lit.index for e, lit in self._lits.items()},
            {name: var.index for name, var in self._choices.items()},
            {p: [lit.index for lit in lits] for p, lits in self._exempt.items()},
            self._exempt_table,
            {e: (h.conjunction, [r[0] for r in h.rows[True]], [r[0] for r in h.rows[False]])
             for e, h in self._halves.items()}))

    def _from_template(self, template: _Template) -> None:
        """The model of ``template`` (a copy) and Python handles on its variables."""
        self.model = template.model.clone()
        handles: dict[int, object] = {}

        def var(index: int):
            # One handle per variable, as building made them (a log's variable is shared
            # by the positions it covers).
            handle = handles.get(index)
            if handle is None:
                handle = handles[index] = self.model.get_bool_var_from_proto_index(index)
            return handle

        self._x_index = template.x_index
        self._x = [[None if i < 0 else var(i) for i in row] for row in template.x_index.tolist()]
        self._false = var(template.false)
        self._lits = {e: var(i) for e, i in template.lits.items()}
        self._choices = {name: var(i) for name, i in template.choices.items()}
        self._exempt = {p: [var(i) for i in lits] for p, lits in template.exempt.items()}
        self._exempt_table = template.exempt_table
        # (Both sides posted: the parts are not needed again.)
        self._halves = {e: _Half(self._lits[e], [], conjunction,
                                 {True: [[i, None] for i in upper],
                                  False: [[i, None] for i in lower]},
                                 {True: True, False: True})
                        for e, (conjunction, upper, lower) in template.halves.items()}
        self._half_vars = {half.literal.index: half for half in self._halves.values()}

    # -- compilation -------------------------------------------------------
    def _build_placements(self) -> None:
        """One Boolean per log placement (start position, length) and one "empty" per position.

        ``self._x[p][v]`` is the literal of Z_p = v (None where impossible:
        the log would leave its line). A (2,1) is the same variable as the
        (2,0) before it, so constraints (a)–(b) hold by construction and
        presolve has no equalities to eliminate; "exactly one of: empty, the
        placements covering p" keeps one value per position.
        """
        m = self.model
        n = self.extent.positions
        self._x: list[list] = [[None] * NUM_VALUES for _ in range(n)]
        for line in line_positions(self.extent):
            ps = [self._p(q) for q in line]
            L = len(ps)
            for pos, p in enumerate(ps):
                self._x[p][0] = m.new_bool_var(f"empty{p}")
                self._x[p][1] = m.new_bool_var(f"log1@{p}")
                if pos + 1 < L:
                    two = m.new_bool_var(f"log2@{p}")
                    self._x[p][2] = self._x[ps[pos + 1]][3] = two
                if pos + 2 < L:
                    three = m.new_bool_var(f"log3@{p}")
                    self._x[p][4] = self._x[ps[pos + 1]][5] = self._x[ps[pos + 2]][6] = three
        for row in self._x:
            m.add_exactly_one([lit for lit in row if lit is not None])
        # -1 where a value is impossible; the solution array gets a trailing 0 for it.
        self._x_index = np.array([[-1 if lit is None else lit.index for lit in row]
                                  for row in self._x], dtype=np.int64)
        self._false = m.new_bool_var("false")
        m.add(self._false == 0)

    def _build_support(self) -> None:
        """Constraints (c)–(d) in disjunctive form (the "tight" formulation).

        Each 3-notch placement above layer 0 gets one exemption literal per
        notch: at most one of them holds, only when the log is placed, and only
        over an empty position. Every position above layer 0 is then empty, or
        over an occupied position, or an exempt notch (``empty_b ≤ empty + ex``).
        1- and 2-notch logs have no exemptions, so they rest on every notch; a
        3-notch log rests on at least two. Exact on integers, and the LP of a
        line with its supports is that of a choice among whole tilings (each
        with its own supported set) rather than of ``Σ_below ≥ 2·x``.
        """
        m = self.model
        exempt = self._exempt
        table = []
        for line in line_positions(self.extent):
            if line[0][1] == 0:
                continue
            ps = [self._p(q) for q in line]
            below = [self._p(Extent.below(q)) for q in line]
            for pos in range(len(ps) - 2):
                log3 = self._x[ps[pos]][4]
                if log3 is None:
                    continue
                notches = [m.new_bool_var(f"exempt{ps[pos + a]}@{ps[pos]}") for a in range(3)]
                m.add(sum(notches) <= log3)
                for a, lit in enumerate(notches):
                    # Exempt only over an empty position: then "exempt" is "unsupported".
                    m.add_implication(lit, self._x[below[pos + a]][0])
                    exempt.setdefault(ps[pos + a], []).append(lit)
                    table.append((lit.index, ps[pos], below[pos + a]))
            for p, b in zip(ps, below):
                m.add(self._x[b][0] <= self._x[p][0] + sum(exempt.get(p, [])))
        self._exempt_table = np.array(table, dtype=np.int64).reshape(-1, 3)

    @staticmethod
    def _is_support_rule(c: Expr) -> bool:
        """Whether ``c`` is one of the grammar's (c)–(d) (``Occ(q, {1,2,3})`` or
        ``Occ(q, {4})`` implies support below), which :meth:`_build_support` replaces."""
        return isinstance(c, Implies) and isinstance(c.a, Occ) \
            and c.a.values in _SUPPORT_ANTECEDENTS and c.a.q[1] > 0

    def _exempt_form(self, p: int):
        """``ex(p)``: 1 when position ``p`` is an unsupported notch (tight formulation)."""
        lits = self._exempt.get(p, ())
        return sum(lits) if lits else 0

    def _build_column_cuts(self) -> None:
        """``[Z_q ≠ ∅ ∨ Z_b(b(q)) ≠ ∅] ≤ [Z_b(b(q)) ≠ ∅] + ex(q) + ex(b(q))`` for q above
        layer 1: q occupied over an empty b(b(q)) is itself unsupported or rests on an
        unsupported b(q). Valid for every structure; its literal is the u/v features'
        at q, so the evidence's objective shares it, and a solve that weighs it keeps only
        the side of its definition the weight needs (:meth:`_objective_literal`; the cut
        holds at the literal's true value either way)."""
        from unseeable.grammar.expr import Or, occupied

        I, J, K = self.extent.shape
        m = self.model
        for i in range(I):
            for j in range(2, J):
                for k in range(K):
                    q, b1, b2 = (i, j, k), (i, j - 1, k), (i, j - 2, k)
                    e = Or(occupied(q), occupied(b2))
                    either = self._objective_literal(e)
                    half = self._halves.get(e)
                    if half is not None:  # its whole definition until a solve weighs it
                        self._side_rows(half, True)
                        self._side_rows(half, False)
                    m.add(either <= 1 - self._x[self._p(b2)][0] + self._exempt_form(self._p(q))
                          + self._exempt_form(self._p(b1)))

    def _unsupported_form(self, e: Expr):
        """The linear form of ``And(Z_q ≠ ∅, Z_b(q) = ∅)`` (an unsupported notch) in the
        tight formulation — its exemption literals — or None for any other expression."""
        if self.formulation != "tight" or not isinstance(e, And) or len(e.args) != 2:
            return None
        a, b = e.args
        if isinstance(a, Occ) and isinstance(b, Occ) and a.values == _EMPTY:
            a, b = b, a
        if not (isinstance(a, Occ) and isinstance(b, Occ) and a.values == NONEMPTY
                and b.values == _EMPTY and a.q[1] > 0 and b.q == Extent.below(a.q)):
            return None
        return self._exempt_form(self._p(a.q))

    def _joint_pairs(self, e: And) -> list[Expr] | None:
        """``e``'s arguments as joints ``And(Occ(q, last notch), Z_n(q) ≠ ∅)`` when ``e``
        is a conjunction of two or more joints (the stacked-joint factor), else None."""
        if self.formulation != "tight" or len(e.args) < 4 or len(e.args) % 2:
            return None
        lasts = {a.q: a for a in e.args if isinstance(a, Occ) and a.values == LAST_NOTCH_CODES}
        nexts = {a.q for a in e.args if isinstance(a, Occ) and a.values == NONEMPTY}
        if 2 * len(lasts) != len(e.args) or len(nexts) != len(lasts):
            return None
        pairs = []
        for q, last in lasts.items():
            nq = Extent.next(q)
            if nq not in nexts:
                return None
            pairs.append(And(last, Occ(nq, NONEMPTY)))
        return pairs

    def _p(self, q: tuple[int, int, int]) -> int:
        i, j, k = q
        _, J, K = self.extent.shape
        return (i * J + j) * K + k

    def _choice(self, name: str):
        var = self._choices.get(name)
        if var is None:
            var = self._choices[name] = self.model.new_bool_var(f"choice:{name}")
        return var

    def _direct_literal(self, e: Expr):
        """A CP-SAT literal for ``e`` without new variables, or None."""
        if isinstance(e, Occ):
            row = self._x[self._p(e.q)]
            if len(e.values) == 1:
                lit = row[next(iter(e.values))]
                return self._false if lit is None else lit
            if len(e.values) == NUM_VALUES - 1:
                lit = row[next(iter(ALL_CODES - e.values))]
                return self._false.Not() if lit is None else lit.Not()
            return None
        if isinstance(e, Choice):
            return self._choice(e.name)
        if isinstance(e, Not) and isinstance(e.arg, Choice):
            return self._choice(e.arg.name).Not()
        return None

    def _lin(self, e: Expr):
        """``[e]`` as a 0/1 linear expression without new variables, or None."""
        if isinstance(e, Occ):
            row = self._x[self._p(e.q)]
            if len(e.values) <= NUM_VALUES // 2:
                return sum(row[v] for v in sorted(e.values) if row[v] is not None)
            return 1 - sum(row[v] for v in sorted(ALL_CODES - e.values) if row[v] is not None)
        if isinstance(e, Const):
            return int(e.value)
        lit = self._direct_literal(e)
        if lit is not None:
            return lit
        return self._unsupported_form(e)

    def _lin01(self, e: Expr):
        lin = self._lin(e)
        return lin if lin is not None else self._lit(e)

    def _lit(self, e: Expr):
        """A CP-SAT literal equivalent to ``e`` (reifying it when needed)."""
        if isinstance(e, Const):
            return self._false.Not() if e.value else self._false
        lit = self._direct_literal(e)
        if lit is not None:
            return lit
        cached = self._lits.get(e)
        if cached is not None:
            if e in self._halves:  # now a part of something else: its whole definition
                self._make_whole(e)
            return cached
        m = self.model
        f = m.new_bool_var("")
        if isinstance(e, Occ):
            m.add(f == self._lin(e))
        elif isinstance(e, (And, Or)):
            parts, conjunction = self._definition_parts(e)
            # Both sides, the rows on each part first.
            self._post_side(f, parts, conjunction, upper=conjunction)
            self._post_side(f, parts, conjunction, upper=not conjunction)
        elif isinstance(e, Implies):
            m.add(f == self._lit(Or(negate(e.a), e.b)))
        elif isinstance(e, Iff):
            a, b = self._lin01(e.a), self._lin01(e.b)
            m.add(a == b).only_enforce_if(f)
            m.add(a + b == 1).only_enforce_if(f.Not())
        elif isinstance(e, AtLeast):
            total = sum(self._lin01(a) for a in e.args)
            m.add(total >= e.k).only_enforce_if(f)
            m.add(total <= e.k - 1).only_enforce_if(f.Not())
        elif isinstance(e, AtMost):
            total = sum(self._lin01(a) for a in e.args)
            m.add(total <= e.k).only_enforce_if(f)
            m.add(total >= e.k + 1).only_enforce_if(f.Not())
        elif isinstance(e, Exactly):
            m.add(f == self._lit(And(AtLeast(e.k, e.args), AtMost(e.k, e.args))))
        else:  # pragma: no cover - simplify() leaves no other nodes
            raise SolverError(f"cannot compile expression {e!r}")
        self._lits[e] = f
        return f

    def _objective_literal(self, e: Expr):
        """``[e]`` as a 0/1 linear form for an objective: as :meth:`_lin01`, except that a
        conjunction or disjunction is reified as a new literal of which each solve keeps
        only the side of its definition that the sign of its weight needs
        (:meth:`_weigh_sides`).

        Maximising ``w·f``, a literal of weight ``w > 0`` needs only ``f ≤ [e]`` and one
        of ``w < 0`` only ``f ≥ [e]``: at an optimum ``f`` is then ``[e]`` either way,
        and at any solution the model's objective is at most the structure's own, so
        optima, bounds, cut-offs and floors mean what they mean with the whole
        definition. The other side's rows (the evidence's features, the prior's stacked
        joints) are left out of the model: a fifth of its constraints at 10x12x10, and a
        fifth of CP-SAT's work on a uniform-prior MAP solve there (docs/decisions.md). A
        literal that becomes part of another expression or of a constraint (:meth:`_lit`)
        keeps its whole definition from then on.
        """
        lin = self._lin(e)
        if lin is not None:
            return lin
        known = self._lits.get(e)
        if known is not None:  # (as it is: a part or a constraint's, or an objective's)
            return known
        if not isinstance(e, (And, Or)):
            return self._lit(e)
        if all(isinstance(a, Occ) for a in e.args) and (
                not isinstance(e, And) or self._joint_pairs(e) is None):
            # Parts that need no new variables: made when a side is first posted (most
            # literals of an estimate's objectives never are).
            parts, conjunction = (lambda: self._definition_parts(e)[0]), isinstance(e, And)
        else:
            parts, conjunction = self._definition_parts(e)
        f = self.model.new_bool_var("")
        self._lits[e] = f
        self._halves[e] = self._half_vars[f.index] = _Half(f, parts, conjunction)
        return f

    def _definition_parts(self, e: And | Or) -> tuple[list, bool]:
        """The 0/1 linear forms ``[e]`` is the conjunction or disjunction of, and whether it
        is a conjunction (a stacked joint's parts: its joints' literals)."""
        conjunction = isinstance(e, And)
        joints = self._joint_pairs(e) if conjunction else None
        if joints is not None:
            return [self._lit(a) for a in joints], True
        return [self._lin01(a) for a in e.args], conjunction

    def _post_side(self, f, parts: list, conjunction: bool, *, upper: bool) -> list:
        """Post one side of ``f = [e]`` for ``e`` the conjunction (``conjunction``) or
        disjunction of ``parts``: ``upper`` ``f ≤ [e]``, else ``f ≥ [e]``. Returns the
        constraints added."""
        m, n = self.model, len(parts)
        if conjunction == upper:  # f ≤ each part (And), or f ≥ each part (Or)
            return [m.add(f <= part) if upper else m.add(f >= part) for part in parts]
        if conjunction:  # And: f ≥ Σ parts − (n − 1)
            return [m.add(sum(parts) - (n - 1) <= f)]
        return [m.add(f <= sum(parts))]  # Or: f ≤ Σ parts

    def _side_rows(self, half: _Half, upper: bool) -> list[list]:
        """The rows of one side of a half-reified literal's definition, posted on first
        use: ``upper`` ``f ≤ [e]``, else ``f ≥ [e]``; each as [constraint index, its
        domain once read]."""
        rows = half.rows[upper]
        if rows is not None:
            return rows
        if callable(half.parts):
            half.parts = half.parts()
        added = self._post_side(half.literal, half.parts, half.conjunction, upper=upper)
        # Each row's domain is read when it is first left out (reading it costs more than
        # posting the row).
        rows = half.rows[upper] = [[c.index, None] for c in added]
        half.active[upper] = True
        return rows

    def _set_side(self, half: _Half, upper: bool, active: bool) -> None:
        """Keep (``active``) or leave out one posted side of a half-reified literal: a row
        left out gets a domain its activity never leaves."""
        if half.active[upper] == active:
            return
        proto = self.model.model_proto.constraints
        for row in half.rows[upper]:
            target = proto[row[0]].linear.domain
            if row[1] is None:
                row[1] = tuple(target)
            if len(row[1]) == 2:  # (an inequality; anything else stays as posted)
                target[0], target[1] = row[1] if active else _ANY_ACTIVITY
        half.active[upper] = active

    def _weigh_sides(self, units: np.ndarray, weights: np.ndarray) -> None:
        """For each half-reified literal among the objective's expressions of non-zero
        weight, keep the side of its definition the weight's sign needs and leave the
        other out. ``units``: each expression's variable index when its form is that
        variable alone (coefficient 1, offset 0), else -1 (:meth:`_slot_table`)."""
        halves = self._half_vars
        if not halves:
            return
        chosen = np.flatnonzero((units >= 0) & (weights != 0))
        for var, w in zip(units[chosen].tolist(), weights[chosen].tolist()):
            half = halves.get(var)
            if half is None:
                continue
            upper = w > 0
            active = half.active
            if active[upper] and not active[not upper]:
                continue  # as the last solve that weighed it left it
            self._side_rows(half, upper)
            self._set_side(half, upper, True)
            if half.rows[not upper] is not None:
                self._set_side(half, not upper, False)

    def _make_whole(self, e: Expr) -> None:
        """Give a half-reified literal its whole definition, for good."""
        half = self._halves.pop(e, None)
        if half is not None:
            del self._half_vars[half.literal.index]
            for upper in (True, False):
                self._side_rows(half, upper)
                self._set_side(half, upper, True)

    def _post(self, e: Expr, enforce: tuple) -> None:
        """Require ``e`` (when every literal of ``enforce`` holds)."""
        m = self.model

        def guarded(ct):
            if enforce:
                ct.only_enforce_if(list(enforce))

        if isinstance(e, Const):
            if not e.value:
                m.add_bool_or([lit.Not() for lit in enforce])  # empty clause: infeasible
            return
        if isinstance(e, And):
            for a in e.args:
                self._post(a, enforce)
            return
        if isinstance(e, Occ) and not enforce:
            row = self._x[self._p(e.q)]
            for v in ALL_CODES - e.values:
                if row[v] is not None:
                    m.add(row[v] == 0)
            return
        if isinstance(e, (Occ, Choice, Not)):
            guarded(m.add(self._lin01(e) >= 1))
            return
        if isinstance(e, Or):
            lits = [self._direct_literal(a) for a in e.args]
            if all(lit is not None for lit in lits):
                m.add_bool_or(lits + [lit.Not() for lit in enforce])
            else:
                guarded(m.add(sum(self._lin01(a) for a in e.args) >= 1))
            return
        if isinstance(e, Implies):
            a_lin = self._lin(e.a)
            if a_lin is not None and not enforce:
                b_lin = self._lin(e.b)
                if b_lin is not None:  # tight linear form of a → b on 0/1 expressions
                    m.add(a_lin <= b_lin)
                    return
                if isinstance(e.b, AtLeast) and all(self._lin(x) is not None for x in e.b.args):
                    m.add(sum(self._lin(x) for x in e.b.args) >= e.b.k * a_lin)
                    return
            self._post(e.b, (*enforce, self._lit(e.a)))
            return
        if isinstance(e, Iff):
            a, b = self._lin01(e.a), self._lin01(e.b)
            if not enforce and a is b:  # e.g. (a)-(b): both sides are one placement variable
                return
            guarded(m.add(a == b))
            return
        if isinstance(e, (AtLeast, AtMost, Exactly)):
            total = sum(self._lin01(a) for a in e.args)
            if isinstance(e, AtLeast):
                guarded(m.add(total >= e.k))
            elif isinstance(e, AtMost):
                guarded(m.add(total <= e.k))
            else:
                guarded(m.add(total == e.k))
            return
        raise SolverError(f"cannot compile constraint {e!r}")  # pragma: no cover

    # -- solving -----------------------------------------------------------
    def _parameters(self, solver, time_limit: float) -> None:
        p = solver.parameters
        p.num_workers = self.workers
        p.linearization_level = 2
        # Measured (benchmarks/solve.py, DESIGN.md §8 re-measured): on this model
        # presolve and probing cost more than they save, and putting every
        # linear constraint in the LP from the start avoids rounds of cut
        # separation — together 2-3x faster at 6x8x6 and 8x10x8, same optima.
        p.cp_model_presolve = False
        p.cp_model_probing_level = 0
        p.add_lp_constraints_lazily = False
        # Without presolve the symmetries found are not used: finding them was pure cost
        # (the same search; 8 % of CP-SAT's time on corpus views' estimates).
        p.symmetry_level = 0
        p.max_time_in_seconds = float(time_limit)
        p.random_seed = 1
        if self.workers > 1:
            p.subsolvers.extend(MULTI_WORKER_SUBSOLVERS[: self.workers])

    def _flat_form(self, e: Expr) -> tuple[list[int], list[int], int]:
        """``[e]``'s linear form as (variable indices, integer coefficients, offset); lists,
        made into arrays once per batch (:meth:`_extend_table`)."""
        if isinstance(e, Occ):  # (the form _lin makes, read off the placement table)
            row = self._x_index[self._p(e.q)]
            if len(e.values) <= NUM_VALUES // 2:
                used = [v for v in row[sorted(e.values)].tolist() if v >= 0]
                return used, [1] * len(used), 0
            used = [v for v in row[sorted(ALL_CODES - e.values)].tolist() if v >= 0]
            return used, [-1] * len(used), 1
        form = self._objective_literal(e)
        if isinstance(form, (int, np.integer)):
            return [], [], int(form)
        if isinstance(form, self._cp.IntVar):  # (a literal of its own: itself)
            return [form.index], [1], 0
        f = self._helper.FlatIntExpr(form)
        return [v.index for v in f.vars], list(f.coeffs), int(f.offset)

    def _slots_of(self, exprs: Sequence[Expr]) -> np.ndarray:
        """Each expression's slot in :meth:`_slot_table`; the forms of new ones
        (:meth:`_flat_form`) made in order and added to the table."""
        get = self._slots.get
        ids = [get(e) for e in exprs]
        if None in ids:
            new = []
            for n, e in enumerate(exprs):
                if ids[n] is None:
                    ids[n] = self._slots[e] = len(self._slots)
                    new.append(self._flat_form(e))
            self._extend_table(new)
        return np.array(ids, dtype=np.int64)

    def _extend_table(self, forms: list[tuple[list[int], list[int], int]]) -> None:
        """Add forms to the slot table."""
        length = np.array([len(f[0]) for f in forms], dtype=np.int64)
        total = int(length.sum())
        variables = np.fromiter(itertools.chain.from_iterable(f[0] for f in forms),
                                dtype=np.int64, count=total)
        coefficients = np.fromiter(itertools.chain.from_iterable(f[1] for f in forms),
                                   dtype=np.int64, count=total)
        offset = np.array([f[2] for f in forms], dtype=np.int64)
        start = np.cumsum(length) - length
        unit = np.full(len(forms), -1, np.int64)
        single = np.flatnonzero(length == 1)
        single = single[(coefficients[start[single]] == 1) & (offset[single] == 0)]
        unit[single] = variables[start[single]]
        old = self._slot_arrays
        if old is not None:
            start = start + len(old[2])
            start, length, variables, coefficients, offset, unit = (
                np.concatenate(pair) for pair in zip(
                    old, (start, length, variables, coefficients, offset, unit)))
        self._slot_arrays = (start, length, variables, coefficients, offset, unit)

    def _slot_table(self) -> tuple[np.ndarray, ...]:
        """The kept forms as arrays: each slot's first entry and length in the variables
        and coefficients, its offset, and its unit variable (its form is that variable
        alone; -1 when not)."""
        if self._slot_arrays is None:
            self._extend_table([])
        return self._slot_arrays

    def _flat_objective(self, objective: Objective
                        ) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray, int]]:
        """(scaled coefficients, ``Σ_e round(c_e·SCALE)·[e]`` flattened: variable indices
        ascending, their integer coefficients (none 0), integer offset).

        The form CP-SAT's own ``maximize``/``add`` make of the weighted sum
        (``FlatIntExpr``: terms merged per variable, sorted, zeros dropped), gathered
        with numpy from the expressions' kept forms (:meth:`_slot_table`), and written
        straight into the proto. Building the sum as a CP-SAT expression, flattening it
        and hinting variable by variable in Python held the GIL for ~4 ms a solve;
        gathering the kept forms one expression at a time took 5 ms a solve on the
        lodge. The protos are the same (tests/solve/test_cpsat.py).
        """
        scaled = np.rint(objective.coefs * SCALE)
        # Every expression's form, in order, weighted or not: the model (its reified
        # literals and their indices) is then the same whatever the weights.
        ids = self._slots_of(objective.exprs)
        start, length, variables, coefficients, offsets, unit = self._slot_table()
        self._weigh_sides(unit[ids], scaled)
        keep = np.flatnonzero(scaled != 0)
        if not len(keep):
            return scaled, (np.zeros(0, np.int64), np.zeros(0, np.int64), 0)
        kept = ids[keep]
        weights = scaled[keep].astype(np.int64)
        sizes = length[kept]
        # The kept forms' entries, one after the other.
        ends = np.cumsum(sizes)
        entry = np.repeat(start[kept] - (ends - sizes), sizes) + np.arange(int(ends[-1]))
        idx = variables[entry]
        terms = coefficients[entry] * np.repeat(weights, sizes)
        kept_offsets = offsets[kept]
        nonzero = kept_offsets != 0
        offset = sum(int(w) * int(o) for w, o in zip(weights[nonzero].tolist(),
                                                     kept_offsets[nonzero].tolist()))
        if not len(idx):
            return scaled, (np.zeros(0, np.int64), np.zeros(0, np.int64), offset)
        if np.abs(terms).sum() < 2**52:  # float sums of integers are exact: bincount will do
            total = np.rint(np.bincount(idx, weights=terms.astype(np.float64))).astype(np.int64)
        else:  # pragma: no cover - weights beyond any log-probability's
            total = np.zeros(int(idx.max()) + 1, np.int64)
            np.add.at(total, idx, terms)
        used = np.flatnonzero(total)
        return scaled, (used, total[used], offset)

    @staticmethod
    def _write_objective(model, flat: tuple[np.ndarray, np.ndarray, int]) -> None:
        """Maximise ``flat`` (indices, coefficients, offset) in ``model``: the proto
        ``CpModel.maximize`` writes for the same sum."""
        variables, coeffs, offset = flat
        model.clear_objective()
        proto = model.model_proto.objective
        proto.vars.extend(variables.tolist())
        proto.coeffs.extend((-coeffs).tolist())
        proto.offset = -offset
        proto.scaling_factor = -1.0

    @staticmethod
    def _add_at_least(model, flat: tuple[np.ndarray, np.ndarray, int], floor: int) -> None:
        """Require ``flat`` (indices, coefficients, offset) ``>= floor`` in ``model``: the
        constraint ``CpModel.add(linear >= floor)`` writes for the same sum."""
        variables, coeffs, offset = flat
        linear = model.model_proto.constraints.add().linear
        linear.vars.extend(variables.tolist())
        linear.coeffs.extend(coeffs.tolist())
        linear.domain.extend([int(floor) - offset, _INT64_MAX])

    def _install(self, objective: Objective, hint: np.ndarray | None,
                 hint_choices: Mapping[str, bool] | None
                 ) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray, int]]:
        """Set the objective and the hint; return (scaled coefficients, flat objective)."""
        scaled, flat = self._flat_objective(objective)
        self._write_objective(self.model, flat)
        self.model.clear_hints()
        if hint is not None:
            self._write_hint(self.model, hint)
            for name, value in (hint_choices or {}).items():
                if name in self._choices:
                    self.model.add_hint(self._choices[name], bool(value))
        return scaled, flat

    def _hint_arrays(self, hint: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(variable indices, 0/1 values) of every placement and empty literal at ``hint``,
        in the order the placements list them (a log's variable at its first position)."""
        table = self._hint_table
        if table is None:
            flat = self._x_index.ravel()
            used = np.flatnonzero(flat >= 0)
            var = flat[used]
            uniq, first, inverse = np.unique(var, return_index=True, return_inverse=True)
            order = np.argsort(first, kind="stable")
            rank = np.empty(len(order), np.int64)
            rank[order] = np.arange(len(order))
            table = self._hint_table = (uniq[order], used // NUM_VALUES, used % NUM_VALUES,
                                        rank[inverse], len(order))
        variables, position, code, slot, n = table
        match = code == np.asarray(hint).ravel()[position]
        # A log's variable is 1 when the hint has it at any of its positions.
        values = np.bincount(slot, weights=match, minlength=n) > 0
        return variables, values.astype(np.int64)

    def _write_hint(self, model, hint: np.ndarray) -> None:
        """Hint ``hint``'s placements in ``model`` (as ``add_hint`` of each, in one go)."""
        variables, values = self._hint_arrays(hint)
        proto = model.model_proto.solution_hint
        proto.vars.extend(variables.tolist())
        proto.values.extend(values.tolist())

    def _status(self, solver, code, model) -> SolveStatus:
        """CP-SAT's answer as a :class:`SolveStatus` (a rejected model is a bug: raise)."""
        cp = self._cp
        statuses = {cp.OPTIMAL: SolveStatus.OPTIMAL, cp.FEASIBLE: SolveStatus.FEASIBLE,
                    cp.INFEASIBLE: SolveStatus.INFEASIBLE, cp.UNKNOWN: SolveStatus.TIMEOUT}
        if code not in statuses:
            raise SolverError(f"CP-SAT rejected the model ({solver.status_name(code)}): "
                              f"{model.validate()}")
        return statuses[code]

    def _decode(self, solver) -> tuple[np.ndarray, dict]:
        sol = np.append(np.asarray(solver.response_proto.solution, dtype=np.int64), 0)
        occupancy = sol[self._x_index].argmax(axis=1).astype(np.int8).reshape(self.extent.shape)
        choices = {name: bool(sol[var.index]) for name, var in self._choices.items()}
        return occupancy, choices

    def improve(self, objective: Objective, *, hint: np.ndarray,
                hint_choices: Mapping[str, bool] | None = None,
                time_limit: float = 60.0) -> RawSolution:
        """A structure whose scaled objective is strictly above ``hint``'s, or a proof of none.

        The question a confidence test asks ("does anything beat the
        estimate under these priors?"), from the whole estimate as the hint
        (every literal of the model, so CP-SAT takes it as a solution at once
        instead of completing it by search), in three steps:

        1. the optimisation with the LP, its objective's domain starting at the
           cut-off (the estimate's value + 1) and stopping at the first
           structure in it, for :data:`IMPROVE_LP_SHARE` of the last solve's
           deterministic work: the LP bound proves "none" as a MAP solve proves
           its optimum, in about a MAP's work. (The feasibility problem with the
           cut-off as a constraint and no objective took 30 s to prove "none"
           where the MAP took 0.8 s, 8×10×8.)
        2. when that does not decide, re-solves of neighbourhoods (blocks of
           columns, every layer; the rest fixed at the estimate, presolved
           away), in the rounds of :data:`NEIGHBOURHOOD_ROUNDS`, those where the
           estimate leaves the most objective on the table first: a better
           structure one block away is found here in a tenth of a second, where
           the LP over the whole model can take seconds to reach it (at
           10×12×10 under shifted priors, 14–22 s);
        3. step 1 without a budget.

        The budgets are deterministic work (step 2 :data:`NEIGHBOURHOOD_WORK` a
        neighbourhood), so the answer is the same on any machine.

        Returns FEASIBLE with the structure found, INFEASIBLE when none beats
        the hint (the hint is optimal), TIMEOUT when undecided.
        """
        cp = self._cp
        t0 = time.perf_counter()
        _, flat = self._install(objective, hint, hint_choices)
        full = self._full_hint(hint, hint_choices)
        value = self._value_at(flat, full)
        if value is None:  # a choice the hint does not give: CP-SAT sets it at best
            value = self._scaled_value(hint, hint_choices)
        cutoff = value + 1
        install_s = time.perf_counter() - t0
        t1 = time.perf_counter()
        steps: list[str] = []

        def left() -> float:
            return max(time_limit - (time.perf_counter() - t0), 1e-3)

        def above_cutoff(fixed=None, work: float | None = None):
            """The status and solver of the model with the objective's domain from the
            cut-off (and ``fixed`` placements at the hint's values), stopping at the first
            structure found or after ``work``."""
            t2 = time.perf_counter()
            query = self.model.clone()
            # The proto minimises -Σ c·x - offset: "Σ c·x + offset >= cutoff" bounds it above.
            query.model_proto.objective.domain.extend([-_INT64_MAX, -(cutoff - flat[2])])
            if fixed is not None:  # fixed domains, presolved away
                domains = query.model_proto.variables
                for index, fixed_value in zip(*(a.tolist() for a in fixed)):
                    domain = domains[index].domain
                    domain[0] = domain[1] = fixed_value
            self._set_hint(query, full)
            solver = cp.CpSolver()
            self._parameters(solver, left())
            solver.parameters.stop_after_first_solution = True
            if fixed is not None:
                solver.parameters.cp_model_presolve = True
            if work is not None:
                solver.parameters.max_deterministic_time = work
            status = self._status(solver, solver.solve(query), query)
            steps.append(f"{'lp' if fixed is None else 'neighbourhood'} {status.value} "
                         f"{time.perf_counter() - t2:.3f}s")
            return status, solver

        # 1. The whole model with the LP, for about a MAP's work.
        status, solver = above_cutoff(
            work=max(IMPROVE_LP_SHARE * (self._last_work or 0.0), IMPROVE_LP_FLOOR))
        # 2. Neighbourhoods of the estimate, the rest fixed and presolved away.
        rounds = iter(NEIGHBOURHOOD_ROUNDS)
        while status == SolveStatus.TIMEOUT and (size := next(rounds, None)) is not None:
            for fixed in self._neighbourhoods(hint, flat, full, *size):
                found, found_by = above_cutoff(fixed, NEIGHBOURHOOD_WORK)
                if found in (SolveStatus.OPTIMAL, SolveStatus.FEASIBLE):
                    status, solver = found, found_by
                    break
        # 3. The whole model with the LP, to the end.
        if status == SolveStatus.TIMEOUT:
            status, solver = above_cutoff()
        solve_s = time.perf_counter() - t1
        occupancy, choices = None, {}
        if status in (SolveStatus.OPTIMAL, SolveStatus.FEASIBLE):
            status = SolveStatus.FEASIBLE  # a structure above the cut-off: not the best one
            occupancy, choices = self._decode(solver)
        bound = objective.constant + (cutoff - 1) / SCALE if status == SolveStatus.INFEASIBLE \
            else math.inf
        logger.debug("cpsat improve %s in %.3fs (install %.3fs; %s)", status.value, solve_s,
                     install_s, ", ".join(steps))
        return RawSolution(status, occupancy, bound, solve_s, install_s, choices)

    def _neighbourhoods(self, hint: np.ndarray, flat: tuple[np.ndarray, np.ndarray, int],
                        full: tuple[np.ndarray, np.ndarray], side: int, count: int):
        """Placements to fix (variable indices, hinted values) for each neighbourhood
        :meth:`improve` re-solves: every placement outside a block of columns ``side``
        a side, at most ``count`` blocks that do not overlap. Blocks are ranked by the
        objective the hint forgoes in them (a term with a positive weight the hint leaves
        false, or a negative one it makes true); none when one block covers the grid."""
        I, J, K = self.extent.shape
        if I <= side and K <= side:
            return
        position = self._variable_positions()
        variables, coeffs, _ = flat
        known = np.full(len(position), -1, np.int64)
        known[full[0]] = full[1]
        x = known[variables]
        forgone = np.where(((coeffs > 0) & (x == 0)) | ((coeffs < 0) & (x == 1)),
                           np.abs(coeffs), 0)
        at = position[variables]
        keep = at >= 0
        column = np.zeros((I, K))
        np.add.at(column, ((at[keep] // (J * K)), at[keep] % K), forgone[keep])
        # Every block's forgone objective (a window sum over the columns).
        starts_i, starts_k = range(max(I - side, 0) + 1), range(max(K - side, 0) + 1)
        sums = np.array([[column[i:i + side, k:k + side].sum() for k in starts_k]
                         for i in starts_i])
        placed, values = self._hint_arrays(hint)
        at_placed = position[placed]
        pi, pk = at_placed // (J * K), at_placed % K
        chosen: list[tuple[int, int]] = []
        for flat_index in np.argsort(-sums, axis=None, kind="stable"):
            if len(chosen) == count or sums.flat[flat_index] <= 0:
                break
            bi, bk = np.unravel_index(flat_index, sums.shape)
            if any(abs(bi - ci) < side and abs(bk - ck) < side for ci, ck in chosen):
                continue  # overlaps a block tried: take the next apart
            chosen.append((int(bi), int(bk)))
            outside = ~((pi >= bi) & (pi < bi + side) & (pk >= bk) & (pk < bk + side))
            yield placed[outside], values[outside]

    def _variable_positions(self) -> np.ndarray:
        """The grid position (index) each variable of the model belongs to: a placement
        its first notch, an exemption its notch, a literal its first ``Occ``; -1 for the
        rest (choices, constants). Kept until literals are added."""
        table = self._position_table
        if table is not None and table[0] == len(self._lits):
            return table[1]
        position = np.full(len(self.model.model_proto.variables), -1, np.int64)
        used = np.flatnonzero(self._x_index.ravel() >= 0)
        var = self._x_index.ravel()[used]
        # The first position a variable appears at (a log's first notch).
        position[var[::-1]] = (used // NUM_VALUES)[::-1]
        if len(self._exempt_table):
            for p, lits in self._exempt.items():
                position[[lit.index for lit in lits]] = p
        _, lits, _, positions, _, _ = self._literal_evaluator()
        if len(lits):
            position[lits] = positions[:, 0]
        self._position_table = (len(self._lits), position)
        return position

    def _literal_evaluator(self) -> tuple:
        """Arrays that evaluate every reified literal that is a conjunction or disjunction of
        ``Occ`` leaves (nearly all: features, joints, stacked joints) on an occupancy at
        once; the rest (choices, counts) are evaluated one by one. Kept until literals are
        added."""
        table = self._literal_table
        if table is not None and table[0] == len(self._lits):
            return table
        simple, other = [], []
        for e, lit in self._lits.items():
            if isinstance(e, Occ):
                simple.append((lit.index, True, (e,)))
            elif isinstance(e, (And, Or)) and all(isinstance(a, Occ) for a in e.args):
                simple.append((lit.index, isinstance(e, And), e.args))
            else:
                other.append((lit.index, e))
        variables = np.array([v for v, *_ in simple], dtype=np.int64)
        conjunction, positions, masks = leaf_table([(c, leaves) for _, c, leaves in simple],
                                                   self.extent)
        table = self._literal_table = (len(self._lits), variables, conjunction, positions, masks,
                                       other)
        return table

    def _full_hint(self, hint: np.ndarray, hint_choices: Mapping[str, bool] | None
                   ) -> tuple[np.ndarray, np.ndarray]:
        """(variable indices, 0/1 values) of every variable of the model at ``hint``: the
        placements, the exemptions, the reified literals, and the choices ``hint_choices``
        gives (literals that depend on a choice it does not give are left out)."""
        z = np.asarray(hint).ravel()
        variables, values = [], []
        placed, placed_values = self._hint_arrays(hint)
        variables.append(placed)
        values.append(placed_values)
        variables.append(np.array([self._false.index], np.int64))
        values.append(np.zeros(1, np.int64))
        if len(self._exempt_table):
            lit, start, below = self._exempt_table.T
            variables.append(lit)
            values.append(((z[start] == 4) & (z[below] == 0)).astype(np.int64))
        _, lits, conjunction, positions, masks, other = self._literal_evaluator()
        if len(lits):
            leaf = masks[np.arange(len(lits))[:, None], np.arange(positions.shape[1]), z[positions]]
            truth = np.where(conjunction, leaf.all(axis=1), leaf.any(axis=1))
            variables.append(lits)
            values.append(truth.astype(np.int64))
        names = dict(hint_choices or {})
        extra = [(var.index, int(bool(names[name]))) for name, var in self._choices.items()
                 if name in names]
        if other:
            from unseeable.grammar.expr import scope

            occupancy = np.asarray(hint)
            for index, e in other:
                if scope(e)[1] <= names.keys():
                    extra.append((index, int(bool(evaluate(e, occupancy, names)))))
        if extra:
            variables.append(np.array([v for v, _ in extra], np.int64))
            values.append(np.array([x for _, x in extra], np.int64))
        return np.concatenate(variables), np.concatenate(values)

    @staticmethod
    def _set_hint(model, full: tuple[np.ndarray, np.ndarray]) -> None:
        """Replace ``model``'s hint by ``full`` (variable indices, values)."""
        model.clear_hints()
        proto = model.model_proto.solution_hint
        proto.vars.extend(full[0].tolist())
        proto.values.extend(full[1].tolist())

    def _value_at(self, flat: tuple[np.ndarray, np.ndarray, int],
                  full: tuple[np.ndarray, np.ndarray]) -> int | None:
        """The scaled objective ``flat`` at the assignment ``full``; None when it leaves a
        variable of the objective out."""
        variables, coeffs, offset = flat
        known = np.full(len(self.model.model_proto.variables), -1, np.int64)
        known[full[0]] = full[1]
        values = known[variables]
        if (values < 0).any():
            return None
        return int(offset + int(np.dot(coeffs, values)))

    def _fixed_copy(self, variables: np.ndarray, values: np.ndarray):
        """A copy of the model (the objective just installed included, no hint) with
        ``variables`` fixed at their 0/1 ``values`` in one clause."""
        fixed = self.model.clone()
        fixed.clear_hints()
        # A literal is -index-1 when negated.
        fixed.model_proto.constraints.add().bool_and.literals.extend(
            np.where(values == 1, variables, -variables - 1).tolist())
        return fixed

    def _scaled_value(self, hint: np.ndarray,
                      hint_choices: Mapping[str, bool] | None) -> int:
        """The installed scaled objective at ``hint`` (choices left free are set at best)."""
        cp = self._cp
        fixed = self._fixed_copy(*self._hint_arrays(hint))  # every placement
        for name, value in (hint_choices or {}).items():
            if name in self._choices:
                fixed.add(self._choices[name] == int(bool(value)))
        solver = cp.CpSolver()
        self._parameters(solver, 60.0)
        code = solver.solve(fixed)
        if code != cp.OPTIMAL:
            raise SolverError("the given structure breaks the grammar or the constraints "
                              f"(CP-SAT: {solver.status_name(code)})")
        return int(round(solver.objective_value))

    def _hint_ties(self, flat: tuple[np.ndarray, np.ndarray, int],
                   full: tuple[np.ndarray, np.ndarray] | None,
                   hint_choices: Mapping[str, bool] | None, optimum: int) -> bool:
        """Whether the hint's whole assignment ``full`` is a solution of the model whose
        scaled objective ``flat`` is ``optimum``: every choice given, its value the
        optimum's, and the model's constraints kept with every variable it gives fixed
        (a propagation, no search)."""
        if full is None or not self._choices.keys() <= dict(hint_choices or {}).keys():
            return False
        if self._value_at(flat, full) != optimum:
            return False
        cp = self._cp
        fixed = self._fixed_copy(*full)
        fixed.clear_objective()
        solver = cp.CpSolver()
        self._parameters(solver, 10.0)
        solver.parameters.linearization_level = 0
        return solver.solve(fixed) in (cp.OPTIMAL, cp.FEASIBLE)

    def lexicographic(self, objective: Objective, secondary: Objective, *, hint: np.ndarray,
                      hint_choices: Mapping[str, bool] | None = None,
                      deterministic_limit: float = 1.0,
                      probe: float | None = LEXICOGRAPHIC_PROBE) -> RawSolution:
        """Best ``secondary`` among structures at least as good as ``hint`` on ``objective``.

        Used to pick the emptiest member of a tie after the exact solve; the
        limit is CP-SAT's deterministic time, so the answer does not depend on
        the machine's speed or load. FEASIBLE when the limit stopped it (the
        structure is still at least as good as ``hint`` on ``objective``).

        ``probe``: the search first runs for at most this much deterministic time,
        and goes on to ``deterministic_limit`` only when it found a structure by then
        (from that structure); none found (TIMEOUT) ends it. On the corpus every such
        search ended proven within 0.04; at 10x12x10 none found anything in the whole
        budget of 0.5, which was then 0.6-0.9 s of the estimate (docs/decisions.md).
        None: the whole limit at once.
        """
        cp = self._cp
        t0 = time.perf_counter()
        _, flat = self._install(objective, None, None)
        # The structure's value from its whole assignment (as improve() takes it), or by
        # CP-SAT with its placements fixed when a choice it needs is not given.
        floor = self._value_at(flat, self._full_hint(hint, hint_choices))
        if floor is None:
            floor = self._scaled_value(hint, hint_choices)
        query = self.model.clone()
        self._add_at_least(query, flat, floor)
        self._write_objective(query, self._flat_objective(secondary)[1])
        self._write_hint(query, hint)
        install_s = time.perf_counter() - t0
        limit = float(deterministic_limit)
        stages = [limit] if probe is None or probe >= limit else [float(probe), limit]
        solve_s, spent = 0.0, 0.0
        found = RawSolution(SolveStatus.TIMEOUT, None, math.inf, 0.0, install_s)
        for until in stages:
            solver = cp.CpSolver()
            self._parameters(solver, 600.0)
            # Its root LP is most of its time and the MIR cuts most of that (the lodge's
            # last tie search 59 -> 35 ms, the same members; docs/decisions.md).
            solver.parameters.add_mir_cuts = False
            solver.parameters.max_deterministic_time = max(until - spent, 0.0)
            t1 = time.perf_counter()
            code = solver.solve(query)
            solve_s += time.perf_counter() - t1
            spent += solver.deterministic_time
            status = self._status(solver, code, query)
            if status not in (SolveStatus.OPTIMAL, SolveStatus.FEASIBLE):
                break
            occupancy, choices = self._decode(solver)
            found = RawSolution(status, occupancy, math.inf, 0.0, install_s, choices)
            if status == SolveStatus.OPTIMAL:
                break
            # Found within the probe, not proven: search on from the whole of what it found.
            self._set_hint(query, self._full_hint(occupancy, choices))
        return dataclasses.replace(found, solve_s=solve_s)

    def solve(self, objective: Objective, *, hint: np.ndarray | None = None,
              hint_choices: Mapping[str, bool] | None = None,
              time_limit: float = 60.0, work_limit: float | None = None) -> RawSolution:
        cp = self._cp
        t0 = time.perf_counter()
        # The hint as a whole assignment: with the objective's literals half-reified
        # (_objective_literal), CP-SAT's search to complete a hint of the placements alone
        # was most of a solve (docs/decisions.md). It is given only to the solve with the
        # full settings: the quick first attempt starts cold, as following a whole hint
        # with the LP at every decision cost more than it saved on the models that attempt
        # settles (:data:`EASY_SOLVE_WORK`). Among exact ties that attempt keeps the hint
        # itself when it is optimal, as a hinted CP-SAT search does (it takes only strictly
        # better solutions than the hint's): a fixpoint's rounds do not wander in a tie.
        scaled, flat = self._install(objective, None, None)
        full = None if hint is None else self._full_hint(hint, hint_choices)
        rounding_slack = float(np.maximum(objective.coefs - scaled / SCALE, 0.0).sum())
        keep = scaled != 0
        install_s = time.perf_counter() - t0

        t1 = time.perf_counter()
        solver, code, work, cold = None, None, 0.0, False
        if work_limit is None and self.workers == 1:
            solver = cp.CpSolver()
            self._parameters(solver, time_limit)
            solver.parameters.use_sat_inprocessing = False
            solver.parameters.max_deterministic_time = EASY_SOLVE_WORK
            code = solver.solve(self.model)
            work = solver.deterministic_time
            cold = code == cp.OPTIMAL
            if code == cp.FEASIBLE:
                # A structure the attempt found but could not prove: the full solve starts
                # from it unless the caller's hint is at least as good (on a 10x12x10 cabin
                # the full solve took 1.68 s cold and 0.97 s from it; docs/decisions.md).
                found = int(round(solver.objective_value))
                given = None if full is None else self._value_at(flat, full)
                if given is None or given < found:
                    full = (np.arange(len(self.model.model_proto.variables), dtype=np.int64),
                            np.asarray(solver.response_proto.solution, dtype=np.int64))
            if code not in (cp.OPTIMAL, cp.INFEASIBLE):
                solver = None
        if solver is None:
            if full is not None:
                self._set_hint(self.model, full)
            solver = cp.CpSolver()
            self._parameters(solver, max(time_limit - (time.perf_counter() - t1), 1e-3))
            if work_limit is not None:
                solver.parameters.max_deterministic_time = float(work_limit)
            code = solver.solve(self.model)
            work += solver.deterministic_time
        solve_s = time.perf_counter() - t1
        status = self._status(solver, code, self.model)
        self._last_work = work
        occupancy, choices = None, {}
        if cold and self._hint_ties(flat, full, hint_choices, int(round(solver.objective_value))):
            occupancy = np.asarray(hint, dtype=np.int8).reshape(self.extent.shape)
            choices = {name: bool(hint_choices[name]) for name in self._choices}
        elif status in (SolveStatus.OPTIMAL, SolveStatus.FEASIBLE):
            occupancy, choices = self._decode(solver)
        if status == SolveStatus.INFEASIBLE:
            bound = -math.inf
        elif objective.exprs and keep.any():
            raw = solver.best_objective_bound
            bound = objective.constant + raw / SCALE + rounding_slack if math.isfinite(raw) \
                else math.inf
        else:  # constant objective: every feasible structure is optimal
            bound = objective.constant + rounding_slack if status != SolveStatus.TIMEOUT \
                else math.inf
        logger.debug("cpsat %s in %.3fs (install %.3fs)", status.value, solve_s, install_s)
        return RawSolution(status, occupancy, bound, solve_s, install_s, choices)
