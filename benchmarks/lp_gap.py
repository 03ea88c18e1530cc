"""Where the exact MAP's LP relaxation is weak: its gap at the root, term by term.

For one instance of ``benchmarks/solve.py`` (same generators, evidence and shipped prior),
the MAP is solved with the shipped CP-SAT model, the model is exported, and its LP
relaxation (every Boolean in [0, 1]) is solved with HiGHS (SciPy). The gap between the LP
bound and the optimum is then split by the kind of objective variable it sits on:

* ``placement``: a log placement's literal (the evidence and priors linear in it);
* ``And n`` / ``Or n``: a reified conjunction or disjunction of n parts (a joint is an
  ``And 2``, a stacked joint an ``And 4``, a segment read where a log or the one two
  layers down shows is an ``Or 2``);
* ``other``: literals of no kept expression (the unsupported-notch exemptions).

A positive share is where the relaxation gains over the optimum. Also printed: how many
variables the LP leaves fractional. A formulation change that closes the gap where it
sits is what would speed up the dense MAP at scale (docs/decisions.md).

With ``--probes``, what the gap depends on: the gap with the exemption literals held at
the optimum's values (:func:`exemption_rows` lists them), with rows tying each log's
exemptions to its placement and supports, and after three rounds of the most violated
cuts over column scopes (:func:`column_cuts`); then CP-SAT's solve of the same model
cold and from the optimum with every literal hinted (is the time spent finding the
optimum, or proving it?).

Usage::

    python benchmarks/lp_gap.py [--extent 10,12,10] [--generator random] [--seed 1000]
                                [--probes]
"""

from __future__ import annotations

import argparse
import itertools
import sys
import tempfile
import time
from collections import defaultdict
from collections.abc import Sequence
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from solve import GENERATORS, _instance  # noqa: E402  (the solve benchmark's instances)


def _literal(index: int) -> tuple[int, int, int]:
    """A proto literal as (variable, sign, constant): its value is ``constant + sign·x``."""
    return (index, 1, 0) if index >= 0 else (-index - 1, -1, 1)


def lp_relaxation(proto, *, extra: Sequence[tuple[dict, float]] = (),
                  fixed: dict[int, float] | None = None) -> tuple[float, np.ndarray, np.ndarray]:
    """The LP relaxation of a CP-SAT model proto of Booleans (linear, exactly-one and
    enforced bool-and constraints): (minimum of the proto's objective, the LP's values,
    the objective's coefficient per variable). ``extra``: rows ``Σ coef·x ≤ rhs`` added
    (cuts, as {variable: coefficient}, rhs); ``fixed``: variables held at a value."""
    import scipy.sparse as sp
    from scipy.optimize import linprog

    n = len(proto.variables)
    rows, cols, vals, lo, hi = [], [], [], [], []

    def row(terms, low, high):
        for var, coef in terms:
            rows.append(len(lo))
            cols.append(var)
            vals.append(coef)
        lo.append(low)
        hi.append(high)

    for c in proto.constraints:
        kind = c.WhichOneof("constraint")
        if kind == "linear":
            if c.enforcement_literal:
                raise ValueError("an enforced linear constraint has no LP row here")
            low, high = c.linear.domain[0], c.linear.domain[-1]
            terms = []
            for v, a in zip(c.linear.vars, c.linear.coeffs):
                var, sign, const = _literal(v)
                terms.append((var, a * sign))
                low, high = low - a * const, high - a * const
            row(terms, low, high)
        elif kind == "exactly_one":
            lits = [_literal(v) for v in c.exactly_one.literals]
            const = sum(k for _, _, k in lits)
            row([(var, sign) for var, sign, _ in lits], 1 - const, 1 - const)
        elif kind == "bool_and":
            (e,) = c.enforcement_literal
            evar, esign, econst = _literal(e)
            for v in c.bool_and.literals:  # each literal ≥ the enforcement literal
                var, sign, const = _literal(v)
                row([(var, sign), (evar, -esign)], econst - const, np.inf)
        else:
            raise ValueError(f"no LP row for a {kind} constraint")
    for coefs, rhs in extra:
        row(coefs.items(), -np.inf, rhs)
    a = sp.csr_matrix((vals, (rows, cols)), shape=(len(lo), n))
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    cost = np.zeros(n)
    for v, coef in zip(proto.objective.vars, proto.objective.coeffs):
        var, sign, _ = _literal(v)
        cost[var] += coef * sign
    upper, lower = np.isfinite(hi), np.isfinite(lo)
    bounds = np.zeros((n, 2))
    bounds[:, 1] = 1.0
    for var, value in (fixed or {}).items():
        bounds[var] = value
    res = linprog(cost, A_ub=sp.vstack([a[upper], -a[lower]]),
                  b_ub=np.concatenate([hi[upper], -lo[lower]]), bounds=bounds, method="highs")
    if res.status != 0:
        raise RuntimeError(f"the LP relaxation was not solved: {res.message}")
    return float(res.fun), res.x, cost


def exemption_rows(backend) -> tuple[list[int], list[tuple[dict, float]]]:
    """The model's exemption literals (an unsupported notch of a 3-notch log), and rows
    valid for every structure that tie them to the placements (none in the model as such):

    * ``y_L − e_a + empty(b_a) ≤ 1``: a 3-notch log placed over an empty ``b_a`` has that
      notch exempt;
    * ``e_a + empty(b_a') ≤ 1`` (a' ≠ a): a log with an exempt notch rests on its other two;
    * ``y_L + empty(b) ≤ 1`` for every notch of a 1- or 2-notch log above layer 0.
    """
    x = backend._x_index
    K = backend.extent.K
    by_log: dict[int, list[tuple[int, int]]] = defaultdict(list)
    for lit, start, below in backend._exempt_table.tolist():
        by_log[start].append((lit, below))
    rows: list[tuple[dict, float]] = []
    for start, notches in by_log.items():
        y = int(x[start, 4])
        for a, (lit, below) in enumerate(notches):
            rows.append(({y: 1, lit: -1, int(x[below, 0]): 1}, 1.0))
            rows += [({lit: 1, int(x[other, 0]): 1}, 1.0)
                     for b, (_, other) in enumerate(notches) if b != a]
    for p in range(len(x)):
        if (p // K) % backend.extent.J == 0:
            continue
        rows += [({int(x[p, code]): 1, int(x[p - K, 0]): 1}, 1.0)
                 for code in (1, 2, 3) if x[p, code] >= 0]
    lits = sorted({lit for lit, _, _ in backend._exempt_table.tolist()})
    return lits, rows


def column_cuts(backend, x: np.ndarray, optimum: np.ndarray) -> list[tuple[dict, float]]:
    """Most violated cuts on column scopes: for three positions one above the other, every
    placement covering them, their exemption literals and the segment reading of the top
    and bottom one (``Or 2``), the integer configurations the local rules allow are
    enumerated and, where ``x`` lies outside their hull, the separating row is returned
    (checked to hold at ``optimum``)."""
    from scipy.optimize import linprog

    from unseeable.grammar.expr import Or, occupied

    table = backend._x_index
    I, J, K = backend.extent.shape
    exempt_at: dict[int, dict[int, int]] = defaultdict(dict)  # notch -> {log var: literal}
    for lit, start, below in backend._exempt_table.tolist():
        exempt_at[below + K][int(table[start, 4])] = lit
    cuts = []
    for i, k, j in itertools.product(range(I), range(K), range(2, J)):
        ps = [backend._p((i, j - 2, k)), backend._p((i, j - 1, k)), backend._p((i, j, k))]
        covering = [{int(v) for v in table[p, 1:] if v >= 0} for p in ps]
        reading = backend._lits.get(Or(occupied((i, j, k)), occupied((i, j - 2, k))))
        scope = list(dict.fromkeys(
            [int(v) for p, cover in zip(ps, covering)
             for v in (table[p, 0], *sorted(cover), *exempt_at[p].values())]
            + ([reading.index] if reading is not None else [])))
        here = x[scope]
        if np.all((here < 1e-7) | (here > 1 - 1e-7)):
            continue
        column = {v: n for n, v in enumerate(scope)}
        configs = []
        for logs in itertools.product(*[[None, *sorted(c)] for c in covering]):
            occupied_ = [log is not None for log in logs]
            choices = [[None] + ([exempt_at[p][log]] if log in exempt_at[p] else [])
                       for p, log in zip(ps, logs)]
            for exempt in itertools.product(*choices):
                # An exempt notch is over an empty position; an occupied one over an empty
                # position in the scope is exempt (the bottom one's support lies outside).
                if any(exempt[t] is not None and occupied_[t - 1] for t in (1, 2)) or any(
                        occupied_[t] and not occupied_[t - 1] and exempt[t] is None
                        for t in (1, 2)):
                    continue
                v = np.zeros(len(scope))
                for p, log, lit in zip(ps, logs, exempt):
                    v[column[int(table[p, 0]) if log is None else log]] = 1
                    if lit is not None:
                        v[column[lit]] = 1
                if reading is not None:
                    v[column[reading.index]] = float(occupied_[0] or occupied_[2])
                configs.append(v)
        hull = np.unique(np.array(configs), axis=0)
        # max a·x − β  subject to  a·v ≤ β for every configuration v, −1 ≤ a ≤ 1
        res = linprog(np.append(-here, 1.0), A_ub=np.hstack([hull, -np.ones((len(hull), 1))]),
                      b_ub=np.zeros(len(hull)), bounds=[(-1, 1)] * len(scope) + [(None, None)],
                      method="highs")
        if res.status == 0 and -res.fun > 1e-5:
            a, beta = res.x[:-1], res.x[-1]
            assert a @ optimum[scope] <= beta + 1e-6, "a column cut removes the optimum"
            cuts.append(({v: float(c) for v, c in zip(scope, a) if abs(c) > 1e-9}, float(beta)))
    return cuts


def main(argv: list[str] | None = None) -> int:
    from google.protobuf import text_format
    from ortools.sat import cp_model_pb2
    from ortools.sat.python import cp_model

    from unseeable.domain import Extent
    from unseeable.errors import UnseeableError
    from unseeable.solve import StructureSolver
    from unseeable.solve.backend import SCALE

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--extent", default="10,12,10", help="I,J,K")
    parser.add_argument("--generator", default="random", choices=GENERATORS)
    parser.add_argument("--seed", type=int, default=1000)
    parser.add_argument("--probes", action="store_true",
                        help="also: the gap with the exemption literals fixed at the optimum, "
                             "with per-log rows, with column cuts; the solve from the optimum")
    args = parser.parse_args(argv)
    try:
        extent = Extent.parse(args.extent, field="--extent")
    except UnseeableError as err:
        print(f"error: {err}", file=sys.stderr)
        return 1

    solver = StructureSolver(extent)
    _, _, shipped = _instance(args.generator, extent, args.seed)
    result = solver.solve(shipped, time_limit=300)
    backend = solver._backend  # the model the MAP was solved on, its last objective in place
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "model.pb.txt"
        backend.model.export_to_file(str(path))
        text = path.read_text()
    proto = text_format.Parse(text, cp_model_pb2.CpModelProto())
    bound, x, cost = lp_relaxation(proto)
    # The optimum's whole assignment (the reified literals' too): the model solved again
    # as the backend solves it.
    model = cp_model.CpModel()
    model.proto.parse_text_format(text)
    cp = cp_model.CpSolver()
    backend._parameters(cp, 300.0)
    if cp.solve(model) != cp_model.OPTIMAL:
        raise RuntimeError("the exported model was not solved to optimality")
    optimum = np.array([cp.value(model.get_bool_var_from_proto_index(i))
                        for i in range(len(x))], float)
    kind: dict[int, str] = {}
    for codes in backend._x_index.tolist():
        for var in codes:
            if var >= 0:
                kind[var] = "placement"
    for expr, lit in backend._lits.items():
        kind.setdefault(lit.index, f"{type(expr).__name__} {len(getattr(expr, 'args', ()))}")
    gap = (cost @ optimum - bound) / SCALE
    share: dict[str, float] = defaultdict(float)
    for var in np.flatnonzero(cost):
        share[kind.get(var, "other")] += cost[var] * (optimum[var] - x[var]) / SCALE
    fractional = np.flatnonzero((x > 1e-6) & (x < 1 - 1e-6))
    counts: dict[str, int] = defaultdict(int)
    for var in fractional:
        counts[kind.get(var, "other")] += 1
    print(f"{extent} {args.generator} seed {args.seed}: MAP {result.log_probability:.3f} "
          f"({result.status.name}); LP gap at the root {gap:.2f} nats; "
          f"{len(fractional)} of {len(x)} variables fractional")
    print(f"{'objective variables':22s} {'optimum − LP (nats)':>20s} {'fractional':>11s}")
    for name in sorted(set(share) | set(counts), key=lambda k: -abs(share.get(k, 0.0))):
        print(f"{name:22s} {share.get(name, 0.0):20.2f} {counts.get(name, 0):11d}")
    if args.probes:
        def gap_of(**kwargs) -> float:
            return (cost @ optimum - lp_relaxation(proto, **kwargs)[0]) / SCALE

        lits, rows = exemption_rows(backend)
        at_optimum = gap_of(fixed={v: optimum[v] for v in lits})
        print(f"exemption literals fixed at the optimum's values ({len(lits)}, "
              f"{int(optimum[lits].sum())} set): gap {at_optimum:.2f}")
        print(f"with the {len(rows)} per-log rows: gap {gap_of(extra=rows):.2f}")
        cuts: list = []
        for round_ in range(3):
            found = column_cuts(backend, lp_relaxation(proto, extra=cuts)[1], optimum)
            if not found:
                break
            cuts += found
            print(f"column cuts, round {round_ + 1}: {len(found)} found, "
                  f"gap {gap_of(extra=cuts):.2f}")
        for name, hinted in (("cold", False), ("from the optimum, every literal hinted", True)):
            again = cp_model.CpModel()
            again.proto.parse_text_format(text)
            again.clear_hints()
            if hinted:
                for var, value in enumerate(optimum):
                    again.add_hint(again.get_bool_var_from_proto_index(var), bool(value))
            solver_ = cp_model.CpSolver()
            backend._parameters(solver_, 300.0)
            t0 = time.perf_counter()
            status = solver_.status_name(solver_.solve(again))
            print(f"CP-SAT {name}: {status} in {time.perf_counter() - t0:.2f} s, "
                  f"{solver_.num_branches} branches")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
