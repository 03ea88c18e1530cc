"""The command line as a user meets it: exit codes, one-line errors, files written."""

import json

import numpy as np
import pytest

from unseeable.cli import main
from unseeable.domain import Extent, Log, Structure, save_evidence, save_structure
from unseeable.domain.evidence import simulate_evidence
from unseeable.vision.pose_choice import AMBIGUOUS_CHOICE_MARGIN


def run(capsys, *args):
    code = main(list(map(str, args)))
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture
def house(tmp_path):
    s = Structure(Extent(3, 2, 3), [Log(0, (0, 0), 3), Log(0, (0, 2), 3), Log(1, (0, 0), 3),
                                    Log(1, (2, 0), 3)])
    save_structure(s, tmp_path / "truth.json")
    # Clear readings (log-odds 3.5-4.6): no rival is within a few misreads of the truth.
    save_evidence(simulate_evidence(s, accuracy=1.0, occluded_fraction=0.0, seed=0,
                                    confidence=(0.97, 0.99)), tmp_path / "ev.json")
    return s, tmp_path


def test_estimate_evidence_file(capsys, house):
    s, d = house
    code, out, err = run(capsys, "estimate", d / "ev.json", "--out", d / "o",
                         "--truth", d / "truth.json")
    assert code == 0, err
    data = json.loads((d / "o" / "estimate.json").read_text())
    assert data["format"] == "unseeable/estimate@2"
    assert data["status"] == "optimal"
    assert len(data["structure"]["logs"]) == 4
    assert data["confident"] is True
    assert data["confidence"]["readings"]["confident"] is True
    assert "errors against the truth: 0" in out


def test_an_estimate_resting_on_weak_readings_is_not_confident(capsys, house):
    """Every reading right but weak (0.6-0.95): the δ* test (nothing is unseen) passes, the
    reading test does not; ``--reading-shift 0`` is the paper's test alone."""
    s, d = house
    save_evidence(simulate_evidence(s, accuracy=1.0, occluded_fraction=0.0, seed=0),
                  d / "weak.json")
    code, out, err = run(capsys, "estimate", d / "weak.json", "--out", d / "o")
    assert code == 0, err
    data = json.loads((d / "o" / "estimate.json").read_text())
    assert data["confident"] is False
    assert data["confidence"]["readings"] == {**data["confidence"]["readings"],
                                              "confident": False, "shift": 2.0}
    assert "rests on a few seen readings" in out
    code, out, err = run(capsys, "estimate", d / "weak.json", "--out", d / "paper",
                         "--reading-shift", "0")
    assert code == 0, err
    data = json.loads((d / "paper" / "estimate.json").read_text())
    assert data["confident"] is True and data["confidence"]["readings"] is None
    assert data["settings"]["confidence"]["reading_shift"] is None


@pytest.mark.parametrize("content, needle", [
    ("{not json", "not valid JSON"),
    ('{"format": "unseeable/camera@1"}', "format"),
    ('{"format": "unseeable/evidence@1", "extent": [0, 1, 1], "features": []}', "extent"),
    ('{"format": "unseeable/evidence@1", "extent": [99, 99, 99], "features": []}', "extent"),
    ('{"format": "unseeable/evidence@1", "extent": [2, 2, 2], '
     '"features": [{"kind": "q", "at": [0, 0, 0], "p": 0.5}]}', "features[0].kind"),
    ('{"format": "unseeable/evidence@1", "extent": [2, 2, 2], '
     '"features": [{"kind": "u", "at": [0, 0, 0], "p": 1.2}]}', "features[0].p"),
])
def test_bad_evidence_gives_one_line_and_no_output(capsys, tmp_path, content, needle):
    bad = tmp_path / "bad.json"
    bad.write_text(content)
    code, out, err = run(capsys, "estimate", bad, "--out", tmp_path / "o")
    assert code == 1
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ")
    assert str(bad) in lines[0] and needle in lines[0]
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("logs, needle", [
    ([{"notches": 3, "layer": 0, "at": [2, 0]}], "off the grid"),
    ([{"notches": 2, "layer": 0, "at": [0, 0]}, {"notches": 2, "layer": 0, "at": [1, 0]}],
     "overlaps"),
    ([{"notches": 1, "layer": 1, "at": [0, 0]}], "grammar"),
    ([{"notches": 4, "layer": 0, "at": [0, 0]}], "notches"),
])
def test_bad_truth_structure(capsys, house, logs, needle):
    _, d = house
    bad = d / "bad-structure.json"
    bad.write_text(json.dumps({"format": "unseeable/structure@1", "extent": [3, 2, 3],
                               "logs": logs}))
    code, _, err = run(capsys, "estimate", d / "ev.json", "--out", d / "o2", "--truth", bad)
    assert code == 1
    assert "logs[" in err and needle in err and str(bad) in err
    assert not (d / "o2").exists()


def test_a_truth_of_another_extent_is_refused_before_the_estimate_is_written(capsys, house):
    _, d = house
    other = d / "other.json"
    save_structure(Structure(Extent(2, 1, 2), [Log(0, (0, 0), 2)]), other)
    code, out, err = run(capsys, "estimate", d / "ev.json", "--out", d / "o4", "--truth", other)
    assert code == 1 and err.startswith("error: ") and len(err.strip().splitlines()) == 1
    assert str(other) in err and "extent" in err and "2x1x2" in err and "3x2x3" in err
    assert not (d / "o4").exists()


def test_the_tie_policy_decides_what_is_built_where_nothing_was_seen(capsys, tmp_path):
    # A course of 5 positions seen only at its two ends: "fewest" builds it whole of two
    # logs, "emptiest" keeps a 1-notch log at each end; estimate.json says which policy.
    # (Under the paper's uniform prior; the default joint prior charges only joints a
    # camera sees, and none of this course's is.)
    from unseeable.domain import Evidence
    from unseeable.domain.features import FeatureKind, feature_index
    from unseeable.grammar.priors import TIE_POLICY

    extent = Extent(5, 1, 1)
    idx = feature_index(extent)
    p = np.full(len(idx.kind), 0.5)
    p[(idx.kind == FeatureKind.END_MINUS) & (idx.at[:, 0] == 0)] = 0.95
    p[(idx.kind == FeatureKind.END_PLUS) & (idx.at[:, 0] == 4)] = 0.95
    save_evidence(Evidence(extent, p), tmp_path / "ends.json")
    filled = {}
    for ties in ("fewest", "emptiest"):
        code, _, err = run(capsys, "estimate", tmp_path / "ends.json", "--out",
                           tmp_path / ties, "--ties", ties, "--joint-cost", "0")
        assert code == 0, err
        data = json.loads((tmp_path / ties / "estimate.json").read_text())
        assert data["settings"]["prior"]["ties"] == ties and len(data["structure"]["logs"]) == 2
        filled[ties] = sum(log["notches"] for log in data["structure"]["logs"])
    assert filled == {"fewest": 5, "emptiest": 2}
    code, _, err = run(capsys, "estimate", tmp_path / "ends.json", "--out", tmp_path / "x",
                       "--ties", "fullest")
    assert code == 1 and "ties" in err and "'fullest'" in err and len(err.splitlines()) == 1
    assert not (tmp_path / "x").exists()
    # the command's default is the pipeline's
    code, _, err = run(capsys, "estimate", tmp_path / "ends.json", "--out", tmp_path / "d")
    assert json.loads((tmp_path / "d" / "estimate.json").read_text())["settings"]["prior"][
        "ties"] == TIE_POLICY
    # The default prior leaves a joint nobody sees free: the course is built whole, as
    # "fewest" wants (a prior on every joint kept a notch empty: a 3- and a 1-notch log).
    logs = json.loads((tmp_path / "d" / "estimate.json").read_text())["structure"]["logs"]
    assert sorted(log["notches"] for log in logs) == [2, 3]
    code, _, err = run(capsys, "estimate", tmp_path / "ends.json", "--out", tmp_path / "n",
                       "--joint-cost", "-1")
    assert code == 1 and "joint_cost" in err and "-1" in err and len(err.splitlines()) == 1
    assert not (tmp_path / "n").exists()
    code, _, err = run(capsys, "estimate", tmp_path / "ends.json", "--out", tmp_path / "s",
                       "--stacked-joint-cost", "-1")
    assert code == 1 and "stacked_joint_cost" in err and len(err.splitlines()) == 1
    assert not (tmp_path / "s").exists()
    code, _, err = run(capsys, "estimate", tmp_path / "ends.json", "--out", tmp_path / "u",
                       "--unsupported-notch-cost", "-2")
    assert code == 1 and "unsupported_notch_cost" in err and len(err.splitlines()) == 1
    assert not (tmp_path / "u").exists()


def test_unknown_backend(capsys, house):
    _, d = house
    code, _, err = run(capsys, "estimate", d / "ev.json", "--out", d / "o3", "--backend", "x")
    assert code == 1 and "backend" in err and "'x'" in err


@pytest.fixture(scope="module")
def hard_view(tmp_path_factory):
    """A view without a pose whose fit must be poor: its extent is too small for the
    assembly in the image (wood lies well outside the extent's box at any pose)."""
    from unseeable.domain import GridPose
    from unseeable.render.raster import RasterLook, rasterise_view
    from unseeable.render.view import View, save_view
    from unseeable.render.workspace import PendulumArm
    from unseeable.training.scenes import random_structure

    s = random_structure(Extent(4, 3, 3), density=0.7, seed=0)
    camera = PendulumArm().camera(120.0)
    yaw = 17.0
    centre = np.array([(s.extent.I - 1) * 32.0, 0.0, (s.extent.K - 1) * 32.0])
    origin = -(GridPose(0.0, 0.0, yaw).rotation @ centre)
    pose = GridPose(float(origin[0]), float(origin[2]), yaw)
    image = rasterise_view(s, pose, camera, look=RasterLook(), seed=2)
    folder = tmp_path_factory.mktemp("hard")
    save_view(View(image, camera, Extent(2, 3, 2)), folder / "view.json")
    return folder


@pytest.mark.slow
def test_a_poor_pose_fit_is_an_error_unless_forced(capsys, hard_view):
    code, out, err = run(capsys, "estimate", hard_view / "view.json", "--out", hard_view / "o")
    assert code == 1 and "poor pose fit" in err and len(err.strip().splitlines()) == 1
    assert str(hard_view / "view.json") in err  # which view was refused
    assert not (hard_view / "o" / "estimate.json").exists()
    code, out, err = run(capsys, "estimate", hard_view / "view.json", "--out", hard_view / "f",
                         "--force-pose", "--no-tolerance")
    assert code == 0, err
    data = json.loads((hard_view / "f" / "estimate.json").read_text())
    view = data["views"][0]
    fit = view["pose_fit"]
    assert fit["source"] == "estimated" and fit["quality"] < 0.5
    assert "fit quality" in out
    # How clearly the structure choice picked the pose, and what that does to confidence.
    margin, ambiguous = fit["choice_margin"], fit["ambiguous"]
    assert ambiguous == (margin is not None and margin < AMBIGUOUS_CHOICE_MARGIN)
    assert data["confident"] == (data["confidence"]["confident"] and not ambiguous
                                 and not view["extent_doubt"] and not view["evidence_doubt"])
    assert ("chosen by a margin" in out) == (margin is not None)
    assert (fit["rival"] is None) == (margin is None)
    assert ("moved by the polish" in out) == fit["moved_by_polish"]


@pytest.fixture(scope="module")
def turned_view(tmp_path_factory):
    """A view without a pose of an assembly turned 150°, with its structure file and its
    truth file: the estimate numbers the grid from the other side (yaw in [-90, 90))."""
    from unseeable.domain import GridPose, feature_values
    from unseeable.render.raster import RasterLook, rasterise_view
    from unseeable.render.view import View, ViewTruth, save_truth, save_view
    from unseeable.render.workspace import PendulumArm
    from unseeable.training.scenes import random_structure
    from unseeable.visibility import feature_visibility

    s = random_structure(Extent(3, 2, 3), density=0.7, seed=0)
    camera = PendulumArm().camera(120.0)
    centre = np.array([(s.extent.I - 1) * 32.0, 0.0, (s.extent.K - 1) * 32.0])
    origin = -(GridPose(0.0, 0.0, 150.0).rotation @ centre)
    pose = GridPose(float(origin[0]), float(origin[2]), 150.0)
    folder = tmp_path_factory.mktemp("turned")
    save_view(View(rasterise_view(s, pose, camera, look=RasterLook(), seed=2), camera,
                   s.extent), folder / "view.json")
    save_structure(s, folder / "structure.json")
    save_truth(ViewTruth(s, pose, camera, feature_values(s.extent, s.occupancy),
                         feature_visibility(s, camera.centre, pose)), folder / "view.truth.json")
    return s, pose, folder


def test_a_truth_file_counts_errors_where_the_logs_are(capsys, turned_view):
    from unseeable.domain import GridPose
    from unseeable.domain.io import structure_from_json
    from unseeable.evaluate import compare_structures

    s, pose, d = turned_view
    code, out, err = run(capsys, "estimate", d / "view.json", "--out", d / "o",
                         "--truth", d / "view.truth.json", "--no-tolerance")
    assert code == 0, err
    data = json.loads((d / "o" / "estimate.json").read_text())
    est_pose = GridPose(**data["pose"])
    assert abs(((est_pose.yaw_deg - pose.yaw_deg) % 360.0) - 180.0) < 2.0  # the other side
    est = structure_from_json(data["structure"], check_grammar=False)
    physical = compare_structures(s, est, truth_pose=pose, estimate_pose=est_pose,
                                  on_misaligned="count").errors
    assert f"errors against the truth: {physical}" in out
    from unseeable.vision import pose_equivalent

    mm, deg = pose_equivalent(est_pose, pose, s.extent)
    assert f"pose against the truth: {mm:.1f} mm, {deg:.2f}° off" in out
    # The structure file alone compares the grids as numbered: not where the logs are.
    code, out, err = run(capsys, "estimate", d / "view.json", "--out", d / "o2",
                         "--truth", d / "structure.json", "--no-tolerance")
    assert code == 0, err
    assert f"errors against the truth: {compare_structures(s, est).errors}" in out
    assert "pose against the truth" not in out  # a structure file has no pose


def test_features_cut_off_by_the_frame_are_reported_and_count_as_unseen(capsys, turned_view):
    from unseeable.camera import Camera
    from unseeable.render.view import View, load_view, save_view

    _, pose, d = turned_view
    view = load_view(d / "view.json")
    cam = view.camera
    half = cam.width // 2 - 20  # the right part of the assembly is cut off
    cut = Camera(half, cam.height, cam.K, cam.R, cam.t, cam.dist)
    save_view(View(view.image[:, :half].copy(), cut, view.extent, pose=pose), d / "cut.json")
    code, out, err = run(capsys, "estimate", d / "cut.json", "--out", d / "cut",
                         "--no-tolerance")
    assert code == 0, err
    data = json.loads((d / "cut" / "estimate.json").read_text())
    outside = data["views"][0]["features_outside_image"]
    assert 0 < outside < len(data["features"])
    assert f"outside the image: {outside} of the extent's" in out
    # Those features were not judged: ½ each, as the occluded ones are.
    assert sum(f["p"] == 0.5 for f in data["features"]) >= outside
    code, out, err = run(capsys, "estimate", d / "view.json", "--out", d / "whole",
                         "--no-tolerance")
    assert json.loads((d / "whole" / "estimate.json").read_text())["views"][0][
        "features_outside_image"] == 0 and "outside the image" not in out


def test_a_structure_file_of_another_extent_is_compared_where_its_logs_stand(capsys,
                                                                             turned_view):
    from unseeable.domain import GridPose
    from unseeable.domain.io import structure_from_json
    from unseeable.evaluate import compare_structures

    _, _, d = turned_view
    other = Structure(Extent(2, 1, 2), [Log(0, (0, 0), 2)])
    save_structure(other, d / "other.json")
    code, out, err = run(capsys, "estimate", d / "view.json", "--out", d / "other",
                         "--truth", d / "other.json", "--no-tolerance")
    assert code == 0, err
    data = json.loads((d / "other" / "estimate.json").read_text())
    est_pose = GridPose(**data["pose"])
    est = structure_from_json(data["structure"], check_grammar=False)
    expected = compare_structures(other, est, truth_pose=est_pose, estimate_pose=est_pose,
                                  on_misaligned="count").errors
    assert f"errors against the truth: {expected}" in out


def test_a_truth_of_another_format_is_refused_before_anything_is_written(capsys, turned_view):
    _, _, d = turned_view
    code, _, err = run(capsys, "estimate", d / "view.json", "--out", d / "o3",
                       "--truth", d / "view.json")
    assert code == 1 and len(err.strip().splitlines()) == 1
    assert str(d / "view.json") in err and "'unseeable/view@1'" in err
    assert not (d / "o3").exists()


@pytest.mark.parametrize("option, value, message", [
    ("--threads", 0, "threads: must be a whole number >= 1 (got 0)"),
    ("--time-limit", 0, "time_limit: must be a positive number of seconds (got 0.0)"),
    ("--time-limit", -5, "time_limit: must be a positive number of seconds (got -5.0)"),
])
def test_a_bad_thread_count_or_time_limit_is_refused_before_anything_is_written(
        capsys, tmp_path, option, value, message):
    from unseeable.camera import Camera
    from unseeable.render.view import View, save_view

    cam = Camera.look_at(eye=[0, 500, -800], target=[0, 0, 0], width=64, height=48,
                         fov_deg=50)
    save_view(View(np.zeros((48, 64, 3), np.uint8), cam, Extent(2, 2, 2)),
              tmp_path / "view.json", image_path=tmp_path / "view.png")
    code, _, err = run(capsys, "estimate", tmp_path / "view.json", "--out", tmp_path / "o",
                       option, value)
    assert code == 1
    assert err.strip() == f"error: {message}"
    assert not (tmp_path / "o").exists()


def test_the_demo_refuses_a_thread_count_below_one_before_rendering(capsys, tmp_path):
    code, _, err = run(capsys, "demo", "--out", tmp_path / "d", "--threads", 0)
    assert code == 1
    assert err.strip() == "error: threads: must be a whole number >= 1 (got 0)"
    assert not (tmp_path / "d").exists()


@pytest.mark.parametrize("converged, cycle, words", [
    (True, 0, "fixpoint"), (False, 2, "cycle of length 2"), (False, 0, "not settled")])
def test_the_summary_says_how_the_visibility_fixpoint_ended(capsys, house, converged, cycle,
                                                           words):
    # A fixpoint stopped by the cap or the time budget is neither a fixpoint nor a cycle.
    import dataclasses

    from unseeable.cli.core import print_estimate_summary
    from unseeable.domain import load_evidence
    from unseeable.pipeline import EstimateSettings, estimate_evidence

    s, tmp = house
    estimate = estimate_evidence(load_evidence(tmp / "ev.json"),
                                 EstimateSettings.from_options(enabled=False))
    view = dataclasses.replace(estimate.views[0], visible=np.ones(len(estimate.priors), bool))
    estimate = dataclasses.replace(estimate, views=(view,), converged=converged,
                                   cycle_length=cycle, iterations=3)
    print_estimate_summary(estimate)
    line = [ln for ln in capsys.readouterr().out.splitlines() if "visibility:" in ln]
    assert len(line) == 1 and words in line[0]
    assert ("not settled" in line[0]) == (words == "not settled")


@pytest.mark.parametrize("doubt, reason", [
    ({"pose_ambiguous": True}, "the pose choice was ambiguous"),
    ({"pose_poor": True}, "the pose fits poorly"),
    ({"extent_doubt": True}, "the extent or the pose is in doubt"),
    ({"evidence_doubt": True, "presence_shift": -2.0}, "show more than the estimate builds"),
])
def test_the_summary_says_why_an_estimate_that_passed_the_delta_test_is_not_confident(
        capsys, doubt, reason):
    import dataclasses

    from unseeable.cli.core import print_estimate_summary
    from unseeable.domain import Extent, Log, Structure, simulate_evidence
    from unseeable.pipeline import PoseReport, estimate_evidence

    truth = Structure(Extent(2, 1, 2), [Log(0, (0, 0), 2), Log(0, (0, 1), 2)])
    sure = estimate_evidence(simulate_evidence(truth, accuracy=1.0, occluded_fraction=0.0,
                                               seed=0))
    assert sure.confidence.confident
    fields = dict(doubt)
    if fields.pop("pose_ambiguous", False):
        fields["pose_report"] = PoseReport("estimated", ambiguous=True)
    if fields.pop("pose_poor", False):
        fields["pose_report"] = PoseReport("estimated", quality=0.3)
    view = dataclasses.replace(sure.views[0], **fields)
    print_estimate_summary(dataclasses.replace(sure, views=(view,)))
    out = capsys.readouterr().out.splitlines()
    line = [ln for ln in out if "confident:" in ln]
    assert len(line) == 1 and "confident: no" in line[0] and reason in line[0]
    # The shift itself is put down to the grid, not to the photograph's look.
    shifted = [ln for ln in out if "detections:" in ln]
    assert len(shifted) == ("presence_shift" in doubt)
    assert all("is the pose off?" in ln and "look" not in ln for ln in shifted)


def test_the_summary_says_an_estimate_that_builds_nothing_from_a_photograph_is_in_doubt(
        capsys):
    import dataclasses

    from unseeable.cli.core import print_estimate_summary
    from unseeable.domain import Extent, GridPose, Structure, simulate_evidence
    from unseeable.pipeline import PoseReport, estimate_evidence

    est = estimate_evidence(simulate_evidence(Structure(Extent(2, 1, 2), []), accuracy=1.0,
                                              occluded_fraction=0.0, seed=0))
    view = dataclasses.replace(est.views[0], pose=GridPose(), pose_report=PoseReport("given"))
    print_estimate_summary(dataclasses.replace(est, views=(view,)))
    line = [ln for ln in capsys.readouterr().out.splitlines() if "confident:" in ln]
    assert len(line) == 1 and "confident: no" in line[0] and "builds nothing" in line[0]


@pytest.mark.slow
def test_a_calibration_file_is_used_recorded_and_refused_when_bad(capsys, turned_view, house):
    from unseeable.vision import default_calibration, save_calibration
    from unseeable.vision.calibration import Calibration

    s, pose, d = turned_view
    cal = default_calibration()
    save_calibration(cal, d / "same.json")
    # Another calibration: the same networks, probabilities clipped to [0.3, 0.7].
    save_calibration(Calibration(cal.models, (0.3, 0.7), cal.info, cal.pose_quality,
                                 cal.context_models), d / "timid.json")
    runs = {}
    for name, extra in (("shipped", []), ("same", ["--calibration", d / "same.json"]),
                        ("timid", ["--calibration", d / "timid.json"])):
        code, out, err = run(capsys, "estimate", d / "view.json", "--out", d / f"c_{name}",
                             "--no-tolerance", *extra)
        assert code == 0, err
        runs[name] = json.loads((d / f"c_{name}" / "estimate.json").read_text())
    assert runs["shipped"]["settings"]["detection"]["calibration"] == "shipped"
    assert runs["same"]["settings"]["detection"]["calibration"] == str(d / "same.json")
    assert runs["same"]["structure"] == runs["shipped"]["structure"]
    judged = [f["p"] for f in runs["timid"]["features"] if f["p"] != 0.5]
    assert judged and max(judged) <= 0.7 and min(judged) >= 0.3
    assert max(f["p"] for f in runs["shipped"]["features"]) > 0.7
    # A missing file or one given with an evidence file: one line, nothing written.
    _, folder = house
    for source, cal_file, needle in ((d / "view.json", d / "none.json", "none.json"),
                                     (folder / "ev.json", d / "same.json", "views only")):
        code, out, err = run(capsys, "estimate", source, "--out", d / "bad",
                             "--calibration", cal_file)
        assert code == 1 and len(err.strip().splitlines()) == 1 and needle in err, err
        assert not (d / "bad").exists()
