"""The paper's estimator: arc consistency + depth-first branch and bound (pure Python).

It is the reference the other backends are checked against, so it shares as
little as possible with them: the grammar is built into the search, not
compiled from :func:`~unseeable.grammar.grammar_constraints`.

Search. Positions are assigned in line order (layer by layer, each line
from its low end, :func:`~unseeable.grammar.line_positions`). Along a line
the values follow the log automaton of constraints (a)–(b) (a (2,0) is
followed by (2,1), …), and because the layer below is complete when a log
is started, support (c)–(d) is checked at once for the whole log. Every
objective expression that mentions only a position q and b(b(q)) is folded
into a 7×7 table of q (features of layer j need layers j and j-2 only), so
the score of a value is known the moment it is placed.

Bound. At the start of layer j the lower layers are fixed, so a dynamic
programme along each line of layer j gives the exact best of that line; the
lines of layer j+1 are bounded the same way with support known only where
layer j already is (recomputed at each line start), and layers above with
support relaxed. A table T_q(v, w) over q and w = Z at b(b(q)) is split into
A_q(v) + B_q(w) >= T_q, B charged in advance to b(b(q)), so the bound of an
unreached layer still depends on the values below it instead of maximising
them out. The bound of a node is its score + the rest of its line + the other
lines, exact for the current layer — the search only backtracks for what a
layer does to the layers above. Measured: 4×4×4 in 0.02–0.04 s median, 1–2 s
worst of 20; 6×8×6 does not finish in 5 s.

Arc consistency. Extra constraints over few positions (e.g. "this position
is occupied") are propagated into per-position domains together with the
grammar before the search (generalised arc consistency on their truth
tables); larger ones are checked in three-valued logic as positions get
values, and ``Choice`` variables are settled at the leaves.
"""

from __future__ import annotations

import logging
import math
import sys
import time
from collections.abc import Mapping, Sequence

import numpy as np

from unseeable.domain.grid import NUM_VALUES, Extent
from unseeable.domain.structure import Structure, is_valid
from unseeable.errors import InputError
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
    scope,
    simplify,
    truth_table,
)
from unseeable.grammar.objective import Objective
from unseeable.grammar.rules import grammar_constraints, line_positions
from unseeable.solve.backend import RawSolution
from unseeable.solve.result import SolveStatus

logger = logging.getLogger(__name__)

__all__ = ["BranchAndBoundBackend"]

_NEG = -math.inf
_EPS = 1e-9
# Line automaton: what the previous value requires here.
_FREE, _NEED3, _NEED5, _NEED6 = 0, 1, 2, 3
_NEXT_STATE = (_FREE, _FREE, _NEED3, _FREE, _NEED5, _NEED6, _FREE)  # after value v
_FORCED = {_NEED3: 3, _NEED5: 5, _NEED6: 6}
_LOG_CODES = {1: (1,), 2: (2, 3), 4: (4, 5, 6)}  # log start value -> its notches
_FULL = (1 << NUM_VALUES) - 1
# Table scopes up to this many positions take part in arc consistency.
_AC_MAX_POSITIONS = 4


class _Timeout(Exception):
    pass


def _eval3(e: Expr, z: list, allowed: list, pidx, choices: Mapping[str, bool]) -> int:
    """Three-valued truth of ``e`` under a partial assignment: 1, 0 or -1 (unknown)."""
    if isinstance(e, Occ):
        p = pidx(e.q)
        v = z[p]
        if v >= 0:
            return int(v in e.values)
        mask = allowed[p]
        inside = sum(1 << c for c in e.values)
        if mask & ~inside == 0:
            return 1
        if mask & inside == 0:
            return 0
        return -1
    if isinstance(e, Choice):
        value = choices.get(e.name)
        return -1 if value is None else int(value)
    if isinstance(e, Const):
        return int(e.value)
    if isinstance(e, Not):
        r = _eval3(e.arg, z, allowed, pidx, choices)
        return r if r < 0 else 1 - r
    if isinstance(e, And):
        out = 1
        for a in e.args:
            r = _eval3(a, z, allowed, pidx, choices)
            if r == 0:
                return 0
            if r < 0:
                out = -1
        return out
    if isinstance(e, Or):
        out = 0
        for a in e.args:
            r = _eval3(a, z, allowed, pidx, choices)
            if r == 1:
                return 1
            if r < 0:
                out = -1
        return out
    if isinstance(e, Implies):
        a = _eval3(e.a, z, allowed, pidx, choices)
        if a == 0:
            return 1
        b = _eval3(e.b, z, allowed, pidx, choices)
        if b == 1:
            return 1
        return 0 if (a == 1 and b == 0) else -1
    if isinstance(e, Iff):
        a = _eval3(e.a, z, allowed, pidx, choices)
        b = _eval3(e.b, z, allowed, pidx, choices)
        return -1 if a < 0 or b < 0 else int(a == b)
    if isinstance(e, (AtLeast, AtMost, Exactly)):
        t = u = 0
        for a in e.args:
            r = _eval3(a, z, allowed, pidx, choices)
            if r == 1:
                t += 1
            elif r < 0:
                u += 1
        k = e.k
        if isinstance(e, AtLeast):
            return 1 if t >= k else (0 if t + u < k else -1)
        if isinstance(e, AtMost):
            return 0 if t > k else (1 if t + u <= k else -1)
        if t > k or t + u < k:
            return 0
        return 1 if (u == 0 and t == k) else -1
    raise TypeError(f"not an expression: {e!r}")  # pragma: no cover


class BranchAndBoundBackend:
    """Exact MAP by arc consistency and depth-first branch and bound; small grids only."""

    name = "bnb"

    @staticmethod
    def available() -> bool:
        return True

    def __init__(self, extent: Extent, constraints: Sequence[Expr], *, workers: int = 1) -> None:
        self.extent = extent
        I, J, K = extent.shape
        self._JK = (J, K)
        n = extent.positions
        self.n = n
        self.lines = [[self._p(q) for q in line] for line in line_positions(extent)]
        self.order = [p for line in self.lines for p in line]
        self.rank = [0] * n
        for t, p in enumerate(self.order):
            self.rank[p] = t
        self.layer_of_line = [line_positions(extent)[ln][0][1] for ln in range(len(self.lines))]
        self.lines_of_layer = [[ln for ln, j in enumerate(self.layer_of_line) if j == jj]
                               for jj in range(J)]
        # Neighbours by flat index (-1 outside the grid).
        self.below = [-1] * n
        self.below2 = [-1] * n
        for p in range(n):
            i, j, k = self._q(p)
            if j >= 1:
                self.below[p] = self._p((i, j - 1, k))
            if j >= 2:
                self.below2[p] = self._p((i, j - 2, k))
        self.allowed = [_FULL] * n
        self.infeasible = False
        self.watch: list[list[int]] = [[] for _ in range(n)]
        self.generic: list[Expr] = []  # constraints checked during the search
        self.choice_constraints: list[Expr] = []  # settled at the leaves
        self.choice_names: set[str] = set()
        small: list[tuple[tuple[int, ...], np.ndarray]] = []
        for c in constraints:
            self._add_constraint(c, small)
        self._arc_consistency(small)
        self._build_moves()

    # -- geometry ----------------------------------------------------------
    def _p(self, q: tuple[int, int, int]) -> int:
        J, K = self._JK
        return (q[0] * J + q[1]) * K + q[2]

    def _q(self, p: int) -> tuple[int, int, int]:
        J, K = self._JK
        return (p // (J * K), (p // K) % J, p % K)

    # -- constraints and arc consistency --------------------------------
    def _add_constraint(self, c: Expr, small: list) -> None:
        if isinstance(c, Const):
            if not c.value:
                self.infeasible = True
            return
        if isinstance(c, And):
            for a in c.args:
                self._add_constraint(a, small)
            return
        positions, names = scope(c)
        if isinstance(c, Occ):
            p = self._p(c.q)
            self.allowed[p] &= sum(1 << v for v in c.values)
            return
        if not names and len(positions) <= _AC_MAX_POSITIONS:
            ordered = tuple(sorted(positions))
            small.append((tuple(self._p(q) for q in ordered), truth_table(c, ordered)))
        if names:
            self.choice_constraints.append(c)
            self.choice_names |= names
        index = len(self.generic)
        self.generic.append(c)
        for q in positions:
            self.watch[self._p(q)].append(index)

    def _arc_consistency(self, small: list) -> None:
        """Generalised arc consistency of the grammar and small constraints on the domains."""
        tables = list(small)
        for c in grammar_constraints(self.extent):
            positions, _ = scope(c)
            ordered = tuple(sorted(positions))
            if isinstance(c, Occ):
                self.allowed[self._p(c.q)] &= sum(1 << v for v in c.values)
            else:
                tables.append((tuple(self._p(q) for q in ordered), truth_table(c, ordered)))
        if all(a == _FULL for a in self.allowed) and not small:
            # Nothing but the grammar's own boundary restrictions: the automaton
            # and the support checks of the search do the rest.
            self._check_domains()
            return
        on_var: dict[int, list[int]] = {}
        for t, (ps, _) in enumerate(tables):
            for p in ps:
                on_var.setdefault(p, []).append(t)
        queue = list(range(len(tables)))
        queued = set(queue)
        while queue:
            t = queue.pop()
            queued.discard(t)
            ps, table = tables[t]
            masks = [np.array([(self.allowed[p] >> v) & 1 for v in range(NUM_VALUES)], dtype=bool)
                     for p in ps]
            live = table
            for axis, m in enumerate(masks):
                shape = [1] * len(ps)
                shape[axis] = NUM_VALUES
                live = live & m.reshape(shape)
            for axis, p in enumerate(ps):
                others = tuple(a for a in range(len(ps)) if a != axis)
                supported = live.any(axis=others) if others else live
                new = sum(1 << v for v in range(NUM_VALUES) if supported[v])
                if new != self.allowed[p]:
                    self.allowed[p] = new
                    for t2 in on_var.get(p, ()):
                        if t2 not in queued:
                            queued.add(t2)
                            queue.append(t2)
        self._check_domains()

    def _check_domains(self) -> None:
        if any(a == 0 for a in self.allowed):
            self.infeasible = True

    # -- objective tables ------------------------------------------------
    def _tables(self, objective: Objective):
        """Per-position 7×7 score tables, position-owned extra terms and leaf terms."""
        n = self.n
        T = np.zeros((n, NUM_VALUES, NUM_VALUES))
        owned: list[list[tuple[Expr, float]]] = [[] for _ in range(n)]
        leaf: list[tuple[Expr, float]] = []
        for e, c in zip(objective.exprs, objective.coefs):
            positions, names = scope(e)
            if names or not positions:
                leaf.append((e, float(c)))
                continue
            ps = sorted((self._p(q) for q in positions), key=self.rank.__getitem__)
            p = ps[-1]
            rest = ps[:-1]
            if not rest:
                T[p] += float(c) * truth_table(e, [self._q(p)])[:, None]
            elif rest == [self.below2[p]]:
                T[p] += float(c) * truth_table(e, [self._q(p), self._q(rest[0])])
            else:
                owned[p].append((e, float(c)))
        gen_opt = [sum(max(c, 0.0) for _, c in owned[p]) for p in range(n)]
        # Split each table T_q(v, w) (w = Z at b(b(q))) into A_q(v) + B_q(w) >= T_q(v, w)
        # with B_q(w) = max_v T_q(v, w), charged in advance ("prepaid", U) to the
        # position b(b(q)) that decides w, and A_q(v) = max_w T_q(v, w) - B_q(w).
        # The search scores a value with E = T - B + U (summing to the exact
        # objective over a full assignment); layers not reached yet are bounded
        # with A + U, which ties a position's value to the features two layers
        # up that it decides instead of maximising them out.
        share = np.zeros((n, NUM_VALUES))  # B_q(w), by q
        prepaid = np.zeros((n, NUM_VALUES))  # U_r(v) = B_q(v) with r = b(b(q))
        own = np.empty((n, NUM_VALUES))  # A_q(v)
        for p in range(n):
            bb = self.below2[p]
            if bb < 0:
                own[p] = T[p][:, 0]  # with b(b(q)) outside only the EMPTY column is read
                continue
            cols = np.array([(self.allowed[bb] >> w) & 1 for w in range(NUM_VALUES)], dtype=bool)
            if not cols.any():
                own[p] = _NEG
                continue
            share[p] = np.where(cols, T[p].max(axis=0), 0.0)
            prepaid[bb] = share[p]
            own[p] = np.where(cols[None, :], T[p] - share[p][None, :], _NEG).max(axis=1)
        exact = T - share[:, None, :] + prepaid[:, :, None]
        return exact.tolist(), (own + prepaid).tolist(), owned, gen_opt, leaf

    # -- the line dynamic programme ---------------------------------------
    def _build_moves(self) -> None:
        """Per line, position and automaton state: the possible values.

        Each move is ``(v, next_state, below, need)``: placing value ``v``
        (a log start covers the whole log, checked against every notch's
        domain), the automaton state after it, the positions below the log's
        notches and how many of them must be occupied (support (c)–(d)).
        """
        allowed, below = self.allowed, self.below
        self._moves = []
        for line in self.lines:
            per_pos = []
            for pos, p in enumerate(line):
                per_state = [[] for _ in range(4)]
                for state, v in _FORCED.items():
                    if (allowed[p] >> v) & 1:
                        per_state[state].append((v, _NEXT_STATE[v], (), 0))
                for v in (0, 1, 2, 4):
                    codes = _LOG_CODES.get(v, (0,))
                    m = len(codes)
                    if pos + m > len(line):
                        continue
                    if any(not (allowed[line[pos + d]] >> codes[d]) & 1 for d in range(m)):
                        continue
                    sup = tuple(below[line[pos + d]] for d in range(m)) \
                        if (v and below[p] >= 0) else ()
                    per_state[_FREE].append((v, _NEXT_STATE[v], sup, 2 if m == 3 else m))
                per_pos.append([tuple(x) for x in per_state])
            self._moves.append(per_pos)

    def _line_dp(self, ln: int, z: list, T: list, tmax: list, gen_opt: list, *,
                 exact_below2: bool, support: bool) -> list[list[float]]:
        """best[pos][state]: the best score of the rest of line ``ln``.

        Support is checked where the layer below is assigned (an unassigned
        position, -1, may still hold a log); ``support=False`` relaxes it.
        """
        line = self.lines[ln]
        moves = self._moves[ln]
        below2 = self.below2
        L = len(line)
        best = [None] * (L + 1)
        best[L] = [0.0, _NEG, _NEG, _NEG]
        nxt = best[L]
        for pos in range(L - 1, -1, -1):
            p = line[pos]
            if exact_below2:
                bb = below2[p]
                w = z[bb] if bb >= 0 else 0
                Tp = T[p]
            else:
                row = tmax[p]
            g = gen_opt[p]
            cur = [_NEG, _NEG, _NEG, _NEG]
            for state in range(4):
                top = _NEG
                for v, ns, sup, need in moves[pos][state]:
                    tail = nxt[ns]
                    if tail == _NEG:
                        continue
                    if support and sup:
                        held = 0
                        for b in sup:
                            if z[b] != 0:
                                held += 1
                        if held < need:
                            continue
                    s = (Tp[v][w] if exact_below2 else row[v]) + tail
                    if s > top:
                        top = s
                if top > _NEG:
                    cur[state] = top + g
            best[pos] = cur
            nxt = cur
        return best

    # -- search --------------------------------------------------------------
    def solve(self, objective: Objective, *, hint: np.ndarray | None = None,
              hint_choices: Mapping[str, bool] | None = None,
              time_limit: float = 60.0, work_limit: float | None = None) -> RawSolution:
        del work_limit  # no deterministic budget here: the answer is exact (or times out)
        t0 = time.perf_counter()
        if self.infeasible:
            return RawSolution(SolveStatus.INFEASIBLE, None, _NEG, 0.0,
                               time.perf_counter() - t0)
        T, tmax, owned, gen_opt, leaf_terms = self._tables(objective)
        J = self.extent.J
        n = self.n
        z = [-1] * n
        leaf_opt = sum(max(c, 0.0) for _, c in leaf_terms)
        # Static bounds of whole layers (support relaxed, b(b(q)) maximised out).
        static_layer = []
        for j in range(J):
            total = 0.0
            for ln in self.lines_of_layer[j]:
                total += self._line_dp(ln, z, T, tmax, gen_opt, exact_below2=False,
                                       support=False)[0][_FREE]
            static_layer.append(total)
        static_from = [0.0] * (J + 2)
        for j in range(J - 1, -1, -1):
            static_from[j] = static_from[j + 1] + static_layer[j]
        root_bound = objective.constant + static_from[0] + leaf_opt
        install_s = time.perf_counter() - t0

        t1 = time.perf_counter()
        deadline = t1 + time_limit
        best = [_NEG, None, {}]  # score, occupancy, choices
        if hint is not None:
            self._try_hint(np.asarray(hint).ravel().tolist(), hint_choices, T, owned,
                           leaf_terms, objective.constant, best)
        nodes = [0]
        line_dp: list = [None] * len(self.lines)
        rest_after: list[float] = [0.0] * len(self.lines)
        above = [0.0] * len(self.lines)  # bound of the layers above, per line of layer j
        order_pos = []  # (line id, pos in line) of each rank
        for ln, line in enumerate(self.lines):
            for pos in range(len(line)):
                order_pos.append((ln, pos))
        first_line_of_layer = {self.lines_of_layer[j][0]: j for j in range(J)}
        const = objective.constant

        def enter_layer(j: int) -> None:
            total = 0.0
            dps = []
            for ln in self.lines_of_layer[j]:
                dp = self._line_dp(ln, z, T, tmax, gen_opt, exact_below2=True, support=True)
                line_dp[ln] = dp
                dps.append((ln, dp[0][_FREE]))
            for ln, v in reversed(dps):
                rest_after[ln] = total
                total += v if v > _NEG else _NEG

        def enter_line(ln: int) -> None:
            # Layer j+1 with b(b(q)) known and support known where layer j is.
            j = self.layer_of_line[ln]
            nxt = 0.0
            if j + 1 < J:
                for ln2 in self.lines_of_layer[j + 1]:
                    nxt += self._line_dp(ln2, z, T, tmax, gen_opt, exact_below2=True,
                                         support=True)[0][_FREE]
            above[ln] = nxt + static_from[j + 2] + leaf_opt

        def leaf(acc: float) -> None:
            value, choices = self._settle_leaf(z, leaf_terms)
            if value is None:
                return
            if acc + value > best[0]:
                best[0], best[1], best[2] = acc + value, list(z), choices

        def search(t: int, acc: float) -> None:
            nodes[0] += 1
            if nodes[0] & 255 == 0 and time.perf_counter() > deadline:
                raise _Timeout
            if t == n:
                leaf(acc)
                return
            ln, pos = order_pos[t]
            line = self.lines[ln]
            if pos == 0:
                if ln in first_line_of_layer:
                    enter_layer(first_line_of_layer[ln])
                enter_line(ln)
            p = line[pos]
            state = _NEXT_STATE[z[line[pos - 1]]] if pos else _FREE
            dp = line_dp[ln]
            nxt = dp[pos + 1]
            outside = rest_after[ln] + above[ln]
            bb = self.below2[p]
            w = z[bb] if bb >= 0 else 0
            row = T[p]
            g = gen_opt[p]
            options = []
            for v, ns, sup, need in self._moves[ln][pos][state]:
                tail = nxt[ns]
                if tail == _NEG:
                    continue
                if sup and sum(1 for b in sup if z[b] != 0) < need:
                    continue
                inc = row[v][w]
                bound = acc + inc + g + tail + outside
                if bound > best[0] + _EPS:
                    options.append((bound, v, inc))
            options.sort(reverse=True)
            for bound, v, inc in options:
                if bound <= best[0] + _EPS:
                    break
                z[p] = v
                if self.watch[p] and not self._generic_ok(p, z):
                    z[p] = -1
                    continue
                extra = sum(c for e, c in owned[p] if self._holds(e, z)) if owned[p] else 0.0
                if bound - g + extra <= best[0] + _EPS:
                    z[p] = -1
                    continue
                search(t + 1, acc + inc + extra)
                z[p] = -1

        status = SolveStatus.OPTIMAL
        old_limit = sys.getrecursionlimit()
        if n + 200 > old_limit:
            sys.setrecursionlimit(n + 200)
        try:
            search(0, const)
        except _Timeout:
            status = SolveStatus.FEASIBLE
        finally:
            sys.setrecursionlimit(old_limit)
        solve_s = time.perf_counter() - t1
        logger.debug("bnb: %d nodes in %.3fs", nodes[0], solve_s)
        if best[1] is None:
            if status == SolveStatus.OPTIMAL:
                return RawSolution(SolveStatus.INFEASIBLE, None, _NEG, solve_s, install_s)
            return RawSolution(SolveStatus.TIMEOUT, None, root_bound, solve_s, install_s)
        occupancy = np.array(best[1], dtype=np.int8).reshape(self.extent.shape)
        bound = best[0] if status == SolveStatus.OPTIMAL else max(root_bound, best[0])
        return RawSolution(status, occupancy, bound, solve_s, install_s, dict(best[2]))

    # -- helpers -------------------------------------------------------------
    def _holds(self, e: Expr, z: list) -> bool:
        return _eval3(e, z, self.allowed, self._p, {}) == 1

    def _generic_ok(self, p: int, z: list) -> bool:
        for index in self.watch[p]:
            if _eval3(self.generic[index], z, self.allowed, self._p, {}) == 0:
                return False
        return True

    def _settle_leaf(self, z: list, leaf_terms: list) -> tuple[float | None, dict]:
        """Best choice values at a complete occupancy: (score of leaf terms, choices) or None."""
        if not self.choice_names and not leaf_terms:
            return 0.0, {}
        occ = np.array(z, dtype=np.int8).reshape(self.extent.shape)
        cons = []
        for c in self.choice_constraints:
            s = simplify(c, self.extent, occupancy=occ)
            if isinstance(s, Const):
                if not s.value:
                    return None, {}
                continue
            cons.append(s)
        terms = []
        value0 = 0.0
        for e, c in leaf_terms:
            s = simplify(e, self.extent, occupancy=occ)
            if isinstance(s, Const):
                value0 += c if s.value else 0.0
            else:
                terms.append((s, c))
        names = sorted(set().union(*(scope(c)[1] for c in cons), *(scope(e)[1] for e, _ in terms))
                       if (cons or terms) else set())
        best: list = [None, {}]
        chosen: dict[str, bool] = {}

        def go(k: int) -> None:
            for c in cons:
                if _eval3(c, z, self.allowed, self._p, chosen) == 0:
                    return
            optimistic = value0
            for e, c in terms:
                r = _eval3(e, z, self.allowed, self._p, chosen)
                optimistic += c if r == 1 else (max(c, 0.0) if r < 0 else 0.0)
            if best[0] is not None and optimistic <= best[0] + _EPS:
                return
            if k == len(names):
                best[0], best[1] = optimistic, dict(chosen)
                return
            for value in (False, True):
                chosen[names[k]] = value
                go(k + 1)
                del chosen[names[k]]
                if best[0] is not None and not terms:
                    return  # feasibility only: the first completion will do

        go(0)
        if best[0] is None:
            return None, {}
        choices = {name: False for name in self.choice_names}
        choices.update(best[1])
        return best[0], choices

    def _try_hint(self, zh: list, hint_choices, T, owned, leaf_terms, const: float,
                  best: list) -> None:
        """Use a valid hint as the first incumbent (it only tightens pruning)."""
        n = self.n
        for p in range(n):
            if not (self.allowed[p] >> zh[p]) & 1:
                return
        occ = np.array(zh, dtype=np.int8).reshape(self.extent.shape)
        try:
            if not is_valid(Structure.from_occupancy(self.extent, occ)):
                return
        except InputError:
            return
        for c in self.generic:
            if scope(c)[1]:
                continue
            if _eval3(c, zh, self.allowed, self._p, {}) != 1:
                return
        value, choices = self._settle_leaf(zh, leaf_terms)
        if value is None:
            return
        score = const + value
        for p in range(n):
            bb = self.below2[p]
            score += T[p][zh[p]][zh[bb] if bb >= 0 else 0]
            score += sum(c for e, c in owned[p] if _eval3(e, zh, self.allowed, self._p, {}) == 1)
        best[0], best[1], best[2] = score, list(zh), choices
