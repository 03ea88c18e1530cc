"""Which wrong detections cost a view its errors, one by one.

For each view asked for (``NAME@ANGLE`` of a corpus built by ``unseeable
corpus build``), the pipeline estimates the structure at the view's recorded
pose (as ``unseeable experiment visibility --known-pose`` does). Its final
priors — the detections (shifted to agree with the estimate, as the pipeline
uses them), with ½ on the features it found occluded — are
then solved again (the MAP with the pipeline's tie policy and structure
prior, ``pipeline.structure_prior``: the joint prior on the joints it sees, the
stacked-joint and the unsupported-notch priors; no further visibility rounds) as
they are, and once per *wrong call*: a feature visible
in the truth whose prior is on the wrong side of ½ (by more than 0.05), set
to the truth (p = 0.95 present, 0.05 absent). It prints

* the errors of the pipeline and of the re-solve (they can differ by a log or
  two: the fixpoint's last solve was warm-started and its ties settled with
  other rounds' priors);
* every wrong call whose correction alone changes the errors (negative: it
  cost errors), with its kind, grid position, truth and prior;
* the errors with all wrong calls corrected, with only those that cost
  errors corrected, and with those set to ½ instead (what a detector that
  merely abstained there would give).

* the estimate's and the truth's log-probabilities, each under the
  visibility and the (context, shifted) priors it implies itself, an image
  line's detection counted once as the pipeline counts it
  (``Observation.log_probability_of``), plus the structure prior's term
  (its joint prior on the joints that visibility sees, and the other two):
  when the estimate scores higher,
  its errors are the evidence's — no better search under these detections
  would find the truth; when the truth scores higher, the fixpoint stopped
  short of a better account.

What it tells: whether a view's errors come from a few decisive detections
(and which), from many small ones, or from what no detection of this view
decides (the hidden parts: compare ``benchmarks/oracle.py``), and whether
the search or the evidence is to blame.

Usage::

    python benchmarks/error_blame.py --corpus DIR lodge@120 lodge@210
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from unseeable.domain import Evidence, LogGeometry
from unseeable.domain.features import FeatureKind, feature_index, feature_values
from unseeable.evaluate.metric import count_errors
from unseeable.grammar import log_probability
from unseeable.pipeline import TIE_POLICY, estimate_view, line_aliases, structure_prior
from unseeable.render.view import load_truth, load_view
from unseeable.solve import StructureSolver
from unseeable.visibility.loop import DEFAULT_THRESHOLD, Observation
from unseeable.vision import detect_features


def blame_view(view_file: Path, truth_file: Path, *, margin: float = 0.05) -> dict:
    """The pipeline's errors on one view and what correcting each wrong call does."""
    view, truth = load_view(view_file), load_truth(truth_file)
    estimate = estimate_view(view, use_view_pose=True)
    shown = truth.shown
    extent = shown.extent
    p = np.asarray(estimate.priors, dtype=float)
    present = feature_values(extent, shown.occupancy).astype(bool)
    visible = np.asarray(truth.visible, dtype=bool)
    index = feature_index(extent)
    # The pipeline's structure prior, on the joints the estimate's final visibility sees.
    prior_of = structure_prior(extent)
    prior = prior_of(estimate.visible) if prior_of else ()

    def errors(priors: np.ndarray) -> int:
        # A fresh solver each time, as the pipeline makes one per view: which member of a
        # hidden tie a search keeps can depend on what the solver solved before.
        result = StructureSolver(extent, ties=TIE_POLICY).solve(
            [Evidence(extent, priors), *prior], time_limit=60)
        return count_errors(shown, result.structure)

    right = np.where(present, 0.95, 0.05)
    wrong = np.flatnonzero(visible & ((p > 0.5) != present) & (np.abs(p - 0.5) > margin))
    base = errors(p)
    single = []
    for f in wrong:
        q = p.copy()
        q[f] = right[f]
        change = errors(q) - base
        if change:
            single.append((change, f))
    single.sort()

    def corrected(features: list[int] | np.ndarray, value: np.ndarray | float) -> int:
        q = p.copy()
        q[features] = value if np.isscalar(value) else value[features]
        return errors(q)

    costly = [f for change, f in single if change < 0]
    # The detections as the pipeline made them at the view's pose, to score any structure
    # under the visibility and context it implies itself.
    det = detect_features(view.image, view.camera, view.pose, extent)
    seen_as = Observation(det.p, view.camera.centre, estimate.pose, judged=det.judged,
                          context_priors=det.priors_given if det.has_context else None,
                          clip=det.calibration.clip,
                          line_aliases=line_aliases(det, view.camera))
    shift = float(estimate.extra.get("presence_shift", 0.0))
    return {
        "self_consistent": {
            name: seen_as.log_probability_of(s, shift=shift) + (log_probability(
                prior_of(seen_as.visibility(s, geometry=LogGeometry(),
                                            threshold=DEFAULT_THRESHOLD)), s) if prior_of else 0)
            for name, s in (("estimate", estimate.structure), ("truth", shown))},
        "pipeline": count_errors(shown, estimate.structure),
        "resolved": base,
        "wrong_calls": len(wrong),
        "single": [(change, FeatureKind(index.kind[f]).label, tuple(int(x) for x in index.at[f]),
                    bool(present[f]), float(p[f])) for change, f in single],
        "all_corrected": corrected(wrong, right),
        "costly_corrected": corrected(costly, right) if costly else base,
        "costly_abstained": corrected(costly, 0.5) if costly else base,
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--corpus", type=Path, required=True, help="corpus folder")
    parser.add_argument("views", nargs="+", help="views as NAME@ANGLE, e.g. lodge@120")
    args = parser.parse_args(argv)
    for spec in args.views:
        name, sep, angle = spec.partition("@")
        view_file = args.corpus / name / f"view{angle}.json"
        if not sep or not view_file.is_file():
            parser.error(f"{spec}: no view {view_file} (give NAME@ANGLE of a corpus view)")
        r = blame_view(view_file, view_file.with_name(f"view{angle}.truth.json"))
        print(f"{name} at {angle}°: {r['pipeline']} errors (re-solved: {r['resolved']}); "
              f"{r['wrong_calls']} wrong calls on visible features")
        for change, kind, at, is_present, prior in r["single"]:
            print(f"  {change:+d}  {kind} {at}  truth {'present' if is_present else 'absent'}, "
                  f"p {prior:.2f}")
        print(f"  all wrong calls corrected: {r['all_corrected']}; those that cost errors "
              f"corrected: {r['costly_corrected']}, left at ½: {r['costly_abstained']}")
        est, tru = r["self_consistent"]["estimate"], r["self_consistent"]["truth"]
        verdict = ("the detections prefer the estimate: its errors are the evidence's"
                   if est >= tru else "the truth is the better account: the fixpoint stopped "
                   "short of it")
        print(f"  log-probability as each implies itself: estimate {est:.2f}, truth {tru:.2f} "
              f"nats; {verdict}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
