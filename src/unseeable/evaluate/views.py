"""Several views and partial disassembly on a rendered corpus (paper §5).

* **Views**: for every structure and every starting station, the other stations
  are added one by one in a fixed, seeded order; the structure is estimated
  jointly from the first 1, 2, …, all of them, and compared with the truth.
* **Disassembly**: for every structure whose proper subsets the corpus renders
  (the arm removed every log on layers ``>= L``), the full view at a station is
  paired with the subset's view from the same station, which is read as a view of
  the full structure with ``removed_from_layer = L``; the pair's errors are
  compared with the full view's alone, and the logs the full view hides (no
  feature of theirs visible) that the pair gets right are counted.

Each job (one structure and station) runs once and is cached as JSON under the
output folder, so an interrupted run resumes.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from unseeable.errors import InputError, UnseeableError, check_whole_number
from unseeable.evaluate.experiments import EvaluationSettings
from unseeable.evaluate.jobs import evaluate_and_write, run_cached, selected_items, structure_rng
from unseeable.evaluate.plots import plot_histograms
from unseeable.executor import Executor, executor_or_processes
from unseeable.fileio import write_json

__all__ = ["ViewsJob", "views_jobs", "evaluate_views_job", "evaluate_views",
           "views_experiment", "VIEWS_FORMAT"]

VIEWS_FORMAT = "unseeable/views-evaluation@1"


@dataclass(frozen=True)
class ViewsJob:
    """One structure from one starting station: the views in the order they are added,
    and the disassembly views paired with the first."""

    name: str
    start: float
    views: tuple[tuple[str, str], ...]  # (view file, truth file), in order
    disassembly: tuple[tuple[str, str, int], ...]  # (subset name, view file, layer L)
    out: Path


def views_jobs(corpus_dir: str | Path, out_dir: str | Path, *, seed: int = 0,
               only: Sequence[str] | None = None, starts: int | None = None
               ) -> list[ViewsJob]:
    """The jobs of the experiment: every structure (or ``only`` these) from every station
    (or the first ``starts`` of a seeded order)."""
    from unseeable.corpus.build import load_corpus
    from unseeable.evaluate.active import removal_subsets

    corpus = load_corpus(corpus_dir)
    out = Path(out_dir)
    jobs = []
    for item in selected_items(corpus, only):
        rng = structure_rng(seed, item.name)
        stations = [float(v.angle) for v in item.views]
        order_of_starts = [stations[i] for i in rng.permutation(len(stations))]
        subsets = removal_subsets(corpus, item)
        for start in order_of_starts[:starts]:
            rest = [a for a in stations if a != start]
            rest = [rest[i] for i in rng.permutation(len(rest))]
            views = tuple((str(item.view(a).view), str(item.view(a).truth))
                          for a in [start, *rest])
            dis = tuple((sub.name, str(sub.view(start).view), layer) for sub, layer in subsets)
            jobs.append(ViewsJob(item.name, start, views, dis,
                                 out / "views" / item.name / f"from{start:g}.json"))
    if not jobs:
        raise InputError("no structures to evaluate", file=corpus_dir, field="entries",
                         value=list(only or []))
    return jobs


def _hidden_logs(truth) -> np.ndarray:
    """Per log of the truth, whether no feature of it is visible in the truth's view."""
    from unseeable.pipeline import log_support

    return ~log_support(truth.structure, np.where(truth.visible, 0.9, 0.5))


def evaluate_views_job(job: ViewsJob, settings: EvaluationSettings) -> dict[str, Any]:
    """Estimate one job's structure from 1, 2, … of its views and from each disassembly
    pair; compare each with the truth."""
    from unseeable.evaluate.metric import compare_structures
    from unseeable.pipeline import Observation, estimate
    from unseeable.render.view import View, load_truth, load_view

    s = settings.estimate
    truth = load_truth(job.views[0][1])
    views = [load_view(v) for v, _ in job.views]
    record: dict[str, Any] = {"format": VIEWS_FORMAT, "name": job.name, "start": job.start,
                              "settings": settings.digest(), "order": [],
                              "failed": None}

    def observe(view, path):
        return Observation.of(view, use_recorded_pose=settings.known_pose, source=path)

    def compared(est):
        return compare_structures(truth.structure, est.structure, truth_pose=truth.pose,
                                  estimate_pose=est.pose, on_misaligned="count")

    try:
        single = None
        for n in range(1, len(views) + 1):
            t0 = time.perf_counter()
            est = estimate([observe(v, p) for v, (p, _) in zip(views[:n], job.views)], s)
            cmp = compared(est)
            if n == 1:
                single = cmp  # the disassembly pairs' baseline: the same estimate
            record["order"].append({
                "views": n, "errors": cmp.errors, "confident": est.confident,
                "seconds": time.perf_counter() - t0,
                "orientations": [v.orientation for v in est.views],
                "registration_margins": [v.registration_margin for v in est.views],
                "disagrees": [v.disagrees for v in est.views]})
        hidden = _hidden_logs(truth)
        pairs = []
        for name, path, layer in job.disassembly:
            sub = load_view(path)
            removed = View(sub.image_path, sub.camera, views[0].extent, pose=sub.pose,
                           removed_from_layer=layer)
            t0 = time.perf_counter()
            est = estimate([observe(views[0], job.views[0][0]), observe(removed, path)], s)
            cmp = compared(est)
            pairs.append({"subset": name, "layer": layer, "errors": cmp.errors,
                          "errors_single": single.errors, "confident": est.confident,
                          "hidden_logs": int(hidden.sum()),
                          "hidden_right_single": int((hidden & single.truth_correct).sum()),
                          "hidden_right_pair": int((hidden & cmp.truth_correct).sum()),
                          "seconds": time.perf_counter() - t0})
        record["disassembly"] = pairs
    except UnseeableError as err:
        record["failed"] = str(err)
    return record


def evaluate_views(corpus_dir: str | Path, out_dir: str | Path, *,
                   settings: EvaluationSettings = EvaluationSettings(), workers: int = 2,
                   executor: Executor | None = None,
                   only: Sequence[str] | None = None, starts: int | None = None,
                   progress: Callable[[int, int], None] | None = None) -> list[dict]:
    """Run (or read back from the cache) every job of the experiment."""
    workers = check_whole_number(workers, field="workers", minimum=1)
    if starts is not None:
        starts = check_whole_number(starts, field="starts", minimum=1)
    jobs = views_jobs(corpus_dir, out_dir, only=only, starts=starts)
    settings = settings.searching_in(out_dir)
    return run_cached(jobs, partial(evaluate_and_write, evaluate_views_job), settings,
                      digest=settings.digest(), record_format=VIEWS_FORMAT, progress=progress,
                      executor=executor_or_processes(executor, workers))


def views_experiment(records: list[dict], out_dir: str | Path) -> dict[str, Any]:
    """Errors per number of views and per disassembly pair: ``views.json`` and
    ``views.png``."""
    from unseeable.evaluate.metric import error_histogram

    ok = [r for r in records if not r.get("failed")]
    if not ok:
        raise InputError("every job failed; nothing to plot", field="records",
                         value=len(records))
    most = max(len(r["order"]) for r in ok)
    by_n = {n: np.array([r["order"][n - 1]["errors"] for r in ok if len(r["order"]) >= n])
            for n in range(1, most + 1)}
    top = int(max(max(v.max() for v in by_n.values()), 1))
    all_views = {r["name"]: r["order"][-1]["errors"] for r in ok}
    pairs = [p for r in ok for p in r.get("disassembly", [])]
    table: dict[str, Any] = {
        "format": "unseeable/experiment-views@1",
        "jobs": len(records),
        "failed": [{"name": r["name"], "start": r["start"], "error": r["failed"]}
                   for r in records if r.get("failed")],
        "t": list(range(top + 1)),
        "histograms": {str(n): error_histogram(v, max_errors=top).tolist()
                       for n, v in by_n.items()},
        "mean_errors": {str(n): float(v.mean()) for n, v in by_n.items()},
        "max_errors": {str(n): int(v.max()) for n, v in by_n.items()},
        "confident_wrong": {str(n): int(sum(1 for r in ok if len(r["order"]) >= n
                                             and r["order"][n - 1]["confident"]
                                             and r["order"][n - 1]["errors"] > 0))
                            for n in by_n},
        "errors_all_views_by_structure": all_views,
        "structures_within_2_all_views": int(sum(e <= 2 for e in all_views.values())),
        "median_seconds": {str(n): float(np.median([r["order"][n - 1]["seconds"] for r in ok
                                                    if len(r["order"]) >= n]))
                           for n in by_n},
        "disassembly": {
            "pairs": len(pairs),
            "mean_errors_single": float(np.mean([p["errors_single"] for p in pairs]))
            if pairs else None,
            "mean_errors_pair": float(np.mean([p["errors"] for p in pairs])) if pairs else None,
            "hidden_logs": int(sum(p["hidden_logs"] for p in pairs)),
            "hidden_right_single": int(sum(p["hidden_right_single"] for p in pairs)),
            "hidden_right_pair": int(sum(p["hidden_right_pair"] for p in pairs)),
        },
    }
    out = Path(out_dir)
    write_json(out / "views.json", table)
    colours = ["tab:red", "tab:orange", "tab:olive", "tab:green", "tab:blue", "tab:purple"]
    plot_histograms(out / "views.png", table["t"],
                    {f"{n} view{'s' * (n > 1)} (mean {table['mean_errors'][str(n)]:.2f})":
                     (table["histograms"][str(n)], colours[(n - 1) % len(colours)])
                     for n in by_n},
                    title=f"Errors with more views ({len(ok)} starts)")
    return table

