"""toulbar2 backend (pytoulbar2, optional): a weighted CSP over the seven-valued Z_q.

Hard constraints and objective terms become cost tables over at most three
variables (the grammar's "2 of 3 notches supported" is posted as three
ternary "one of each pair" tables); larger constraints (language, choices)
go through auxiliary Booleans and generalised linear constraints. Costs are
``round(-score · SCALE)``, shifted to be non-negative per table.

Measured (DESIGN.md §8): ``vac=1`` and ``useRASPS=1`` work best; without a
finite initial upper bound toulbar2 crashed on 8×8×8 instances, so one is
always given — the cost of the all-EMPTY structure (or of the hint, a good
warm start) plus one unit, since toulbar2 returns only strictly better
solutions; when it finds none, that structure is the optimum.

toulbar2 keeps global state, so each solve rebuilds its network from the
tables kept since construction (only the objective tables are new).
"""

from __future__ import annotations

import contextlib
import logging
import math
import os
import sys
import time
from collections.abc import Iterator, Mapping, Sequence

import numpy as np

from unseeable.domain.grid import NUM_VALUES, Extent
from unseeable.errors import SolverError
from unseeable.grammar.expr import (
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
    negate,
    scope,
    truth_table,
)
from unseeable.grammar.objective import Objective
from unseeable.grammar.rules import grammar_constraints
from unseeable.solve.backend import SCALE, RawSolution
from unseeable.solve.result import SolveStatus

logger = logging.getLogger(__name__)

__all__ = ["Toulbar2Backend"]

_INSTALL = "pip install pytoulbar2"
_MAX_TABLE_VARS = 3


def _import():
    try:
        import pytoulbar2
        from pytoulbar2.pytoulbar2 import tb2
    except ImportError as err:
        raise SolverError(f"the toulbar2 backend needs pytoulbar2: {_INSTALL}") from err
    return pytoulbar2, tb2


@contextlib.contextmanager
def _quiet_stdout() -> Iterator[None]:
    """Silence toulbar2's own prints ("Time limit expired...") at the file-descriptor level."""
    try:
        fd = sys.stdout.fileno()
    except (AttributeError, OSError, ValueError):  # no real stdout (e.g. captured): nothing to do
        yield
        return
    sys.stdout.flush()
    saved = os.dup(fd)
    try:
        with open(os.devnull, "w") as devnull:
            os.dup2(devnull.fileno(), fd)
            yield
    finally:
        os.dup2(saved, fd)
        os.close(saved)


class _Network:
    """Variables, hard tables and linear constraints of Φ + constraints (solver-free)."""

    def __init__(self, extent: Extent) -> None:
        self.extent = extent
        self.n = extent.positions
        self.domains: list[int] = [NUM_VALUES] * self.n  # variable -> domain size
        self.names: dict[str, int] = {}  # choice name -> variable
        self.hard: dict[tuple[int, ...], np.ndarray] = {}  # scope -> allowed (bool table)
        self.linear: list[tuple[list[tuple[int, int, int]], str, int]] = []
        self.aux: dict[Expr, int] = {}
        self.infeasible = False

    def _p(self, q) -> int:
        _, J, K = self.extent.shape
        return (q[0] * J + q[1]) * K + q[2]

    def choice(self, name: str) -> int:
        if name not in self.names:
            self.names[name] = len(self.domains)
            self.domains.append(2)
        return self.names[name]

    def new_bool(self) -> int:
        self.domains.append(2)
        return len(self.domains) - 1

    def table_scope(self, e: Expr) -> tuple[list, list, list[int]] | None:
        """(positions, names, variables) when ``e`` fits a table, else None."""
        positions, names = scope(e)
        if len(positions) + len(names) > _MAX_TABLE_VARS:
            return None
        positions = sorted(positions)
        names = sorted(names)
        return positions, names, [self._p(q) for q in positions] + [self.choice(m)
                                                                    for m in names]

    def add_hard_table(self, variables: list[int], allowed: np.ndarray) -> None:
        order = np.argsort(variables)
        key = tuple(int(variables[a]) for a in order)
        allowed = np.transpose(allowed, order)
        if not allowed.any():
            self.infeasible = True
        if key in self.hard:
            self.hard[key] = self.hard[key] & allowed
        else:
            self.hard[key] = allowed.copy()

    # -- compilation of constraints ---------------------------------------
    def post(self, e: Expr) -> None:
        if isinstance(e, Const):
            if not e.value:
                self.infeasible = True
            return
        if isinstance(e, And):
            for a in e.args:
                self.post(a)
            return
        if isinstance(e, Implies) and isinstance(e.b, And):
            for b in e.b.args:
                self.post(Implies(e.a, b))
            return
        if isinstance(e, Implies) and isinstance(e.b, AtLeast) and e.b.k == len(e.b.args) - 1:
            # "all but one" = one of every pair: ternary tables instead of one wide table
            xs = e.b.args
            for i in range(len(xs)):
                for j in range(i + 1, len(xs)):
                    self.post(Implies(e.a, Or(xs[i], xs[j])))
            return
        ts = self.table_scope(e)
        if ts is not None:
            positions, names, variables = ts
            self.add_hard_table(variables, truth_table(e, positions, names))
            return
        if isinstance(e, Implies):
            self.post(Or(negate(e.a), e.b))
            return
        if isinstance(e, Iff):
            self.post(Implies(e.a, e.b))
            self.post(Implies(e.b, e.a))
            return
        if isinstance(e, Or):
            self.add_linear([t for a in e.args for t in self.indicator(a)], ">=", 1)
            return
        if isinstance(e, (AtLeast, AtMost, Exactly)):
            terms = [t for a in e.args for t in self.indicator(a)]
            op = {AtLeast: ">=", AtMost: "<=", Exactly: "=="}[type(e)]
            self.add_linear(terms, op, e.k)
            return
        raise SolverError(f"cannot compile constraint {e!r} for toulbar2")  # pragma: no cover

    def add_linear(self, terms: list[tuple[int, int, int]], op: str, rhs: int) -> None:
        self.linear.append((terms, op, int(rhs)))

    def indicator(self, e: Expr) -> list[tuple[int, int, int]]:
        """``[e]`` as Σ coef·[var = value] (one term per value), adding a Boolean if needed."""
        if isinstance(e, Occ):
            p = self._p(e.q)
            return [(p, v, 1) for v in sorted(e.values)]
        if isinstance(e, Choice):
            return [(self.choice(e.name), 1, 1)]
        if isinstance(e, Not) and isinstance(e.arg, Choice):
            return [(self.choice(e.arg.name), 0, 1)]
        return [(self.reify(e), 1, 1)]

    def reify(self, e: Expr) -> int:
        """A Boolean variable r with r ⇔ e."""
        if e in self.aux:
            return self.aux[e]
        r = self.new_bool()
        self.aux[e] = r
        ts = self.table_scope(e) if len(scope(e)[0]) + len(scope(e)[1]) < _MAX_TABLE_VARS \
            else None
        if ts is not None:
            positions, names, variables = ts
            truth = truth_table(e, positions, names)
            allowed = np.stack([~truth, truth], axis=-1)  # last axis: r
            self.add_hard_table([*variables, r], allowed)
            return r
        neg_R = [(r, 1, -1)]
        if isinstance(e, (And, Or)):
            parts = [self.indicator(a) for a in e.args]
            total = [t for part in parts for t in part]
            if isinstance(e, And):
                for part in parts:  # r → each
                    self.add_linear(part + neg_R, ">=", 0)
                self.add_linear(total + neg_R, "<=", len(parts) - 1)  # all → r
            else:
                for part in parts:  # each → r
                    self.add_linear(part + neg_R, "<=", 0)
                self.add_linear(total + neg_R, ">=", 0)  # r → some
            return r
        if isinstance(e, AtLeast):
            total = [t for a in e.args for t in self.indicator(a)]
            n, k = len(e.args), e.k
            self.add_linear(total + [(r, 1, -k)], ">=", 0)  # r → Σ ≥ k
            self.add_linear(total + [(r, 1, -(n - k + 1))], "<=", k - 1)  # ¬r → Σ ≤ k-1
            return r
        if isinstance(e, AtMost):
            inner = self.reify(AtLeast(e.k + 1, e.args))
            self.add_hard_table([inner, r], np.array([[False, True], [True, False]]))
            return r
        if isinstance(e, Exactly):
            inner = self.reify(And(AtLeast(e.k, e.args), AtMost(e.k, e.args)))
            self.add_hard_table([inner, r], np.eye(2, dtype=bool))
            return r
        if isinstance(e, Implies):
            inner = self.reify(Or(negate(e.a), e.b))
        elif isinstance(e, Iff):
            inner = self.reify(And(Or(negate(e.a), e.b), Or(negate(e.b), e.a)))
        else:  # pragma: no cover
            raise SolverError(f"cannot compile expression {e!r} for toulbar2")
        self.add_hard_table([inner, r], np.eye(2, dtype=bool))
        return r


class Toulbar2Backend:
    """Weighted-CSP model for toulbar2; tables kept, the network rebuilt per solve."""

    name = "toulbar2"

    @staticmethod
    def available() -> bool:
        try:
            _import()
        except SolverError:
            return False
        return True

    def __init__(self, extent: Extent, constraints: Sequence[Expr], *, workers: int = 1) -> None:
        self._pt, self._tb2 = _import()
        self.extent = extent
        self.net = _Network(extent)
        for c in grammar_constraints(extent):
            self.net.post(c)
        for c in constraints:
            self.net.post(c)
        self.constraints = tuple(constraints)
        # Objective expressions seen before: expr -> (variables, truth table) or reified var.
        self._obj_cache: dict[Expr, tuple[tuple[int, ...], np.ndarray]] = {}

    def _objective_tables(self, objective: Objective) -> dict[tuple[int, ...], np.ndarray]:
        """Scope -> summed score table (float, objective units without the constant)."""
        tables: dict[tuple[int, ...], np.ndarray] = {}
        net = self.net
        for e, c in zip(objective.exprs, objective.coefs):
            hit = self._obj_cache.get(e)
            if hit is None:
                ts = net.table_scope(e)
                if ts is not None:
                    positions, names, variables = ts
                    order = np.argsort(variables)
                    key = tuple(int(variables[a]) for a in order)
                    hit = (key, np.transpose(truth_table(e, positions, names), order))
                else:  # wide expression: a reified Boolean carries it
                    r = net.reify(e)
                    hit = ((r,), np.array([False, True]))
                self._obj_cache[e] = hit
            key, truth = hit
            if key in tables:
                tables[key] = tables[key] + c * truth
            else:
                tables[key] = c * truth.astype(float)
        return tables

    def solve(self, objective: Objective, *, hint: np.ndarray | None = None,
              hint_choices: Mapping[str, bool] | None = None,
              time_limit: float = 60.0, work_limit: float | None = None) -> RawSolution:
        del work_limit  # no deterministic budget here: the answer is exact (or times out)
        pt, tb2 = self._pt, self._tb2
        net = self.net
        t0 = time.perf_counter()
        if net.infeasible:
            return RawSolution(SolveStatus.INFEASIBLE, None, -math.inf, 0.0, 0.0)
        scores = self._objective_tables(objective)
        # Integer costs: cost = max(r) - r with r = round(score * SCALE) per table.
        costs: dict[tuple[int, ...], np.ndarray] = {}
        offset = 0  # Σ max(r): score_int(Z) = offset - cost(Z)
        slack = 0.0  # rounding: score(Z) <= const + score_int(Z)/SCALE + slack
        for key, score in scores.items():
            r = np.rint(score * SCALE)
            slack += float(np.maximum(score - r / SCALE, 0.0).max())
            top = float(r.max())
            offset += top
            costs[key] = top - r
        hard = net.hard

        def cost_of(assignment: np.ndarray) -> float | None:
            """Integer cost of a full assignment, None when it breaks a hard table."""
            for key, allowed in hard.items():
                if not allowed[tuple(assignment[list(key)])]:
                    return None
            return float(sum(c[tuple(assignment[list(key)])] for key, c in costs.items()))

        def full_assignment(z: np.ndarray, choices: Mapping[str, bool]) -> np.ndarray | None:
            a = np.zeros(len(net.domains), dtype=np.int64)
            a[: net.n] = z.ravel()
            for name, var in net.names.items():
                a[var] = int(bool(choices.get(name, False)))
            occ = z.reshape(self.extent.shape)
            names = {m: bool(a[v]) for m, v in net.names.items()}
            for e, var in net.aux.items():
                a[var] = int(bool(evaluate(e, occ, names)))
            for lin_terms, op, rhs in net.linear:
                total = sum(coef for var, value, coef in lin_terms if a[var] == value)
                if not {">=": total >= rhs, "<=": total <= rhs, "==": total == rhs}[op]:
                    return None
            return a

        # A feasible starting point gives the finite initial upper bound.
        start, start_cost = None, None
        candidates = []
        if hint is not None:
            candidates.append((np.asarray(hint, dtype=np.int64), hint_choices or {}))
        candidates.append((np.zeros(self.extent.shape, dtype=np.int64), {}))
        for z, ch in candidates:
            a = full_assignment(z, ch)
            if a is not None:
                c = cost_of(a)
                if c is not None:
                    start, start_cost = a, c
                    break
        if start_cost is None:  # still finite: the worst cost of every table, plus one
            ub = float(sum(c.max() for c in costs.values())) + 1.0
        else:
            ub = start_cost + 1.0

        cfn = pt.CFN(ubinit=None, resolution=0, vac=1, verbose=-1)
        cfn.Option.useRASPS = 1
        tb2.option.showSolutions = 0
        tb2.option.allSolutions = 0
        status = SolveStatus.OPTIMAL
        try:
            self._build(cfn, costs)
            install_s = time.perf_counter() - t0
            t1 = time.perf_counter()
            tb2.check()
            tb2.option.limited = False
            cfn.CFN.timer(max(1, int(math.ceil(time_limit))))
            cfn.CFN.wcsp.updateDUb(ub)
            with _quiet_stdout():
                cfn.CFN.wcsp.sortConstraints()
                cfn.CFN.solve()
            solve_s = time.perf_counter() - t1
            found = len(cfn.CFN.solutions()) > 0
            timed_out = bool(tb2.option.limited)  # set by toulbar2 when its timer fired
            dual = float(cfn.CFN.getDDualBound())
            solution = np.array(cfn.CFN.solution(), dtype=np.int64) if found else None
            found_cost = float(cfn.CFN.wcsp.getDPrimalBound()) if found else None
        except pt.pytb2.Contradiction:
            install_s = time.perf_counter() - t0
            solve_s, found, timed_out, dual = 0.0, False, False, ub
            solution, found_cost = None, None
        finally:
            tb2.option.limited = False
        if found:
            best, best_cost = solution, found_cost
        elif start is not None:
            best, best_cost = start, start_cost
        else:
            best, best_cost = None, None
        if timed_out:
            status = SolveStatus.FEASIBLE if best is not None else SolveStatus.TIMEOUT
        elif best is None:
            status = SolveStatus.INFEASIBLE
        if status == SolveStatus.INFEASIBLE:
            bound = -math.inf
        elif status == SolveStatus.OPTIMAL:
            bound = objective.constant + (offset - best_cost) / SCALE + slack
        else:
            lower = min(dual, best_cost) if best_cost is not None else dual
            bound = objective.constant + (offset - lower) / SCALE + slack
        occupancy, choices = None, {}
        if best is not None:
            occupancy = best[: net.n].astype(np.int8).reshape(self.extent.shape)
            choices = {name: bool(best[var]) for name, var in net.names.items()}
        logger.debug("toulbar2 %s in %.3fs", status.value, solve_s)
        return RawSolution(status, occupancy, bound, solve_s, install_s, choices)

    def _build(self, cfn, costs: dict[tuple[int, ...], np.ndarray]) -> None:
        net = self.net
        n = net.n
        cfn.AddVariables(n, "z", 0, NUM_VALUES - 1)
        for var in range(n, len(net.domains)):
            cfn.AddVariable(f"b{var}", [0, 1])
        # Hard tables: 0 allowed, Top forbidden; grouped by arity for the vectorised calls.
        grouped: dict[tuple, list] = {}
        for key, allowed in net.hard.items():
            table = np.where(allowed, 0.0, cfn.Top)
            grouped.setdefault(table.shape, []).append((key, table))
        for key, c in costs.items():
            grouped.setdefault(c.shape, []).append((key, c.astype(float)))
        for shape, items in grouped.items():
            arity = len(shape)
            if 0 < arity <= 3 and all(s == NUM_VALUES for s in shape) and len(items) > 1:
                scopes = np.array([k for k, _ in items], dtype=np.int32)
                if arity == 1:
                    scopes = scopes[:, 0]
                tables = np.stack([t for _, t in items])
                cfn.AddFunctions(scopes, tables)
            else:
                for key, t in items:
                    cfn.AddFunction(list(key), t.ravel().tolist())
        for lin_terms, op, rhs in net.linear:
            cfn.AddGeneralizedLinearConstraint(lin_terms, op, rhs)
