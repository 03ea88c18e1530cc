"""Descriptions as evidence on a rendered corpus (paper §6, Fig. language).

* **Corpus**: every image of a structure with a door or a window is estimated
  without and with its true description — :func:`~unseeable.language.describe` of
  the structure the image shows, left and right seen from the image's camera —
  and both estimates are compared with the truth (error histograms and means).
  With an estimated pose the description is compiled at the pose the estimate
  without it found (:func:`~unseeable.language.estimate_with_description`).
* **Demonstration** (the paper's figure): four estimates of one structure drawn
  from the first view's camera, green right and red wrong — (a) view 1 alone,
  (b) view 2 alone, (c) views 1 and 2 together, (d) view 1 with one sentence.
  The structure and views are chosen by :data:`DEMONSTRATION_RULE`.

Each image's evaluation runs once and is cached as JSON under the output folder
(``language/<name>/view<angle>.json``), so an interrupted run resumes.
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
from unseeable.evaluate.jobs import evaluate_and_write, run_cached, selected_items
from unseeable.evaluate.plots import plot_histograms, save_figure
from unseeable.executor import Executor, executor_or_processes
from unseeable.fileio import write_json
from unseeable.pipeline.search_cache import pose_searches_cached

__all__ = ["LanguageJob", "language_jobs", "evaluate_language_image", "evaluate_language",
           "language_experiment", "language_demonstration", "LANGUAGE_FORMAT", "LANGUAGE_REVISION",
           "DEMONSTRATION_RULE", "DEMONSTRATION_CANDIDATES"]

LANGUAGE_FORMAT = "unseeable/language-evaluation@1"
#: Part of every record's cache key: changed whenever the language gives other constraints
#: for the same description (records made before are computed again).
LANGUAGE_REVISION = "doors of three layers or more"

#: How the demonstration's structure, views and sentence are chosen.
DEMONSTRATION_RULE = (
    "view 1: the image with the most errors alone that its view with one true sentence "
    "estimates exactly; images tried first those its whole true description estimates "
    "exactly, each group by its errors alone, most first, corpus order on ties, at most "
    "DEMONSTRATION_CANDIDATES images; the sentence: the first relation sentence of "
    "describe() (longest first) that does it; view 2: the other view of the structure with "
    "the most errors alone. Without an exact one, the image and sentence that remove the "
    "most errors.")
#: Images tried for the demonstration (each costs one estimate per sentence).
DEMONSTRATION_CANDIDATES = 8


@dataclass(frozen=True)
class LanguageJob:
    """One image: its view and truth files, where its record goes."""

    name: str
    angle: float
    view: Path
    truth: Path
    out: Path


def _has_opening(structure) -> bool:
    from unseeable.grammar.shapes import find_shapes

    return bool(find_shapes(structure, ("door", "window")))


def language_jobs(corpus_dir: str | Path, out_dir: str | Path, *,
                  only: Sequence[str] | None = None) -> list[LanguageJob]:
    """Every image of a structure with a door or a window (or of ``only`` these)."""
    from unseeable.corpus.build import load_corpus

    corpus = load_corpus(corpus_dir)
    out = Path(out_dir)
    jobs = []
    for item in selected_items(corpus, only):
        if not _has_opening(item.structure):
            continue
        for view in item.views:
            stem = Path(view.view).stem
            jobs.append(LanguageJob(item.name, float(view.angle), Path(view.view),
                                    Path(view.truth), out / "language" / item.name /
                                    f"{stem}.json"))
    if not jobs:
        raise InputError("no image of a structure with a door or a window", file=corpus_dir,
                         field="entries", value=list(only or []))
    return jobs


def true_description(view, truth) -> list[str]:
    """The sentences true of the structure an image shows, left and right as its camera
    sees them."""
    from unseeable.language import Viewpoint, describe

    return describe(truth.shown, viewpoint=Viewpoint.from_camera(view.camera, truth.pose))


def _errors(truth, est) -> Any:
    from unseeable.evaluate.metric import compare_structures

    return compare_structures(truth.shown, est.structure, truth_pose=truth.pose,
                              estimate_pose=est.pose, on_misaligned="count")


def evaluate_language_image(job: LanguageJob, settings: EvaluationSettings) -> dict[str, Any]:
    """Estimate one image without and with its true description; compare with the truth."""
    from unseeable.language import chosen_placements, estimate_with_description, parse
    from unseeable.pipeline import Observation, estimate
    from unseeable.render.view import load_truth, load_view

    view = load_view(job.view)
    truth = load_truth(job.truth)
    s = settings.estimate
    sentences = true_description(view, truth)
    record: dict[str, Any] = {"format": LANGUAGE_FORMAT, "name": job.name, "angle": job.angle,
                              "settings": settings.digest(), "revision": LANGUAGE_REVISION,
                              "known_pose": settings.known_pose,
                              "sentences": sentences, "truth_logs": len(truth.shown.logs),
                              "failed": None}
    obs = Observation.of(view, use_recorded_pose=settings.known_pose, source=job.view)
    t0 = time.perf_counter()
    without = estimate([obs], s)
    t1 = time.perf_counter()
    described = estimate_with_description([obs], sentences, s, without=without)
    t2 = time.perf_counter()
    placed = chosen_placements(parse(sentences), (), described.result.choices)
    record.update({
        "errors_without": _errors(truth, without).errors,
        "errors_with": _errors(truth, described).errors,
        "confident_without": without.confident,
        "confident_with": described.confident,
        "seconds_without": t1 - t0,
        "seconds_with": t2 - t1,
        "placed": {k: p.to_json() for k, p in placed.items()},
    })
    return record


def _failed_image(job: LanguageJob, settings: EvaluationSettings, err: UnseeableError
                  ) -> dict:
    return {"format": LANGUAGE_FORMAT, "name": job.name, "angle": job.angle,
            "settings": settings.digest(), "revision": LANGUAGE_REVISION,
            "failed": str(err)}


def evaluate_language(corpus_dir: str | Path, out_dir: str | Path, *,
                      settings: EvaluationSettings = EvaluationSettings(), workers: int = 2,
                      executor: Executor | None = None,
                      only: Sequence[str] | None = None,
                      progress: Callable[[int, int], None] | None = None) -> list[dict]:
    """Evaluate (or read back from the cache) every image of :func:`language_jobs`.

    Returns
    -------
    list of dict
        One record per image, in corpus order.
    """
    workers = check_whole_number(workers, field="workers", minimum=1)
    jobs = language_jobs(corpus_dir, out_dir, only=only)
    settings = settings.searching_in(out_dir)
    return run_cached(jobs, partial(evaluate_and_write, evaluate_language_image,
                                    failed=_failed_image), settings, digest=settings.digest(),
                      record_format=LANGUAGE_FORMAT, revision=LANGUAGE_REVISION,
                      executor=executor_or_processes(executor, workers),
                      progress=progress)


def language_experiment(records: list[dict], out_dir: str | Path) -> dict[str, Any]:
    """Errors without and with the true description: ``language.json`` and
    ``language.png`` (the error histograms)."""
    from unseeable.evaluate.metric import error_histogram

    ok = [r for r in records if not r.get("failed")]
    if not ok:
        raise InputError("every image failed; nothing to plot", field="records",
                         value=len(records))
    without = np.array([r["errors_without"] for r in ok])
    with_ = np.array([r["errors_with"] for r in ok])
    top = int(max(without.max(), with_.max(), 1))
    table = {
        "format": "unseeable/experiment-language@1",
        "images": len(records),
        "evaluated": len(ok),
        "known_pose": bool(ok[0].get("known_pose")),
        "failed": [{"name": r["name"], "angle": r["angle"], "error": r["failed"]}
                   for r in records if r.get("failed")],
        "t": list(range(top + 1)),
        "without": error_histogram(without, max_errors=top).tolist(),
        "with": error_histogram(with_, max_errors=top).tolist(),
        "mean_errors_without": float(without.mean()),
        "mean_errors_with": float(with_.mean()),
        "exact_without": int(np.sum(without == 0)),
        "exact_with": int(np.sum(with_ == 0)),
        "better": int(np.sum(with_ < without)),
        "same": int(np.sum(with_ == without)),
        "worse": [{"name": r["name"], "angle": r["angle"], "without": r["errors_without"],
                   "with": r["errors_with"]} for r in ok
                  if r["errors_with"] > r["errors_without"]],
        "median_seconds_without": float(np.median([r["seconds_without"] for r in ok])),
        "median_seconds_with": float(np.median([r["seconds_with"] for r in ok])),
        "images_by_structure": {r["name"]: [] for r in ok},
    }
    for r in ok:
        table["images_by_structure"][r["name"]].append(
            {"angle": r["angle"], "without": r["errors_without"], "with": r["errors_with"]})
    out = Path(out_dir)
    write_json(out / "language.json", table)
    plot_histograms(out / "language.png", table["t"],
                    {f"image alone (mean {table['mean_errors_without']:.2f})":
                     (table["without"], "tab:blue"),
                     f"image + true description (mean {table['mean_errors_with']:.2f})":
                     (table["with"], "tab:red")},
                    title=f"Errors without and with a description ({len(ok)} images)")
    return table


def _relation_sentences(sentences: Sequence[str]) -> list[str]:
    """The sentences that relate two things, longest (most said) first."""
    from unseeable.language import parse

    related = [s for s in sentences if parse(s).relations]
    return sorted(related, key=len, reverse=True)


def language_demonstration(records: list[dict], corpus_dir: str | Path, out_dir: str | Path,
                           *, settings: EvaluationSettings = EvaluationSettings(),
                           candidates: int = DEMONSTRATION_CANDIDATES) -> dict[str, Any]:
    """The paper's Fig. language on the corpus: ``language-figure.png`` and ``.json``.

    Parameters
    ----------
    records : list of dict
        :func:`evaluate_language`'s records (the errors of each image alone).
    corpus_dir, out_dir
    settings : EvaluationSettings
    candidates : int
        Images tried (:data:`DEMONSTRATION_RULE`).

    Returns
    -------
    dict
        The figure's table (also written as JSON).
    """
    with pose_searches_cached(settings.pose_searches):
        return _demonstration(records, corpus_dir, out_dir, settings, candidates)


def _demonstration(records: list[dict], corpus_dir: str | Path, out_dir: str | Path,
                   settings: EvaluationSettings, candidates: int) -> dict[str, Any]:
    from unseeable.corpus.build import load_corpus
    from unseeable.language import estimate_with_description
    from unseeable.pipeline import Observation, estimate
    from unseeable.render.view import load_truth, load_view

    candidates = check_whole_number(candidates, field="candidates", minimum=1)
    ok = [r for r in records if not r.get("failed") and r["errors_without"] > 0]
    if not ok:
        raise InputError("no image has errors alone: nothing for a sentence to fix",
                         field="records", value=len(records))
    corpus = load_corpus(corpus_dir)
    s = settings.estimate
    order = sorted(range(len(ok)), key=lambda n: (ok[n]["errors_with"] > 0,
                                                  -ok[n]["errors_without"], n))
    best = None  # (errors fixed, record, sentence, estimate, view, truth, seconds)
    tried = []
    for n in order[:candidates]:
        r = ok[n]
        item = corpus[r["name"]]
        v = item.view(r["angle"])
        view, truth = load_view(v.view), load_truth(v.truth)
        obs = Observation.of(view, use_recorded_pose=settings.known_pose, source=v.view)
        without = None
        for sentence in _relation_sentences(r["sentences"]):
            if without is None and not settings.known_pose:
                without = estimate([obs], s)
            t0 = time.perf_counter()
            est = estimate_with_description([obs], [sentence], s, without=without)
            errors = _errors(truth, est).errors
            tried.append({"name": r["name"], "angle": r["angle"], "sentence": sentence,
                          "errors_without": r["errors_without"], "errors": errors})
            fixed = r["errors_without"] - errors
            if best is None or (fixed, -errors) > (best[0], -best[7]):
                best = (fixed, r, sentence, est, view, truth, time.perf_counter() - t0, errors)
            if errors == 0:
                break
        if best is not None and best[7] == 0:
            break
    if best is None:
        raise InputError("no image with errors has a sentence relating two things",
                         field="records", value=len(ok))
    _, r1, sentence, est_sentence, view1, truth1, _, _ = best
    item = corpus[r1["name"]]
    others = [r for r in records if r["name"] == r1["name"] and r["angle"] != r1["angle"]
              and not r.get("failed")]
    if not others:
        raise InputError("the structure has no second view", field="records",
                         value=r1["name"])
    r2 = max(others, key=lambda r: (r["errors_without"], -abs(r["angle"] - r1["angle"])))
    v2 = item.view(r2["angle"])
    view2 = load_view(v2.view)
    obs1 = Observation.of(view1, use_recorded_pose=settings.known_pose,
                          source=item.view(r1["angle"]).view)
    obs2 = Observation.of(view2, use_recorded_pose=settings.known_pose, source=v2.view)
    panels = [
        ("(a) view 1 alone", estimate([obs1], s)),
        ("(b) view 2 alone", estimate([obs2], s)),
        ("(c) views 1 and 2", estimate([obs1, obs2], s)),
        (f"(d) view 1 + \u201c{sentence}\u201d", est_sentence),
    ]
    table: dict[str, Any] = {
        "format": "unseeable/experiment-language-figure@1",
        "rule": DEMONSTRATION_RULE,
        "structure": r1["name"],
        "view1": r1["angle"],
        "view2": r2["angle"],
        "sentence": sentence,
        "known_pose": settings.known_pose,
        "panels": [],
        "tried": tried,
    }
    pictures = []
    for title, est in panels:
        cmp = _errors(truth1, est)
        table["panels"].append({"title": title, "errors": cmp.errors,
                                "logs": len(est.structure.logs) if est.structure else 0,
                                "truth_logs": len(truth1.shown.logs)})
        pictures.append((f"{title}: {cmp.errors} error{'s' * (cmp.errors != 1)}",
                         _rendering(est, cmp, view1)))
    out = Path(out_dir)
    _four_panels(out / "language-figure.png", pictures,
                 f"{r1['name']}: view {r1['angle']:g}° and view {r2['angle']:g}°")
    table["png"] = "language-figure.png"
    write_json(out / "language-figure.json", table)
    return table


def _rendering(est, comparison, view) -> np.ndarray:
    """The estimate drawn from ``view``'s camera, green right and red wrong."""
    from unseeable.render.pictures import estimate_pictures

    if est.structure is None:
        return np.full((view.camera.height, view.camera.width, 3), 238, np.uint8)
    pics = estimate_pictures(view.image, est.structure, est.pose, view.camera,
                             correct=comparison.estimate_correct)
    return pics["rendering"]


def _four_panels(path: Path, pictures: list[tuple[str, np.ndarray]], title: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(pictures), figsize=(4.2 * len(pictures), 4.2), dpi=110)
    for ax, (caption, image) in zip(np.atleast_1d(axes), pictures):
        ax.imshow(image)
        ax.set_title(caption, fontsize=9, wrap=True)
        ax.axis("off")
    fig.suptitle(title, fontsize=11)
    save_figure(fig, path)
