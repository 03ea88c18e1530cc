"""Fitting the calibration on rendered training scenes: ``unseeable calibrate``'s library."""

import numpy as np
import pytest

from unseeable.errors import InputError, VisionError
from unseeable.vision.calibration import GROUPS


def raster_training_family():
    """A small raster-drawn scene family: calibrate's tests in seconds, not minutes."""
    from dataclasses import replace

    from unseeable.training.scenes import VALIDATION

    return replace(VALIDATION, name="raster-calibrate-test", renderer="raster", width=320,
                   height=240)


@pytest.mark.slow
def test_calibrate_gives_the_same_models_in_one_process_or_two(tmp_path):
    from unseeable.training import calibrate

    spec = raster_training_family()
    runs = [calibrate(6, spec=spec, cache=tmp_path, pose=False, workers=w, max_iter=20)
            for w in (1, 2)]
    for g in GROUPS:
        for kind in ("models", "context_models"):
            one, two = (getattr(c, kind)[g] for c in runs)
            assert np.array_equal(one.w1, two.w1) and one.b2 == two.b2
    assert runs[0].info == runs[1].info


@pytest.mark.slow
def test_calibrate_goes_on_when_the_pose_estimator_refuses_a_training_scene(tmp_path,
                                                                          monkeypatch):
    # A refit once stopped after 35 minutes on one scene with too few straight edges for
    # the yaw: such a scene has no pose sample, and the refit must not die of it.
    from unseeable.training import fit

    def pose_sample(scene, **_):
        if scene.seed == refused_seed:
            raise VisionError("no straight edges in the image to fix the assembly's yaw")
        rng = np.random.default_rng(scene.seed)
        return rng.random(4), bool(scene.seed % 2)

    spec = raster_training_family()
    refused_seed = fit.make_scene(spec, 3, cache=tmp_path).seed
    monkeypatch.setattr(fit, "pose_sample", pose_sample)
    cal = fit.calibrate(13, spec=spec, cache=tmp_path, workers=1, max_iter=20)
    assert cal.info["pose_refused_scenes"] == 1
    assert cal.pose_quality is not None


@pytest.mark.slow
def test_calibrate_resumes_where_it_stopped_with_the_same_result(tmp_path, monkeypatch):
    # A refit takes hours on a slow machine; one stopped in either stage must go on from
    # the scene it stopped at (stage 1's models from the checkpoint once fitted), and
    # resuming must give exactly what an uninterrupted run gives.
    from unseeable.training import fit

    options = dict(spec=raster_training_family(), cache=tmp_path, pose=False, workers=1,
                   max_iter=20)
    fresh = fit.calibrate(6, **options)
    checkpoint = tmp_path / "cal.json.stage1"
    folder = tmp_path / "cal.json.stage1.scenes"
    scene_job = fit.judge_scene
    judged = {1: [], 2: []}
    stop = {1: 3, 2: 2}  # scenes each stage judges before the run stops

    def counted(task):
        stage = 1 if task[6] is None else 2  # estimate_with: None in stage 1
        if stop[stage] is not None and len(judged[stage]) == stop[stage]:
            raise KeyboardInterrupt
        judged[stage].append(task[0])
        return scene_job(task)

    monkeypatch.setattr(fit, "judge_scene", counted)
    with pytest.raises(KeyboardInterrupt):
        fit.calibrate(6, checkpoint=checkpoint, **options)
    assert not checkpoint.exists() and len(list(folder.glob("1-*.pkl"))) == 3

    with pytest.raises(InputError, match="other training scenes or options"):
        fit.calibrate(6, checkpoint=checkpoint, resume=True, members=2, **options)
    judged[1].clear()
    stop[1] = None
    with pytest.raises(KeyboardInterrupt):
        fit.calibrate(6, checkpoint=checkpoint, resume=True, **options)
    assert judged[1] == [3, 4, 5] and checkpoint.is_file()

    # Stopped again in stage 2's fit, after two of its three networks (one per group).
    from unseeable.vision import calibration_fit

    fit_network = calibration_fit.fit_network
    fitted = []

    def counted_fit(task):
        if stop_fit is not None and len(fitted) == stop_fit:
            raise KeyboardInterrupt
        fitted.append(task[0])
        return fit_network(task)

    monkeypatch.setattr(calibration_fit, "fit_network", counted_fit)
    judged = {1: [], 2: []}
    stop[2], stop_fit = None, 2
    with pytest.raises(KeyboardInterrupt):
        fit.calibrate(6, checkpoint=checkpoint, resume=True, **options)
    assert judged == {1: [], 2: [2, 3, 4, 5]} and len(fitted) == 2
    assert len(list(folder.glob("net-2-*.pkl"))) == 2

    judged, fitted, stop_fit = {1: [], 2: []}, [], None
    resumed = fit.calibrate(6, checkpoint=checkpoint, resume=True, **options)
    assert judged == {1: [], 2: []} and len(fitted) == 1  # only the network not kept
    assert not checkpoint.exists() and not folder.exists()  # done: nothing left to resume
    for g in GROUPS:
        for kind in ("models", "context_models"):
            one, two = (getattr(c, kind)[g] for c in (fresh, resumed))
            assert np.array_equal(one.w1, two.w1) and one.b2 == two.b2
    assert resumed.info == fresh.info
    with pytest.raises(InputError, match="no calibration checkpoint"):
        fit.calibrate(6, checkpoint=checkpoint, resume=True, **options)
