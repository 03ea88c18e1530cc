"""What kind of errors a view's estimate makes, against what perfect detectors leave.

The paper's metric counts errors; this says what they are. Every error group
(``compare_structures(...).groups``) is one of: the same notches divided into
other logs (``split``: joints misplaced), notches filled that the truth leaves
empty (``extra``), notches left empty that it fills (``missing``), or both
(``mixed``). For each view, with the pose known, it compares two estimates
with the truth:

* the pipeline's (``estimate_view``, as ``unseeable experiment`` runs it);
* perfect detectors on the features visible in the truth, the pipeline's tie
  policy elsewhere (``benchmarks/oracle.py``): what no detector could remove.

The difference between the two, kind by kind, is what better detections could
win. It then tells the features whose value differs between the truth and the
pipeline's estimate by how the pipeline saw them: hidden in both (the tie
policy's choice), seen in one only (visibility), or seen in both with the
detection on the estimate's side (a wrong call) or on the truth's (outvoted),
by feature kind (end, u, v, w: DESIGN.md §2).

Usage::

    python benchmarks/error_census.py --family validation-halls --scenes 60
    python benchmarks/error_census.py --corpus DIR [--only lodge,hall] [--records F]
"""

from __future__ import annotations

import argparse
import collections
import sys
from pathlib import Path

import numpy as np
from rich.progress import Progress

from unseeable.corpus import load_corpus
from unseeable.domain.features import FeatureKind, feature_index, feature_values
from unseeable.evaluate.metric import ERROR_KINDS, compare_structures
from unseeable.fileio import write_json
from unseeable.parallel import run_in_processes
from unseeable.pipeline import TIE_POLICY, estimate_view
from unseeable.render.view import View
from unseeable.vision.scenes import make_scene, scene_spec

sys.path.insert(0, str(Path(__file__).resolve().parent))
from oracle import oracle_estimate  # noqa: E402  (perfect detectors on visible features)

from vision import FAMILIES  # noqa: E402  (the vision benchmark's held-out families)

#: How the pipeline saw a feature whose value differs between truth and estimate.
SEEN = ("hidden in both", "seen in the truth only", "seen in the estimate only",
        "seen, call on the estimate's side", "seen, call on the truth's side",
        "seen, no reading (½)")


def _feature_group(kind: np.ndarray) -> np.ndarray:
    labels = {k.value: ("end" if k.label.startswith("end") else k.label) for k in FeatureKind}
    return np.array([labels[int(k)] for k in kind], dtype=object)


def differing_features(truth_present: np.ndarray, truth_visible: np.ndarray,
                       estimate_present: np.ndarray, estimate_visible: np.ndarray,
                       priors: np.ndarray) -> np.ndarray:
    """For each feature, the index into :data:`SEEN` of how it was seen, -1 where
    truth and estimate agree on its value.

    Examples
    --------
    >>> t = np.array([True, True, False, True])
    >>> e = np.array([True, False, True, False])
    >>> differing_features(t, np.array([1, 1, 1, 0], bool), e, np.array([1, 1, 1, 0], bool),
    ...                    np.array([0.9, 0.2, 0.3, 0.5])).tolist()
    [-1, 3, 4, 0]
    """
    seen_t, seen_e = truth_visible, estimate_visible
    call_estimate = (priors > 0.5) == estimate_present
    how = np.select(
        [~seen_t & ~seen_e, seen_t & ~seen_e, ~seen_t & seen_e, priors == 0.5, call_estimate],
        [0, 1, 2, 5, 3], default=4)
    return np.where(truth_present != estimate_present, how, -1)


def census_record(task: tuple) -> dict:
    """One view: errors by kind of the pipeline and of perfect detectors, and how the
    pipeline saw the features it got wrong."""
    label, source = task
    if isinstance(source, int):  # a scene of a rendered family
        family = label.split("#")[0]
        scene = make_scene(FAMILIES[family] if family in FAMILIES else scene_spec(family),
                           source)
        view = View(scene.image, scene.camera, scene.extent, pose=scene.pose)
        truth, visible = scene.structure, scene.visible
    else:  # a corpus view (CorpusView)
        view, view_truth = source.load_view(), source.load_truth()
        truth, visible = view_truth.structure, view_truth.visible
    extent = truth.extent
    est = estimate_view(view, use_view_pose=True)
    present = feature_values(extent, truth.occupancy) > 0
    oracle = oracle_estimate(truth, visible, present, 0.95, TIE_POLICY)
    how = differing_features(present, np.asarray(visible),
                             feature_values(extent, est.structure.occupancy) > 0,
                             np.asarray(est.visible), np.asarray(est.priors))
    group = _feature_group(feature_index(extent).kind)
    seen = collections.Counter(f"{SEEN[h]}|{g}" for h, g in zip(how, group) if h >= 0)
    return {"view": label, "logs": len(truth.logs),
            "pipeline": compare_structures(truth, est.structure).errors_by_kind(),
            "perfect": compare_structures(truth, oracle).errors_by_kind(),
            "features": dict(seen)}


def summarise(records: list[dict]) -> list[str]:
    """The census's tables as lines of text."""
    total = {side: {k: sum(r[side][k] for r in records) for k in ERROR_KINDS}
             for side in ("pipeline", "perfect")}
    n = len(records)
    lines = [f"{n} views, pose known; errors summed (per view)",
             f"{'kind':10s} {'pipeline':>16s} {'perfect detectors':>18s} {'difference':>12s}"]
    for k in (*ERROR_KINDS, "all"):
        a = sum(total["pipeline"].values()) if k == "all" else total["pipeline"][k]
        b = sum(total["perfect"].values()) if k == "all" else total["perfect"][k]
        lines.append(f"{k:10s} {a:8d} ({a / n:5.2f}) {b:10d} ({b / n:5.2f}) {a - b:+12d}")
    groups = ("end", "u", "v", "w")
    seen = collections.Counter()
    for r in records:
        seen.update(r["features"])
    lines += ["", "features whose value the estimate gets wrong, by how the pipeline saw them",
              f"{'':36s}" + "".join(f"{g:>7s}" for g in groups)]
    for how in SEEN:
        lines.append(f"{how:36s}" + "".join(f"{seen[f'{how}|{g}']:7d}" for g in groups))
    return lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--corpus", type=Path, help="corpus folder")
    parser.add_argument("--family", help="a rendered scene family instead of a corpus: "
                        f"one of benchmarks/vision.py's ({', '.join(sorted(FAMILIES))}) or a "
                        "training family")
    parser.add_argument("--scenes", type=int, default=60, help="scenes of --family")
    parser.add_argument("--only", default="", help="comma-separated design names")
    parser.add_argument("--workers", type=int, default=2, help="processes")
    parser.add_argument("--records", type=Path, help="also write every view's record here")
    args = parser.parse_args(argv)
    if (args.corpus is None) == (args.family is None):
        parser.error("give one of --corpus and --family")
    if args.scenes < 1 or args.workers < 1:
        parser.error("--scenes and --workers must be at least 1")
    if args.family is not None:
        tasks = [(f"{args.family}#{n}", n) for n in range(args.scenes)]
    else:
        only = {n for n in args.only.split(",") if n}
        tasks = [(f"{item.name}@{view.angle:g}", view) for item in load_corpus(args.corpus)
                 if not only or item.name in only
                 for view in sorted(item.views, key=lambda v: v.angle)]
        if not tasks:
            parser.error(f"no views under {args.corpus}"
                         + (f" for {sorted(only)}" if only else ""))
    records = []
    with Progress(transient=True) as progress:
        bar = progress.add_task("estimating", total=len(tasks))
        for record in run_in_processes(census_record, tasks, workers=args.workers):
            records.append(record)
            progress.advance(bar)
    print("\n".join(summarise(records)))
    if args.records is not None:
        write_json(args.records, records)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
