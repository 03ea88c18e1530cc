"""Views with their truth for the benchmarks, and the one adapter to the estimator.

* :func:`corpus_views` / :func:`family_views`: the views of a rendered corpus
  (``unseeable corpus build``: designs in the corpus's order, each design's
  views by station angle), or the scenes of a rendered family
  (``benchmarks/vision.py``'s ``FAMILIES`` or a training family), as picklable
  :class:`ViewSource` tasks; :meth:`ViewSource.load` gives the view with its
  truth (:class:`TruthView`).
* :func:`add_view_arguments` / :func:`views_from_args`: the shared options
  ``--corpus``, ``--family``, ``--scenes``, ``--only``, ``--every``, ``--workers``.
* :func:`map_views`: a function over tasks in worker processes
  (:func:`unseeable.parallel.run_in_processes`), results in task order.
* :func:`run_pipeline` and :func:`fixpoint_on_detection`: every call the
  benchmarks make into :mod:`unseeable.pipeline` (and the estimator's own
  fixpoint), behind one small interface (:class:`PipelineRun`). When the
  estimator's API changes, this section is the one to edit.
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from rich.progress import Progress

from unseeable.domain import GridPose, Structure
from unseeable.parallel import run_in_processes

sys.path.insert(0, str(Path(__file__).resolve().parent))

__all__ = ["ViewSource", "TruthView", "corpus_views", "family_views", "add_view_arguments",
           "views_from_args", "map_views", "PipelineRun", "run_pipeline",
           "fixpoint_on_detection"]


# ---- views and their truth ---------------------------------------------------------------

@dataclass(frozen=True)
class ViewSource:
    """One view to measure: a corpus view (its files) or a scene of a rendered family.

    Attributes
    ----------
    label : str
        ``NAME@ANGLE`` for a corpus view, ``FAMILY#N`` for a scene.
    group : str
        The design's or the family's name.
    angle : float or None
        The corpus view's station angle (degrees).
    view_file, truth_file : Path or None
        The corpus view's files.
    scene : int or None
        The family scene's number.
    """

    label: str
    group: str
    angle: float | None = None
    view_file: Path | None = None
    truth_file: Path | None = None
    scene: int | None = None

    @property
    def key(self) -> str:
        """A name for seeding draws per view: the truth file's absolute path, or the label."""
        return str(self.truth_file.resolve()) if self.truth_file is not None else self.label

    def load(self) -> TruthView:
        """The view and its truth (a family scene is rendered, or read from the cache)."""
        from unseeable.render.view import View, load_truth, load_view

        if self.scene is None:
            truth = load_truth(self.truth_file)
            return TruthView(self, load_view(self.view_file), truth.shown, truth.pose,
                             np.asarray(truth.present, bool), np.asarray(truth.visible, bool))
        from unseeable.training.scenes import make_scene, scene_spec
        from vision import FAMILIES

        spec = FAMILIES[self.group] if self.group in FAMILIES else scene_spec(self.group)
        scene = make_scene(spec, self.scene)
        view = View(scene.image, scene.camera, scene.extent, pose=scene.pose)
        return TruthView(self, view, scene.structure, scene.pose,
                         np.asarray(scene.present, bool), np.asarray(scene.visible, bool))


@dataclass(frozen=True, eq=False)
class TruthView:
    """A view with what the simulator knows about it.

    Attributes
    ----------
    source : ViewSource
    view : View
        Image, camera, extent and the recorded pose.
    truth : Structure
        The structure photographed.
    pose : GridPose
        Its true pose.
    present, visible : (N,) bool
        Per feature of ``truth.extent``: present in the truth, visible from the camera.
    """

    source: ViewSource
    view: Any
    truth: Structure
    pose: GridPose
    present: np.ndarray
    visible: np.ndarray


def _names(only: str | Iterable[str]) -> set[str]:
    if isinstance(only, str):
        return {n for n in only.split(",") if n}
    return set(only)


def corpus_views(corpus: str | Path, *, only: str | Iterable[str] = (),
                 every: int = 1) -> list[ViewSource]:
    """Every ``every``-th view of a rendered corpus, designs in the corpus's order, each
    design's views by station angle; ``only``: these designs (names, or comma-separated)."""
    from unseeable.corpus import load_corpus

    names = _names(only)
    out = [ViewSource(f"{item.name}@{view.angle:g}", item.name, float(view.angle),
                      view.view, view.truth)
           for item in load_corpus(corpus) if not names or item.name in names
           for view in sorted(item.views, key=lambda v: v.angle)]
    return out[::every]


def family_views(family: str, scenes: int, *, every: int = 1) -> list[ViewSource]:
    """Every ``every``-th of the first ``scenes`` scenes of a rendered family."""
    return [ViewSource(f"{family}#{n}", family, scene=n) for n in range(scenes)][::every]


def add_view_arguments(parser, *, families: bool = False, workers: int = 2) -> None:
    """Add ``--corpus``, ``--only``, ``--every``, ``--workers`` (and ``--family``,
    ``--scenes`` when the measure takes scene families)."""
    parser.add_argument("--corpus", type=Path, required=not families, help="corpus folder")
    if families:
        parser.add_argument("--family", help="a rendered scene family instead of a corpus: "
                            "one of benchmarks/vision.py's families or a training family")
        parser.add_argument("--scenes", type=int, default=60, help="scenes of --family")
    parser.add_argument("--only", default="", help="comma-separated design names")
    parser.add_argument("--every", type=int, default=1, help="every n-th view only")
    parser.add_argument("--workers", type=int, default=workers, help="processes")


def views_from_args(parser, args) -> list[ViewSource]:
    """The views the options of :func:`add_view_arguments` ask for (``parser.error``
    when they ask for none or are inconsistent)."""
    family = getattr(args, "family", None)
    if (args.corpus is None) == (family is None):
        parser.error("give one of --corpus and --family")
    if args.every < 1 or args.workers < 1 or getattr(args, "scenes", 1) < 1:
        parser.error("--every, --workers and --scenes must be at least 1")
    if family is not None:
        return family_views(family, args.scenes, every=args.every)
    views = corpus_views(args.corpus, only=args.only, every=args.every)
    if not views:
        only = _names(args.only)
        parser.error(f"no views under {args.corpus}" + (f" for {sorted(only)}" if only else ""))
    return views


class _Indexed:
    """``fn`` applied to ``(index, task)``, keeping the index (picklable when ``fn`` is)."""

    def __init__(self, fn: Callable[[Any], Any]) -> None:
        self.fn = fn

    def __call__(self, item: tuple[int, Any]) -> tuple[int, Any]:
        return item[0], self.fn(item[1])


def map_views(fn: Callable[[Any], Any], tasks: Sequence[Any], *, workers: int,
              description: str = "estimating") -> list[Any]:
    """``[fn(task) for task in tasks]`` in ``workers`` processes, with a progress bar.

    ``fn`` must be importable by the workers (a module-level function of a script
    run as ``python benchmarks/...`` is).
    """
    out: list[Any] = [None] * len(tasks)
    with Progress(transient=True) as progress:
        bar = progress.add_task(description, total=len(tasks))
        for n, result in run_in_processes(_Indexed(fn), list(enumerate(tasks)),
                                          workers=workers):
            out[n] = result
            progress.advance(bar)
    return out


# ---- the adapter to the estimator ----------------------------------------------------------

@dataclass(frozen=True, eq=False)
class PipelineRun:
    """What the benchmarks read of one estimate of one photograph.

    Attributes
    ----------
    structure : Structure or None
    pose : GridPose
        The pose the features were detected at.
    priors : (N,) float
        The evidence the estimate was made under (the detections, shifted by
        ``presence_shift``; ½ on features occluded or not judged).
    visible : (N,) bool
        The estimate's visibility.
    presence_shift : float
        The shift of the detections' log-odds the estimate was made under.
    confident : bool or None
        The δ* test (None when not run).
    timings : dict
        Seconds per stage (``total_s``: all).
    detection : FeatureDetection
        The detections at ``pose``.
    camera : Camera
        The view's camera.
    """

    structure: Structure | None
    pose: GridPose
    priors: np.ndarray
    visible: np.ndarray
    presence_shift: float
    confident: bool | None
    timings: dict
    detection: Any
    camera: Any

    def line_aliases(self):
        """The segment features that share image lines, as the estimator counts them."""
        from unseeable.pipeline import line_aliases

        return line_aliases(self.detection, self.camera)

    def view_evidence(self, view, *, start: np.ndarray | None = None,
                      correct: Callable[[np.ndarray], np.ndarray] | None = None):
        """The detections as the estimator's fixpoint takes them
        (:class:`~unseeable.visibility.loop.ViewEvidence`): ``start`` priors (default the
        detection's), re-weighed by what lies behind each feature when the calibration
        can, image lines counted once; every prior passed through ``correct``."""
        from unseeable.visibility.loop import ViewEvidence

        det = self.detection
        fix = (lambda p: p) if correct is None else correct
        context = None
        if det.has_context:
            def context(behind):
                return fix(det.priors_given(behind))
        return ViewEvidence(
            fix(det.p if start is None else start), self.camera.centre, det.pose,
            judged=det.judged, removed_from_layer=view.removed_from_layer,
            context_priors=context,
            clip=None if det.calibration is None else det.calibration.clip,
            line_aliases=self.line_aliases())


def run_pipeline(view, *, known_pose: bool = True, confidence: bool = True,
                 calibration=None, presence_shift: bool = True, lines_once: bool = True,
                 threads: int = 1, strict_pose: bool = True,
                 joint_cost: float | None = None) -> PipelineRun:
    """The shipped estimator on one photograph (as ``unseeable experiment`` runs it).

    Parameters
    ----------
    view : View
    known_pose : bool
        Use the pose the view records (polished on the image); False: find it.
    confidence : bool
        Run the δ* test.
    calibration : Calibration, optional
        The detectors' (the shipped one by default).
    presence_shift, lines_once : bool
        The estimator's switches of those names.
    threads : int
        Threads of the pose search.
    strict_pose : bool
        Refuse a poorly fitting estimated pose (:class:`~unseeable.errors.VisionError`).
    joint_cost : float, optional
        The structure prior's cost of a joint (default: the shipped prior's).
    """
    from unseeable.pipeline import EstimateSettings, estimate_view

    settings = EstimateSettings.from_options(
        calibration=calibration, presence_shift=presence_shift, lines_once=lines_once,
        threads=threads, strict=strict_pose, enabled=confidence, joint_cost=joint_cost)
    est = estimate_view(view, settings, use_recorded_pose=known_pose)
    record = est.views[0]
    return PipelineRun(est.structure, record.pose, np.asarray(record.priors, float),
                       np.asarray(record.visible, bool), float(record.presence_shift),
                       est.confident, dict(est.timings), record.detection, view.camera)


def fixpoint_on_detection(view, detection, *, correct: Callable[[np.ndarray], np.ndarray]
                          ) -> PipelineRun:
    """The estimator's structure ⇄ visibility fixpoint at a known pose on given detections,
    every prior they give passed through ``correct`` first.

    As :func:`run_pipeline` makes its estimate at a known pose (context re-weighing,
    presence shift, image lines counted once, the shipped structure prior and tie
    policy), from ``detection`` (e.g. :attr:`PipelineRun.detection`) instead of
    detecting again; ``correct`` maps an ``(N,)`` array of the detection's priors to
    the priors to use (the start priors and each re-weighing by what lies behind).
    No confidence test.
    """
    from unseeable.grammar.priors import StructurePrior
    from unseeable.solve import StructureSolver
    from unseeable.visibility import BACKGROUND_INPUTS, initial_visibility
    from unseeable.visibility.loop import estimate_with_visibility

    prior = StructurePrior()
    det = detection
    extent = view.extent
    # With context, the estimator starts from every feature seen against the table.
    start = (det.priors_given(np.zeros((len(det.p), len(BACKGROUND_INPUTS))))
             if det.has_context else det.p)
    given = PipelineRun(None, det.pose, det.p, det.judged, 0.0, None, {}, det, view.camera)
    evidence = given.view_evidence(view, start=start, correct=correct)
    solver = StructureSolver(extent, ties=prior.ties)
    fp = estimate_with_visibility(evidence, extent, solver=solver,
                                  initial_visibility=initial_visibility(extent, view.camera,
                                                                        det.pose),
                                  time_limit=60.0, budget_s=60.0, presence_shift=True,
                                  structure_prior=prior.given_visibility(extent))
    priors = np.where(fp.visibility[0] & evidence.judged, fp.priors[0], 0.5)
    shift = fp.presence_shift[0] if fp.presence_shift else 0.0
    return PipelineRun(fp.result.structure, det.pose, priors, np.asarray(fp.visibility[0]),
                       float(shift), None, {}, det, view.camera)
