"""Would trusting the detectors less (or more) help the estimate? Tempered priors on a corpus.

For every view of a corpus (``unseeable corpus build``), the detectors judge
the features at the recorded pose (polished on the image, as the pipeline
does); with the ground-truth ("manual") visibility, each visible judged
feature gets its calibrated prior tempered in log-odds,
``p' = σ(τ · logit p)``, the others ½; the MAP structure (the pipeline's tie
policy) is compared with the truth. ``τ < 1`` trusts the detectors less and
lets the grammar overrule more of them; ``τ = 1`` is the pipeline.

Usage::

    python benchmarks/trust.py --corpus DIR --temperatures 0.5,0.7,1,1.4
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from unseeable.domain import Evidence
from unseeable.evaluate.metric import count_errors
from unseeable.pipeline import TIE_POLICY
from unseeable.render.view import load_truth, load_view
from unseeable.solve import StructureSolver
from unseeable.vision import default_calibration, detect_features


def tempered(p: np.ndarray, temperature: float) -> np.ndarray:
    """``σ(τ · logit p)`` for priors ``p`` in (0, 1)."""
    p = np.clip(np.asarray(p, float), 1e-6, 1 - 1e-6)
    return 1.0 / (1.0 + np.exp(-temperature * np.log(p / (1 - p))))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--corpus", type=Path, required=True, help="corpus folder")
    parser.add_argument("--temperatures", default="0.5,0.7,1,1.4",
                        help="comma-separated log-odds factors τ")
    args = parser.parse_args(argv)
    temperatures = [float(t) for t in args.temperatures.split(",")]
    files = sorted(args.corpus.glob("*/view*.truth.json"))
    if not files:
        parser.error(f"no view*.truth.json files under {args.corpus}")
    calibration = default_calibration()
    errors = {t: [] for t in temperatures}
    solvers: dict = {}
    for f in files:
        view = load_view(f.with_name(f.name.replace(".truth.json", ".json")))
        truth = load_truth(f)
        det = detect_features(view.image, view.camera, truth.pose, view.extent,
                              calibration=calibration)
        extent = truth.structure.extent
        solver = solvers.setdefault(extent, StructureSolver(extent, ties=TIE_POLICY))
        seen = truth.visible & det.judged
        for t in temperatures:
            evidence = Evidence(extent, np.where(seen, tempered(det.p, t), 0.5))
            result = solver.solve(evidence, time_limit=60)
            errors[t].append(count_errors(truth.shown, result.structure,
                                          truth_pose=truth.pose, estimate_pose=det.pose))
    print(f"Tempered detector priors, manual visibility, {len(files)} views")
    print(f"{'tau':>5s} {'mean errors':>12s} {'<= 12':>7s} {'max':>5s}")
    for t in temperatures:
        e = np.array(errors[t])
        print(f"{t:5.2f} {e.mean():12.2f} {np.mean(e <= 12):7.3f} {e.max():5d}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
