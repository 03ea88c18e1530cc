"""Between the detectors and the oracle: corpus errors if the detectors were right more often.

For every view of a corpus (``unseeable corpus build``), the pipeline
estimates the structure at the view's recorded pose with automatic
visibility (as ``unseeable experiment visibility --known-pose`` does), but
each wrong call of the detectors on a feature visible in the truth (p > ½
on an absent feature, p ≤ ½ on a present one) is put right with probability
``R`` (its prior mirrored, ``p → 1 − p``: a call as sure, now right), the
same features at every step of the fixpoint. ``R = 0`` is the shipped
pipeline, ``R = 1`` about ``benchmarks/oracle.py``'s perfect detectors (with
the detectors' own confidences). It prints, for each ``R``, the detectors'
accuracy on visible features that results, the mean errors and the share of
images within the paper's 12: how much better the detectors must be for a
given error goal.

Usage::

    python benchmarks/better_detectors.py --corpus DIR [--rates 0,0.3,0.6] [--workers 2]
"""

from __future__ import annotations

import argparse
import zlib
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from unseeable.domain.features import feature_values
from unseeable.evaluate.metric import count_errors
from unseeable.pipeline import estimate_view
from unseeable.render.view import load_truth, load_view
from unseeable.vision import default_calibration
from unseeable.vision.calibration import Calibration


@dataclass(frozen=True)
class CorrectedCalibration(Calibration):
    """The shipped calibration, with the wrong calls on the ``fixed`` features mirrored."""

    present: np.ndarray | None = None
    fixed: np.ndarray | None = None

    def probabilities(self, scores, *, behind=None):
        p = super().probabilities(scores, behind=behind)
        wrong = self.fixed & scores.judged & ((p > 0.5) != self.present)
        return np.where(wrong, 1.0 - p, p)


def view_result(args: tuple[Path, float]) -> tuple[int, int, int]:
    """Errors of one view, and the right and judged visible calls behind them."""
    truth_file, rate = args
    view = load_view(truth_file.with_name(truth_file.name.replace(".truth.json", ".json")))
    truth = load_truth(truth_file)
    shown = truth.shown
    present = feature_values(shown.extent, shown.occupancy) > 0
    visible = np.asarray(truth.visible, bool)
    # The same draw for a view at every rate: a higher rate fixes a superset.
    draw = np.random.default_rng(zlib.crc32(str(truth_file.resolve()).encode())).random(
        len(present))
    base = default_calibration()
    cal = CorrectedCalibration(base.models, base.clip, base.info, base.pose_quality,
                               base.context_models, present=present,
                               fixed=visible & (draw < rate))
    est = estimate_view(view, use_view_pose=True, confidence=False, calibration=cal)
    p = np.asarray(est.priors, float)
    judged = visible & (p != 0.5)
    right = int(((p > 0.5) == present)[judged].sum())
    errors = count_errors(shown, est.structure, truth_pose=truth.pose, estimate_pose=est.pose)
    return errors, right, int(judged.sum())


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--corpus", type=Path, required=True, help="corpus folder")
    parser.add_argument("--rates", default="0,0.3,0.6",
                        help="comma-separated shares R of wrong calls put right")
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args(argv)
    files = sorted(args.corpus.glob("*/view*.truth.json"))
    if not files:
        parser.error(f"no view*.truth.json files under {args.corpus}")
    try:
        rates = [float(r) for r in args.rates.split(",")]
    except ValueError:
        parser.error(f"--rates must be numbers in [0, 1], got {args.rates!r}")
    if not all(0.0 <= r <= 1.0 for r in rates):
        parser.error(f"--rates must be numbers in [0, 1], got {args.rates!r}")
    if args.workers < 1:
        parser.error(f"--workers must be at least 1, got {args.workers}")
    print(f"{len(files)} views, known pose, automatic visibility")
    print(f"{'R':>5s} {'detectors right':>16s} {'mean errors':>12s} {'<= 12':>7s} {'max':>5s}")
    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        for rate in rates:
            rows = list(pool.map(view_result, [(f, rate) for f in files], chunksize=4))
            errors = np.array([r[0] for r in rows])
            right = sum(r[1] for r in rows) / max(sum(r[2] for r in rows), 1)
            print(f"{rate:5.2f} {100 * right:15.1f}% {errors.mean():12.2f} "
                  f"{100 * np.mean(errors <= 12):6.1f}% {errors.max():5d}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
