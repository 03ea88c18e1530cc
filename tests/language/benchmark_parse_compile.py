"""Benchmark: parse + compile a description on the lodge's extent, and the model's size.

Run ``python tests/language/benchmark_parse_compile.py``; prints a table. Not a test:
timings depend on the machine.

* parse + compile: seconds, the first call (the lark grammar is built once per process)
  and the median of 20 further calls;
* the left/right encoding's size: implications of the order encoding against the pairs
  that forbidding incompatible placement pairs would need (``Not(And(a, b))`` each);
* solve: CP-SAT with the grammar and the description, no evidence.
"""

from __future__ import annotations

import statistics
import time

import numpy as np


def main() -> None:
    from unseeable.corpus import load_design
    from unseeable.grammar.expr import Implies
    from unseeable.language import (
        Viewpoint,
        compile_description,
        entity_placements,
        lateral_ranks,
        parse,
        relation_holds,
    )
    from unseeable.solve import StructureSolver

    entry = load_design("lodge")
    extent = entry.structure.extent
    viewpoint = Viewpoint(np.array([0.0, 785.0, -900.0]), entry.pose)
    sentences = ["window left of and perpendicular to door",
                 "a door and a window and a wall. window left of door. door coplanar to wall. "
                 "wall right of window"]
    print(f"lodge extent {extent}: placements "
          + ", ".join(f"{k} {len(entity_placements(k, extent))}"
                      for k in ("door", "window", "wall")))
    print(f"{'description':<48} {'first s':>8} {'median s':>9} {'selectors':>9} "
          f"{'order':>6} {'exprs':>6} {'solve s':>8}")
    for text in sentences:
        t0 = time.perf_counter()
        psi = compile_description(parse(text), extent, viewpoint=viewpoint)
        first = time.perf_counter() - t0
        times = []
        for _ in range(20):
            t0 = time.perf_counter()
            psi = compile_description(parse(text), extent, viewpoint=viewpoint)
            times.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        status = StructureSolver(extent, constraints=psi).solve([]).status.value
        solve_s = time.perf_counter() - t0
        size = psi.size
        label = text if len(text) <= 46 else text[:43] + "..."
        print(f"{label:<48} {first:8.3f} {statistics.median(times):9.3f} "
              f"{size['selectors']:9d} {size['order_choices']:6d} {len(psi):6d} "
              f"{solve_s:8.2f} ({status})")

    # Left/right: order encoding against forbidden pairs.
    psi = compile_description("window left of door", extent, viewpoint=viewpoint)
    ranks = lateral_ranks(extent, viewpoint)
    windows, doors = entity_placements("window", extent), entity_placements("door", extent)
    forbidden = sum(not relation_holds("left_of", w, d, ranks) for w in windows for d in doors)
    relation_parts = psi[-1].args if hasattr(psi[-1], "args") else (psi[-1],)
    order_parts = psi[-2].args if hasattr(psi[-2], "args") else (psi[-2],)
    implications = sum(isinstance(e, Implies) for e in (*relation_parts, *order_parts))
    print(f"'window left of door': order encoding {implications} implications "
          f"({psi.size['order_choices']} order Choices); forbidding pairs would need "
          f"{forbidden} of the {len(windows) * len(doors)} pairs")


if __name__ == "__main__":
    main()
