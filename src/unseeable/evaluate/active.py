"""Active vision on a rendered corpus (paper §5, Figs. active and results).

The paper's protocol, with the corpus's photographs standing in for the robot's
actions. For each starting image, three processes run from the same single-view
estimate (the baseline), each with its own candidate actions:

* **views**: the other images of the same structure (moving the camera);
* **disassembly**: images of the structure's arm-removal subsets (every log on layers
  ``>= L`` taken off) from the same station, read as views of the full structure with
  ``removed_from_layer = L``;
* **combined**: both kinds, the subsets from any station.

Every image with candidates of each kind (a structure the corpus renders with at
least one removal subset) is a starting image. Each process takes actions by the
smallest δ′ (:func:`~unseeable.active.run_active`) until confident, nothing is left
to learn, or ``max_actions``; its errors at termination are compared with the
baseline's on the same image.

The **robot** jobs run the closed loop (:func:`~unseeable.active.active_in_workspace`'s
loop) on every corpus structure from one station: the arm's stations and removal
levels are rendered on demand with the corpus's render settings.

Each job is cached as JSON under the output folder, so an interrupted run resumes.
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

__all__ = ["ActiveJob", "RobotJob", "PROCESSES", "removal_subsets", "active_jobs",
           "robot_jobs", "results_figure", "evaluate_active_job", "evaluate_robot_job",
           "evaluate_active",
           "active_experiment", "ACTIVE_RECORD_FORMAT", "ROBOT_RECORD_FORMAT"]

ACTIVE_RECORD_FORMAT = "unseeable/active-evaluation@1"
ROBOT_RECORD_FORMAT = "unseeable/robot-evaluation@1"
#: The three processes, in the paper's order.
PROCESSES = ("views", "disassembly", "combined")


@dataclass(frozen=True)
class ActiveJob:
    """One starting image and each process's candidates: ``(view file, layer or None,
    name)``; a layer reads a subset's view as the full structure's with
    ``removed_from_layer``."""

    name: str
    start: float
    view: str
    truth: str
    candidates: dict  # process -> tuple of (view file, layer, name)
    out: Path
    max_actions: int


@dataclass(frozen=True)
class RobotJob:
    """The closed loop on one corpus structure from one station: ``view``, the corpus's
    photograph from that station when it has one (the workspace's arm took it; the loop
    starts from it instead of rendering the same scene again)."""

    name: str
    structure: str
    pose: dict
    start: float
    stations: tuple[float, ...]
    render: dict
    out: Path
    max_actions: int
    view: str | None = None


#: Part of the robot records' cache key: their protocol (the first photograph is the
#: corpus's own).
ROBOT_REVISION = "2026-12-06 first photograph from the corpus"


def removal_subsets(corpus, item) -> list[tuple[Any, int]]:
    """The corpus structures that are ``item`` after the arm removed every log on layers
    ``>= L``, with ``L`` (the same footprint, and exactly the logs below ``L``)."""
    found = []
    for other in item.contains:
        sub = corpus[other]
        layer = sub.structure.extent.J
        if sub.structure.logs != item.structure.removed_from_layer(layer).logs \
                or sub.structure.extent.shape[::2] != item.structure.extent.shape[::2]:
            continue  # a subset, but not the arm's removal of whole layers
        found.append((sub, layer))
    return found


def active_jobs(corpus_dir: str | Path, out_dir: str | Path, *, seed: int = 0,
                only: Sequence[str] | None = None, starts: int | None = None,
                max_actions: int = 5) -> list[ActiveJob]:
    """Every starting image with candidates of each kind (or the first ``starts``
    stations of each structure, in a seeded order)."""
    from unseeable.corpus.build import load_corpus

    corpus = load_corpus(corpus_dir)
    out = Path(out_dir)
    jobs = []
    for item in selected_items(corpus, only):
        subsets = removal_subsets(corpus, item)
        if not subsets:
            continue
        stations = [float(v.angle) for v in item.views]
        order = [stations[i] for i in structure_rng(seed, item.name).permutation(len(stations))]
        for start in order[:starts]:
            views = tuple((str(item.view(a).view), None, f"station {a:g}°")
                          for a in stations if a != start)
            here = tuple((str(sub.view(start).view), layer,
                          f"station {start:g}°, layers ≥ {layer} off") for sub, layer in subsets)
            anywhere = tuple((str(sub.view(a).view), layer, f"station {a:g}°, layers ≥ {layer} off")
                             for sub, layer in subsets for a in sub.angles)
            jobs.append(ActiveJob(item.name, start, str(item.view(start).view),
                                  str(item.view(start).truth),
                                  {"views": views, "disassembly": here,
                                   "combined": views + anywhere},
                                  out / "active" / item.name / f"from{start:g}.json",
                                  max_actions))
    if not jobs:
        raise InputError("no structure with a removal subset to evaluate", file=corpus_dir,
                         field="entries", value=list(only or []))
    return jobs


def _photograph_at(item, angle: float) -> str | None:
    """The corpus's photograph of ``item`` from the arm's station ``angle``, if it has one."""
    try:
        return str(item.view(angle).view)
    except InputError:
        return None


def robot_jobs(corpus_dir: str | Path, out_dir: str | Path, *, start: float = 150.0,
               only: Sequence[str] | None = None, max_actions: int = 5) -> list[RobotJob]:
    """The closed loop on every corpus structure (or ``only`` these) from ``start``."""
    from unseeable.corpus.build import load_corpus

    corpus = load_corpus(corpus_dir)
    out = Path(out_dir)
    jobs = [RobotJob(item.name, str(item.structure_file), item.pose.to_json(), float(start),
                     corpus.angles, dict(corpus.render),
                     out / "robot" / f"{item.name}.json", max_actions,
                     _photograph_at(item, start))
            for item in corpus if not only or item.name in only]
    if not jobs:
        raise InputError("no structures to evaluate", file=corpus_dir, field="entries",
                         value=list(only or []))
    return jobs


def _steps(run) -> list[dict]:
    steps = []
    for n, step in enumerate(run.steps):
        plan = run.steps[n - 1].plan if n else None
        chosen = None if plan is None else plan.candidates[plan.chosen]
        conf = step.estimate.confidence
        steps.append({"action": None if step.action is None else step.action.name,
                      "errors": step.errors, "confident": step.confident,
                      "tolerance": None if conf is None else conf.tolerance,
                      "in_doubt": any(v.in_doubt for v in step.estimate.views),
                      "delta_low": None if chosen is None else chosen.low,
                      "delta_high": None if chosen is None else chosen.high,
                      "solves": None if plan is None else plan.solves,
                      "groups": None if plan is None else plan.groups,
                      "tie": None if plan is None else plan.tie,
                      "seconds": step.seconds})
    return steps


def _final(est) -> dict:
    """The estimate's structure and pose, for pictures."""
    from unseeable.domain.io import structure_to_json

    return {"structure": None if est.structure is None else structure_to_json(est.structure),
            "pose": None if est.pose is None else est.pose.to_json()}


def _summary(run) -> dict:
    last = run.steps[-1]
    return {"errors": last.errors, "confident": last.confident, "stopped": run.stopped,
            "actions": len(run.steps) - 1, "steps": _steps(run), **_final(run.estimate)}


def evaluate_active_job(job: ActiveJob, settings: EvaluationSettings) -> dict[str, Any]:
    """The baseline and the three processes from one starting image."""
    from unseeable.active import Action, PhotographPool, run_active
    from unseeable.pipeline import Observation, estimate
    from unseeable.pipeline.files import errors_against_truth
    from unseeable.render.view import View, load_truth, load_view

    s = settings.estimate
    truth = load_truth(job.truth)
    first = load_view(job.view)
    record: dict[str, Any] = {"format": ACTIVE_RECORD_FORMAT, "name": job.name,
                              "start": job.start, "view": job.view, "truth": job.truth,
                              "settings": settings.digest(),
                              "max_actions": job.max_actions, "failed": None}
    try:
        t0 = time.perf_counter()
        obs = Observation.of(first, use_recorded_pose=settings.known_pose, source=job.view)
        baseline = estimate([obs], s)
        record["baseline"] = {
            "errors": errors_against_truth(baseline, truth.structure, truth_pose=truth.pose),
            "confident": baseline.confident, "seconds": time.perf_counter() - t0,
            **_final(baseline)}
        for process in PROCESSES:
            actions = []
            for path, layer, name in job.candidates[process]:
                v = load_view(path)
                if layer is not None:  # a subset's view read as the full structure's
                    v = View(v.image_path, v.camera, first.extent, pose=v.pose,
                             removed_from_layer=layer)
                actions.append(Action(name, v.camera, removed_from_layer=layer, source=v))
            t1 = time.perf_counter()
            run = run_active([obs], PhotographPool(actions, known_pose=settings.known_pose),
                             s, max_actions=job.max_actions, truth=truth.structure,
                             truth_pose=truth.pose, first=baseline)
            record[process] = {**_summary(run), "candidates": len(actions),
                               "seconds": time.perf_counter() - t1}
    except UnseeableError as err:
        record["failed"] = str(err)
    return record


def evaluate_robot_job(job: RobotJob, settings: EvaluationSettings) -> dict[str, Any]:
    """The simulated robot's closed loop on one structure."""
    from unseeable.active import WorkspaceSource, run_active
    from unseeable.domain.io import load_structure
    from unseeable.pipeline import Observation
    from unseeable.render.settings import RenderSettings, SceneRandomisation
    from unseeable.render.view import load_view, pose_from_json
    from unseeable.render.workspace import PendulumArm, Workspace

    structure = load_structure(job.structure)
    pose = pose_from_json(job.pose)
    render = job.render
    ws = Workspace(structure, pose=pose,
                   arm=PendulumArm(width=int(render["width"]), height=int(render["height"])),
                   # The corpus's renderer and look (its samples, its randomisation if any).
                   settings=RenderSettings(spp=int(render["spp"]), randomisation=(
                       SceneRandomisation() if render.get("randomise") else None)),
                   seed=int(render.get("seed", 0)))
    record: dict[str, Any] = {"format": ROBOT_RECORD_FORMAT, "name": job.name,
                              "start": job.start, "settings": settings.digest(),
                              "revision": ROBOT_REVISION,
                              "max_actions": job.max_actions, "failed": None}
    try:
        t0 = time.perf_counter()
        source = WorkspaceSource(ws, job.stations, known_pose=settings.known_pose,
                                 taken=[(job.start, None)])
        first = load_view(job.view) if job.view is not None else ws.observe(job.start)
        obs = Observation.of(first, use_recorded_pose=settings.known_pose,
                             source=f"station {job.start:g}°")
        run = run_active([obs], source, settings.estimate, max_actions=job.max_actions,
                         truth=structure, truth_pose=pose)
        record.update(_summary(run))
        record["seconds"] = time.perf_counter() - t0
    except UnseeableError as err:
        record["failed"] = str(err)
    return record


def evaluate_active(corpus_dir: str | Path, out_dir: str | Path, *,
                    settings: EvaluationSettings = EvaluationSettings(), workers: int = 2,
                    executor: Executor | None = None, only: Sequence[str] | None = None,
                    starts: int | None = None, max_actions: int = 5, robot: bool = True,
                    robot_start: float = 150.0,
                    progress: Callable[[int, int], None] | None = None
                    ) -> tuple[list[dict], list[dict]]:
    """Run (or read back from the cache) every job: the processes' records, then the
    robot's (empty without ``robot``)."""
    workers = check_whole_number(workers, field="workers", minimum=1)
    max_actions = check_whole_number(max_actions, field="max_actions", minimum=0)
    if starts is not None:
        starts = check_whole_number(starts, field="starts", minimum=1)
    jobs = active_jobs(corpus_dir, out_dir, only=only, starts=starts, max_actions=max_actions)
    robots = robot_jobs(corpus_dir, out_dir, start=robot_start, only=only,
                        max_actions=max_actions) if robot else []
    run = executor_or_processes(executor, workers)
    total = len(jobs) + len(robots)
    settings = settings.searching_in(out_dir)

    def report(offset: int):
        return None if progress is None else (lambda done, _: progress(offset + done, total))

    records = run_cached(jobs, partial(evaluate_and_write, evaluate_active_job), settings,
                         digest=settings.digest(), record_format=ACTIVE_RECORD_FORMAT,
                         executor=run, progress=report(0))
    robot_records = run_cached(robots, partial(evaluate_and_write, evaluate_robot_job),
                               settings, digest=settings.digest(),
                               record_format=ROBOT_RECORD_FORMAT, revision=ROBOT_REVISION,
                               executor=run,
                               progress=report(len(jobs))) if robots else []
    return records, robot_records


def _showcase(records: list[dict]) -> dict | None:
    """The starting image of Fig. results: the largest baseline error that a process
    brought down (the first such by name and station)."""
    drawable = [r for r in records if r.get("view") and r["baseline"].get("structure")]
    ranked = sorted(drawable, key=lambda r: (-(r["baseline"]["errors"]
                                             - min(r[p]["errors"] for p in PROCESSES)),
                                            r["name"], r["start"]))
    return ranked[0] if ranked else None


def results_figure(record: dict, path: str | Path, *, width: int = 420) -> Path:
    """Fig. results: the baseline's and each process's final estimate on the starting
    photograph, each log green when right and red when wrong, side by side."""
    import cv2

    from unseeable.active import crop_to_assembly
    from unseeable.domain.io import structure_from_json
    from unseeable.evaluate.metric import compare_structures
    from unseeable.render.pictures import truth_picture
    from unseeable.render.view import load_truth, load_view, pose_from_json, write_image

    view = load_view(record["view"])
    truth = load_truth(record["truth"])
    panels = []
    for key in ("baseline", "disassembly", "views", "combined"):
        r = record[key]
        if r.get("structure") is None:
            continue
        s = structure_from_json(r["structure"])
        pose = pose_from_json(r["pose"])
        cmp = compare_structures(truth.structure, s, truth_pose=truth.pose, estimate_pose=pose,
                                 on_misaligned="count")
        pic = truth_picture(view.image, s, pose, view.camera, correct=cmp.estimate_correct,
                            truth=truth.structure, truth_pose=truth.pose,
                            truth_correct=cmp.truth_correct, legend=False)
        pic = crop_to_assembly(pic, view.camera.size, s.extent, pose, view.camera)
        h, w = pic.shape[:2]
        pic = cv2.resize(np.ascontiguousarray(pic), (width, round(h * width / w)),
                         interpolation=cv2.INTER_AREA)
        band = np.full((28, width, 3), 255, np.uint8)
        cv2.putText(band, f"{key}: {r['errors']} errors", (6, 20), cv2.FONT_HERSHEY_SIMPLEX,
                    0.55, (0, 0, 0), 1, cv2.LINE_AA)
        panels.append(np.vstack([band, pic]))
    gap = np.full((panels[0].shape[0], 6, 3), 255, np.uint8)
    row = panels[0]
    for p in panels[1:]:
        row = np.hstack([row, gap, p])
    write_image(path, row)
    return Path(path)


def active_experiment(records: list[dict], robot_records: list[dict],
                      out_dir: str | Path) -> dict[str, Any]:
    """Error histograms at termination (``active.png``), actions per image, δ′ of the
    chosen actions and the robot's loop (``active.json``)."""
    from unseeable.evaluate.metric import error_histogram

    ok = [r for r in records if not r.get("failed")]
    if not ok:
        raise InputError("every job failed; nothing to plot", field="records",
                         value=len(records))
    errors = {"baseline": np.array([r["baseline"]["errors"] for r in ok])}
    for p in PROCESSES:
        errors[p] = np.array([r[p]["errors"] for r in ok])
    top = int(max(max(int(v.max()) for v in errors.values()), 1))

    def confident_wrong(p: str) -> int:
        key = (lambda r: r["baseline"]) if p == "baseline" else (lambda r: r[p])
        return int(sum(1 for r in ok if key(r)["confident"] and key(r)["errors"] > 0))

    by_structure: dict[str, int] = {}
    for r in ok:
        by_structure[r["name"]] = max(by_structure.get(r["name"], 0), r["combined"]["errors"])
    chosen = {p: [s for r in ok for s in r[p]["steps"][1:]] for p in PROCESSES}
    table: dict[str, Any] = {
        "format": "unseeable/experiment-active@1",
        "images": len(ok),
        "structures": len(by_structure),
        "failed": [{"name": r["name"], "start": r["start"], "error": r["failed"]}
                   for r in records if r.get("failed")],
        "t": list(range(top + 1)),
        "histograms": {k: error_histogram(v, max_errors=top).tolist()
                       for k, v in errors.items()},
        "mean_errors": {k: float(v.mean()) for k, v in errors.items()},
        "max_errors": {k: int(v.max()) for k, v in errors.items()},
        "confident_wrong": {k: confident_wrong(k) for k in errors},
        "confident": {k: int(sum(1 for r in ok if (r["baseline"] if k == "baseline"
                                                   else r[k])["confident"]))
                      for k in errors},
        "actions_per_image": {p: float(np.mean([r[p]["actions"] for r in ok]))
                              for p in PROCESSES},
        "stopped": {p: {why: int(sum(1 for r in ok if r[p]["stopped"] == why))
                        for why in sorted({r[p]["stopped"] for r in ok})}
                    for p in PROCESSES},
        "chosen_delta": {p: [s["delta_low"] for s in chosen[p]] for p in PROCESSES},
        "search_solves": {p: int(sum(s["solves"] for s in chosen[p])) for p in PROCESSES},
        "search_groups": {p: int(sum(s["groups"] for s in chosen[p])) for p in PROCESSES},
        "combined_errors_by_structure": by_structure,
        "combined_structures_within_2": int(sum(e <= 2 for e in by_structure.values())),
        "median_seconds": {p: float(np.median([r[p]["seconds"] for r in ok]))
                           for p in PROCESSES},
    }
    robots = [r for r in robot_records if not r.get("failed")]
    if robot_records:
        table["robot"] = {
            "structures": len(robot_records),
            "failed": [{"name": r["name"], "error": r["failed"]}
                       for r in robot_records if r.get("failed")],
            "confident": int(sum(r["confident"] for r in robots)),
            "confident_wrong": int(sum(1 for r in robots
                                       if r["confident"] and r["errors"] > 0)),
            "mean_errors_start": float(np.mean([r["steps"][0]["errors"] for r in robots]))
            if robots else None,
            "mean_errors_end": float(np.mean([r["errors"] for r in robots])) if robots else None,
            "mean_actions": float(np.mean([r["actions"] for r in robots])) if robots else None,
            "by_structure": {r["name"]: {"errors_start": r["steps"][0]["errors"],
                                         "errors": r["errors"], "actions": r["actions"],
                                         "confident": r["confident"], "stopped": r["stopped"]}
                             for r in robots},
        }
    out = Path(out_dir)
    showcase = _showcase(ok)
    if showcase is not None:
        table["results_figure"] = {"name": showcase["name"], "start": showcase["start"],
                                   "file": "results.png"}
        results_figure(showcase, out / "results.png")
    write_json(out / "active.json", table)
    colours = {"baseline": "tab:blue", "disassembly": "tab:cyan", "views": "gold",
               "combined": "tab:red"}
    plot_histograms(out / "active.png", table["t"],
                    {f"{k} (mean {table['mean_errors'][k]:.2f})": (table["histograms"][k],
                                                                   colours[k])
                     for k in ("baseline", "disassembly", "views", "combined")},
                    title=f"Errors at termination ({len(ok)} starting images)")
    return table
