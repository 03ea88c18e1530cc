"""The interactive page of an estimate (unseeable.report): what it shows, and that it
draws in a real browser (headless Chromium) without script errors."""

import json
import os
import re
import shutil
import subprocess
from pathlib import Path

import cv2
import numpy as np
import pytest
import typer
from typer.testing import CliRunner

from unseeable.domain import Extent, GridPose, Log, Structure, feature_values, simulate_evidence
from unseeable.domain.io import save_structure, structure_to_json
from unseeable.errors import InputError
from unseeable.evaluate.metric import compare_structures
from unseeable.fileio import read_json, write_json
from unseeable.pipeline import (
    EstimateSettings,
    Observation,
    estimate,
    estimate_evidence,
    load_estimate,
    write_estimate,
)
from unseeable.render.raster import RasterLook, rasterise_view
from unseeable.render.view import View, ViewTruth, load_view, save_truth, save_view
from unseeable.render.workspace import PendulumArm
from unseeable.report import (
    estimate_page_html,
    estimate_scene,
    log_feature_keys,
    write_estimate_page,
)
from unseeable.report.command import view_command
from unseeable.visibility.geometry import log_cylinders

CABIN = Structure(Extent(3, 4, 3), [
    Log(0, (0, 0), 3), Log(0, (0, 2), 3), Log(1, (0, 0), 3), Log(1, (2, 0), 3),
    Log(2, (0, 0), 3), Log(2, (0, 2), 3), Log(3, (0, 0), 3), Log(3, (2, 0), 3)])
POSE = GridPose(-64.0, -64.0, 20.0)
NO_CONFIDENCE = EstimateSettings.from_options(enabled=False)


@pytest.fixture(scope="module")
def two_views(tmp_path_factory):
    """A joint estimate of the cabin from two rendered views (the arm at 150° and 40°), in a
    folder with its view files and the truth: ``(folder, cameras)``."""
    folder = tmp_path_factory.mktemp("two-views")
    arm = PendulumArm(width=320, height=240)
    observations, cameras = [], []
    for name, angle in (("near", 150.0), ("far", 40.0)):
        camera = arm.camera(angle)
        image = rasterise_view(CABIN, POSE, camera, look=RasterLook(), seed=2)
        path = folder / f"{name}.json"
        save_view(View(image, camera, CABIN.extent, pose=POSE), path)
        observations.append(Observation.of(load_view(path), source=path))
        cameras.append(camera)
    est = estimate(observations, NO_CONFIDENCE)
    write_estimate(est, folder)
    present = feature_values(CABIN.extent, CABIN.occupancy)
    save_truth(ViewTruth(CABIN, POSE, cameras[0], present, np.ones_like(present)),
               folder / "near.truth.json")
    return folder, cameras


@pytest.fixture(scope="module")
def bare(tmp_path_factory):
    """A bare-evidence estimate of the cabin (no pose, no camera) with most features
    unjudged: some logs inferred, some wrong."""
    folder = tmp_path_factory.mktemp("bare")
    ev = simulate_evidence(CABIN, accuracy=0.95, occluded_fraction=0.8, seed=1)
    write_estimate(estimate_evidence(ev, NO_CONFIDENCE, source="cabin.evidence.json"), folder)
    return folder


# ---- what the page shows ------------------------------------------------------------------

def test_logs_stand_where_the_reference_pose_puts_them(two_views):
    folder, _ = two_views
    scene = estimate_scene(folder / "estimate.json")
    data = load_estimate(folder / "estimate.json")
    assert data.structure.model_dump(mode="json") == structure_to_json(CABIN)
    pose = GridPose(**data.pose.model_dump())  # the given pose, polished on the images
    assert pose.distance(POSE)[0] < 3.0
    axes = np.array([log["axis"] for log in scene["logs"]])
    np.testing.assert_allclose(axes, pose.grid_to_world(log_cylinders(CABIN)), atol=0.01)
    lengths = np.linalg.norm(axes[:, 1] - axes[:, 0], axis=1)
    np.testing.assert_allclose(lengths, [(log.notches - 1) * 64 + 2 * 22 for log in CABIN.logs],
                               atol=0.02)
    assert scene["radius"] == 9.5
    # The grid frame: its origin and axes where the pose puts them.
    np.testing.assert_allclose(scene["grid"]["origin"], [pose.x, 0.0, pose.z], atol=0.01)
    np.testing.assert_allclose(scene["grid"]["i"], pose.rotation[:, 0], atol=0.01)


def test_each_log_lists_its_own_features_with_the_estimates_evidence(two_views):
    folder, _ = two_views
    scene = estimate_scene(folder / "estimate.json")
    data = read_json(folder / "estimate.json")
    by_key = {(f["kind"], tuple(f["at"])): f for f in data["features"]}
    assert [log["seen"] for log in scene["logs"]] == data["logs_seen"]
    for n, log in enumerate(scene["logs"]):
        keys = log_feature_keys(CABIN, n)
        m = CABIN.logs[n].notches
        assert len(keys) == 2 + 2 * m + (m - 1)
        assert [(f["kind"], tuple(f["at"])) for f in log["features"]] == keys
        for f in log["features"]:
            recorded = by_key[(f["kind"], tuple(f["at"]))]
            assert (f["p"], f["value"], f["visible"]) == \
                (recorded["p"], recorded["value"], recorded["visible"])
        # A log is seen exactly when one of its own features was judged (in some view;
        # with the cabin in full sight of the reference view, in that one).
        judged = any(f["p"] != 0.5 for f in log["features"])
        assert not judged or log["seen"]
        assert log["positions"] == [list(q) for q in CABIN.logs[n].positions()]


def test_cameras_are_drawn_where_the_views_were_taken(two_views):
    folder, cameras = two_views
    scene = estimate_scene(folder / "estimate.json")
    assert [c["reference"] for c in scene["cameras"]] == [True, False]
    assert scene["notes"] == []
    for drawn, camera in zip(scene["cameras"], cameras):
        np.testing.assert_allclose(drawn["centre"], camera.centre, atol=0.01)
        corners = np.array(drawn["corners"])
        # The frustum opens in front of the camera, towards the assembly.
        assert np.all(camera.world_to_camera(corners)[:, 2] > 0)
        uv = camera.project(corners)
        np.testing.assert_allclose(uv, [[0, 0], [320, 0], [320, 240], [0, 240]], atol=0.05)


def test_a_view_posed_in_its_own_table_frame_is_brought_into_the_reference_frame(two_views,
                                                                                  tmp_path):
    """Independent views: view 2's pose places the joint grid in view 2's own table frame;
    the page maps its camera through the grid into the reference view's frame."""
    folder, cameras = two_views
    data = read_json(folder / "estimate.json")
    reference = GridPose(**data["pose"])
    moved = GridPose(reference.x + 100.0, reference.z, reference.yaw_deg)  # 100 mm further on
    data["views"][1]["pose"] = moved.to_json()
    data["settings"]["pose"]["independent"] = True
    write_json(tmp_path / "estimate.json", data)
    scene = estimate_scene(tmp_path / "estimate.json")
    np.testing.assert_allclose(scene["cameras"][0]["centre"], cameras[0].centre, atol=0.01)
    expected = reference.grid_to_world(moved.world_to_grid(cameras[1].centre))
    np.testing.assert_allclose(scene["cameras"][1]["centre"], expected, atol=0.01)
    assert np.linalg.norm(expected - cameras[1].centre) == pytest.approx(100.0)


def test_a_view_file_that_cannot_be_read_is_skipped_with_a_note(two_views, tmp_path):
    folder, _ = two_views
    data = read_json(folder / "estimate.json")
    data["views"][0]["source"] = str(folder / "near.json")
    data["views"][1]["source"] = "gone/far <view>.json"
    write_json(tmp_path / "estimate.json", data)
    (tmp_path / "broken.json").write_text("{not json")
    scene = estimate_scene(tmp_path / "estimate.json")
    assert len(scene["cameras"]) == 1 and scene["cameras"][0]["reference"]
    assert len(scene["notes"]) == 1 and "far <view>.json" in scene["notes"][0]
    data["views"][1]["source"] = "broken.json"  # found beside the estimate, but unreadable
    write_json(tmp_path / "estimate.json", data)
    scene = estimate_scene(tmp_path / "estimate.json")
    assert len(scene["cameras"]) == 1
    assert "broken.json" in scene["notes"][0] and "not valid JSON" in scene["notes"][0]


def test_bare_evidence_puts_the_grid_at_the_origin_without_cameras(bare):
    scene = estimate_scene(bare / "estimate.json")
    est = load_estimate(bare / "estimate.json")
    structure = Structure(Extent(*est.structure.extent),
                          [Log(g.layer, g.at, g.notches) for g in est.structure.logs])
    assert scene["cameras"] == [] and scene["notes"] == []
    np.testing.assert_allclose([log["axis"] for log in scene["logs"]],
                               log_cylinders(structure), atol=0.01)
    assert scene["grid"]["origin"] == [0.0, 0.0, 0.0]
    assert scene["summary"]["pose"] is None
    # Most features unjudged: the grammar inferred some logs.
    assert [log["seen"] for log in scene["logs"]] == est.logs_seen
    assert not all(est.logs_seen)


def test_seen_flags_follow_their_logs_in_a_file_listing_them_in_another_order(bare, tmp_path):
    data = read_json(bare / "estimate.json")
    data["structure"]["logs"].reverse()
    data["logs_seen"].reverse()
    write_json(tmp_path / "estimate.json", data)
    reordered = estimate_scene(tmp_path / "estimate.json")
    original = estimate_scene(bare / "estimate.json")
    assert [(log["layer"], log["at"], log["seen"]) for log in reordered["logs"]] == \
        [(log["layer"], log["at"], log["seen"]) for log in original["logs"]]


def test_the_truth_judges_each_log_and_its_missed_logs_are_drawn(bare, tmp_path):
    est = load_estimate(bare / "estimate.json")
    structure = Structure(Extent(*est.structure.extent),
                          [Log(g.layer, g.at, g.notches) for g in est.structure.logs])
    save_structure(CABIN, tmp_path / "truth.json")
    scene = estimate_scene(bare / "estimate.json", truth=tmp_path / "truth.json")
    expected = compare_structures(CABIN, structure)
    assert [log["correct"] for log in scene["logs"]] == expected.estimate_correct.tolist()
    assert not all(log["correct"] for log in scene["logs"])
    missed = [(m["layer"], tuple(m["at"]), m["notches"]) for m in scene["missed"]]
    assert missed == [(log.layer, log.at, log.notches)
                      for log, ok in zip(CABIN.logs, expected.truth_correct) if not ok]
    assert missed
    np.testing.assert_allclose([m["axis"] for m in scene["missed"]],
                               log_cylinders(CABIN)[~expected.truth_correct], atol=0.01)
    assert scene["truth"]["errors"] == expected.errors > 0
    # The estimate as its own truth: every log right, none missed.
    save_structure(structure, tmp_path / "same.json")
    same = estimate_scene(bare / "estimate.json", truth=tmp_path / "same.json")
    assert all(log["correct"] for log in same["logs"]) and same["missed"] == []


def test_a_view_truth_file_compares_physically_through_both_poses(two_views):
    folder, _ = two_views
    scene = estimate_scene(folder / "estimate.json", truth=folder / "near.truth.json")
    assert scene["truth"]["errors"] == 0
    assert all(log["correct"] for log in scene["logs"]) and scene["missed"] == []


def test_files_at_fault_are_named(bare, tmp_path):
    with pytest.raises(InputError, match="no such file"):
        estimate_scene(tmp_path / "none.json")
    write_json(tmp_path / "structure.json", structure_to_json(CABIN))
    with pytest.raises(InputError, match=r"structure\.json: format"):
        estimate_scene(tmp_path / "structure.json")
    other = Structure(Extent(2, 1, 2), [Log(0, (0, 0), 2)])
    save_structure(other, tmp_path / "small.json")
    with pytest.raises(InputError, match=r"small\.json: extent"):
        estimate_scene(bare / "estimate.json", truth=tmp_path / "small.json")
    data = read_json(bare / "estimate.json")
    data["logs_seen"] = data["logs_seen"][:-1]
    write_json(tmp_path / "estimate.json", data)
    with pytest.raises(InputError, match="logs_seen"):
        estimate_scene(tmp_path / "estimate.json")


def test_the_page_is_self_contained_and_carries_the_scene(two_views, tmp_path):
    folder, _ = two_views
    data = read_json(folder / "estimate.json")
    data["views"][1]["source"] = "</script><script>alert(1)</script>.json"
    write_json(tmp_path / "estimate.json", data)
    page = estimate_page_html(tmp_path / "estimate.json")
    assert not re.search(r"<(script|link|img)[^>]+(src|href)=", page)
    assert "http://" not in page and "https://" not in page
    assert page.count("</script>") == 3  # the error trap, the scene, the renderer
    scene_text = re.search(r'<script type="application/json" id="scene-data">(.*?)</script>',
                           page, re.S).group(1)
    assert json.loads(scene_text) == json.loads(json.dumps(estimate_scene(
        tmp_path / "estimate.json")))


def test_the_view_command_writes_the_page_beside_the_estimate(two_views, tmp_path):
    folder, _ = two_views
    app = typer.Typer()
    app.command(name="view")(view_command)
    app.command(name="other")(lambda: None)  # a second command keeps "view" a subcommand
    shutil.copy(folder / "estimate.json", tmp_path / "estimate.json")
    result = CliRunner().invoke(app, ["view", str(tmp_path / "estimate.json"), "--truth",
                                      str(folder / "near.truth.json")])
    assert result.exit_code == 0, result.output
    assert (tmp_path / "estimate.html").is_file()
    assert "8 logs" in result.output and "0 errors" in result.output
    out = tmp_path / "pages" / "cabin.html"
    result = CliRunner().invoke(app, ["view", str(tmp_path / "estimate.json"), "--out",
                                      str(out)])
    assert result.exit_code == 0 and out.is_file()


# ---- in a real browser ---------------------------------------------------------------------

CHROMIUM = shutil.which("chromium")
needs_chromium = pytest.mark.skipif(CHROMIUM is None, reason="Debian's chromium is not on "
                                    "PATH (scripts/setup.sh installs it as root)")


def _chromium(url: str, profile: Path, *args: str) -> subprocess.CompletedProcess:
    """Run headless Chromium on ``url`` with console messages logged to stderr."""
    return subprocess.run(
        [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
         "--no-first-run", "--disable-background-networking", "--disable-component-update",
         "--disable-sync", f"--user-data-dir={profile}", "--enable-logging=stderr", "--v=0",
         "--window-size=800,600", *args, url],
        capture_output=True, text=True, timeout=120, check=False)


def _load(page: Path, tmp_path: Path, fragment: str = "") -> dict[str, str]:
    """The page's ``#status`` attributes once loaded, after checking the console is quiet."""
    url = page.resolve().as_uri() + fragment
    run = _chromium(url, tmp_path / "profile-dom", "--dump-dom")
    assert run.returncode == 0, run.stderr[-2000:]
    console = [line for line in run.stderr.splitlines() if ":CONSOLE" in line]
    assert console == [], console  # the page logs nothing; anything here is an error
    status = re.search(r'<div id="status"([^>]*)>', run.stdout)
    assert status, run.stdout[-2000:]
    attrs = dict(re.findall(r'([\w-]+)="([^"]*)"', status.group(1)))
    attrs["dom"] = run.stdout
    return attrs


def _screenshot(page: Path, tmp_path: Path, name: str, fragment: str = "") -> np.ndarray:
    shot = tmp_path / name
    run = _chromium(page.resolve().as_uri() + fragment, tmp_path / "profile-shot",
                    f"--screenshot={shot}")
    assert run.returncode == 0 and shot.is_file(), run.stderr[-2000:]
    keep = os.environ.get("UNSEEABLE_SCREENSHOTS")  # a folder to keep the screenshots in
    if keep:
        Path(keep).mkdir(parents=True, exist_ok=True)
        shutil.copy(shot, Path(keep) / name)
    image = cv2.imread(str(shot))
    assert image is not None and image.shape[:2] == (600, 800)
    return image


def _colours(image: np.ndarray) -> int:
    return len(np.unique(image.reshape(-1, 3), axis=0))


def _pixels_of_hue(image: np.ndarray, rgb) -> int:
    """Pixels of the hue of ``rgb`` (any shade of it), strongly coloured."""
    hsv = cv2.cvtColor(image, cv2.COLOR_BGR2HSV).reshape(-1, 3).astype(int)
    ref = cv2.cvtColor(np.uint8([[rgb[::-1]]]), cv2.COLOR_BGR2HSV)[0, 0].astype(int)
    near = np.abs((hsv[:, 0] - ref[0] + 90) % 180 - 90) <= 6
    return int(np.count_nonzero(near & (hsv[:, 1] > 100) & (hsv[:, 2] > 60)))


@needs_chromium
def test_the_page_draws_in_chromium_and_a_click_opens_a_logs_evidence(two_views, tmp_path):
    folder, _ = two_views
    page = write_estimate_page(folder / "estimate.json", tmp_path / "views.html",
                               truth=folder / "near.truth.json")
    status = _load(page, tmp_path, "#selftest")
    assert status["data-errors"] == ""
    assert int(status["data-drawn"]) >= 1 and int(status["data-faces"]) > 100
    assert status["data-logs"] == "8" and status["data-cameras"] == "2"
    # A click on the front-most log face selected that log and opened its panel.
    outcome = status["data-selftest"].split(" | ")
    assert outcome[0].startswith("ok log:"), outcome
    # A drag then turned the view (keeping the selection), the wheel moved it back.
    assert outcome[1:] == ["orbit ok", "zoom ok"], outcome
    assert 'id="panel" class="card"' in status["dom"]  # no longer hidden
    image = _screenshot(page, tmp_path, "report-views.png")
    assert _colours(image) > 200
    # Right logs are painted green (no wrong ones: the estimate is the truth).
    assert _pixels_of_hue(image, (40, 170, 60)) > 2000


@needs_chromium
def test_a_bare_evidence_page_draws_and_lists_a_logs_features(bare, tmp_path):
    page = write_estimate_page(bare / "estimate.json", tmp_path / "bare.html")
    status = _load(page, tmp_path, "#log=0")
    assert status["data-errors"] == "" and int(status["data-drawn"]) >= 1
    assert status["data-cameras"] == "0" and status["data-selected"] == "log:0"
    dom = status["dom"]
    assert "<h2>" in dom and "Log 0" in dom
    rows = re.findall(r'<tr class="(?:judged|unjudged)">', dom)
    notches = read_json(bare / "estimate.json")["structure"]["logs"][0]["notches"]
    assert len(rows) == 2 + 2 * notches + (notches - 1)
    image = _screenshot(page, tmp_path, "report-bare.png")
    assert _colours(image) > 200
    assert _pixels_of_hue(image, (40, 170, 60)) > 1000  # seen logs, green


@needs_chromium
def test_a_page_with_a_missing_view_file_says_so(two_views, tmp_path):
    folder, _ = two_views
    data = read_json(folder / "estimate.json")
    data["views"][1]["source"] = "</script>gone.json"
    write_json(tmp_path / "estimate.json", data)
    page = write_estimate_page(tmp_path / "estimate.json", tmp_path / "missing.html")
    status = _load(page, tmp_path)
    assert status["data-errors"] == "" and status["data-cameras"] == "1"
    assert status["data-notes"] == "1" and "&lt;/script&gt;gone.json" in status["dom"]
