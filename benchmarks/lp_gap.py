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

Usage::

    python benchmarks/lp_gap.py [--extent 10,12,10] [--generator random] [--seed 1000]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from collections import defaultdict
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from solve import GENERATORS, _instance  # noqa: E402  (the solve benchmark's instances)


def _literal(index: int) -> tuple[int, int, int]:
    """A proto literal as (variable, sign, constant): its value is ``constant + sign·x``."""
    return (index, 1, 0) if index >= 0 else (-index - 1, -1, 1)


def lp_relaxation(proto) -> tuple[float, np.ndarray, np.ndarray]:
    """The LP relaxation of a CP-SAT model proto of Booleans (linear, exactly-one and
    enforced bool-and constraints): (minimum of the proto's objective, the LP's values,
    the objective's coefficient per variable)."""
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
    a = sp.csr_matrix((vals, (rows, cols)), shape=(len(lo), n))
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    cost = np.zeros(n)
    for v, coef in zip(proto.objective.vars, proto.objective.coeffs):
        var, sign, _ = _literal(v)
        cost[var] += coef * sign
    upper, lower = np.isfinite(hi), np.isfinite(lo)
    res = linprog(cost, A_ub=sp.vstack([a[upper], -a[lower]]),
                  b_ub=np.concatenate([hi[upper], -lo[lower]]), bounds=(0, 1), method="highs")
    if res.status != 0:
        raise RuntimeError(f"the LP relaxation was not solved: {res.message}")
    return float(res.fun), res.x, cost


def main(argv: list[str] | None = None) -> int:
    from google.protobuf import text_format
    from ortools.sat import cp_model_pb2
    from ortools.sat.python import cp_model

    from unseeable.domain import Extent
    from unseeable.solve import StructureSolver
    from unseeable.solve.backend import SCALE

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--extent", default="10,12,10", help="I,J,K")
    parser.add_argument("--generator", default="random", choices=GENERATORS)
    parser.add_argument("--seed", type=int, default=1000)
    args = parser.parse_args(argv)
    extent = Extent(*(int(x) for x in args.extent.split(",")))

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
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
