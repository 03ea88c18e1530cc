"""Fitting the detector calibration on rendered training scenes (``unseeable calibrate``)."""

from __future__ import annotations

import functools
import hashlib
import logging
import pickle
from collections.abc import Callable, Iterable
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from unseeable.domain import GridPose, LogGeometry
from unseeable.errors import InputError, VisionError, check_whole_number
from unseeable.executor import Executor, executor_or_processes
from unseeable.fileio import atomic_write_bytes
from unseeable.training.scenes import (
    TRAIN,
    TRAIN_HALLS,
    TRAIN_LOOKS,
    TRAIN_TALL,
    TRAIN_WALLS,
    Scene,
    SceneSpec,
    make_scene,
)
from unseeable.vision.calibration import GROUPS, Calibration, GroupModel, NetworkKey
from unseeable.vision.calibration_fit import fit_calibration, fit_pose_quality
from unseeable.vision.detectors import DetectorSettings, feature_kind_groups, score_features
from unseeable.vision.pose import PoseSettings, estimate_pose, pose_equivalent, refine_pose
from unseeable.vision.pose_choice import select_pose
from unseeable.vision.scale import view_edge_maps

__all__ = ["scene_samples", "training_samples", "pose_sample", "calibrate", "judge_scene"]

logger = logging.getLogger(__name__)


def _jittered(pose: GridPose, rng: np.random.Generator, noise: tuple[float, float]) -> GridPose:
    t_mm, yaw_deg = noise
    return GridPose(pose.x + float(rng.normal(0, t_mm)), pose.z + float(rng.normal(0, t_mm)),
                    pose.yaw_deg + float(rng.normal(0, yaw_deg)))


def scene_samples(scene: Scene, *, geometry: LogGeometry = LogGeometry(),
                  settings: DetectorSettings = DetectorSettings(),
                  pose_noise: tuple[float, float] = (1.0, 0.3), refine: bool = True,
                  seed: int = 0, estimate_with: Calibration | None = None
                  ) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Detector statistics and truth of the visible features of one scene, per group.

    The detectors see the scene as they will at run time: from the true pose
    disturbed by ``pose_noise`` (mm, degrees; 1σ) and then, with ``refine``,
    polished on the image, as :func:`unseeable.vision.detect_features` does.

    Parameters
    ----------
    estimate_with : Calibration, optional
        Take what lies behind each feature from the pipeline's own estimate of
        the scene (:func:`unseeable.pipeline.estimate_view` at the true pose,
        with this calibration) instead of from the true structure: the
        context the models will be given at run time. The pipeline works in
        the default log geometry, as the estimate here does.

    Returns
    -------
    dict of str to (stats (M, S), present (M,) bool, behind (M, 2) float)
        ``behind``: :func:`unseeable.visibility.background_context`, the
        context models' extra inputs.
    """
    from unseeable.visibility import background_context

    rng = np.random.default_rng([int(seed), int(scene.seed)])
    maps = view_edge_maps(scene.image, scene.camera, sigma=settings.sigma)
    pose = _jittered(scene.pose, rng, pose_noise)
    if refine:
        pose = refine_pose(maps, scene.camera, scene.extent, pose, geometry=geometry,
                           settings=PoseSettings(sigma=settings.sigma))
    scores = score_features(scene.image, scene.camera, pose, scene.extent, mask=scene.visible,
                            geometry=geometry, settings=settings, maps=maps)
    structure, at = scene.structure, scene.pose
    if estimate_with is not None:
        from unseeable.pipeline import EstimateSettings, estimate_view
        from unseeable.render.view import View

        view = View(image=scene.image, camera=scene.camera, extent=scene.extent, pose=scene.pose)
        settings = EstimateSettings.from_options(enabled=False, calibration=estimate_with)
        estimate = estimate_view(view, settings)
        structure, at = estimate.structure, estimate.pose
    behind = background_context(structure, scene.camera.centre, at, geometry=geometry)
    out = {}
    for name, member in feature_kind_groups(scores.kind).items():
        sel = member & scores.judged
        stats = scores.end_stats if name == "end" else scores.segment_stats
        out[name] = (stats[sel], scene.present[sel], behind[sel])
    return out


def training_samples(scenes: Iterable[Scene], **kwargs) -> dict[str, tuple[np.ndarray, ...]]:
    """:func:`scene_samples` of many scenes, concatenated per group."""
    parts: dict[str, list] = {g: [] for g in GROUPS}
    for scene in scenes:
        for g, arrays in scene_samples(scene, **kwargs).items():
            parts[g].append(arrays)
    return _concatenated(parts)


def _concatenated(parts: dict[str, list]) -> dict[str, tuple[np.ndarray, ...]]:
    return {g: tuple(np.concatenate(column) for column in zip(*items))
            for g, items in parts.items() if items}


def pose_sample(scene: Scene, *, geometry: LogGeometry = LogGeometry(),
                calibration: Calibration | None = None) -> tuple[np.ndarray, bool]:
    """Fit statistics of the pose estimated on one scene, and whether it came out right.

    Right means that the pose the structure choice (:func:`~unseeable.vision.select_pose`,
    with ``calibration``'s detectors) makes of the fit is within 2 mm and 1° of the truth
    (a half turn being the same pose): the pose a user of ``unseeable pose`` or the
    pipeline gets, so that the quality fitted on these samples is the probability of that.
    """
    maps = view_edge_maps(scene.image, scene.camera, pose=True)
    fit = estimate_pose(scene.image, scene.camera, scene.extent, geometry=geometry,
                        strict=False, maps=maps)
    chosen = select_pose(scene.image, scene.camera, scene.extent, fit, calibration=calibration,
                         geometry=geometry, maps=maps)
    dt, dy = pose_equivalent(chosen.pose, scene.pose, scene.extent, geometry=geometry)
    return fit.stats, bool(dt <= 2.0 and dy <= 1.0)


def calibrate(count: int, *, spec: SceneSpec = TRAIN, walls: int = 0, tall: int = 0,
              looks: int = 0, halls: int = 0, start: int = 0,
              cache: Path | None = None, geometry: LogGeometry = LogGeometry(),
              settings: DetectorSettings = DetectorSettings(), pose: bool = True,
              progress: Callable[[int, int], None] | None = None, workers: int = 1,
              executor: Executor | None = None, max_iter: int = 1000, members: int = 1,
              checkpoint: Path | None = None,
              resume: bool = False) -> Calibration:
    """Render (or read from the cache) ``count`` training scenes and fit the calibration.

    In two stages: the plain models and context models told the truth's share of wood
    behind each feature; then, with that calibration, the pipeline's own estimate of every
    scene (at its true pose), and the final context models fitted on what lies behind each
    feature under that estimate (:func:`scene_samples` ``estimate_with``) — the context
    they get at run time.

    Parameters
    ----------
    count : int
        Number of training scenes.
    spec : SceneSpec
        The scene family (the training family by default; never the validation one).
    walls : int
        Number of walled training scenes (:data:`~unseeable.training.scenes.TRAIN_WALLS`:
        cabins, walls and partitions) added to the ``count`` scenes of ``spec``.
    tall : int
        Number of tall and large training scenes (:data:`~unseeable.training.scenes.TRAIN_TALL`:
        towers, screen walls, big cabins) added as well.
    looks : int
        Number of training scenes in the looks the others lack
        (:data:`~unseeable.training.scenes.TRAIN_LOOKS`: hard shadows, plain logs) added too.
    halls : int
        Number of big cabins with several rooms, doors and windows
        (:data:`~unseeable.training.scenes.TRAIN_HALLS`) added too.
    start : int
        Index of the first scene.
    cache : path, optional
        Render cache (see :func:`unseeable.training.scenes.default_cache_dir`).
    geometry : LogGeometry
    settings : DetectorSettings
    pose : bool
        Also fit the pose quality model (runs the pose estimator on every scene but the
        tall ones).
    progress : callable(done, total), optional
        Called after each scene of either stage (``total``: twice the scene count).
    workers : int
        Processes reading and judging the scenes (when no ``executor`` is given), and
        fitting the networks. The result does not depend on it.
    executor : Executor, optional
        Reads and judges the scenes (:mod:`unseeable.executor`: local processes or a Dask
        cluster); default ``workers`` local processes. The result does not depend on it.
    max_iter : int
        L-BFGS iterations of each network's fit
        (:func:`~unseeable.vision.calibration_fit.fit_group`).
    members : int
        Networks in each plain and final context model
        (:func:`~unseeable.vision.calibration_fit.fit_calibration`).
    checkpoint : path, optional
        File that keeps stage 1's models (about half the time of a refit), written once
        stage 1 is fitted, so that a refit that stops in stage 2 need not redo stage 1.
        Every scene either stage judges, and every network it fits, is kept too, as it
        comes, in the folder ``checkpoint`` + ``.scenes``. Both are removed when the
        calibration is done.
    resume : bool
        Take up a stopped run: stage 1's models from ``checkpoint`` when it was fitted,
        and in either stage the scenes already judged and networks already fitted,
        judging and fitting only the rest. What is
        kept must be of the same scenes and options; it records those, not the code, so
        do not resume after changing the detectors. The result is the one a run without
        a checkpoint gives.

    Returns
    -------
    Calibration

    Raises
    ------
    InputError
        ``resume`` with nothing kept to resume from, or with what another run of other
        scenes or options kept.
    """
    check_whole_number(members, field="members", minimum=1)
    if resume and checkpoint is None:
        raise InputError("calibrate: resume=True needs a checkpoint file, got None")
    jobs = [(spec, n) for n in range(start, start + count)]
    jobs += [(TRAIN_WALLS, n) for n in range(start, start + walls)]
    jobs += [(TRAIN_TALL, n) for n in range(start, start + tall)]
    jobs += [(TRAIN_LOOKS, n) for n in range(start, start + looks)]
    jobs += [(TRAIN_HALLS, n) for n in range(start, start + halls)]
    total = 2 * len(jobs)
    judging = executor_or_processes(executor, workers)
    pose_stats, pose_right = [], []
    refused = 0  # scenes the pose estimator refused outright: no pose sample

    def samples(estimate_with: Calibration | None, done: int, stage: int,
                saved: dict[tuple[int, int], tuple]) -> dict[str, tuple]:
        nonlocal refused
        parts: dict[str, list] = {g: [] for g in GROUPS}
        tasks = [(index, family, n, geometry, cache, settings, estimate_with,
                  # The pose-quality model is fitted on the random and walled scenes only:
                  # with the tall ones as well it refused more of the validation views, most
                  # of them right, and the poses it returned were no more often right
                  # (docs/benchmarks.md); the big cabins are left out with them. In stage 2,
                  # so that the choice has stage 1's detectors.
                  pose and estimate_with is not None
                  and family not in (TRAIN_TALL, TRAIN_HALLS))
                 for index, (family, n) in enumerate(jobs)]
        results: dict[int, tuple] = {}
        for index in range(len(tasks)):
            if (stage, index) in saved:  # judged before the run was stopped
                results[index] = saved[(stage, index)]
        done += len(results)
        if results and progress is not None:
            progress(done, total)
        todo = [task for task in tasks if task[0] not in results]
        for index, arrays, pose_result, pose_failed in judging.map_unordered(judge_scene,
                                                                             todo):
            results[index] = (arrays, pose_result, pose_failed)
            if scenes_folder is not None:
                _save_scene(scenes_folder, key, stage, index, results[index])
            done += 1
            if progress is not None:
                progress(done, total)
        # In the scenes' order, whichever finished first: the fits do not depend on workers.
        for index in range(len(tasks)):
            arrays, pose_result, pose_failed = results[index]
            refused += pose_failed
            for g, a in arrays.items():
                parts[g].append(a)
            if pose_result is not None:
                pose_stats.append(pose_result[0])
                pose_right.append(pose_result[1])
        return _concatenated(parts)

    info = {"scenes": int(count), "scene_family": spec.name, "scene_key": spec.key(),
            "first_scene": int(start), "walled_scenes": int(walls),
            "walled_key": TRAIN_WALLS.key(), "tall_scenes": int(tall),
            "tall_key": TRAIN_TALL.key(), "max_iter": int(max_iter)}
    if looks:
        info.update(looks_scenes=int(looks), looks_key=TRAIN_LOOKS.key())
    if halls:
        info.update(halls_scenes=int(halls), halls_key=TRAIN_HALLS.key())
    # Everything stage 1 depends on but the code: a checkpoint of other options is refused.
    key = hashlib.sha256(repr(([(f.key(), n) for f, n in jobs], geometry, settings,
                               max_iter, members)).encode()).hexdigest()
    # Every scene judged is kept beside the checkpoint as it comes, so that a run stopped
    # while judging (each stage's longest part) resumes at the scene it stopped at.
    scenes_folder = None if checkpoint is None else _scenes_folder(Path(checkpoint))
    saved: dict[tuple[int, int], tuple] = {}
    networks: dict[tuple[str, NetworkKey], GroupModel] = {}
    if scenes_folder is not None and not resume:
        _clear_kept(scenes_folder)  # another run's: stale
    elif scenes_folder is not None:
        saved, networks = _read_kept(scenes_folder, key)

    def kept(fit: str) -> dict[str, Any]:
        # Each network is kept as it is fitted too: a stage's fit takes most of an hour on
        # two cores, and a run stopped in it takes up the networks it had.
        if scenes_folder is None:
            return {}
        return {"fitted": {name: net for (f, name), net in networks.items() if f == fit},
                "on_fitted": functools.partial(_save_network, scenes_folder, key, fit)}
    if resume and Path(checkpoint).is_file():
        plain, first = _read_stage_one(Path(checkpoint), key)
        if progress is not None:
            progress(len(jobs), total)
    else:
        if resume and not saved and not networks:
            raise InputError(f"{checkpoint}: no calibration checkpoint to resume from")
        # Stage 1: the plain models, and context models told the truth's share of wood
        # behind each feature, which the pipeline needs to estimate the training scenes as
        # it would.
        truth = samples(None, 0, 1, saved)
        plain = fit_calibration({g: (s, p) for g, (s, p, _) in truth.items()}, info=info,
                                max_iter=max_iter, members=members, workers=workers,
                                **kept("1"))
        # One network each is enough for these: they only lead stage 2's estimates.
        first = fit_calibration({g: (s, p, b[:, :1]) for g, (s, p, b) in truth.items()},
                                info=plain.info, plain=plain.models, max_iter=max_iter,
                                workers=workers, **kept("1-lead"))
        if checkpoint is not None:
            # Pickled, not the calibration file's JSON: its rounding would make a resumed
            # run differ from an uninterrupted one.
            atomic_write_bytes(checkpoint, pickle.dumps(
                {"format": _CHECKPOINT_FORMAT, "key": key, "plain": plain, "first": first}))
            logger.info("stage 1 of the calibration saved in %s", checkpoint)
    # Stage 2: the context models, given what lies behind each feature under the pipeline's
    # own estimate: told the truth's background they trusted it more than an estimate's
    # deserves (docs/benchmarks.md, "What lies behind a feature").
    estimated = samples(first, len(jobs), 2, saved)
    cal = fit_calibration(estimated, info={**plain.info, "context_from": "estimate"},
                          plain=first.models, max_iter=max_iter, members=members,
                          workers=workers, **kept("2"))
    if pose:
        right = np.asarray(pose_right, bool)
        cal.info["pose_right_share"] = round(float(right.mean()), 4)
        cal.info["pose_right_of"] = "chosen"
        if refused:
            cal.info["pose_refused_scenes"] = refused
        model = fit_pose_quality(np.asarray(pose_stats), right)
        cal = replace(cal, pose_quality=model)
    if checkpoint is not None:
        Path(checkpoint).unlink(missing_ok=True)
        _clear_kept(scenes_folder)
        if scenes_folder.is_dir() and not any(scenes_folder.iterdir()):
            scenes_folder.rmdir()
    return cal


_CHECKPOINT_FORMAT = "unseeable-calibrate-stage1/1"
_SCENE_FORMAT = "unseeable-calibrate-scene/1"
_NETWORK_FORMAT = "unseeable-calibrate-network/1"


def _read_stage_one(path: Path, key: str) -> tuple[Calibration, Calibration]:
    """Stage 1's plain and leading calibrations from a checkpoint :func:`calibrate` wrote."""
    if not path.is_file():
        raise InputError(f"{path}: no calibration checkpoint to resume from")
    saved = _read_record(path, _CHECKPOINT_FORMAT, "a calibration checkpoint", key)
    logger.info("stage 1 of the calibration read from %s", path)
    return saved["plain"], saved["first"]


def _read_record(path: Path, expected: str, what: str, key: str) -> dict:
    """One of the pickled records :func:`calibrate` keeps, checked to be of its format and
    of this run's scenes and options (``key``)."""
    try:
        # Our own file, written by calibrate on this machine.
        saved = pickle.loads(path.read_bytes())  # noqa: S301
    except Exception as err:  # a truncated or foreign file: any unpickling error
        raise InputError(f"{path}: not {what} ({err})") from err
    if not isinstance(saved, dict) or saved.get("format") != expected:
        raise InputError(f"{path}: not {what} (format "
                         f"{saved.get('format') if isinstance(saved, dict) else None!r}, "
                         f"expected {expected!r})")
    if saved.get("key") != key:
        raise InputError(f"{path}: {what} kept for other training scenes or options than "
                         "these; run without resuming to start afresh")
    return saved


def _scenes_folder(checkpoint: Path) -> Path:
    """Where :func:`calibrate` keeps the scenes it judged and networks it fitted: beside its
    checkpoint."""
    return checkpoint.with_name(checkpoint.name + ".scenes")


def _save_scene(folder: Path, key: str, stage: int, index: int, result: tuple) -> None:
    # Pickled, as the checkpoint is: the samples must come back bit for bit.
    atomic_write_bytes(folder / f"{stage}-{index:05d}.pkl",
                       pickle.dumps({"format": _SCENE_FORMAT, "key": key, "result": result}))


def _save_network(folder: Path, key: str, fit: str, name: NetworkKey,
                  network: GroupModel) -> None:
    (group, prefix), seed = name
    atomic_write_bytes(folder / f"net-{fit}-{prefix}{group}-{seed}.pkl",
                       pickle.dumps({"format": _NETWORK_FORMAT, "key": key, "fit": fit,
                                     "name": name, "network": network}))


def _clear_kept(folder: Path) -> None:
    for path in folder.glob("*.pkl"):
        path.unlink()


def _read_kept(folder: Path, key: str) -> tuple[dict[tuple[int, int], tuple],
                                                dict[tuple[str, NetworkKey], GroupModel]]:
    """What a stopped run kept: judged scenes by (stage, scene index) (:func:`_save_scene`)
    and fitted networks by (fit, network) (:func:`_save_network`)."""
    saved, networks = {}, {}
    for path in sorted(folder.glob("*.pkl")):
        if path.name.startswith("net-"):
            record = _read_record(path, _NETWORK_FORMAT, "a fitted network", key)
            networks[(record["fit"], record["name"])] = record["network"]
            continue
        try:
            stage, index = (int(part) for part in path.stem.split("-"))
        except ValueError as err:
            raise InputError(f"{path}: not a judged training scene ({err})") from err
        saved[(stage, index)] = _read_record(path, _SCENE_FORMAT, "a judged training scene",
                                             key)["result"]
    if saved or networks:
        logger.info("%d judged training scenes and %d fitted networks read from %s",
                    len(saved), len(networks), folder)
    return saved, networks


def judge_scene(task: tuple) -> tuple[int, dict[str, tuple], tuple[np.ndarray, bool] | None,
                                      bool]:
    """One training scene's samples (and its pose sample when asked): a worker's task.

    Returns the scene's index, its samples, its pose sample (None when not asked or when
    the pose estimator could not fit the scene at all) and whether it could not.
    """
    index, family, n, geometry, cache, settings, estimate_with, with_pose = task
    scene = make_scene(family, n, geometry=geometry, cache=cache)
    arrays = scene_samples(scene, geometry=geometry, settings=settings,
                           estimate_with=estimate_with)
    pose_result, pose_failed = None, False
    if with_pose:
        try:
            pose_result = pose_sample(scene, geometry=geometry, calibration=estimate_with)
        except VisionError as err:
            # A scene the estimator refuses outright (e.g. too few straight edges for the
            # yaw) has no fit statistics: the pipeline refuses such a photograph before the
            # quality model is asked, so it has no place among the model's samples.
            logger.warning("%s scene %d: no pose sample (%s)", family.name, n, err)
            pose_failed = True
    return index, arrays, pose_result, pose_failed
