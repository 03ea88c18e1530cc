"""Photograph to truth, as a user runs it: the installed ``unseeable estimate`` on small
rendered views of corpus designs (path-traced by Mitsuba and flat-shaded by the
rasteriser), with the pose recorded in the view file and estimated from the image, from
one view and from two stations; and the demo.

Each estimate is run once per module (a subprocess) and judged by several tests: its
errors against the truth stay under a bound, ``confident`` is never claimed for a wrong
estimate, the pictures are PNGs of a sensible size, and ``estimate.json`` validates.

The bounds are the errors measured on 2026-12-06 (over commit 1e2a12a) plus a margin of
two logs: an estimate on the wrong pose or extent makes tens of errors, so a bound this close
to the measured figure still catches the regressions a user would notice.
"""

from __future__ import annotations

import re
import shutil
import subprocess
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
import pytest

from unseeable.corpus import load_design
from unseeable.domain import GridPose
from unseeable.domain.io import structure_from_json
from unseeable.evaluate.metric import compare_structures
from unseeable.pipeline import load_estimate
from unseeable.render.view import load_truth

WIDTH, HEIGHT = 320, 240
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
README = Path(__file__).resolve().parents[2] / "README.md"


@dataclass(frozen=True)
class Case:
    """One estimate run: views of ``design`` rendered by ``renderer`` at ``angles`` (the
    first is the reference view), the pose ``known`` (recorded in the view files) or
    estimated from the images."""

    renderer: str  # "mitsuba" or "raster"
    design: str
    angles: tuple[float, ...]
    known: bool

    @property
    def id(self) -> str:
        stations = "+".join(f"{a:g}" for a in self.angles)
        return f"{self.renderer}-{self.design}-{stations}-{'known' if self.known else 'estimated'}"

    def single(self) -> Case:
        """The same run from the reference view alone."""
        return Case(self.renderer, self.design, self.angles[:1], self.known)


# Errors measured on 2026-12-06 (in brackets) and the bound the tests hold them to.
BOUNDS = {
    Case("raster", "cabin-door-L3", (150.0,), True): 4,  # [2]
    Case("raster", "cabin-door-L3", (150.0,), False): 4,  # [2]
    Case("raster", "crib", (150.0,), True): 3,  # [1]
    Case("mitsuba", "tower-3-L3", (150.0,), True): 2,  # [0]
    Case("mitsuba", "cabin-4x4-L3", (150.0,), False): 2,  # [0]
}
QUICK = Case("raster", "cabin-door-L3", (150.0,), True)  # the one run of the quick subset
DEMO_BOUND = 3  # [1]: cabin-door at 150°, 320x240, 4 spp, pose estimated from the image

# Runs the δ* test alone called confident while wrong; the reading test must not.
ONCE_CONFIDENT_BUT_WRONG = [
    # 1 error: a seen 3-notch log at layer 0, (2, 3), misread as three 1-notch logs.
    Case("mitsuba", "cabin-door-L3", (150.0,), True),
    # 30 errors: the pose estimated from the image about 80 mm off (fit quality 0.84,
    # choice margin 0.18, not flagged ambiguous); the grid's readings then disagree.
    Case("raster", "corner-walls", (150.0,), False),
]

# Two stations against the reference station alone.
TWO_VIEWS = [
    pytest.param(Case("raster", "cabin-door-L3", (150.0, 90.0), False), marks=pytest.mark.slow,
                 id="raster-cabin-door-L3-150+90-estimated"),  # [0] against [2] alone
    pytest.param(Case("raster", "crib", (150.0, 90.0), True), marks=[
        pytest.mark.slow,
        pytest.mark.xfail(strict=True, reason=(
            "src: two stations of crib with the pose known make 3 errors (two log lines "
            "split), the 150° view alone 1 (a log missing)"))],
        id="raster-crib-150+90-known"),  # [3] against [1] alone
]


def _cases(table, *, quick=None, xfail=None):
    params = []
    for case in table:
        marks = [] if case == quick else [pytest.mark.slow]
        if xfail is not None:
            marks.append(pytest.mark.xfail(strict=True, reason=xfail[case]))
        params.append(pytest.param(case, marks=marks, id=case.id))
    return params


# --------------------------------------------------------------------------- the runs

def render_views(case: Case, folder: Path) -> list[tuple[Path, Path]]:
    """Render the case's views into ``folder``: per station the view file (with the pose
    when known, else without) and the truth file."""
    from unseeable.render.view import View, save_truth, save_view

    entry = load_design(case.design)
    s, pose = entry.structure, entry.pose
    folder.mkdir(parents=True, exist_ok=True)
    files = []
    if case.renderer == "mitsuba":
        from unseeable.render.settings import RenderSettings
        from unseeable.render.workspace import PendulumArm, Workspace

        ws = Workspace(s, pose=pose, arm=PendulumArm(width=WIDTH, height=HEIGHT),
                       settings=RenderSettings(spp=8), seed=0)
        shots = []
        for angle in case.angles:
            view = ws.observe(angle)
            shots.append((view, ws.truth(view)))
    else:
        from unseeable.domain import feature_values
        from unseeable.render.raster import RasterLook, rasterise_view
        from unseeable.render.view import ViewTruth
        from unseeable.render.workspace import PendulumArm
        from unseeable.visibility import feature_visibility

        shots = []
        for angle in case.angles:
            camera = PendulumArm(width=WIDTH, height=HEIGHT).camera(angle)
            image = rasterise_view(s, pose, camera, look=RasterLook(), seed=int(angle))
            shots.append((View(image, camera, s.extent, pose=pose),
                          ViewTruth(s, pose, camera, feature_values(s.extent, s.occupancy),
                                    feature_visibility(s, camera.centre, pose))))
    for view, truth in shots:
        name = f"view{view.camera.width}-{len(files) + 1}"
        image = folder / f"{name}.png"
        recorded = view.pose if case.known else None
        save_view(View(view.image, view.camera, view.extent, pose=recorded), folder /
                  f"{name}.json", image_path=image)
        save_truth(truth, folder / f"{name}.truth.json")
        files.append((folder / f"{name}.json", folder / f"{name}.truth.json"))
    return files


def run_unseeable(*args, cwd: Path) -> subprocess.CompletedProcess:
    """The installed console script, as a user runs it."""
    command = shutil.which("unseeable")
    assert command is not None, "the console script `unseeable` is not on PATH"
    return subprocess.run([command, *map(str, args)], capture_output=True, text=True,
                          cwd=cwd, timeout=900)


@dataclass(frozen=True)
class Run:
    case: Case
    done: subprocess.CompletedProcess
    out: Path
    truth: Path
    printed_errors: int | None


@pytest.fixture(scope="module")
def estimate_run(tmp_path_factory):
    """``estimate_run(case)``: the case's views rendered and estimated (once per module)."""
    runs: dict[Case, Run] = {}

    def run(case: Case) -> Run:
        if case not in runs:
            folder = tmp_path_factory.mktemp(case.id.replace("+", "_"))
            files = render_views(case, folder / "views")
            out = folder / "out"
            truth = files[0][1]
            done = run_unseeable("estimate", *[v for v, _ in files], "--out", out,
                                 "--truth", truth, cwd=folder)
            found = re.findall(r"errors against the truth: (\d+)", done.stdout)
            runs[case] = Run(case, done, out, truth, int(found[0]) if len(found) == 1 else None)
        return runs[case]

    return run


def errors_in_the_file(out: Path, truth_file: Path) -> tuple[int, object]:
    """The errors of ``out/estimate.json`` against a truth file (the logs compared where
    they stand), recomputed without the command; and the validated estimate file."""
    data = load_estimate(out / "estimate.json")
    truth = load_truth(truth_file)
    structure = structure_from_json(data.model_dump(mode="json")["structure"],
                                    check_grammar=False)
    comparison = compare_structures(truth.structure, structure, truth_pose=truth.pose,
                                    estimate_pose=GridPose(**data.pose.model_dump()),
                                    on_misaligned="count")
    return comparison.errors, data


def check_finished(run: Run) -> None:
    assert run.done.returncode == 0, run.done.stderr
    assert "Traceback" not in run.done.stdout + run.done.stderr
    assert run.printed_errors is not None, run.done.stdout


def check_png(path: Path, size: tuple[int, int] | None = None) -> np.ndarray:
    """``path`` is a PNG that shows something: of ``size`` (width, height) when given,
    else of a size a person can look at (a picture may be cropped to the assembly and
    enlarged, or shrunk to PICTURE_MAX_SIDE)."""
    data = path.read_bytes()
    assert data[:8] == PNG_SIGNATURE, f"{path} is not a PNG"
    image = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR)
    assert image is not None, f"{path} does not decode"
    if size is not None:
        assert image.shape == (size[1], size[0], 3), (path, image.shape)
    else:
        assert image.ndim == 3 and image.shape[2] == 3, (path, image.shape)
        assert min(image.shape[:2]) >= 64 and 160 <= max(image.shape[:2]) <= 1600, (
            path, image.shape)
    assert image.std() > 5.0, f"{path} is (almost) one colour"
    return image


# --------------------------------------------------------------------------- one view

@pytest.mark.parametrize("case", _cases(BOUNDS, quick=QUICK))
def test_errors_against_the_truth_stay_under_the_measured_bound(estimate_run, case):
    run = estimate_run(case)
    check_finished(run)
    recomputed, data = errors_in_the_file(run.out, run.truth)
    assert run.printed_errors == recomputed  # the summary counts what the file holds
    assert recomputed <= BOUNDS[case], run.done.stdout
    assert data.structure.extent == tuple(load_design(case.design).structure.extent.as_list())
    assert data.views[0].pose_fit.source == ("given" if case.known else "estimated")


@pytest.mark.parametrize("case", _cases(BOUNDS, quick=QUICK)
                         + _cases(ONCE_CONFIDENT_BUT_WRONG))
def test_confident_is_never_claimed_for_a_wrong_estimate(estimate_run, case):
    run = estimate_run(case)
    check_finished(run)
    errors, data = errors_in_the_file(run.out, run.truth)
    assert data.confident is not None  # the command runs the confidence test by default
    assert ("confident: yes" in run.done.stdout) == data.confident
    assert not (data.confident and errors > 0), (
        f"confident with {errors} errors against the truth:\n{run.done.stdout}")


@pytest.mark.parametrize("case", _cases(BOUNDS, quick=QUICK))
def test_the_pictures_are_pngs_of_a_sensible_size(estimate_run, case):
    run = estimate_run(case)
    check_finished(run)
    check_png(run.out.parent / "views" / f"view{WIDTH}-1.png", (WIDTH, HEIGHT))
    check_png(run.out / "overlay.png")
    check_png(run.out / "estimate.png")
    for name in ("overlay.png", "estimate.png", "estimate.json"):
        assert f"{run.out / name}" in run.done.stdout  # the summary says where it wrote


@pytest.mark.parametrize("case", _cases(BOUNDS, quick=QUICK))
def test_estimate_json_validates_and_holds_the_views_features(estimate_run, case):
    run = estimate_run(case)
    check_finished(run)
    data = load_estimate(run.out / "estimate.json")
    assert data.format == "unseeable/estimate@2"
    assert data.status in ("optimal", "feasible")
    assert len(data.views) == len(case.angles)
    assert data.features is not None and len(data.features) > 0
    assert all(0.0 <= f.p <= 1.0 for f in data.features)


# --------------------------------------------------------------------------- two views

@pytest.mark.parametrize("case", TWO_VIEWS)
def test_a_second_station_makes_no_more_errors_than_the_first_alone(estimate_run, case):
    both, alone = estimate_run(case), estimate_run(case.single())
    check_finished(both)
    check_finished(alone)
    errors, data = errors_in_the_file(both.out, both.truth)
    assert both.printed_errors == errors
    assert [v.source for v in data.views] == [str(p) for p in sorted(
        (both.out.parent / "views").glob(f"view{WIDTH}-?.json"))]
    for n in (1, 2):
        check_png(both.out / f"overlay_{n}.png")
    check_png(both.out / "estimate.png")
    assert not (both.out / "overlay.png").exists()
    assert not (data.confident and errors > 0)
    assert errors <= alone.printed_errors, (both.done.stdout, alone.done.stdout)


# --------------------------------------------------------------------------- the demo

def demo_table_files() -> list[str]:
    """The files README.md's table under "What `unseeable demo` writes" lists."""
    text = README.read_text(encoding="utf-8")
    section = text.split("## What `unseeable demo` writes", 1)[1].split("\n## ", 1)[0]
    return re.findall(r"^\| `([^`]+)` \|", section, flags=re.MULTILINE)


def test_the_readme_lists_the_demos_files():
    # What the demo test checks for must not be an empty list.
    assert {"view.png", "view.json", "estimate.json", "overlay.png",
            "estimate.png"} <= set(demo_table_files())


@pytest.mark.slow
def test_the_demo_writes_its_files_and_estimates_within_the_bound(tmp_path):
    from unseeable.pipeline import run_demo

    out = tmp_path / "demo"
    # `unseeable demo` has no size option: the demo at a small size, in this process.
    result = run_demo(out, size=(WIDTH, HEIGHT), spp=4)
    missing = [name for name in demo_table_files() if not (out / name).is_file()]
    assert not missing, f"README.md's demo table lists files the demo did not write: {missing}"
    errors, data = errors_in_the_file(out, out / "view.truth.json")
    assert result.errors == errors
    assert errors <= DEMO_BOUND, result.pose_note
    assert result.pose_note == "pose estimated from the image"
    assert not (data.confident and errors > 0)
    check_png(out / "view.png", (WIDTH, HEIGHT))
    check_png(out / "overlay.png")
    check_png(out / "estimate.png")
    assert {str(p) for p in result.files.values()} <= {str(out / n) for n in demo_table_files()}
