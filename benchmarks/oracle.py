"""What one view allows at best: errors with perfect detectors on the visible features.

For every view of a corpus (``unseeable corpus build``), the evidence is the
truth on the features visible in the truth (p = 0.95 for present, 0.05 for
absent) and ½ elsewhere; the estimate is the MAP with the pipeline's tie
policy (the emptiest member of a tie). Its errors against the truth are what
no detector can remove from that single view: logs hidden from the camera.
Comparing them with ``unseeable experiment visibility`` tells how much of
the error is the detectors' and how much is unseeability.

Usage::

    python benchmarks/oracle.py --corpus DIR
"""

from __future__ import annotations

import argparse
import collections
from pathlib import Path

import numpy as np

from unseeable.domain import Evidence
from unseeable.evaluate.metric import count_errors
from unseeable.pipeline import TIES
from unseeable.render import load_truth
from unseeable.solve import StructureSolver


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--corpus", type=Path, required=True, help="corpus folder")
    parser.add_argument("--accuracy", type=float, default=0.95,
                        help="probability given to the true value of a visible feature")
    args = parser.parse_args(argv)
    files = sorted(args.corpus.glob("*/view*.truth.json"))
    if not files:
        parser.error(f"no view*.truth.json files under {args.corpus}")
    by_design: dict[str, list[int]] = collections.defaultdict(list)
    solvers: dict = {}
    for f in files:
        truth = load_truth(f)
        extent = truth.structure.extent
        p = np.where(truth.visible, np.where(truth.present, args.accuracy, 1 - args.accuracy),
                     0.5)
        solver = solvers.setdefault(extent, StructureSolver(extent, ties=TIES))
        result = solver.solve(Evidence(extent, p), time_limit=60)
        by_design[f.parent.name].append(count_errors(truth.structure, result.structure))
    errors = np.array([e for v in by_design.values() for e in v])
    print(f"Perfect detectors on visible features, {len(errors)} views of {len(by_design)} designs")
    print(f"{'design':24s} errors per view")
    for name, v in sorted(by_design.items()):
        print(f"{name:24s} {v}")
    print(f"mean {errors.mean():.2f}, max {errors.max()}, "
          f"share <= 12: {np.mean(errors <= 12):.3f}, exact: {np.mean(errors == 0):.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
