"""Benchmark of the exact MAP and the confidence decision at scale (prints tables).

Instances come from two generators, ``--instances`` of each per extent:

* ``random`` — :func:`unseeable.grammar.random_structure` at density 0.8 (dense: most
  supported positions hold a log);
* ``cabins`` — :func:`cabins`: 3×3 Lincoln-Log cabins of random heights scattered over
  the table, walls of 3-notch logs resting on their two corners, some wall logs replaced
  by corner posts (openings) — sparse, and built of the disjunctive support rule.

Each gets simulated evidence (85 % detector accuracy, 40 % of features occluded).
Measured, interleaved instance by instance on one kept CP-SAT model per extent
(1 worker, ties "any" — the MAP itself, without the tie policy's search):

* the MAP under the paper's uniform prior and under the shipped builder prior
  (:class:`unseeable.grammar.priors.StructurePrior`, joint cost on the joints the
  evidence reads, as :func:`unseeable.solve.estimate_structure` charges it);
* the δ* decision under the shipped prior (:func:`unseeable.confidence.estimate_changes`:
  does any structure beat the estimate with the occluded priors shifted 0.2 away from
  it?), and the same decision where the answer is "no" (no shift: a proof that the
  estimate is optimal);
* ``--variants``: the plain CP-SAT formulation against the tight one (same instances,
  same optimum required);
* ``--workers``: 1 CP-SAT worker against 2 with several subsolver pairs (wall and CPU);
* ``--parameters``: the shipped-prior MAP under CP-SAT parameter changes from the
  backend's settings (:data:`PARAMETER_SETS`; CPU time and CP-SAT's deterministic time,
  which the machine's load does not move; same optimum required);
* ``--end-to-end``: ``unseeable estimate FILE --out DIR`` on each instance's evidence file
  (the command as a user runs it: start-up, MAP with the tie policy, confidence, pictures),
  and the library call :func:`unseeable.pipeline.estimate_evidence` alone.

Times are seconds of the call (objective compile, install, search), wall and CPU time of
this process (one worker: CPU time is what the call costs, less moved by other programs
than wall time); the machine's load average is printed with the tables, since absolute
figures on a shared machine move with it — compare columns of one run.

Usage::

    python benchmarks/solve.py                      # 20 instances, 4 extents (long)
    python benchmarks/solve.py --quick              # 5 instances, 4x4x4 and 6x8x6
    python benchmarks/solve.py --extents 10,12,10 --instances 5 --variants --workers
    python benchmarks/solve.py --extents 10,12,10 --generators random --instances 3 \
        --no-map --parameters
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np

from unseeable.confidence import estimate_changes
from unseeable.domain import Extent, Log, Structure, is_valid, save_evidence, simulate_evidence
from unseeable.grammar import EvidenceTerm, compile_objective, log_probability, random_structure
from unseeable.grammar.priors import StructurePrior
from unseeable.solve import SolveStatus, StructureSolver
from unseeable.solve.cpsat import CpSatBackend

GENERATORS = ("random", "cabins")
DEFAULT_EXTENTS = ("4,4,4", "6,8,6", "8,10,8", "10,12,10")
#: Subsolver pairs tried with 2 workers ("portfolio": CP-SAT's own choice).
WORKER_SETS = {"1": (1, ()), "2 max_lp+default_lp": (2, ("max_lp", "default_lp")),
               "2 max_lp+quick_restart": (2, ("max_lp", "quick_restart")),
               "2 max_lp+pseudo_costs": (2, ("max_lp", "pseudo_costs")),
               "2 portfolio": (2, None)}
#: CP-SAT parameter changes tried on the shipped-prior MAP (1 worker; "settings": the
#: backend's own, :meth:`CpSatBackend._parameters`, in one solve: without the quick first
#: attempt that :meth:`CpSatBackend.solve` makes, see ``EASY_SOLVE_WORK``).
PARAMETER_SETS = {
    "settings": {},
    "lazy LP constraints": {"add_lp_constraints_lazily": True},
    "linearization 1": {"linearization_level": 1},
    "presolve": {"cp_model_presolve": True},
    "symmetry 0": {"symmetry_level": 0},
    "LP search": {"search_branching": "LP_SEARCH"},
    "pseudo-cost search": {"search_branching": "PSEUDO_COST_SEARCH"},
    "core": {"optimize_with_core": True},
    "LB tree search": {"optimize_with_lb_tree_search": True},
    "cut level 0": {"cut_level": 0},
    "5 root cut rounds": {"max_cut_rounds_at_level_zero": 5},
    "no SAT inprocessing": {"use_sat_inprocessing": False},
    "no inprocessing minimization": {"inprocessing_minimization_dtime": 0.0},
}


def cabins(extent: Extent, *, seed: int) -> Structure:
    """3×3 cabins of random heights at random places (valid under the grammar).

    A cabin on footprint ``[i0, i0+2] × [k0, k0+2]`` has on even layers a 3-notch log
    along i at k0 and at k0+2, on odd layers one along k at i0 and at i0+2: each rests on
    the two corner logs below it, its middle notch over the empty inside. With chance 0.2
    a wall log above the bottom is two corner posts instead (an opening); a cabin's
    height is drawn from 1 to J; cabins never share a position.

    Examples
    --------
    >>> is_valid(cabins(Extent(6, 4, 6), seed=1))
    True
    """
    rng = np.random.default_rng(seed)
    I, J, K = extent.shape
    taken = np.zeros((I, K), dtype=bool)
    logs: list[Log] = []
    if I < 3 or K < 3:
        return Structure(extent, [])
    for _ in range(int(rng.integers(1, max(2, (I * K) // 9 + 1)))):
        for _attempt in range(20):
            i0, k0 = int(rng.integers(0, I - 2)), int(rng.integers(0, K - 2))
            if not taken[i0:i0 + 3, k0:k0 + 3].any():
                break
        else:
            continue
        taken[i0:i0 + 3, k0:k0 + 3] = True
        height = int(rng.integers(1, J + 1))
        for j in range(height):
            for side in (0, 2):
                at = (i0, k0 + side) if j % 2 == 0 else (i0 + side, k0)
                if j > 0 and rng.random() < 0.2:  # an opening: posts on the two corners
                    far = (at[0] + 2, at[1]) if j % 2 == 0 else (at[0], at[1] + 2)
                    logs += [Log(j, at, 1), Log(j, far, 1)]
                else:
                    logs.append(Log(j, at, 3))
    structure = Structure(extent, logs)
    assert is_valid(structure)
    return structure


def _instance(generator: str, extent: Extent, seed: int):
    if generator == "random":
        truth = random_structure(extent, density=0.8, seed=seed)
    else:
        truth = cabins(extent, seed=seed)
    evidence = simulate_evidence(truth, accuracy=0.85, occluded_fraction=0.4, seed=seed)
    uniform = [EvidenceTerm(evidence)]
    shipped = [*uniform, *StructurePrior().given_visibility(extent)([evidence.judged])]
    return evidence, uniform, shipped


def _timed(fn, *args, **kwargs):
    """``fn(*args, **kwargs)``, its wall time and its CPU time (this process)."""
    c0, t0 = time.process_time(), time.perf_counter()
    out = fn(*args, **kwargs)
    return out, time.perf_counter() - t0, time.process_time() - c0


def _med(values: list[float]) -> str:
    finite = [v for v in values if np.isfinite(v)]
    return f"{statistics.median(values):.3f}" if finite else "-"


def _max(values: list[float]) -> str:
    return f"{max(values):.3f}" if values else "-"


def _load() -> str:
    return "load average " + ", ".join(f"{x:.2f}" for x in os.getloadavg())


def run_map(extents, generators, instances, seed0, time_limit) -> list[tuple]:
    """Uniform MAP, shipped MAP, δ* decision and "no" decision per extent and generator."""
    rows = []
    for extent in extents:
        solver = StructureSolver(extent)
        for generator in generators:
            wall = {k: [] for k in ("uniform", "shipped", "dstar", "no")}
            cpu = {k: [] for k in wall}
            ratio = []
            proven, changed, settled = [0, 0], 0, 0
            for n in range(instances):
                evidence, uniform, shipped = _instance(generator, extent, seed0 + n)
                r_uni, *t_uni = _timed(solver.solve, uniform, time_limit=time_limit)
                r_ship, *t_ship = _timed(solver.solve, shipped, time_limit=time_limit)
                proven[0] += r_uni.status == SolveStatus.OPTIMAL
                proven[1] += r_ship.status == SolveStatus.OPTIMAL
                occluded = ~evidence.judged
                change, *t_d = _timed(estimate_changes, solver, shipped, r_ship, occluded, 0.2,
                                      time_limit=time_limit)
                changed += change
                # No shift: nothing beats the MAP, the decision is a proof.
                none, *t_no = _timed(solver.find_better, shipped, r_ship, time_limit=time_limit)
                # Never a better structure than a proven optimum; undecided within the time
                # limit is counted (settled: proofs of none).
                if r_ship.status == SolveStatus.OPTIMAL:
                    assert none.status != SolveStatus.FEASIBLE, (extent, generator, n)
                settled += none.status == SolveStatus.INFEASIBLE
                for key, (w, c) in (("uniform", t_uni), ("shipped", t_ship), ("dstar", t_d),
                                    ("no", t_no)):
                    wall[key].append(w)
                    cpu[key].append(c)
                ratio.append(t_d[1] / t_ship[1])
            row = (str(extent), generator,
                   _med(wall["uniform"]), _med(cpu["uniform"]), _max(wall["uniform"]),
                   f"{proven[0]}/{instances}",
                   _med(wall["shipped"]), _med(cpu["shipped"]), _max(wall["shipped"]),
                   f"{proven[1]}/{instances}",
                   _med(wall["dstar"]), _med(cpu["dstar"]), _max(wall["dstar"]),
                   f"{changed}/{instances}", _med(wall["no"]), _med(cpu["no"]),
                   f"{settled}/{instances}",
                   f"{statistics.median(ratio):.2f}", f"{max(ratio):.2f}")
            rows.append(row)
            print("  map", *row, flush=True)
    return rows


def run_variants(extents, generators, instances, seed0, time_limit) -> list[tuple]:
    """Plain against tight CP-SAT formulation, interleaved, under both priors."""
    rows = []
    for extent in extents:
        backends = {f: CpSatBackend(extent, (), formulation=f) for f in ("plain", "tight")}
        for generator in generators:
            times = {(f, p): [] for f in backends for p in ("uniform", "shipped")}
            for n in range(instances):
                _, uniform, shipped = _instance(generator, extent, seed0 + n)
                for prior, terms in (("uniform", uniform), ("shipped", shipped)):
                    objective = compile_objective(extent, terms)
                    values = {}
                    for f, backend in backends.items():
                        raw, _, t = _timed(backend.solve, objective, time_limit=time_limit)
                        proven = raw.status == SolveStatus.OPTIMAL
                        times[f, prior].append(t if proven else np.inf)
                        if proven:
                            values[f] = log_probability(
                                terms, Structure.from_occupancy(extent, raw.occupancy))
                    if len(values) == 2:
                        assert abs(values["plain"] - values["tight"]) < 1e-6, (extent, n)
            row = [str(extent), generator]
            for prior in ("uniform", "shipped"):
                plain, tight = times["plain", prior], times["tight", prior]
                speedup = statistics.median(p / t for p, t in zip(plain, tight))
                row += [_med(plain), _med(tight), f"{speedup:.1f}x"]
            rows.append(tuple(row))
            print("  variants", *row, flush=True)
    return rows


def _solves_under(extents, generators, instances, seed0, time_limit, settings: dict,
                  label: str, summarise) -> list[tuple]:
    """The shipped-prior MAP on the kept tight model, once per entry of ``settings`` (name
    -> function setting up a fresh ``CpSolver``) per instance; ``summarise(extent,
    generator, per)`` makes the table's rows from ``per[name]``, a list of (code, wall, CPU,
    deterministic time, objective value) per instance."""
    from ortools.sat.python import cp_model

    rows = []
    for extent in extents:
        backend = CpSatBackend(extent, ())
        for generator in generators:
            per = {name: [] for name in settings}
            for n in range(instances):
                _, _, shipped = _instance(generator, extent, seed0 + n)
                backend._install(compile_objective(extent, shipped), None, None)
                for name, setup in settings.items():
                    solver = cp_model.CpSolver()
                    backend._parameters(solver, time_limit)
                    setup(solver)
                    code, t, c = _timed(solver.solve, backend.model)
                    per[name].append((code, t, c, solver.deterministic_time,
                                      solver.objective_value))
            for row in summarise(extent, generator, per):
                rows.append(row)
                print(f"  {label}", *row, flush=True)
    return rows


def run_workers(extents, generators, instances, seed0, time_limit) -> list[tuple]:
    """The shipped-prior MAP with 1 worker and with 2 (several subsolver pairs)."""
    from ortools.sat.python import cp_model

    def setup(workers, subsolvers):
        def apply(solver):
            solver.parameters.num_workers = workers
            if subsolvers:
                solver.parameters.subsolvers.extend(subsolvers)
        return apply

    def summarise(extent, generator, per):
        row = [str(extent), generator]
        for name in WORKER_SETS:
            row += [_med([t if code == cp_model.OPTIMAL else np.inf
                          for code, t, *_ in per[name]]),
                    _med([c for _, _, c, *_ in per[name]])]
        return [tuple(row)]

    return _solves_under(extents, generators, instances, seed0, time_limit,
                         {name: setup(*spec) for name, spec in WORKER_SETS.items()},
                         "workers", summarise)


def run_parameters(extents, generators, instances, seed0, time_limit) -> list[tuple]:
    """The shipped-prior MAP under each of :data:`PARAMETER_SETS` (CPU and deterministic
    time, medians; an instance not proven within the time limit counts as infinite)."""
    from ortools.sat.python import cp_model

    def setup(changes):
        def apply(solver):
            for key, value in changes.items():
                if key == "search_branching":
                    value = getattr(cp_model, value)
                setattr(solver.parameters, key, value)
        return apply

    def summarise(extent, generator, per):
        for n in range(instances):
            optima = {round(per[name][n][4]) for name in PARAMETER_SETS
                      if per[name][n][0] == cp_model.OPTIMAL}
            assert len(optima) <= 1, (extent, generator, n, optima)
        rows = []
        for name in PARAMETER_SETS:
            proven = [code == cp_model.OPTIMAL for code, *_ in per[name]]
            cpu = [c if ok else np.inf for ok, (_, _, c, _, _) in zip(proven, per[name])]
            work = [w if ok else np.inf for ok, (_, _, _, w, _) in zip(proven, per[name])]
            rows.append((str(extent), generator, name, _med(cpu), _med(work),
                         f"{sum(proven)}/{instances}"))
        return rows

    return _solves_under(extents, generators, instances, seed0, time_limit,
                         {name: setup(changes) for name, changes in PARAMETER_SETS.items()},
                         "parameters", summarise)


def run_end_to_end(extents, generators, instances, seed0, time_limit) -> list[tuple]:
    """``unseeable estimate`` on an evidence file (wall time of the command) and the
    library's :func:`~unseeable.pipeline.estimate_evidence` with the default settings
    (confidence included), per extent and generator."""
    from unseeable.pipeline import EstimateSettings, estimate_evidence

    settings = EstimateSettings().replace(time_limit=time_limit)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for extent in extents:
            for generator in generators:
                command, library, library_cpu, confident = [], [], [], 0
                for n in range(instances):
                    evidence, _, _ = _instance(generator, extent, seed0 + n)
                    path = Path(tmp) / f"evidence-{n}.json"
                    save_evidence(evidence, path)
                    est, wall, cpu = _timed(estimate_evidence, evidence, settings)
                    library.append(wall)
                    library_cpu.append(cpu)
                    confident += bool(est.confident)
                    t0 = time.perf_counter()
                    subprocess.run([shutil.which("unseeable") or "unseeable", "estimate", str(path),
                                    "--out", str(Path(tmp) / f"out-{n}"),
                                    "--time-limit", str(time_limit)],
                                   check=True, capture_output=True)
                    command.append(time.perf_counter() - t0)
                row = (str(extent), generator, _med(library), _med(library_cpu),
                       _max(library), _med(command), _max(command),
                       f"{confident}/{instances}")
                rows.append(row)
                print("  end-to-end", *row, flush=True)
    return rows


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
                        help=f"extents I,J,K (default {' '.join(DEFAULT_EXTENTS)})")
    parser.add_argument("--generators", default=",".join(GENERATORS),
                        help=f"comma-separated subset of {','.join(GENERATORS)}")
    parser.add_argument("--instances", type=int, default=20)
    parser.add_argument("--time-limit", type=float, default=60.0)
    parser.add_argument("--seed", type=int, default=1000)
    parser.add_argument("--variants", action="store_true",
                        help="also time the plain formulation against the tight one")
    parser.add_argument("--workers", action="store_true",
                        help="also time 2 CP-SAT workers against 1")
    parser.add_argument("--parameters", action="store_true",
                        help="also time the shipped-prior MAP under CP-SAT parameter changes")
    parser.add_argument("--end-to-end", action="store_true",
                        help="also time `unseeable estimate` on the evidence files")
    parser.add_argument("--no-map", action="store_true", help="skip the main table")
    parser.add_argument("--quick", action="store_true",
                        help="5 instances on 4x4x4 and 6x8x6")
    args = parser.parse_args(argv)
    extents = [Extent.parse(e) for e in (args.extents or DEFAULT_EXTENTS)]
    if args.quick:
        extents = extents[:2] if args.extents is None else extents
        args.instances = min(args.instances, 5)
    generators = [g for g in args.generators.split(",") if g]
    for g in generators:
        if g not in GENERATORS:
            parser.error(f"unknown generator {g!r}")
    common = (extents, generators, args.instances, args.seed, args.time_limit)
    print(f"start: {_load()}", flush=True)
    map_rows = [] if args.no_map else run_map(*common)
    variant_rows = run_variants(*common) if args.variants else []
    worker_rows = run_workers(*common) if args.workers else []
    parameter_rows = run_parameters(*common) if args.parameters else []
    end_rows = run_end_to_end(*common) if args.end_to_end else []
    print(f"end: {_load()}")
    if map_rows:
        print()
        print(f"Exact MAP and δ* decision (s; medians of wall and CPU time, maximum of wall "
              f"time, over {args.instances} instances; 1 CP-SAT worker, kept model). δ*: the "
              "δ* = 0.2 test (changed: how often the estimate gave way); no: the same "
              "decision without shift (a proof of \"none\"; settled: how many were proven "
              "within the time limit); ratio: δ* / shipped MAP in CPU "
              "time, per instance")
        _table(("extent", "gen", "uniform", "cpu", "max", "proven", "shipped", "cpu", "max",
                "proven", "δ*", "cpu", "max", "changed", "no", "cpu", "settled", "ratio med",
                "ratio max"), map_rows)
    if variant_rows:
        print()
        print("Formulations (s, CPU time of the search, median; speed-up: median "
              "per-instance plain / tight)")
        _table(("extent", "gen", "uniform plain", "tight", "speed-up", "shipped plain",
                "tight", "speed-up"), variant_rows)
    if worker_rows:
        print()
        print("CP-SAT workers, shipped prior, tight model (s, median wall / median CPU)")
        header = ["extent", "gen"]
        for name in WORKER_SETS:
            header += [f"{name} wall", "cpu"]
        _table(header, worker_rows)
    if parameter_rows:
        print()
        print("CP-SAT parameters, shipped prior, tight model, 1 worker (medians: CPU s, "
              "deterministic time)")
        _table(("extent", "gen", "parameters", "cpu", "work", "proven"), parameter_rows)
    if end_rows:
        print()
        print("End to end, shipped settings, confidence included (s, wall, medians; "
              "library: estimate_evidence, with its CPU time, which the machine's load moves "
              "less; command: `unseeable estimate FILE --out DIR`, start-up and pictures "
              "included)")
        _table(("extent", "gen", "library", "cpu", "max", "command", "max", "confident"),
               end_rows)


if __name__ == "__main__":
    main()
