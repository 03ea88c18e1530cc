"""Time to parse and compile a description (prints a table).

For every corpus design with a door, window or wall: its true description
(`describe`), parsed and compiled to the solver's constraints on the design's
extent, and the longest sentences the language allows on the lodge's extent. Each
figure is the median of ``--repeats`` runs in a fresh cache state (the placement
and lateral-rank caches cleared), so it is what a user's first sentence costs.

    python benchmarks/language.py [--repeats 5]
"""

from __future__ import annotations

import argparse
import statistics
import time

from unseeable.corpus import list_designs, load_design
from unseeable.language import compile_description, describe, parse
from unseeable.language.relations import entity_placements

#: Sentences that use every noun and relation at once.
LONG = [
    ["window left of and perpendicular to door", "door right of and coplanar to wall",
     "window left of wall"],
    ["a door and a window and a wall", "window right of and coplanar to door",
     "wall perpendicular to door and left of window"],
]


def _cold() -> None:
    from unseeable.grammar import shapes

    entity_placements.cache_clear()
    shapes._placements.cache_clear()
    shapes._compiled.cache_clear()
    shapes.conditions.cache_clear()
    shapes._literal_arrays.cache_clear()


def _time(sentences: list[str], extent, viewpoint, repeats: int) -> tuple[float, int]:
    times = []
    for _ in range(repeats):
        _cold()
        t0 = time.perf_counter()
        psi = compile_description(parse(sentences), extent, viewpoint=viewpoint)
        times.append(time.perf_counter() - t0)
    return statistics.median(times), psi.size["selectors"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    rows = []
    for entry in list_designs():
        sentences = describe(entry.structure)
        if sentences:
            seconds, selectors = _time(sentences, entry.structure.extent, None, args.repeats)
            rows.append((entry.name, "x".join(map(str, entry.structure.extent.shape)),
                         len(sentences), selectors, seconds))
    lodge = load_design("lodge")
    for n, sentences in enumerate(LONG, 1):
        seconds, selectors = _time(sentences, lodge.structure.extent, None, args.repeats)
        rows.append((f"lodge, long description {n}",
                     "x".join(map(str, lodge.structure.extent.shape)), len(sentences),
                     selectors, seconds))
    print("Parse and compile a description, cold caches (s, median of "
          f"{args.repeats})")
    print(f"{'structure':32s} {'extent':8s} {'sentences':>9s} {'selectors':>9s} "
          f"{'seconds':>8s}")
    for name, extent, count, selectors, seconds in rows:
        print(f"{name:32s} {extent:8s} {count:9d} {selectors:9d} {seconds:8.3f}")
    print(f"max {max(r[4] for r in rows):.3f} s")


if __name__ == "__main__":
    main()
