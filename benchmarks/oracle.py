"""What one view allows at best: errors with perfect detectors on the visible features.

For every view of a corpus (``unseeable corpus build``), the evidence is the
truth on the features visible in the truth (p = 0.95 for present, 0.05 for
absent) and ½ elsewhere; the estimate is the MAP with the pipeline's tie
policy (``--ties`` for another). Its errors against the truth are what no
detector can remove from that single view: logs hidden from the camera, and
which member of a tie of hidden completions was kept. Comparing them with
``unseeable experiment visibility`` tells how much of the error is the
detectors' and how much is unseeability.

With ``--family F --scenes N`` it measures scenes of a rendered family
instead (the calibration's training families and the vision benchmark's,
``benchmarks/vision.py``): structures no design of the corpus made, random
grammar samples among them, to tell a tie policy's worth beyond our designs.

Usage::

    python benchmarks/oracle.py --corpus DIR [--only lodge,hall] [--ties emptiest]
    python benchmarks/oracle.py --family validation-halls --scenes 60 [--ties emptiest]
"""

from __future__ import annotations

import argparse
import collections
import sys
from pathlib import Path

import numpy as np

from unseeable.corpus import load_corpus
from unseeable.domain import Evidence
from unseeable.evaluate.metric import count_errors
from unseeable.pipeline import TIE_POLICY
from unseeable.render import load_truth
from unseeable.solve import TIES, StructureSolver
from unseeable.vision.scenes import make_scene, scene_spec

sys.path.insert(0, str(Path(__file__).resolve().parent))
from vision import FAMILIES  # noqa: E402  (the vision benchmark's held-out families)


def oracle_estimate(structure, visible, present, accuracy: float, ties: str):
    """The MAP estimate under perfect detections on the visible features."""
    extent = structure.extent
    p = np.where(visible, np.where(present, accuracy, 1 - accuracy), 0.5)
    # A fresh solver per view, as the pipeline makes: which member of a tie a search
    # keeps depends on what the solver solved before.
    return StructureSolver(extent, ties=ties).solve(Evidence(extent, p), time_limit=60).structure


def oracle_errors(structure, visible, present, accuracy: float, ties: str) -> int:
    """Errors of the MAP estimate under perfect detections on the visible features."""
    return count_errors(structure, oracle_estimate(structure, visible, present, accuracy, ties))


def _family(name: str, scenes: int, accuracy: float, ties: str) -> int:
    spec = FAMILIES[name] if name in FAMILIES else scene_spec(name)
    errors = np.array([oracle_errors(s.structure, s.visible, s.present > 0, accuracy, ties)
                       for s in (make_scene(spec, n) for n in range(scenes))])
    print(f"Perfect detectors on visible features, {scenes} scenes of {name}, ties: {ties}")
    print(f"mean {errors.mean():.2f}, sum {errors.sum()}, max {errors.max()}, "
          f"share <= 12: {np.mean(errors <= 12):.3f}, exact: {np.mean(errors == 0):.3f}")
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--corpus", type=Path, help="corpus folder")
    parser.add_argument("--family", help="a rendered scene family instead of a corpus: "
                        "train, train-walls, train-tall, train-looks, train-halls, or one "
                        f"of benchmarks/vision.py's ({', '.join(sorted(FAMILIES))})")
    parser.add_argument("--scenes", type=int, default=60, help="scenes of --family")
    parser.add_argument("--accuracy", type=float, default=0.95,
                        help="probability given to the true value of a visible feature")
    parser.add_argument("--only", default="", help="comma-separated design names")
    parser.add_argument("--ties", choices=TIES, default=TIE_POLICY,
                        help=f"tie policy (default: the pipeline's, {TIE_POLICY})")
    args = parser.parse_args(argv)
    if (args.corpus is None) == (args.family is None):
        parser.error("give one of --corpus and --family")
    if args.family is not None:
        return _family(args.family, args.scenes, args.accuracy, args.ties)
    only = {n for n in args.only.split(",") if n}
    # The manifest's order: designs as listed, each view by station angle.
    views = [(item.name, view) for item in load_corpus(args.corpus)
             if not only or item.name in only
             for view in sorted(item.views, key=lambda v: v.angle)]
    if not views:
        parser.error(f"no views under {args.corpus}" + (f" for {sorted(only)}" if only else ""))
    by_design: dict[str, list[str]] = collections.defaultdict(list)
    errors = []
    for name, view in views:
        truth = load_truth(view.truth)
        errors.append(oracle_errors(truth.structure, truth.visible, truth.present,
                                     args.accuracy, args.ties))
        by_design[name].append(f"{view.angle:g}°: {errors[-1]}")
    errors = np.array(errors)
    print(f"Perfect detectors on visible features, {len(errors)} views of {len(by_design)} "
          f"designs, ties: {args.ties}")
    print(f"{'design':24s} errors per view (station angle: errors)")
    for name, v in by_design.items():
        print(f"{name:24s} {', '.join(v)}")
    print(f"mean {errors.mean():.2f}, max {errors.max()}, "
          f"share <= 12: {np.mean(errors <= 12):.3f}, exact: {np.mean(errors == 0):.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
