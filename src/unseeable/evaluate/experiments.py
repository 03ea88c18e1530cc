"""The paper's experiments on a rendered corpus (paper §6).

* Visibility: error histograms of structure estimation with ground-truth
  ("manual") visibility and with automatic visibility (the fixpoint).
* Confidence: false positives (confident, wrong) and false negatives (not
  confident, right) of the δ* test (the paper's) and of the shipped test (δ* and
  the reading test), and the distribution of the estimation tolerance δ.

Both read one per-image evaluation, run once and cached as JSON under the
output folder (``images/<name>/view<angle>.json``), so rerunning a plot costs
nothing and an interrupted run resumes. Images run in parallel processes.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import logging
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from unseeable.confidence.tolerance import DELTA_STAR
from unseeable.errors import InputError, UnseeableError, check_whole_number
from unseeable.evaluate.jobs import evaluate_and_write, run_cached, selected_items
from unseeable.evaluate.plots import plot_histograms, save_figure
from unseeable.executor import Executor, executor_or_processes
from unseeable.fileio import write_json
from unseeable.pipeline.settings import EstimateSettings

__all__ = ["ImageJob", "EvaluationSettings", "evaluate_image", "evaluate_corpus",
           "visibility_experiment", "confidence_experiment", "RESULT_FORMAT"]

logger = logging.getLogger(__name__)

# @3: errors also by kind (errors_auto_by_kind, errors_manual_by_kind); @2: visibility
# agreement compares features matched physically (an estimated pose may number the grid
# from another side) and a quarter-turned pose counts as wrong; @1 records compared
# features index by index and took quarter turns for right.
RESULT_FORMAT = "unseeable/image-evaluation@3"
#: Part of every record's cache key: changed whenever the estimator gives other results
#: for the same settings, so that records made by an older one are computed again
#: rather than mixed with new ones (the package version moves more slowly).
ESTIMATOR_REVISION = "2026-12-06 estimate settings in one record"


@dataclass(frozen=True)
class EvaluationSettings:
    """What every image of an experiment is evaluated with.

    Attributes
    ----------
    estimate : EstimateSettings
        The estimator's settings, for manual and automatic visibility alike (the
        experiments use a 30 s solve limit).
    known_pose : bool
        Use the view's recorded pose instead of finding it from the image.
    pose_searches : path or None
        A folder of cached pose searches (:mod:`~unseeable.pipeline.search_cache`),
        shared by every experiment on the corpus: each photograph's pose is searched
        once. Not part of :meth:`digest`: the estimates are the same with or without it.
        The experiment functions set it to ``<out>/pose-searches`` when it is None.
    """

    estimate: EstimateSettings = EstimateSettings.from_options(time_limit=30.0)
    known_pose: bool = False
    pose_searches: Path | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.estimate, EstimateSettings):
            raise InputError("must be an EstimateSettings", field="estimate",
                             value=type(self.estimate).__name__)
        # Checked here, once: in the workers a bad calibration would fail every image alike.
        self.estimate.detection.loaded_calibration()

    def searching_in(self, out_dir: str | Path) -> EvaluationSettings:
        """These settings, caching pose searches in ``out_dir/pose-searches`` unless they
        already name a folder."""
        if self.pose_searches is not None:
            return self
        return dataclasses.replace(self, pose_searches=Path(out_dir) / "pose-searches")

    def digest(self) -> str:
        """Cache key: these settings (a calibration file by its contents, the shipped one's
        included), the package version and the estimator's revision."""
        from importlib.resources import files

        import unseeable

        shipped = files("unseeable") / "data" / "calibration.json"
        cal = (hashlib.sha256(shipped.read_bytes()).hexdigest()
               if self.estimate.detection.calibration is None and shipped.is_file() else "")
        text = json.dumps({"estimate": self.estimate.digest(), "known_pose": self.known_pose,
                           "version": unseeable.__version__, "revision": ESTIMATOR_REVISION,
                           "calibration": cal}, sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()[:16]


@dataclass(frozen=True)
class ImageJob:
    name: str
    angle: float
    view: Path
    truth: Path
    out: Path


def evaluate_image(job: ImageJob, settings: EvaluationSettings) -> dict[str, Any]:
    """Estimate one image with manual and automatic visibility; compare with the truth."""
    from unseeable.pipeline import Observation, estimate
    from unseeable.render.view import load_truth, load_view
    from unseeable.vision import pose_equivalent

    view = load_view(job.view)
    truth = load_truth(job.truth)
    shown = truth.shown
    s = settings.estimate
    record: dict[str, Any] = {"format": RESULT_FORMAT, "name": job.name, "angle": job.angle,
                              "settings": settings.digest(), "truth_logs": len(shown.logs),
                              "delta_star": s.confidence.delta_star}
    t0 = time.perf_counter()
    try:
        auto = estimate([Observation.of(view, use_recorded_pose=settings.known_pose,
                                        source=job.view)], s)
    except UnseeableError as err:
        record.update({"failed": str(err), "seconds": time.perf_counter() - t0})
        return record
    seconds = time.perf_counter() - t0
    # Manual visibility is the truth's, so it goes with the true pose (the paper's
    # annotators marked visibility on the image, independent of any pose estimate).
    manual = estimate([Observation(view, pose=truth.pose, manual_visibility=truth.visible)],
                      s.replace(enabled=False))
    kw = {"truth_pose": truth.pose, "estimate_pose": auto.pose}
    # The pipeline may report the grid numbered from the other side (a half turn). A
    # quarter turn on a square footprint is not the same grid (its layers run the other
    # way, half a layer apart), so it counts as a wrong pose.
    pose_err = (0.0, 0.0) if auto.pose is None else pose_equivalent(
        auto.pose, truth.pose, truth.structure.extent)
    auto_cmp = _comparison(shown, auto, kw)
    manual_cmp = _comparison(shown, manual, {**kw, "estimate_pose": manual.pose})
    v = auto.views[0]
    report = v.pose_report
    record.update({
        "failed": None,
        "errors_auto": auto_cmp.errors,
        "errors_manual": manual_cmp.errors,
        "errors_auto_by_kind": auto_cmp.errors_by_kind(),
        "errors_manual_by_kind": manual_cmp.errors_by_kind(),
        "confident": auto.confident,
        "confident_at_pose": auto.confidence.confident if auto.confidence else None,
        # The paper's test alone: δ* over the unseen features (the estimate's `confident`
        # also needs the reading test when the settings ask for it).
        "confident_delta_star": auto.confident_by_delta_star,
        "reading_shift": s.confidence.reading_shift,
        "pose_choice_margin": None if report is None else report.choice_margin,
        "presence_shift": v.presence_shift,
        "extent_doubt": v.extent_doubt,
        "evidence_doubt": v.evidence_doubt,
        "tolerance": auto.confidence.tolerance if auto.confidence else None,
        "iterations": auto.iterations,
        "converged": auto.converged,
        "cycle_length": auto.cycle_length,
        "visibility_agreement": _visibility_agreement(auto, truth),
        "pose_error_mm": pose_err[0],
        "pose_error_deg": pose_err[1],
        "seconds": seconds,
        "timings": auto.timings,
    })
    return record


def _visibility_agreement(auto, truth) -> float:
    """Share of features whose visibility the estimate got right, the estimate's features
    matched physically to the truth's (an estimated pose may number the grid from another side)."""
    from unseeable.evaluate.metric import match_features

    if auto.pose is None or auto.structure is None:
        return float(np.mean(auto.visible == truth.visible))
    match = match_features(auto.structure.extent, auto.pose, truth.structure.extent,
                           truth.pose)
    ok = match >= 0
    if not ok.any():
        return 0.0
    return float(np.mean(auto.visible[ok] == truth.visible[match[ok]]))


def _comparison(truth, estimate, kw):
    from unseeable.evaluate.metric import compare_structures

    # An estimated grid that does not line up with the truth's (a wrong pose): every log
    # of both counts as an error.
    return compare_structures(truth, estimate.structure, on_misaligned="count", **kw)


def _failed_image(job: ImageJob, settings: EvaluationSettings, err: UnseeableError) -> dict:
    return {"format": RESULT_FORMAT, "name": job.name, "angle": job.angle,
            "settings": settings.digest(), "failed": str(err)}


def evaluate_corpus(corpus_dir: str | Path, out_dir: str | Path, *,
                    settings: EvaluationSettings = EvaluationSettings(), workers: int = 2,
                    executor: Executor | None = None,
                    only: Sequence[str] | None = None,
                    progress: Callable[[int, int], None] | None = None) -> list[dict]:
    """Evaluate every image of a rendered corpus (cached per image and settings).

    Returns
    -------
    list of dict
        One record per image, in corpus order.
    """
    from unseeable.corpus.build import load_corpus

    workers = check_whole_number(workers, field="workers", minimum=1)
    corpus = load_corpus(corpus_dir)
    out = Path(out_dir)
    settings = settings.searching_in(out)
    jobs = []
    for item in selected_items(corpus, only):
        for view in item.views:
            stem = Path(view.view).stem
            jobs.append(ImageJob(item.name, float(view.angle), Path(view.view),
                                 Path(view.truth), out / "images" / item.name / f"{stem}.json"))
    if not jobs:
        raise InputError("no images to evaluate", file=corpus_dir, field="entries",
                         value=list(only or []))
    return run_cached(jobs, partial(evaluate_and_write, evaluate_image, failed=_failed_image),
                      settings, digest=settings.digest(),
                      record_format=RESULT_FORMAT, progress=progress,
                      executor=executor_or_processes(executor, workers))


def _ok(records):
    return [r for r in records if not r.get("failed")]


def visibility_experiment(records: list[dict], out_dir: str | Path) -> dict[str, Any]:
    """Error histograms, manual vs automatic visibility: ``visibility.json`` and ``.png``."""
    from unseeable.evaluate.metric import ERROR_KINDS, error_histogram

    ok = _ok(records)
    if not ok:
        raise InputError("every image failed; nothing to plot", field="records",
                         value=len(records))
    manual = np.array([r["errors_manual"] for r in ok])
    auto = np.array([r["errors_auto"] for r in ok])
    top = int(max(manual.max(), auto.max(), 1))
    table = {
        "format": "unseeable/experiment-visibility@1",
        "images": len(records),
        "evaluated": len(ok),
        "failed": [{"name": r["name"], "angle": r["angle"], "error": r["failed"]}
                   for r in records if r.get("failed")],
        "t": list(range(top + 1)),
        "manual": error_histogram(manual, max_errors=top).tolist(),
        "automatic": error_histogram(auto, max_errors=top).tolist(),
        "mean_errors_manual": float(manual.mean()),
        "mean_errors_automatic": float(auto.mean()),
        "max_errors_automatic": int(auto.max()),
        "exact_automatic": float(np.mean(auto == 0)),
        "exact_manual": float(np.mean(manual == 0)),
        # What the errors are (evaluate.metric.ERROR_KINDS), summed over the images.
        "errors_by_kind": {side: {kind: int(sum(r[key][kind] for r in ok)) for kind in ERROR_KINDS}
                           for side, key in (("automatic", "errors_auto_by_kind"),
                                             ("manual", "errors_manual_by_kind"))},
        "mean_iterations": float(np.mean([r["iterations"] for r in ok])),
        # A fixpoint stopped by the estimate cap or the time budget is not a cycle.
        "cycles": int(sum(1 for r in ok if r["cycle_length"])),
        "mean_visibility_agreement": float(np.mean([r["visibility_agreement"] for r in ok])),
        "mean_seconds": float(np.mean([r["seconds"] for r in ok])),
        "median_seconds": float(np.median([r["seconds"] for r in ok])),
    }
    out = Path(out_dir)
    write_json(out / "visibility.json", table)
    plot_histograms(out / "visibility.png", table["t"],
                     {"manual visibility": (table["manual"], "tab:blue"),
                      "automatic visibility": (table["automatic"], "tab:red")},
                     title=f"Error histograms over {len(ok)} images")
    return table


def confidence_experiment(records: list[dict], out_dir: str | Path) -> dict[str, Any]:
    """False positives/negatives of the δ* test and the δ distribution.

    ``false_negatives_exact_ties`` counts the false negatives whose tolerance is 0:
    right estimates that another structure matches exactly in probability (a hidden
    tie the tie policy settled), which no threshold δ* could call confident.
    """
    ok = [r for r in _ok(records) if r.get("confident") is not None]
    if not ok:
        raise InputError("no image has a confidence judgement", field="records",
                         value=len(records))
    correct = np.array([r["errors_auto"] == 0 for r in ok])
    # The paper's δ* test alone (records made without the reading test have only that).
    confident = np.array([bool(r.get("confident_delta_star", r["confident"])) for r in ok])
    shipped = np.array([bool(r["confident"]) for r in ok])
    tol = np.array([np.nan if r["tolerance"] is None else r["tolerance"] for r in ok])
    shifts = {r.get("reading_shift") for r in ok}
    table = {
        "format": "unseeable/experiment-confidence@1",
        "images": len(ok),
        "correct": int(correct.sum()),
        "confident": int(confident.sum()),
        "false_positives": int(np.sum(confident & ~correct)),
        "false_negatives": int(np.sum(~confident & correct)),
        # Tolerance 0: another structure is exactly as probable (a hidden tie the tie
        # policy settled), so any hypothetical evidence at all changes the estimate.
        "false_negatives_exact_ties": int(np.sum(~confident & correct & (tol == 0))),
        "true_positives": int(np.sum(confident & correct)),
        "true_negatives": int(np.sum(~confident & ~correct)),
        "tolerance_correct": [float(t) for t in tol[correct]],
        "tolerance_wrong": [float(t) for t in tol[~correct]],
        # With the reading test (the shipped confidence): the seen features' readings may
        # also be worth up to s* less.
        "reading_shift": shifts.pop() if len(shifts) == 1 else None,
        "with_readings": {
            "confident": int(shipped.sum()),
            "false_positives": int(np.sum(shipped & ~correct)),
            "false_negatives": int(np.sum(~shipped & correct)),
            "false_negatives_exact_ties": int(np.sum(~shipped & correct & (tol == 0))),
        },
    }
    out = Path(out_dir)
    write_json(out / "confidence.json", table)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 3.6), dpi=110)
    bins = np.linspace(0, 0.5, 21)
    ax.hist([tol[correct & ~np.isnan(tol)], tol[~correct & ~np.isnan(tol)]], bins=bins,
            stacked=True, color=["tab:green", "tab:red"],
            label=[f"correct estimates ({int(correct.sum())})",
                   f"wrong estimates ({int((~correct).sum())})"])
    delta_star = ok[0].get("delta_star", DELTA_STAR)
    delta_star = DELTA_STAR if delta_star is None else delta_star
    ax.axvline(delta_star, color="k", ls="--", lw=1, label=f"δ* = {delta_star:g}")
    ax.set_xlabel("estimation tolerance δ")
    ax.set_ylabel("images")
    fp, fn = table["false_positives"], table["false_negatives"]
    ties = table["false_negatives_exact_ties"]
    ax.set_title(f"Confidence over {len(ok)} images: {fp} false positive{'s' * (fp != 1)},\n"
                 f"{fn} false negative{'s' * (fn != 1)}"
                 f"{f' ({ties} of them exact ties)' if ties else ''}", fontsize=11)
    ax.legend(fontsize=8)
    save_figure(fig, out / "confidence.png")
    return table
