"""The paper reproduced in one run: the corpus, every experiment, one report.

:func:`reproduce` runs these stages in order (:data:`STAGES`), each timed and
each reporting its progress through one ``progress(stage, done, total)``
callback, all on one executor (local processes or a Dask cluster,
:mod:`unseeable.executor`):

``corpus``
    Render the corpus, or read it back (:func:`~unseeable.corpus.build.build_corpus`:
    cached view by view, resumable).
``visibility``
    Every image with manual and automatic visibility
    (:func:`~unseeable.evaluate.experiments.evaluate_corpus`,
    :func:`~unseeable.evaluate.experiments.visibility_experiment`).
``confidence``
    The δ* test and the tolerance δ on the same per-image records
    (:func:`~unseeable.evaluate.experiments.confidence_experiment`).
``views``
    Several views and disassembly pairs (:mod:`unseeable.evaluate.views`).
``active``
    Active vision from each starting image (views, disassembly, combined) and the
    simulated robot's closed loop (:mod:`unseeable.evaluate.active`).
``language``
    Estimates without and with each image's true description, and Fig. language
    (:mod:`unseeable.evaluate.language`).
``showcase``
    One estimate written out with its interactive 3-D page
    (:func:`~unseeable.report.write_estimate_page`): the image of the visibility
    stage with the most errors.

Each stage's result is the table its experiment function returns, as
``unseeable experiment …`` prints it. Then the report (``report.md``,
``report.html`` and ``report.json``, :func:`unseeable.report.paper.write_report`)
puts every table and figure beside the paper's published number.

Folders:

* the corpus folder (default ``OUT/corpus``; ``OUT/corpus-quick`` for
  :data:`QUICK`) and the results folder (default ``CORPUS/results``, the
  experiment commands' own) are caches: their records stay when a run stops, so
  a rerun computes only what is missing;
* ``OUT`` receives the report, its figures and tables (``figures/``) and the
  showcase (``showcase/``) whole or not at all
  (:func:`~unseeable.fileio.output_folder`).

:data:`FULL` runs what the experiment commands run by default; :data:`QUICK` is
a small subset (two designs, three stations, small images) that shows every
stage and section in minutes.
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import logging
import os
import platform
import subprocess
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from typing import Any

from unseeable.corpus.build import CORPUS_FORMAT, DEFAULT_ANGLES, MANIFEST
from unseeable.errors import InputError, check_whole_number
from unseeable.evaluate.experiments import EvaluationSettings
from unseeable.executor import Executor, open_executor
from unseeable.fileio import check_format, check_output_folder, output_folder, read_json

__all__ = ["ReproduceSettings", "StageResult", "Reproduction", "reproduce", "plan", "FULL",
           "load_reproduction",
           "QUICK", "QUICK_DESIGNS", "STAGES", "REPRODUCTION_FORMAT", "check_corpus_folder",
           "code_version", "machine"]

logger = logging.getLogger(__name__)

REPRODUCTION_FORMAT = "unseeable/reproduction@1"

#: The stages of a run, in order, with their titles.
STAGES: dict[str, str] = {
    "corpus": "corpus",
    "visibility": "visibility: manual vs automatic",
    "confidence": "confidence: the δ* test",
    "views": "several views and disassembly",
    "active": "active vision and the robot",
    "language": "language",
    "showcase": "showcase estimate in 3-D",
}

#: The designs of :data:`QUICK`: a cabin with a door (the language stage's description)
#: and the cabin the arm leaves after taking its upper layers off (so every active-vision
#: process and the disassembly pairs have candidates).
QUICK_DESIGNS = ("cabin-door", "cabin-door-L3")


@dataclass(frozen=True)
class ReproduceSettings:
    """What a reproduction runs.

    Attributes
    ----------
    name : str
        ``"full"`` or ``"quick"`` (or a name of one's own), shown in the report.
    designs : tuple of str or None
        The corpus designs rendered and evaluated (None: all 32).
    angles : tuple of float
        The arm's stations, degrees.
    size : (int, int)
        Image width and height, pixels.
    spp : int
        Samples per pixel of the renderer.
    seed : int
        The corpus's root seed.
    randomise : bool
        Randomise each structure's look (``unseeable corpus build --randomise``).
    starts : int or None
        Starting stations per structure for the active-vision experiment (a seeded
        choice; None: every one).
    view_starts : int or None
        Starting stations per structure for the several-views experiment (each start
        adds every other station in turn, so one start already holds 1 to 5 views).
    max_actions : int
        Actions at most per active-vision process and robot run.
    robot : bool
        Run the simulated robot's closed loop on every design.
    robot_start : float
        The robot's first station, degrees.
    known_pose : bool
        Give the estimator the views' recorded poses instead of finding them.
    time_limit : float
        Seconds per solve (the experiment commands' 30 s).
    prior, backend : str
        The structure prior and the MAP solver (the commands' ``--prior``,
        ``--backend``).
    language_figure : bool
        Draw Fig. language (a few more estimates).
    showcase : bool
        Write one estimate and its 3-D page.
    """

    name: str = "full"
    designs: tuple[str, ...] | None = None
    angles: tuple[float, ...] = DEFAULT_ANGLES
    size: tuple[int, int] = (640, 480)
    spp: int = 24
    seed: int = 0
    randomise: bool = False
    starts: int | None = None
    view_starts: int | None = 1
    max_actions: int = 5
    robot: bool = True
    robot_start: float = 150.0
    known_pose: bool = False
    time_limit: float = 30.0
    prior: str = "builder"
    backend: str = "cpsat"
    language_figure: bool = True
    showcase: bool = True

    def __post_init__(self) -> None:
        if self.designs is not None:
            if isinstance(self.designs, str) or not self.designs \
                    or not all(isinstance(d, str) and d for d in self.designs):
                raise InputError("must be a non-empty list of design names", field="designs",
                                 value=self.designs)
            object.__setattr__(self, "designs", tuple(self.designs))
        object.__setattr__(self, "angles", tuple(float(a) for a in self.angles))
        if len(self.size) != 2:
            raise InputError("must be (width, height)", field="size", value=self.size)
        for n, side in enumerate(self.size):
            check_whole_number(side, field=f"size[{n}]", minimum=1)
        check_whole_number(self.spp, field="spp", minimum=1)
        for name in ("starts", "view_starts"):
            if getattr(self, name) is not None:
                check_whole_number(getattr(self, name), field=name, minimum=1)
        check_whole_number(self.max_actions, field="max_actions", minimum=0)

    @property
    def corpus_folder(self) -> str:
        """The corpus's folder inside the output folder when none is given."""
        return "corpus" if self.name == "full" else f"corpus-{self.name}"

    def evaluation(self) -> EvaluationSettings:
        """The settings every experiment evaluates with (those of ``unseeable experiment
        …`` with the same options, so that their cached records are shared)."""
        from unseeable.pipeline import EstimateSettings

        return EvaluationSettings(
            estimate=EstimateSettings.from_options(time_limit=self.time_limit,
                                                   prior=self.prior, backend=self.backend),
            known_pose=self.known_pose)

    def render_block(self) -> dict[str, Any]:
        """The corpus manifest's ``render`` fields these settings determine."""
        return {"angles": [float(a) for a in self.angles], "width": int(self.size[0]),
                "height": int(self.size[1]), "spp": int(self.spp), "seed": int(self.seed),
                "randomise": bool(self.randomise)}

    def to_json(self) -> dict[str, Any]:
        return {"name": self.name, "designs": None if self.designs is None
                else list(self.designs), "angles": list(self.angles),
                "size": list(self.size), "spp": self.spp, "seed": self.seed,
                "randomise": self.randomise, "starts": self.starts,
                "view_starts": self.view_starts,
                "max_actions": self.max_actions, "robot": self.robot,
                "robot_start": self.robot_start, "known_pose": self.known_pose,
                "time_limit": self.time_limit, "prior": self.prior, "backend": self.backend,
                "language_figure": self.language_figure, "showcase": self.showcase}

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> ReproduceSettings:
        """The settings :meth:`to_json` wrote (fields it does not know raise)."""
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(data) - known)
        if unknown:
            raise InputError("unknown setting", field=f"settings.{unknown[0]}",
                             value=data[unknown[0]])
        values = dict(data)
        for name in ("designs", "angles", "size"):
            if isinstance(values.get(name), list):
                values[name] = tuple(values[name])
        return cls(**values)


#: The whole paper, with the defaults of ``unseeable corpus build`` and of each
#: ``unseeable experiment`` command: 32 designs at 5 stations (640×480, 24 samples per
#: pixel), one starting station per structure for the several views (as docs/results.md)
#: and every one for active vision, 5 actions at most, the robot on every design.
FULL = ReproduceSettings()

#: A small subset that runs every stage and fills every section of the report in a few
#: minutes on 2 cores: :data:`QUICK_DESIGNS` at 3 stations (120°, 150°, 180°), 320×240
#: at 8 samples per pixel, one starting station per structure, at most 2 actions (the
#: robot on both designs), the pose estimated as in the full run.
QUICK = ReproduceSettings(name="quick", designs=QUICK_DESIGNS, angles=(120.0, 150.0, 180.0),
                          size=(320, 240), spp=8, starts=1, max_actions=2)


@dataclass(frozen=True)
class StageResult:
    """What one stage did.

    Attributes
    ----------
    name : str
        A key of :data:`STAGES`.
    seconds : float
        Wall time.
    jobs : int
        Its units of work (views rendered or read back, images, structures × starts…).
    tables : dict
        The experiment functions' tables by name (``"visibility"``, ``"robot"`` is in
        ``"active"``, ``"language-figure"``, …), as they return them.
    figures : tuple of str
        Its figures and tables, relative to the output folder.
    note : str or None
        Why a stage or part of one has no table (e.g. no image of this corpus has a
        door or a window).
    """

    name: str
    seconds: float
    jobs: int = 0
    tables: dict[str, Any] = field(default_factory=dict)
    figures: tuple[str, ...] = ()
    note: str | None = None

    @property
    def title(self) -> str:
        return STAGES.get(self.name, self.name)

    def to_json(self) -> dict[str, Any]:
        return {"name": self.name, "title": self.title, "seconds": self.seconds,
                "jobs": self.jobs, "tables": self.tables, "figures": list(self.figures),
                "note": self.note}


@dataclass(frozen=True)
class Reproduction:
    """A finished run: its settings, where it read and wrote, each stage's result.

    Attributes
    ----------
    settings : ReproduceSettings
    out, corpus, results : Path
        The report folder and the two caches.
    stages : tuple of StageResult
        In :data:`STAGES` order.
    version : dict
        :func:`code_version`.
    machine : dict
        :func:`machine` (the load average at the start and at the end of the run).
    executor : str
        What ran the jobs (e.g. ``"2 local processes"``).
    started : str
        ISO 8601 time (UTC, seconds) of the start.
    seconds : float
        Wall time of the stages.
    files : dict
        The report's files by name (``"markdown"``, ``"html"``, ``"json"``), final paths.
    """

    settings: ReproduceSettings
    out: Path
    corpus: Path
    results: Path
    stages: tuple[StageResult, ...]
    version: dict[str, Any]
    machine: dict[str, Any]
    executor: str
    started: str
    seconds: float
    files: dict[str, Path] = field(default_factory=dict)

    def stage(self, name: str) -> StageResult:
        """The result of stage ``name``."""
        for s in self.stages:
            if s.name == name:
                return s
        raise KeyError(name)

    def to_json(self) -> dict[str, Any]:
        return {"format": REPRODUCTION_FORMAT, "settings": self.settings.to_json(),
                "corpus": str(self.corpus), "results": str(self.results),
                "version": self.version, "machine": self.machine, "executor": self.executor,
                "started": self.started, "seconds": self.seconds,
                "stages": [s.to_json() for s in self.stages]}


def load_reproduction(folder: str | Path) -> Reproduction:
    """The finished run whose report is in ``folder`` (its ``report.json``), to write its
    report again or publish it (:func:`unseeable.report.paper.publish_report`) without
    running anything.

    Raises
    ------
    InputError
        Naming the file: no report there, another format, or a field that does not read.
    """
    folder = Path(folder)
    path = folder / "report.json"
    data = read_json(path)
    check_format(data, REPRODUCTION_FORMAT, file=path)
    try:
        stages = tuple(StageResult(name=st["name"], seconds=float(st["seconds"]),
                                   jobs=int(st.get("jobs", 0)), tables=dict(st["tables"]),
                                   figures=tuple(st["figures"]), note=st.get("note"))
                       for st in data["stages"])
        return Reproduction(
            settings=ReproduceSettings.from_json(data["settings"]), out=folder,
            corpus=Path(data["corpus"]), results=Path(data["results"]), stages=stages,
            version=dict(data["version"]), machine=dict(data["machine"]),
            executor=str(data["executor"]), started=str(data["started"]),
            seconds=float(data["seconds"]),
            files={"markdown": folder / "report.md", "html": folder / "report.html",
                   "json": path})
    except InputError as err:
        raise InputError(err.message, file=path, field=err.field, value=err.value) from None
    except KeyError as err:
        raise InputError(f"is not a finished run's report (no {err.args[0]!r})",
                         file=path) from None
    except (TypeError, ValueError) as err:
        raise InputError(f"is not a finished run's report ({err})", file=path) from None


# ---- run context --------------------------------------------------------------------------


def code_version() -> dict[str, Any]:
    """The package version and, when the package runs from a git checkout, ``git
    describe`` (``-dirty`` with uncommitted changes) and the commit; None where unknown.

    Reads the repository without taking its locks (``--no-optional-locks``).
    """
    import unseeable

    info: dict[str, Any] = {"package": unseeable.__version__, "describe": None,
                            "commit": None}
    here = Path(unseeable.__file__).resolve().parent

    def git(*args: str) -> str:
        env = {**os.environ, "GIT_OPTIONAL_LOCKS": "0"}
        done = subprocess.run(["git", "--no-optional-locks", *args], cwd=here, env=env,
                              capture_output=True, text=True, timeout=20, check=True)
        return done.stdout.strip()

    try:
        top = Path(git("rev-parse", "--show-toplevel")).resolve()
        if here != top / "src" / "unseeable":  # installed somewhere inside another repository
            return info
        info["commit"] = git("rev-parse", "HEAD") or None
        info["describe"] = git("describe", "--always", "--dirty", "--tags") or None
    except (OSError, subprocess.SubprocessError, ValueError) as err:
        logger.debug("no git version: %s", err)
    return info


def machine() -> dict[str, Any]:
    """This machine: CPU count (and those this process may use), processor, platform,
    Python, and the load average now (None where the system does not tell)."""
    info: dict[str, Any] = {"cpus": os.cpu_count(), "usable_cpus": None,
                            "processor": platform.processor() or platform.machine(),
                            "platform": platform.platform(),
                            "python": platform.python_version(), "load": None}
    with contextlib.suppress(AttributeError, OSError):
        info["usable_cpus"] = len(os.sched_getaffinity(0))
    with contextlib.suppress(OSError):
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                info["processor"] = line.split(":", 1)[1].strip()
                break
    with contextlib.suppress(AttributeError, OSError):
        info["load"] = [round(x, 2) for x in os.getloadavg()]
    return info


def check_corpus_folder(corpus: str | Path, settings: ReproduceSettings, *,
                        field: str = "--corpus") -> Path:
    """Check, before any work, that ``corpus`` can hold this run's corpus.

    It must be a folder one can write to (or one that can be made). When it holds a
    corpus already, its manifest must be of this version's format and rendered with
    these settings: another corpus's views would otherwise be rendered over (a corpus
    of other settings goes in a folder of its own).

    Raises
    ------
    InputError
        Naming ``field`` and the folder.
    """
    path = check_output_folder(corpus, field=field)
    manifest = path / MANIFEST
    if not manifest.is_file():
        return path
    try:
        data = read_json(manifest)
    except InputError as err:
        raise InputError(f"holds a corpus manifest that cannot be read ({err.message})",
                         field=field, value=str(path)) from None
    fmt = data.get("format") if isinstance(data, dict) else None
    if fmt != CORPUS_FORMAT:
        raise InputError(f"holds a corpus of another version (format {fmt!r}; this version "
                         f"reads {CORPUS_FORMAT!r}): build it again in a new folder",
                         field=field, value=str(path))
    render = data.get("render") if isinstance(data.get("render"), dict) else {}
    theirs = {"angles": [float(a) for a in render.get("angles", [])
                         if isinstance(a, (int, float))],
              **{k: render.get(k) for k in ("width", "height", "spp", "seed")},
              "randomise": bool(render.get("randomise", False))}
    ours = settings.render_block()
    if theirs != ours:
        raise InputError(f"was rendered with other settings ({_render_text(theirs)}) than "
                         f"this run's ({_render_text(ours)}); give another folder",
                         field=field, value=str(path))
    return path


def _render_text(block: dict[str, Any]) -> str:
    angles = ",".join(f"{a:g}" for a in block.get("angles") or [])
    return (f"{block.get('width')}x{block.get('height')}, {block.get('spp')} spp, seed "
            f"{block.get('seed')}, stations {angles or '-'}"
            + (", randomised" if block.get("randomise") else ""))


# ---- stages -------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Run:
    """What every stage reads: settings, folders, the executor, the progress callback."""

    settings: ReproduceSettings
    evaluation: EvaluationSettings
    corpus: Path
    results: Path
    figures: Path
    showcase: Path
    executor: Executor
    progress: Callable[[str, int, int], None]

    @property
    def only(self) -> list[str] | None:
        return None if self.settings.designs is None else list(self.settings.designs)

    def reporter(self, stage: str, *, extra: int = 0) -> Callable[[int, int], None]:
        """A ``progress(done, total)`` for an experiment function, reported as ``stage``
        with ``extra`` steps of its own after the jobs."""
        return lambda done, total: self.progress(stage, done, total + extra)


def _stage_corpus(run: _Run) -> StageResult:
    from unseeable.corpus.build import build_corpus, plan_views
    from unseeable.render.settings import RenderSettings

    s = run.settings
    options = dict(angles=s.angles, size=s.size, settings=RenderSettings(spp=s.spp),
                   seed=s.seed, only=s.designs, randomise=s.randomise)
    total = len(plan_views(run.corpus, **options))
    done = [0]
    run.progress("corpus", 0, total)

    def advance(item: Any, rendered: bool) -> None:
        done[0] += 1
        run.progress("corpus", done[0], total)

    report = build_corpus(run.corpus, executor=run.executor, progress=advance, **options)
    table = {"views": report.total, "rendered": len(report.rendered),
             "cached": len(report.skipped),
             "structures": len({job.name for job in plan_views(run.corpus, **options)}),
             "render_seconds": float(sum(d.seconds for d in report.rendered)),
             "manifest": str(report.manifest)}
    return StageResult("corpus", 0.0, report.total, {"corpus": table})


def _stage_visibility(run: _Run) -> tuple[StageResult, list[dict]]:
    from unseeable.evaluate.experiments import evaluate_corpus, visibility_experiment

    records = evaluate_corpus(run.corpus, run.results, settings=run.evaluation,
                              workers=run.executor.workers, executor=run.executor,
                              only=run.only, progress=run.reporter("visibility"))
    table, note = _table(lambda: visibility_experiment(records, run.figures))
    return StageResult("visibility", 0.0, len(records),
                       {} if table is None else {"visibility": table},
                       _written(run, "visibility.png", "visibility.json"), note), records


def _stage_confidence(run: _Run, records: list[dict]) -> StageResult:
    from unseeable.evaluate.experiments import confidence_experiment

    run.progress("confidence", 0, 1)
    table, note = _table(lambda: confidence_experiment(records, run.figures))
    run.progress("confidence", 1, 1)
    return StageResult("confidence", 0.0, len(records),
                       {} if table is None else {"confidence": table},
                       _written(run, "confidence.png", "confidence.json"), note)


def _stage_views(run: _Run) -> StageResult:
    from unseeable.evaluate.views import evaluate_views, views_experiment

    records = evaluate_views(run.corpus, run.results, settings=run.evaluation,
                             workers=run.executor.workers, executor=run.executor,
                             only=run.only, starts=run.settings.view_starts,
                             progress=run.reporter("views"))
    table, note = _table(lambda: views_experiment(records, run.figures))
    return StageResult("views", 0.0, len(records), {} if table is None else {"views": table},
                       _written(run, "views.png", "views.json"), note)


def _stage_active(run: _Run) -> StageResult:
    from unseeable.evaluate.active import active_experiment, active_jobs, evaluate_active

    s = run.settings
    try:
        active_jobs(run.corpus, run.results, only=run.only, starts=s.starts,
                    max_actions=s.max_actions)
    except InputError as err:
        return StageResult("active", 0.0, note=f"not run: {err.message}")
    records, robots = evaluate_active(
        run.corpus, run.results, settings=run.evaluation, workers=run.executor.workers,
        executor=run.executor, only=run.only, starts=s.starts, max_actions=s.max_actions,
        robot=s.robot, robot_start=s.robot_start, progress=run.reporter("active"))
    table, note = _table(lambda: active_experiment(records, robots, run.figures))
    return StageResult("active", 0.0, len(records) + len(robots),
                       {} if table is None else {"active": table},
                       _written(run, "active.png", "results.png", "active.json"), note)


def _stage_language(run: _Run) -> StageResult:
    from unseeable.evaluate.language import (
        evaluate_language,
        language_demonstration,
        language_experiment,
        language_jobs,
    )

    try:
        jobs = language_jobs(run.corpus, run.results, only=run.only)
    except InputError as err:
        return StageResult("language", 0.0, note=f"not run: {err.message}")
    extra = 1 if run.settings.language_figure else 0
    records = evaluate_language(run.corpus, run.results, settings=run.evaluation,
                                workers=run.executor.workers, executor=run.executor,
                                only=run.only, progress=run.reporter("language", extra=extra))
    tables: dict[str, Any] = {}
    table, note = _table(lambda: language_experiment(records, run.figures))
    if table is not None:
        tables["language"] = table
    if extra:
        figure, why = _table(lambda: language_demonstration(records, run.corpus, run.figures,
                                                            settings=run.evaluation))
        if figure is not None:
            tables["language-figure"] = figure
        else:
            note = f"Fig. language not drawn: {why}"
        run.progress("language", len(jobs) + 1, len(jobs) + 1)
    return StageResult("language", 0.0, len(records), tables,
                       _written(run, "language.png", "language-figure.png", "language.json",
                                "language-figure.json"), note)


def _stage_showcase(run: _Run, records: list[dict]) -> StageResult:
    """One estimate, written out with its 3-D page: the image of the visibility stage
    with the most errors (corpus order on ties), coloured right and wrong by its truth."""
    from unseeable.corpus.build import load_corpus
    from unseeable.pipeline import Observation, estimate, write_estimate
    from unseeable.pipeline.search_cache import pose_searches_cached
    from unseeable.render.view import load_view
    from unseeable.report import estimate_scene, write_scene_page

    ok = [r for r in records if not r.get("failed")]
    if not ok:
        return StageResult("showcase", 0.0, note="not run: every image failed")
    run.progress("showcase", 0, 1)
    chosen = max(ok, key=lambda r: (r["errors_auto"], -records.index(r)))
    view = load_corpus(run.corpus)[chosen["name"]].view(chosen["angle"])
    with pose_searches_cached(run.evaluation.pose_searches):
        est = estimate([Observation.of(load_view(view.view),
                                       use_recorded_pose=run.settings.known_pose,
                                       source=view.view)], run.evaluation.estimate)
    run.showcase.mkdir(parents=True, exist_ok=True)
    path = write_estimate(est, run.showcase)
    scene = estimate_scene(path, truth=view.truth)
    page = write_scene_page(scene, run.showcase / "estimate.html")
    run.progress("showcase", 1, 1)
    table = {"name": chosen["name"], "angle": chosen["angle"],
             "errors": scene["truth"]["errors"], "truth_logs": scene["truth"]["logs"],
             "logs": None if est.structure is None else len(est.structure.logs),
             "confident": est.confident,
             "estimate": str(path.relative_to(run.figures.parent)),
             "page": str(page.relative_to(run.figures.parent))}
    return StageResult("showcase", 0.0, 1, {"showcase": table},
                       (table["estimate"], table["page"]))


def _table(make: Callable[[], dict]) -> tuple[dict | None, str | None]:
    """An experiment's table, or None and why when it has nothing to tabulate (every
    image failed, no image has errors for a sentence to fix, …)."""
    try:
        return make(), None
    except InputError as err:
        logger.info("no table: %s", err)
        return None, err.message


def _written(run: _Run, *names: str) -> tuple[str, ...]:
    return tuple(f"figures/{n}" for n in names if (run.figures / n).is_file())


@contextlib.contextmanager
def _executor(executor: Executor | None, scheduler: Any, workers: int,
              field: str) -> Iterator[Executor]:
    if executor is not None:
        yield executor
        return
    with open_executor(scheduler, workers=workers, field=field) as opened:
        yield opened


def reproduce(out: str | Path, *, settings: ReproduceSettings = FULL,
              corpus: str | Path | None = None, results: str | Path | None = None,
              workers: int = 2, scheduler: str | None = None,
              executor: Executor | None = None,
              progress: Callable[[str, int, int], None] | None = None) -> Reproduction:
    """Run every stage of the paper and write the report into ``out``.

    Parameters
    ----------
    out : path
        The report folder: ``report.md``, ``report.html``, ``report.json``,
        ``figures/`` and ``showcase/`` are written into it whole, at the end, or not at
        all.
    settings : ReproduceSettings
        :data:`FULL` (default) or :data:`QUICK`, or one's own.
    corpus : path, optional
        The corpus folder, a cache (default ``out/corpus``, or ``out/corpus-<name>``
        for settings other than the full ones). A corpus already there must have been
        rendered with the same settings.
    results : path, optional
        The experiments' record cache (default ``corpus/results``, that of
        ``unseeable experiment``).
    workers : int
        Local processes when neither ``scheduler`` nor ``executor`` is given.
    scheduler : str, optional
        An executor spec (``local:N``, ``tcp://HOST:PORT``; :func:`open_executor`),
        opened for the run.
    executor : Executor, optional
        An executor already open (overrides ``scheduler`` and ``workers``).
    progress : callable, optional
        ``progress(stage, done, total)`` as each stage's jobs finish (``stage`` a key
        of :data:`STAGES`).

    Returns
    -------
    Reproduction

    Raises
    ------
    InputError
        Before any work: ``out`` or ``corpus`` not a folder one can write to, a
        corpus of another version or of other render settings, an unreachable or
        malformed scheduler (each naming ``--out``, ``--corpus`` or ``--scheduler``).
        During the run: an input a stage cannot use; ``out`` is then as it was.
    """
    from unseeable.report.paper import write_report

    out = check_output_folder(out, field="--out")
    corpus_dir = Path(corpus) if corpus is not None else out / settings.corpus_folder
    corpus_dir = check_corpus_folder(corpus_dir.absolute(), settings)
    results_dir = check_output_folder(corpus_dir / "results" if results is None
                                      else Path(results).absolute(),
                                      field="--corpus" if results is None else "results")
    if executor is None and scheduler is None:
        workers = check_whole_number(workers, field="--workers", minimum=1)
    # Every stage reads the pose searches the visibility stage made (and the showcase and
    # Fig. language, run here, too): each photograph's pose is searched once.
    evaluation = settings.evaluation().searching_in(results_dir)
    report = progress or (lambda stage, done, total: None)
    started = _dt.datetime.now(_dt.UTC).replace(microsecond=0)
    host = machine()
    version = code_version()
    with _executor(executor, scheduler, workers, "--scheduler") as run_on, \
            output_folder(out, field="--out") as folder:
        logger.info("reproducing (%s) on %s into %s", settings.name, run_on.description, out)
        run = _Run(settings, evaluation, corpus_dir, results_dir, folder.path / "figures",
                   folder.path / "showcase", run_on, report)
        run.figures.mkdir()
        t_start = time.perf_counter()
        stages: list[StageResult] = []

        def timed(stage: Callable[[], Any]) -> Any:
            t0 = time.perf_counter()
            outcome = stage()
            result = outcome[0] if isinstance(outcome, tuple) else outcome
            stages.append(replace(result, seconds=time.perf_counter() - t0))
            logger.info("%s: %.1f s", result.name, stages[-1].seconds)
            return outcome

        timed(lambda: _stage_corpus(run))
        _, records = timed(lambda: _stage_visibility(run))
        timed(lambda: _stage_confidence(run, records))
        timed(lambda: _stage_views(run))
        timed(lambda: _stage_active(run))
        timed(lambda: _stage_language(run))
        if settings.showcase:
            timed(lambda: _stage_showcase(run, records))
        seconds = time.perf_counter() - t_start
        host = {**host, "load_start": host.pop("load"), "load_end": machine()["load"]}
        reproduction = Reproduction(settings, out, corpus_dir, results_dir, tuple(stages),
                                    version, host, run_on.description,
                                    started.isoformat(), seconds)
        written = write_report(reproduction, folder.path)
        files = {name: folder.final(path) for name, path in written.items()}
    return replace(reproduction, files=files)


def plan(corpus: str | Path, settings: ReproduceSettings = FULL) -> dict[str, int]:
    """The jobs each experiment stage of ``settings`` would run on a built ``corpus``
    (read from its manifest; nothing runs): images, views jobs, active-vision starting
    images, robot runs, language images."""
    from unseeable.corpus.build import load_corpus
    from unseeable.evaluate.active import active_jobs, robot_jobs
    from unseeable.evaluate.language import language_jobs
    from unseeable.evaluate.views import views_jobs

    only: Sequence[str] | None = settings.designs
    items = [item for item in load_corpus(corpus) if only is None or item.name in only]
    scratch = Path(corpus) / "results"

    def count(make: Callable[[], list]) -> int:
        try:
            return len(make())
        except InputError:
            return 0

    return {
        "structures": len(items),
        "images": sum(len(item.views) for item in items),
        "views": count(lambda: views_jobs(corpus, scratch, only=only,
                                          starts=settings.view_starts)),
        "active": count(lambda: active_jobs(corpus, scratch, only=only, starts=settings.starts,
                                            max_actions=settings.max_actions)),
        "robot": count(lambda: robot_jobs(corpus, scratch, start=settings.robot_start,
                                          only=only)) if settings.robot else 0,
        "language": count(lambda: language_jobs(corpus, scratch, only=only)),
    }
