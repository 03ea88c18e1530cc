"""The active-vision loop with a pool of photographs and with the robot
(unseeable.active.run, .sources, .files)."""

import json

import pytest
from scene import HIDDEN_CABIN, POSE, RasterWorkspace, raster_view

from unseeable.active import (
    STOP_REASONS,
    PhotographPool,
    WorkspaceSource,
    pool_actions,
    run_active,
    write_active,
)
from unseeable.errors import InputError
from unseeable.pipeline import EstimateSettings, Observation
from unseeable.render.view import View, save_view


@pytest.fixture(scope="module")
def pool_run(tmp_path_factory):
    """From station 150°, choosing among four other stations and three disassemblies."""
    d = tmp_path_factory.mktemp("pool")
    files = []
    for angle, layer in [(90.0, None), (120.0, None), (180.0, None), (210.0, None),
                         (150.0, 1), (150.0, 2), (150.0, 3)]:
        name = f"c{angle:g}" + ("" if layer is None else f"-L{layer}")
        files.append(d / f"{name}.json")
        save_view(raster_view(angle, layer), files[-1], image_path=d / f"{name}.png")
    actions = pool_actions(files, raster_view(150.0))
    pool = PhotographPool(actions, known_pose=True)
    run = run_active([Observation.of(raster_view(150.0))], pool, max_actions=4,
                     truth=HIDDEN_CABIN, truth_pose=POSE)
    return run, pool, d


def test_the_loop_takes_actions_until_confident_and_is_then_right(pool_run):
    run, pool, _ = pool_run
    assert run.stopped in STOP_REASONS
    assert run.steps[0].confident is False and len(run.steps) >= 2
    assert run.stopped == "confident" and run.estimate.confident
    assert run.steps[-1].errors == 0
    # Each step adds the photograph its plan chose, and a chosen candidate is used once.
    for before, after in zip(run.steps, run.steps[1:]):
        assert after.action is before.plan.action
    assert len({id(a) for a in run.actions}) == len(run.actions)


def test_a_candidate_image_is_read_only_once_chosen(pool_run):
    run, pool, _ = pool_run
    for a in pool.actions:
        assert a.source.loaded == any(a is b for b in run.actions)


def test_the_run_is_written_as_estimate_steps_and_a_strip(pool_run, tmp_path):
    from unseeable.pipeline import load_estimate
    from unseeable.render.view import read_image

    run, _, _ = pool_run
    files = write_active(run, tmp_path, truth=HIDDEN_CABIN, truth_pose=POSE)
    assert load_estimate(files["estimate"]).confident is True
    data = json.loads(files["active"].read_text())
    assert data["format"] == "unseeable/active@1" and data["stopped"] == "confident"
    assert [s["step"] for s in data["steps"]] == list(range(len(run.steps)))
    first = data["steps"][0]["plan"]
    assert first["chosen_action"] == run.actions[0].name and first["solves"] >= 1
    assert all({"delta_low", "delta_high", "revealed_features"} <= set(c)
               for c in first["candidates"])
    strip = read_image(files["strip"])
    assert strip.shape[0] > 200 * len(run.steps)


def test_no_actions_at_all_is_a_stop_not_an_error():
    pool = PhotographPool([], known_pose=True)
    run = run_active([Observation.of(raster_view(150.0))], pool, max_actions=3)
    assert run.stopped == "no actions" and len(run.steps) == 1
    run = run_active([Observation.of(raster_view(150.0))], pool, max_actions=0)
    assert run.stopped == "max actions"


def test_bad_input_is_refused():
    with pytest.raises(InputError, match="max_actions"):
        run_active([Observation.of(raster_view(150.0))], PhotographPool([]), max_actions=-1)
    with pytest.raises(InputError, match="confidence"):
        run_active([Observation.of(raster_view(150.0))], PhotographPool([]),
                   EstimateSettings.from_options(enabled=False))


def test_a_candidate_of_another_extent_is_refused_naming_its_file(tmp_path):
    from unseeable.domain import Extent

    v = raster_view(90.0)
    other = View(v.image, v.camera, Extent(4, 4, 3), pose=POSE)
    save_view(other, tmp_path / "other.json", image_path=tmp_path / "other.png")
    with pytest.raises(InputError, match="extent") as err:
        pool_actions([tmp_path / "other.json"], raster_view(150.0))
    assert "other.json" in str(err.value)


def test_the_robot_cannot_put_back_what_it_removed():
    ws = RasterWorkspace()
    source = WorkspaceSource(ws, (90.0, 150.0), taken=[(150.0, None)], known_pose=True)
    first = source.available()
    assert [(a.station, a.removed_from_layer) for a in first][:1] == [(90.0, None)]
    assert {a.removed_from_layer for a in first} == {None, 1, 2, 3}
    removal = next(a for a in first if a.removed_from_layer == 2 and a.station == 90.0)
    obs = source.take(removal)
    assert obs.view.removed_from_layer == 2 and ws.observed == [(90.0, 2)]
    later = source.available()
    assert {a.removed_from_layer for a in later} == {1, 2}
    assert all((a.station, a.removed_from_layer) != (90.0, 2) for a in later)
    with pytest.raises(InputError, match="off the table"):
        source.take(first[0])


def test_the_robot_loop_reads_only_its_pictures_and_ends_right_when_confident():
    ws = RasterWorkspace()
    source = WorkspaceSource(ws, (90.0, 120.0, 150.0, 180.0, 210.0), taken=[(150.0, None)])
    run = run_active([Observation.of(ws.observe(150.0), use_recorded_pose=False)], source,
                     max_actions=4, truth=HIDDEN_CABIN, truth_pose=POSE)
    assert len(ws.observed) == len(run.steps)
    assert all(o.pose is None for o in run.estimate.model.observations)  # found, not read
    assert run.steps[0].confident is False
    assert run.stopped == "confident" and run.steps[-1].errors == 0
