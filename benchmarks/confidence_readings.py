"""The reading test against the δ* test on scene families: false positives and negatives.

For each scene of the chosen families (``benchmarks/vision.py``'s ``FAMILIES``; renders
are cached) the shipped estimator runs on one photograph (pose known, or estimated with
``--estimated-pose``), and the record keeps, besides its errors and the δ* test's
verdict: the estimation tolerance, the reading tolerance
(:func:`unseeable.confidence.readings.reading_tolerance`: the largest log-odds shift of
every seen feature against the estimate that it survives with the unseen ones at δ*),
and every feature on which the estimate and the truth differ (seen or not, its prior).
``--summary`` prints, for each reading shift s*, the false positives (confident and
wrong) and false negatives (not confident and exact) of the δ* test with the reading test
added.

Choose s* on the development families (``validation``, ``seamed-tables-dev``,
``defocus-dev``) only, then report the held-out ones at that s*.

Usage::

    nice -n 10 python benchmarks/confidence_readings.py --family validation \
        seamed-tables-dev defocus-dev --scenes 40 --out /tmp/dev.json
    python benchmarks/confidence_readings.py --summary /tmp/dev.json
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from unseeable.errors import UnseeableError

sys.path.insert(0, str(Path(__file__).resolve().parent))
from vision import FAMILIES  # noqa: E402

SHIFTS = (0.0, 0.25, 0.5, 0.75, 1.0, 1.25, 1.5, 2.0, 2.5, 3.0)
TEMPERS = (0.1, 0.2, 0.3, 0.4, 0.5)
ERASES = (0.5, 0.75, 1.0, 1.25, 1.5, 2.0, 2.5, 3.0)


def differing_features(est, truth, truth_pose) -> list[dict]:
    """The features on which the estimate and the truth differ, matched physically."""
    from unseeable.domain.features import FeatureKind, feature_index, feature_values
    from unseeable.evaluate.metric import match_features

    s = est.structure
    ext = s.extent
    ours = feature_values(ext, s.occupancy)
    match = match_features(ext, est.pose, truth.extent, truth_pose)
    truth_values = feature_values(truth.extent, truth.occupancy)
    theirs = np.where(match >= 0, truth_values[np.maximum(match, 0)], False)
    idx = feature_index(ext)
    out = []
    for n in np.flatnonzero(ours != theirs):
        views = []
        for v in est.views:
            views.append({"visible": bool(v.visible[n]), "p": round(float(v.priors[n]), 3),
                          "removed_from_layer": v.removed_from_layer})
        out.append({"feature": FeatureKind(int(idx.kind[n])).label,
                    "at": idx.at[n].tolist(), "estimate": bool(ours[n]),
                    "truth": bool(theirs[n]), "views": views})
    return out


def judge(est, *, delta_star: float = 0.2) -> dict:
    """The reading tolerance of an estimate (with the unseen features at δ*)."""
    from unseeable.confidence.readings import reading_tolerance, seen_support
    from unseeable.domain.features import feature_index
    from unseeable.grammar import EvidenceTerm

    m = est.model
    evidence = [t for t in m.terms if isinstance(t, EvidenceTerm)]
    layer = feature_index(est.structure.extent).at[:, 1]
    seen = np.zeros(len(est.views[0].priors), dtype=bool)
    weights = np.zeros(len(seen))
    for t, v in zip(evidence, est.views):
        # As the pipeline's occluded_features: visible and judged by the detectors.
        looked = v.visible & v.detection.judged
        if v.removed_from_layer is not None:
            looked = looked & (layer < v.removed_from_layer)
        seen |= looked
        p = np.clip(t.evidence.p, 1e-6, 1 - 1e-6)
        weights += np.where(looked, np.abs(np.log(p / (1 - p))), 0.0)
    if est.confidence is not None and int((~seen).sum()) != est.confidence.occluded:
        print(f"warning: {int((~seen).sum())} unseen here, {est.confidence.occluded} in the "
              "pipeline", file=sys.stderr)
    tol, resolves = reading_tolerance(m.solver, m.terms, est.result, ~seen, delta=delta_star)
    temper, more = reading_tolerance(m.solver, m.terms, est.result, ~seen, delta=delta_star,
                                     weights=weights, largest=1.0, resolution=0.005)
    # The library's caps (the views' readings for the estimate), as the pipeline uses them.
    caps = seen_support(est.structure, m.terms, ~seen)
    erase, more2 = reading_tolerance(m.solver, m.terms, est.result, ~seen, delta=delta_star,
                                     caps=caps)
    return {"reading_tolerance": tol, "reading_resolves": resolves + more + more2,
            "temper_tolerance": temper, "erase_tolerance": erase, "seen": int(seen.sum())}


def scene_record(task: tuple[str, int, bool]) -> dict:
    from unseeable.evaluate.metric import count_errors
    from unseeable.pipeline import EstimateSettings, estimate_view
    from unseeable.render.view import View
    from unseeable.training.scenes import make_scene

    family, n, known_pose = task
    scene = make_scene(FAMILIES[family], n)
    view = View(scene.image, scene.camera, scene.extent,
                pose=scene.pose if known_pose else None)
    record = {"family": family, "scene": n, "known_pose": known_pose}
    settings = EstimateSettings.from_options(threads=1, strict=True)
    try:
        est = estimate_view(view, settings, use_recorded_pose=known_pose)
    except UnseeableError as err:
        return {**record, "failed": str(err)}
    if est.structure is None:
        return {**record, "failed": "no structure"}
    errors = count_errors(scene.structure, est.structure, truth_pose=scene.pose,
                          estimate_pose=est.pose, on_misaligned="count")
    record.update({"failed": None, "errors": errors, "confident": bool(est.confident),
                   "delta_test": bool(est.confidence.confident),
                   "tolerance": est.confidence.tolerance,
                   "in_doubt": any(v.in_doubt for v in est.views)})
    record.update(judge(est))
    v = est.views[0]
    if known_pose and est.structure.extent == scene.extent:
        # The calibrated readings of the seen features against the truth (reliability).
        seen = v.visible & v.detection.judged
        record["readings"] = [[round(float(p), 3), int(t)] for p, t in
                              zip(np.asarray(v.priors)[seen], (scene.present > 0)[seen])]
    if errors:
        try:
            record["differ"] = differing_features(est, scene.structure, scene.pose)
        except UnseeableError:
            record["differ"] = None
    return record


def corpus_records(corpus_dir: Path, searches: Path | None) -> list[dict]:
    """Every corpus photograph estimated as ``unseeable experiment`` does (pose
    estimated, its searches read from ``searches``), with the reading tolerances."""
    from unseeable.corpus.build import load_corpus
    from unseeable.evaluate.experiments import EvaluationSettings
    from unseeable.evaluate.metric import compare_structures
    from unseeable.pipeline import Observation, estimate
    from unseeable.pipeline.search_cache import pose_searches_cached
    from unseeable.render.view import load_truth, load_view

    settings = EvaluationSettings()
    records = []
    with pose_searches_cached(searches):
        for item in load_corpus(corpus_dir):
            for v in item.views:
                record = {"family": "corpus", "scene": f"{item.name}@{v.angle:g}",
                          "known_pose": False}
                view = load_view(v.view)
                truth = load_truth(v.truth)
                try:
                    est = estimate([Observation.of(view, use_recorded_pose=False,
                                                   source=v.view)], settings.estimate)
                except UnseeableError as err:
                    records.append({**record, "failed": str(err)})
                    continue
                if est.structure is None:
                    records.append({**record, "failed": "no structure"})
                    continue
                errors = compare_structures(truth.shown, est.structure, on_misaligned="count",
                                            truth_pose=truth.pose,
                                            estimate_pose=est.pose).errors
                record.update({"failed": None, "errors": errors,
                               "confident": bool(est.confident),
                               "delta_test": bool(est.confidence.confident),
                               "tolerance": est.confidence.tolerance})
                record.update(judge(est))
                records.append(record)
                print(json.dumps({k: record[k] for k in ("scene", "errors", "confident",
                                                         "erase_tolerance")}), flush=True)
    return records


def summary(records: list[dict]) -> str:
    lines = []
    groups: dict[tuple[str, bool], list[dict]] = {}
    for r in records:
        groups.setdefault((r["family"], r["known_pose"]), []).append(r)
    for (family, known), rs in sorted(groups.items()):
        ok = [r for r in rs if r["failed"] is None]
        exact = np.array([r["errors"] == 0 for r in ok])
        base = np.array([r["confident"] for r in ok])
        tol = np.array([r["reading_tolerance"] for r in ok])
        cells = [f"base FP {int(np.sum(base & ~exact))}/FN {int(np.sum(~base & exact))}"]
        for s in SHIFTS:
            c = base & (tol >= s)
            cells.append(f"s={s:g}: {int(np.sum(c & ~exact))}/{int(np.sum(~c & exact))}")
        if all("temper_tolerance" in r for r in ok):
            temper = np.array([r["temper_tolerance"] for r in ok])
            for t in TEMPERS:
                c = base & (temper >= t)
                cells.append(f"t={t:g}: {int(np.sum(c & ~exact))}/{int(np.sum(~c & exact))}")
        if all("erase_tolerance" in r for r in ok):
            erase = np.array([r["erase_tolerance"] for r in ok])
            for t in ERASES:
                c = base & (erase >= t)
                cells.append(f"e={t:g}: {int(np.sum(c & ~exact))}/{int(np.sum(~c & exact))}")
        mode = "known" if known else "estimated"
        lines.append(f"{family} ({mode}, {len(ok)} ok, {int(exact.sum())} exact): "
                     + ", ".join(cells))
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--family", nargs="+", default=["validation"], choices=sorted(FAMILIES))
    parser.add_argument("--scenes", type=int, default=40)
    parser.add_argument("--estimated-pose", action="store_true")
    parser.add_argument("--out", type=Path)
    parser.add_argument("--summary", type=Path, nargs="+",
                        help="print the FP/FN table of these record files and stop")
    parser.add_argument("--corpus", type=Path, help="a rendered corpus instead of families")
    parser.add_argument("--searches", type=Path,
                        help="the corpus's pose-search cache folder (with --corpus)")
    args = parser.parse_args(argv)
    if args.corpus is not None:
        records = corpus_records(args.corpus, args.searches)
        if args.out is not None:
            args.out.write_text(json.dumps(records, indent=1))
        print(summary(records))
        return 0
    if args.summary:
        records = [r for f in args.summary for r in json.loads(f.read_text())]
        print(summary(records))
        return 0
    records = []
    for family in args.family:
        for n in range(args.scenes):
            r = scene_record((family, n, not args.estimated_pose))
            records.append(r)
            if r["failed"] is None and (r["errors"] or not r["confident"]):
                print(json.dumps({k: r[k] for k in ("family", "scene", "errors", "confident",
                                                    "tolerance", "reading_tolerance")}),
                      flush=True)
            if args.out is not None:
                args.out.write_text(json.dumps(records, indent=1))
    print(summary(records))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
