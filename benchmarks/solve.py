"""Benchmark of the MAP backends on simulated evidence (prints tables).

For each extent, ``--instances`` random valid structures
(:func:`unseeable.grammar.random_structure`, density 0.5) get simulated
evidence (85 % detector accuracy, 40 % of features occluded). Measured:

* solve time of cpsat with 1 and 2 workers, bnb (with a time limit; how
  often it proves the optimum), toulbar2 — all must agree on the optimum;
* model building (the grammar and the kept model) apart from solving, and
  CP-SAT's presolve alone (``stop_after_presolve``) to show where time goes;
* the re-solve of the confidence check — occluded priors shifted by 0.2 away
  from the estimate — in the kept model, without and with the estimate as a
  warm-start hint, and as the decision the check needs
  (:meth:`StructureSolver.find_better`, the estimate as cut-off).

Usage::

    python benchmarks/solve.py                 # full run (several minutes)
    python benchmarks/solve.py --quick         # 5 instances, 4x4x4 and 6x8x6 only
    python benchmarks/solve.py --extents 8,10,8 --backends cpsat1,cpsat2
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from unseeable.domain import Evidence, Extent, feature_values, simulate_evidence
from unseeable.grammar import (
    compile_objective,
    grammar_constraints,
    log_probability,
    random_structure,
)
from unseeable.solve import SolveStatus, StructureSolver, available_backends

ALL_BACKENDS = ("cpsat1", "cpsat2", "bnb", "toulbar2")


def _instances(extent: Extent, count: int, seed0: int):
    for n in range(count):
        truth = random_structure(extent, density=0.5, seed=seed0 + n)
        yield truth, simulate_evidence(truth, accuracy=0.85, occluded_fraction=0.4,
                                       seed=seed0 + n)


def _backend(name: str) -> tuple[str, int]:
    if name.startswith("cpsat"):
        return "cpsat", int(name[5:] or 1)
    return name, 1


def _fmt(values: list[float]) -> tuple[str, str]:
    if not values:
        return "-", "-"
    return f"{statistics.median(values):.3f}", f"{max(values):.3f}"


def run(extents: list[Extent], backends: list[str], instances: int, bnb_limit: float,
        time_limit: float, seed0: int, warm_backends: list[str], warm_instances: int,
        warm_limit: float) -> None:
    rows = []
    build_rows = []
    warm_rows = []
    for extent in extents:
        cases = list(_instances(extent, instances, seed0))
        optimum: dict[int, float] = {}
        # -- building ----------------------------------------------------------
        grammar_constraints.cache_clear()
        t0 = time.perf_counter()
        grammar_constraints(extent)
        grammar_s = time.perf_counter() - t0
        t0 = time.perf_counter()
        kept = StructureSolver(extent, workers=1)
        cpsat_build_s = time.perf_counter() - t0
        objective_s = []
        install_s = []
        presolve_s = []
        for _truth, ev in cases:
            t0 = time.perf_counter()
            compile_objective(extent, ev)
            objective_s.append(time.perf_counter() - t0)
            r = kept.solve(ev, time_limit=time_limit)
            install_s.append(r.timings["build_s"] - (cpsat_build_s if r.resolves == 0 else 0))
        # CP-SAT presolve alone, on the kept model
        from ortools.sat.python import cp_model

        for _truth, ev in cases[: min(5, len(cases))]:
            obj = compile_objective(extent, ev)
            backend = kept._backend
            backend.solve(obj, time_limit=time_limit)  # installs this objective
            solver = cp_model.CpSolver()
            backend._parameters(solver, time_limit)
            solver.parameters.stop_after_presolve = True
            t0 = time.perf_counter()
            solver.solve(backend.model)
            presolve_s.append(time.perf_counter() - t0)
        build_rows.append((str(extent), grammar_s, cpsat_build_s, statistics.median(objective_s),
                           statistics.median(install_s), statistics.median(presolve_s)))
        print("  build", *(f"{v:.3f}" for v in build_rows[-1][1:]), flush=True)

        # -- solving -----------------------------------------------------------
        for name in backends:
            backend, workers = _backend(name)
            limit = bnb_limit if backend == "bnb" else time_limit
            times, cpus, builds, proven = [], [], [], 0
            for n, (_truth, ev) in enumerate(cases):
                t0 = time.perf_counter()
                solver = StructureSolver(extent, backend=backend, workers=workers)
                builds.append(time.perf_counter() - t0)
                c0 = time.process_time()
                r = solver.solve(ev, time_limit=limit)
                cpus.append(time.process_time() - c0)
                times.append(r.timings["solve_s"])
                if r.status == SolveStatus.OPTIMAL:
                    proven += 1
                    if n in optimum and abs(optimum[n] - r.log_probability) > 1e-4:
                        raise AssertionError(f"{name} disagrees on {extent} #{n}: "
                                             f"{r.log_probability} vs {optimum[n]}")
                    optimum.setdefault(n, r.log_probability)
            med, mx = _fmt(times)
            rows.append((str(extent), name, med, mx, _fmt(cpus)[0], f"{proven}/{len(cases)}",
                         f"{statistics.median(builds):.3f}"))
            print(f"  {extent} {name}: median {med} s, max {mx} s, proven {proven}/{len(cases)}",
                  flush=True)

        # -- warm start of the confidence re-solve -----------------------------------
        for name in [b for b in warm_backends if b != "bnb"]:
            backend, workers = _backend(name)
            solver = StructureSolver(extent, backend=backend, workers=workers)
            cold, warm, decide, proven = [], [], [], [0, 0]
            for _truth, ev in cases[:warm_instances]:
                first = solver.solve(ev, time_limit=time_limit)
                occluded = ev.p == 0.5
                value = feature_values(extent, first.structure.occupancy)
                shifted = Evidence(extent, np.where(occluded, np.where(value, 0.3, 0.7), ev.p))
                a = solver.solve(shifted, time_limit=warm_limit)
                b = solver.solve(shifted, hint=first, time_limit=warm_limit)
                c = solver.find_better(shifted, first, time_limit=warm_limit)
                if b.status == SolveStatus.OPTIMAL:  # the two answers must agree
                    before = log_probability(shifted, first.structure, first.choices)
                    assert (c.status == SolveStatus.FEASIBLE) == (b.log_probability > before + 1e-7)
                decide.append(c.timings["solve_s"] + c.timings["build_s"])
                if a.status == b.status == SolveStatus.OPTIMAL:
                    assert abs(a.log_probability - b.log_probability) < 1e-4
                proven[0] += a.status == SolveStatus.OPTIMAL
                proven[1] += b.status == SolveStatus.OPTIMAL
                cold.append(a.timings["solve_s"])
                warm.append(b.timings["solve_s"])
            speedup = statistics.median(c / w for c, w in zip(cold, warm))
            decide_up = statistics.median(c / d for c, d in zip(cold, decide))
            row = (str(extent), name, *_fmt(cold), *_fmt(warm), f"{speedup:.2f}x",
                   f"{proven[0]}/{len(cold)}", f"{proven[1]}/{len(warm)}", *_fmt(decide),
                   f"{decide_up:.1f}x")
            warm_rows.append(row)
            print("  re-solve", *row, flush=True)

    print()
    print("Solve time (s, wall) over simulated instances (85 % accuracy, 40 % occluded); "
          "cpu = process CPU time of the whole solve call (all threads)")
    _table(("extent", "backend", "median", "max", "cpu median", "proven", "build"), rows)
    print()
    print("Where the time goes (medians, s): grammar Φ as expressions; CP-SAT model of Φ; "
          "objective compile; objective install in kept model; CP-SAT presolve alone")
    _table(("extent", "grammar", "cpsat model", "objective", "install", "presolve"),
           [(e, *(f"{v:.3f}" for v in vals)) for e, *vals in build_rows])
    if warm_rows:
        print()
        print("Confidence re-solve (occluded priors shifted 0.2 away from the estimate) in the "
              f"kept model, {warm_limit:g} s limit")
        _table(("extent", "backend", "cold med", "cold max", "hinted med", "hinted max",
                "speed-up (median ratio)", "cold proven", "hinted proven",
                "find_better med", "find_better max", "speed-up"), warm_rows)
        print("find_better: the question the δ tests ask — does any structure beat the "
              "estimate under the shifted priors? — with the estimate as cut-off and hint")


def _table(header, rows) -> None:
    widths = [max(len(str(x)) for x in col) for col in zip(header, *rows)]
    line = "  ".join(f"{h:<{w}}" for h, w in zip(header, widths))
    print(line)
    print("-" * len(line))
    for row in rows:
        print("  ".join(f"{str(x):<{w}}" for x, w in zip(row, widths)))


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--extents", nargs="*", default=None,
                        help="extents I,J,K (default 4,4,4 6,8,6 8,10,8)")
    parser.add_argument("--backends", default=",".join(ALL_BACKENDS),
                        help=f"comma-separated subset of {','.join(ALL_BACKENDS)}")
    parser.add_argument("--instances", type=int, default=20)
    parser.add_argument("--warm-backends", default="cpsat1,cpsat2",
                        help="backends for the warm-start re-solve (toulbar2 is slow there)")
    parser.add_argument("--warm-instances", type=int, default=10,
                        help="instances per extent for the warm-start re-solve")
    parser.add_argument("--warm-time-limit", type=float, default=30.0)
    parser.add_argument("--bnb-limit", type=float, default=5.0,
                        help="bnb time limit per instance (s)")
    parser.add_argument("--time-limit", type=float, default=60.0)
    parser.add_argument("--seed", type=int, default=1000)
    parser.add_argument("--quick", action="store_true",
                        help="5 instances on 4x4x4 and 6x8x6")
    args = parser.parse_args(argv)
    extents = [Extent.parse(e) for e in (args.extents or ["4,4,4", "6,8,6", "8,10,8"])]
    backends = [b for b in args.backends.split(",") if b]
    for b in backends:
        if b not in ALL_BACKENDS:
            parser.error(f"unknown backend {b!r}")
    if "toulbar2" in backends and "toulbar2" not in available_backends():
        print("pytoulbar2 not installed: skipping toulbar2")
        backends.remove("toulbar2")
    if args.quick:
        extents = extents[:2] if args.extents is None else extents
        args.instances = min(args.instances, 5)
    warm = [b for b in args.warm_backends.split(",") if b and b in backends]
    run(extents, backends, args.instances, args.bnb_limit, args.time_limit, args.seed, warm,
        args.warm_instances, args.warm_time_limit)


if __name__ == "__main__":
    main()
