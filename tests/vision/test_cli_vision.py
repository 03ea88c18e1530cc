"""The vision commands as a user meets them: files written, one-line errors."""

import json

import pytest

import unseeable.cli.vision  # noqa: F401  (registers the commands)
from unseeable.cli import main
from unseeable.domain import load_evidence
from unseeable.render.view import View, save_view


def run(capsys, *args):
    code = main(list(map(str, args)))
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture
def view_file(tmp_path, scatter_view):
    s, pose, cam, image = scatter_view
    path = tmp_path / "view.json"
    save_view(View(image, cam, s.extent, pose), path, image_path=tmp_path / "view.png")
    return path, s, pose


def test_detect_writes_evidence_and_overlay(capsys, tmp_path, view_file):
    path, s, pose = view_file
    code, out, err = run(capsys, "detect", path, "--out", tmp_path / "det")
    assert code == 0, err
    ev = load_evidence(tmp_path / "det" / "evidence.json")
    assert ev.extent == s.extent
    assert 0 < ev.judged.sum() < len(ev.p)  # the initial visibility estimate, not everything
    assert (tmp_path / "det" / "overlay.png").stat().st_size > 1000
    assert "judged" in out


def test_detect_all_features(capsys, tmp_path, view_file):
    path, s, pose = view_file
    code, _, err = run(capsys, "detect", path, "--out", tmp_path / "d2", "--features", "all",
                       "--no-refine")
    assert code == 0, err
    ev = load_evidence(tmp_path / "d2" / "evidence.json")
    first = load_evidence(tmp_path / "d2" / "evidence.json")
    # All features in the image are judged: more than the visible guess would give.
    run(capsys, "detect", path, "--out", tmp_path / "d3", "--no-refine")
    some = load_evidence(tmp_path / "d3" / "evidence.json")
    assert ev.judged.sum() > some.judged.sum() > 0
    assert (first.p == ev.p).all()


@pytest.mark.slow
def test_pose_ignores_the_views_pose(capsys, tmp_path, view_file):
    path, s, pose = view_file
    data = json.loads(path.read_text())
    data["pose"] = {"x": 500.0, "z": 500.0, "yaw_deg": 5.0}  # wrong on purpose
    path.write_text(json.dumps(data))
    code, out, err = run(capsys, "pose", path, "--out", tmp_path / "pose")
    assert code == 0, err
    got = json.loads((tmp_path / "pose" / "pose.json").read_text())
    assert got["source"] == "estimated" and 0.0 <= got["quality"] <= 1.0
    # With rival candidates, how clearly the structure choice picked this one.
    assert (got["choice_margin"] is None) == (got["rival"] is None)
    if got["choice_margin"] is not None:
        from unseeable.vision.pose_choice import AMBIGUOUS_CHOICE_MARGIN

        assert got["choice_margin"] >= 0.0
        assert got["ambiguous"] == (got["choice_margin"] < AMBIGUOUS_CHOICE_MARGIN)
    from unseeable.domain import GridPose
    from unseeable.vision import pose_equivalent

    dt, dy = pose_equivalent(GridPose(got["x"], got["z"], got["yaw_deg"]), pose, s.extent)
    assert dt < 3.0 and dy < 1.0
    assert (tmp_path / "pose" / "overlay.png").exists()
    # The pose `unseeable estimate` uses for the same view (its recorded pose removed).
    from unseeable.pipeline import Observation, find_pose
    from unseeable.render.view import load_view

    found = find_pose(Observation.of(load_view(path), use_recorded_pose=False)).pose
    assert (found.x, found.z, found.yaw_deg) == (got["x"], got["z"], got["yaw_deg"])


def test_errors_are_one_line(capsys, tmp_path, view_file):
    path, _, _ = view_file
    code, _, err = run(capsys, "detect", path, "--out", tmp_path / "x", "--features", "some")
    assert code == 1 and "--features" in err and len(err.strip().splitlines()) == 1
    code, _, err = run(capsys, "detect", tmp_path / "missing.json", "--out", tmp_path / "x")
    assert code == 1 and "missing.json" in err
    code, _, err = run(capsys, "calibrate", "--scenes", "0", "--out", tmp_path / "c.json")
    assert code == 1 and "--scenes" in err
    code, _, err = run(capsys, "calibrate", "--tall", "-3", "--out", tmp_path / "c.json")
    assert code == 1 and "--tall" in err and "-3" in err
    code, _, err = run(capsys, "calibrate", "--looks", "-1", "--out", tmp_path / "c.json")
    assert code == 1 and "--looks" in err and "-1" in err
    code, _, err = run(capsys, "calibrate", "--workers", "0", "--out", tmp_path / "c.json")
    assert code == 1 and "--workers" in err
    code, _, err = run(capsys, "calibrate", "--members", "0", "--out", tmp_path / "c.json")
    assert code == 1 and "--members" in err and "0" in err
    code, out, err = run(capsys, "calibrate", "--resume", "--out", tmp_path / "c.json")
    # One line and nothing else: the bar (on stderr) is not shown before its first report.
    assert code == 1 and "c.json.stage1" in err and err.count("\n") == 1 and err.strip()
    assert out == ""
    assert not (tmp_path / "c.json").exists()


def test_merge_calibrations_writes_one_file_of_all_networks(capsys, tmp_path):
    from unseeable.vision import default_calibration, load_calibration, save_calibration
    from unseeable.vision.calibration import Calibration

    cal = default_calibration()
    save_calibration(cal, tmp_path / "a.json")
    code, out, err = run(capsys, "merge-calibrations", tmp_path / "a.json", tmp_path / "a.json",
                         "--out", tmp_path / "m.json")
    assert code == 0, err
    merged = load_calibration(tmp_path / "m.json")
    assert len(merged.models["long"].members) == 2 * len(cal.models["long"].members)
    assert f"{len(merged.models['long'].members)} networks" in out and "m.json" in out
    # Bad input: one line naming the file and the value, exit code 1, nothing written.
    save_calibration(Calibration(cal.models, (0.05, 0.95), cal.info, cal.pose_quality,
                                 cal.context_models), tmp_path / "b.json")
    for args, words in ((["a.json"], ["two or more"]),
                        (["a.json", "b.json"], ["b.json", "clip", "0.05"]),
                        (["a.json", "none.json"], ["none.json"])):
        code, out, err = run(capsys, "merge-calibrations", *(tmp_path / a for a in args),
                             "--out", tmp_path / "x.json")
        assert code == 1 and len(err.strip().splitlines()) == 1, err
        assert all(w in err for w in words), err
        assert not (tmp_path / "x.json").exists()


def test_a_poor_pose_fit_fails_cleanly(capsys, tmp_path, scatter_view):
    s, pose, cam, image = scatter_view
    from unseeable.domain import Extent

    path = tmp_path / "v.json"
    save_view(View(image, cam, Extent(2, 3, 3), None), path, image_path=tmp_path / "v.png")
    code, _, err = run(capsys, "pose", path, "--out", tmp_path / "p")
    assert code == 1 and "poor pose fit" in err
    assert str(path) in err  # which view was refused
    assert not (tmp_path / "p" / "pose.json").exists()


def test_detect_refuses_a_thread_count_below_one_even_with_a_recorded_pose(capsys, tmp_path,
                                                                          view_file):
    path, _, _ = view_file
    code, _, err = run(capsys, "detect", path, "--out", tmp_path / "t", "--threads", 0)
    assert code == 1
    assert err.strip() == "error: threads: must be a whole number >= 1 (got 0)"
    assert not (tmp_path / "t").exists()
