"""Time of a joint estimate from several photographs, and what each added view costs.

For one corpus structure (the 114-log lodge by default), the structure is estimated
jointly from its first 1, 2, …, 5 views (stations in corpus order, the pose found
from the images unless ``--known-pose``, one table frame), one estimate at a time,
each timed twice after an untimed warm-up; the script prints per number of views
the median wall time, the stages' times and the errors against the truth.

Run: ``python benchmarks/views_time.py --corpus DIR [--name lodge] [--known-pose]
[--repeats 2]`` with ``DIR`` from ``unseeable corpus build``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.table import Table

from unseeable.corpus.build import load_corpus
from unseeable.evaluate.metric import compare_structures
from unseeable.pipeline import EstimateSettings, Observation, estimate


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--corpus", type=Path, required=True)
    parser.add_argument("--name", default="lodge")
    parser.add_argument("--known-pose", action="store_true")
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--threads", type=int, default=2,
                        help="threads of the pose search (as `unseeable estimate`)")
    args = parser.parse_args(argv)
    console = Console()
    item = load_corpus(args.corpus)[args.name]
    views = [v.load_view() for v in item.views]
    truth = item.views[0].load_truth()
    settings = EstimateSettings.from_options(threads=args.threads)

    def run(n: int):
        obs = [Observation.of(v, use_recorded_pose=args.known_pose, source=str(p.view))
               for v, p in zip(views[:n], item.views)]
        t0 = time.perf_counter()
        est = estimate(obs, settings)
        return time.perf_counter() - t0, est

    run(1)  # loads the numba kernels and the calibration
    table = Table(title=f"joint estimate of {args.name} ({len(item.structure.logs)} logs), "
                        f"pose {'known' if args.known_pose else 'estimated'}")
    for col in ("views", "median s", "added view s", "pose s", "evidence s", "structure s",
                "confidence s", "errors", "confident"):
        table.add_column(col, justify="right")
    before = 0.0
    for n in range(1, len(views) + 1):
        runs = [run(n) for _ in range(args.repeats)]
        seconds = float(np.median([r[0] for r in runs]))
        est = runs[-1][1]
        errors = compare_structures(truth.structure, est.structure, truth_pose=truth.pose,
                                    estimate_pose=est.pose, on_misaligned="count").errors
        t = est.timings
        table.add_row(str(n), f"{seconds:.2f}", f"{seconds - before:+.2f}" if n > 1 else "",
                      f"{t.get('pose_s', 0):.2f}", f"{t.get('evidence_s', 0):.2f}",
                      f"{t.get('structure_s', 0):.2f}", f"{t.get('confidence_s', 0):.2f}",
                      str(errors), str(est.confident))
        before = seconds
    console.print(table)
    return 0


if __name__ == "__main__":
    sys.exit(main())
