"""The installed ``unseeable`` command refusing bad input, as a user meets it.

Every case runs the console script in a subprocess and asserts what a user (or a script
around the command) relies on: exit code 1, exactly one line on stderr that names the
file and/or the field and the value at fault, no traceback anywhere, and nothing
written (the ``--out`` folder does not exist afterwards).
"""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from unseeable.domain import Extent, Log, Structure, save_evidence, save_structure
from unseeable.domain.evidence import simulate_evidence


def run_unseeable(*args, cwd: Path) -> subprocess.CompletedProcess:
    """The installed console script, as a user runs it."""
    command = shutil.which("unseeable")
    assert command is not None, "the console script `unseeable` is not on PATH"
    return subprocess.run([command, *map(str, args)], capture_output=True, text=True,
                          cwd=cwd, timeout=600)


def assert_refused(done: subprocess.CompletedProcess, needles, out: Path | None) -> str:
    """Exit code 1, one line on stderr holding every needle, no traceback, no ``out``."""
    both = done.stdout + done.stderr
    assert "Traceback" not in both, both
    assert done.returncode == 1, both
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1, f"expected one line on stderr, got {len(lines)}:\n{done.stderr}"
    line = lines[0]
    assert line.startswith("error: "), line
    for needle in needles:
        assert str(needle) in line, f"{needle!r} not in {line!r}"
    if out is not None:
        assert not out.exists(), f"{out} was written: {sorted(p.name for p in out.iterdir())}"
    return line


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """A folder of good and bad inputs (see the names)."""
    from unseeable.render.view import View, save_view, write_image
    from unseeable.render.workspace import PendulumArm

    d = tmp_path_factory.mktemp("inputs")
    house = Structure(Extent(3, 2, 3), [Log(0, (0, 0), 3), Log(0, (0, 2), 3),
                                        Log(1, (0, 0), 3), Log(1, (2, 0), 3)])
    save_structure(house, d / "house.structure.json")
    save_evidence(simulate_evidence(house, accuracy=1.0, occluded_fraction=0.0, seed=0),
                  d / "house.evidence.json")
    save_structure(Structure(Extent(2, 1, 2), [Log(0, (0, 0), 2)]), d / "other.structure.json")
    (d / "camera-format.json").write_text('{"format": "unseeable/camera@1"}')
    (d / "not-json.json").write_text("{not json")
    # A camera the estimator accepts (it refuses one too coarse for the detectors).
    camera = PendulumArm(width=320, height=240).camera(150.0)
    save_view(View(np.full((240, 320, 3), 90, np.uint8), camera, Extent(2, 2, 2)),
              d / "view.json", image_path=d / "view.png")
    data = json.loads((d / "view.json").read_text())
    (d / "no-image.json").write_text(json.dumps({**data, "image": "gone.png"}))
    write_image(d / "small.png", np.zeros((24, 32, 3), np.uint8))
    (d / "wrong-size.json").write_text(json.dumps({**data, "image": "small.png"}))
    (d / "a-file").write_text("not a folder\n")
    return d


@pytest.fixture(scope="module")
def hard_view(tmp_path_factory):
    """A view without a pose whose fit must be poor: its extent is too small for the
    assembly in the image (as ``test_cli_core.hard_view``, at 320x240)."""
    from unseeable.domain import GridPose
    from unseeable.render.raster import RasterLook, rasterise_view
    from unseeable.render.view import View, save_view
    from unseeable.render.workspace import PendulumArm
    from unseeable.training.scenes import random_structure

    s = random_structure(Extent(4, 3, 3), density=0.7, seed=0)
    camera = PendulumArm(width=320, height=240).camera(120.0)
    yaw = 17.0
    centre = np.array([(s.extent.I - 1) * 32.0, 0.0, (s.extent.K - 1) * 32.0])
    origin = -(GridPose(0.0, 0.0, yaw).rotation @ centre)
    pose = GridPose(float(origin[0]), float(origin[2]), yaw)
    image = rasterise_view(s, pose, camera, look=RasterLook(), seed=2)
    folder = tmp_path_factory.mktemp("hard")
    save_view(View(image, camera, Extent(2, 3, 2)), folder / "view.json")
    return folder / "view.json"


ESTIMATE = "estimate"
EVIDENCE = "{d}/house.evidence.json"
# name: (the arguments after `unseeable`, {d} the inputs folder and `--out` added; what the
# error line must name).
REFUSALS = {
    "missing-file": ([ESTIMATE, "{d}/nothere.json"], ["{d}/nothere.json", "no such file"]),
    "missing-truth-file": ([ESTIMATE, EVIDENCE, "--truth", "{d}/nothere.json"],
                           ["{d}/nothere.json"]),
    "missing-structure-to-render": (["render", "{d}/nothere.json", "--angles", "90"],
                                    ["{d}/nothere.json"]),
    "wrong-format": ([ESTIMATE, "{d}/camera-format.json"],
                     ["{d}/camera-format.json", "format", "'unseeable/camera@1'"]),
    "structure-given-as-input": ([ESTIMATE, "{d}/house.structure.json"],
                                 ["{d}/house.structure.json", "format",
                                  "'unseeable/structure@1'"]),
    "not-json": ([ESTIMATE, "{d}/not-json.json"], ["{d}/not-json.json", "not valid JSON"]),
    "png-given-as-input": ([ESTIMATE, "{d}/view.png"], ["{d}/view.png"]),
    "truth-of-another-format": ([ESTIMATE, EVIDENCE, "--truth", "{d}/view.json"],
                                ["{d}/view.json", "'unseeable/view@1'"]),
    "threads-0": ([ESTIMATE, EVIDENCE, "--threads", "0"], ["threads", "(got 0)"]),
    "time-limit-0": ([ESTIMATE, EVIDENCE, "--time-limit", "0"], ["time_limit", "(got 0.0)"]),
    "joint-cost-negative": ([ESTIMATE, EVIDENCE, "--joint-cost", "-1"],
                            ["joint_cost", "(got -1.0)"]),
    "joint-cost-huge": ([ESTIMATE, EVIDENCE, "--joint-cost", "1e300"],
                        ["joint_cost", "(got 1e+300)"]),
    "prior-unknown": ([ESTIMATE, EVIDENCE, "--prior", "nonsense"], ["prior", "'nonsense'"]),
    "backend-unknown": ([ESTIMATE, EVIDENCE, "--backend", "x"], ["backend", "'x'"]),
    "ties-unknown": ([ESTIMATE, EVIDENCE, "--ties", "fullest"], ["ties", "'fullest'"]),
    "truth-of-another-extent": ([ESTIMATE, EVIDENCE, "--truth", "{d}/other.structure.json"],
                                ["extent", "2x1x2", "3x2x3"]),
    "view-image-missing": ([ESTIMATE, "{d}/no-image.json"],
                           ["{d}/no-image.json", "image", "gone.png'"]),
    "view-image-of-the-wrong-size": ([ESTIMATE, "{d}/wrong-size.json"],
                                     ["{d}/wrong-size.json", "image", "32x24", "320x240"]),
    "several-files-one-not-a-view": ([ESTIMATE, "{d}/view.json", EVIDENCE],
                                     [EVIDENCE, "format", "'unseeable/evidence@1'"]),
    "demo-threads-0": (["demo", "--threads", "0"], ["threads", "(got 0)"]),
    "render-angles-not-numbers": (["render", "{d}/house.structure.json", "--angles", "abc"],
                                  ["--angles", "'abc'"]),
    "render-angles-one-not-a-number": (
        ["render", "{d}/house.structure.json", "--angles", "90,abc"],
        ["--angles", "'90,abc'"]),
    "render-angles-empty": (["render", "{d}/house.structure.json", "--angles", ""],
                            ["--angles"]),
    # A bad angle after a good one is refused before the good one is rendered.
    "render-angles-nan-after-a-good-one": (
        ["render", "{d}/house.structure.json", "--angles", "90,nan", "--size", "64x48",
         "--spp", "1"], ["angle", "nan"]),
}


def _fill(items, d: Path) -> list[str]:
    return [str(item).replace("{d}", str(d)) for item in items]


@pytest.fixture(scope="module")
def refusals(files, tmp_path_factory):
    """Every case of :data:`REFUSALS` run once, each in its own folder, a few at a time
    (each run is mostly the start-up of a process): name -> (result, its --out)."""
    from concurrent.futures import ThreadPoolExecutor

    folders = {name: tmp_path_factory.mktemp(name) for name in REFUSALS}

    def run(name):
        out = folders[name] / "out"
        done = run_unseeable(*_fill(REFUSALS[name][0], files), "--out", out,
                             cwd=folders[name])
        return name, (done, out)

    with ThreadPoolExecutor(max_workers=4) as pool:
        return dict(pool.map(run, REFUSALS))


@pytest.mark.parametrize("name", list(REFUSALS))
def test_bad_input_is_one_line_exit_1_and_nothing_written(files, refusals, name):
    done, out = refusals[name]
    assert_refused(done, _fill(REFUSALS[name][1], files), out)


def test_grammar_count_of_an_empty_extent(tmp_path):
    done = run_unseeable("grammar", "count", "--extent", "0,1,1", cwd=tmp_path)
    assert_refused(done, ["extent", "(got 0)"], None)
    assert not any(tmp_path.iterdir())


def test_corpus_build_into_a_file(files, tmp_path):
    target = files / "a-file"
    done = run_unseeable("corpus", "build", "--out", target, "--only", "wall-door",
                         "--size", "64x48", "--spp", "1", cwd=tmp_path)
    assert_refused(done, [str(target)], None)
    assert target.read_text() == "not a folder\n"
    assert not any(tmp_path.iterdir())


@pytest.mark.slow
def test_a_poor_pose_fit_is_refused_naming_the_view(hard_view, tmp_path):
    out = tmp_path / "out"
    done = run_unseeable("estimate", hard_view, "--out", out, cwd=tmp_path)
    assert_refused(done, [str(hard_view), "poor pose fit", "quality", "2x3x2"], out)
