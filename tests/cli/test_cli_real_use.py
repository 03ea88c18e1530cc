"""What a user meets after the README: outputs that cannot be written, impossible cameras and
poses, huge grids, answers not found in time, library warnings, the help screen.

Every refusal is one line on stderr, the documented exit code and nothing on disk.
"""

from __future__ import annotations

import copy
import errno
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from unseeable.cli import EXIT_TIME_LIMIT, main
from unseeable.domain import Extent, GridPose, Log, Structure, save_evidence, save_structure
from unseeable.domain.evidence import simulate_evidence


def run(capsys, *args):
    code = main(list(map(str, args)))
    out, err = capsys.readouterr()
    return code, out, err


def one_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("error: ") and "Traceback" not in err, err
    return lines[0]


def listing(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    """An evidence file, a structure file, a view of that structure with its pose (drawn
    by the raster renderer, fast), and a file that is not a folder."""
    from unseeable.render.raster import RasterLook, rasterise_view
    from unseeable.render.view import View, save_view
    from unseeable.render.workspace import PendulumArm, default_pose

    d = tmp_path_factory.mktemp("inputs")
    house = Structure(Extent(3, 2, 3), [Log(0, (0, 0), 3), Log(0, (0, 2), 3),
                                        Log(1, (0, 0), 3), Log(1, (2, 0), 3)])
    save_structure(house, d / "house.json")
    save_evidence(simulate_evidence(house, accuracy=1.0, occluded_fraction=0.0, seed=0),
                  d / "ev.json")
    camera = PendulumArm().camera(120.0)
    pose = default_pose(house.extent)
    image = rasterise_view(house, pose, camera, look=RasterLook(), seed=1)
    save_view(View(image, camera, house.extent, pose), d / "view.json")
    save_view(View(image, camera, house.extent), d / "view-nopose.json",
              image_path=d / "view.png")
    (d / "a-file").write_text("not a folder\n")
    return d


def edited_view(inputs: Path, name: str, edit) -> Path:
    """A copy of the view file with ``edit(data)`` applied (the image stays where it is)."""
    data = json.loads((inputs / "view.json").read_text())
    data["image"] = str(inputs / data["image"])
    data = copy.deepcopy(data)
    edit(data)
    path = inputs / name
    path.write_text(json.dumps(data))
    return path


# ---- outputs that cannot be written -------------------------------------------------------

COMMANDS = {
    "estimate": ["estimate", "{d}/ev.json"],
    "pose": ["pose", "{d}/view.json"],
    "detect": ["detect", "{d}/view.json"],
    "render": ["render", "{d}/house.json", "--angles", "150", "--size", "64x48", "--spp", "1"],
    "demo": ["demo", "--spp", "1"],
}


def _args(name: str, d: Path) -> list[str]:
    return [a.replace("{d}", str(d)) for a in COMMANDS[name]]


@pytest.mark.parametrize("command", sorted(COMMANDS))
@pytest.mark.parametrize("where, needle", [("a-file", "is a file; give a folder"),
                                           ("a-file/sub", "is a file, not a folder")])
def test_an_out_that_is_a_file_or_under_one_is_refused_before_any_work(
        capsys, inputs, command, where, needle, monkeypatch):
    # Refused before any work: nothing may start to render or estimate.
    import unseeable.pipeline as pipeline

    monkeypatch.setattr(pipeline, "run_demo", lambda *a, **k: pytest.fail("demo ran"))
    monkeypatch.setattr(pipeline, "find_pose", lambda *a, **k: pytest.fail("pose ran"))
    monkeypatch.setattr(pipeline, "estimate_files", lambda *a, **k: pytest.fail("ran"))
    before = listing(inputs)
    code, out, err = run(capsys, *_args(command, inputs), "--out", inputs / where)
    assert code == 1 and out == ""
    line = one_line(err)
    assert "--out" in line and needle in line and str(inputs / where) in line
    assert listing(inputs) == before and (inputs / "a-file").read_text() == "not a folder\n"


@pytest.mark.parametrize("args, name", [
    (["cad", "--notches", "2"], "mesh.stl"),
    (["camera", "locate", "{d}/view.png", "--intrinsics", "{d}/none.json", "--chessboard",
      "9x6", "--square", "25"], "camera.json"),
    (["view", "new", "{d}/view.png", "--camera", "{d}/none.json", "--extent", "3,2,3"],
     "view.json"),
])
def test_a_single_file_output_that_is_a_folder_is_refused_first(capsys, tmp_path, inputs, args,
                                                                 name):
    folder = tmp_path / name
    folder.mkdir()
    code, _, err = run(capsys, *[a.replace("{d}", str(inputs)) for a in args],
                       "--out", folder)
    assert code == 1
    line = one_line(err)
    assert "--out" in line and "is a folder; give a file name" in line
    assert listing(tmp_path) == [name]


def test_a_folder_you_cannot_write_to_is_refused(capsys, tmp_path, inputs, monkeypatch):
    # As root, os.access says yes to every folder: the answer for another user is faked here
    # (and met for real on a read-only mount in the test below).
    locked = tmp_path / "locked"
    locked.mkdir()
    real = os.access
    monkeypatch.setattr(os, "access", lambda p, mode, **k: False
                        if Path(p).absolute() == locked.absolute() and mode & os.W_OK
                        else real(p, mode, **k))
    code, _, err = run(capsys, "estimate", inputs / "ev.json", "--out", locked)
    assert code == 1 and "is a folder you cannot write to" in one_line(err)
    code, _, err = run(capsys, "estimate", inputs / "ev.json", "--out", locked / "new")
    assert code == 1 and f"cannot be made: you cannot write to {locked}" in one_line(err)
    assert listing(tmp_path) == ["locked"]


def _unshare_works() -> bool:
    if shutil.which("unshare") is None or shutil.which("unseeable") is None:
        return False
    done = subprocess.run(["unshare", "-m", "true"], capture_output=True)
    return done.returncode == 0


@pytest.mark.skipif(not _unshare_works(), reason="needs `unshare -m` (mount namespaces)")
def test_a_read_only_folder_is_refused_by_the_installed_command(inputs, tmp_path):
    folder = tmp_path / "read-only"
    folder.mkdir()
    script = (f"mount --bind {folder} {folder} && mount -o remount,bind,ro {folder} && "
              f"exec {shutil.which('unseeable')} estimate {inputs / 'ev.json'} "
              f"--out {folder / 'out'}")
    done = subprocess.run(["unshare", "-m", "sh", "-c", script], capture_output=True,
                          text=True, timeout=300)
    if "mount:" in done.stderr:
        pytest.skip(f"cannot mount here: {done.stderr.strip()}")
    assert done.returncode == 1, done.stderr
    line = one_line(done.stderr)
    assert "--out" in line and f"you cannot write to {folder}" in line
    assert listing(folder) == []


@pytest.fixture
def full_disk(monkeypatch):
    """``write_estimate`` failing as on a full disk, after the pictures are written."""
    import unseeable.pipeline as pipeline

    real = pipeline.write_estimate

    def failing(estimate, out_dir):
        real(estimate, out_dir)  # the file is half there, as a full disk leaves it
        raise OSError(errno.ENOSPC, "No space left on device",
                      str(Path(out_dir) / "estimate.json"))

    monkeypatch.setattr(pipeline, "write_estimate", failing)


def test_a_failure_writing_estimate_json_leaves_no_pictures_behind(capsys, inputs, tmp_path,
                                                                   full_disk):
    out = tmp_path / "new" / "out"
    code, stdout, err = run(capsys, "estimate", inputs / "view.json", "--out", out,
                            "--no-tolerance")
    assert code == 1 and stdout == ""
    line = one_line(err)
    assert "--out" in line and "No space left on device" in line and str(out) in line
    assert listing(tmp_path) == []  # not even the folders made on the way
    # Into a folder that exists: its files stay as they were, no new file comes in.
    out.mkdir(parents=True)
    (out / "notes.txt").write_text("mine")
    code, _, err = run(capsys, "estimate", inputs / "view.json", "--out", out,
                       "--no-tolerance")
    assert code == 1 and listing(out) == ["notes.txt"]


def test_an_existing_folder_receives_the_new_files_and_keeps_its_others(capsys, inputs,
                                                                       tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    (out / "overlay.png").write_text("an old picture")
    code, stdout, err = run(capsys, "estimate", inputs / "view.json", "--out", out,
                            "--no-tolerance")
    assert code == 0, err
    assert listing(out) == ["estimate.json", "estimate.png", "notes.txt", "overlay.png"]
    assert (out / "notes.txt").read_text() == "mine"
    assert (out / "overlay.png").read_bytes()[:4] == b"\x89PNG"
    assert f"wrote {out / 'estimate.json'}" in stdout  # where the files are, not were


def test_render_leaves_no_view_behind_when_a_later_view_fails(capsys, inputs, tmp_path,
                                                              monkeypatch):
    from unseeable.errors import RenderError
    from unseeable.render.workspace import Workspace

    real = Workspace.observe
    calls = []

    def second_fails(self, angle, **options):
        calls.append(angle)
        if len(calls) == 2:
            raise RenderError("the renderer ran out of memory")
        return real(self, angle, **options)

    monkeypatch.setattr(Workspace, "observe", second_fails)
    out = tmp_path / "views"
    code, stdout, err = run(capsys, "render", inputs / "house.json", "--angles", "150,210",
                            "--size", "64x48", "--spp", "1", "--out", out)
    assert code == 1 and calls == [150.0, 210.0]
    assert "ran out of memory" in one_line(err)
    assert listing(tmp_path) == []


# ---- honest answers -----------------------------------------------------------------------

def _focal(f):
    def edit(data):
        data["camera"]["K"][0][0] = data["camera"]["K"][1][1] = f
    return edit


def _looking_up(data):
    R = np.array(data["camera"]["R"])
    t = np.array(data["camera"]["t"])
    turn = np.diag([-1.0, 1.0, -1.0])  # half a turn about the camera's own y axis
    data["camera"]["R"] = (turn @ R).tolist()
    data["camera"]["t"] = (turn @ t).tolist()


def _pose_off(data):
    data["pose"] = {"x": 3000.0, "z": 3000.0, "yaw_deg": 0.0}


@pytest.mark.parametrize("name, edit, needles", [
    ("huge-focal", _focal(1e9), ["camera.K", "mm of the table", "in pixels?"]),
    ("tiny-focal", _focal(1e-3), ["camera.K", "mm per pixel", "in pixels?"]),
    ("looking-up", _looking_up, ["camera", "does not see the table"]),
    ("pose-off-the-image", _pose_off, ["pose", "outside the image", "none of the extent's",
                                       "[3000.0, 3000.0, 0.0]"]),
])
@pytest.mark.parametrize("command", ["estimate", "detect", "pose"])
def test_a_camera_or_pose_that_cannot_show_the_assembly_is_an_error_naming_the_file(
        capsys, inputs, tmp_path, name, edit, needles, command):
    if command == "pose" and name == "pose-off-the-image":
        pytest.skip("`pose` ignores the recorded pose")
    view = edited_view(inputs, f"{name}.json", edit)
    code, out, err = run(capsys, command, view, "--out", tmp_path / "out")
    assert code == 1 and out == ""
    line = one_line(err)
    assert str(view) in line
    for needle in needles:
        assert needle in line, line
    assert listing(tmp_path) == []


def test_a_pose_found_off_the_image_is_refused(capsys, inputs, tmp_path, monkeypatch):
    # However the pose search comes to it, a pose that leaves the photograph empty is not
    # an answer.
    import unseeable.pipeline as pipeline
    from unseeable.pipeline.files import check_estimated_poses

    view = inputs / "view-nopose.json"
    real = pipeline.find_pose

    def astray(observation, settings, **options):
        import dataclasses

        found = real(observation, settings, **options)
        return dataclasses.replace(found, pose=GridPose(3000.0, 3000.0, 0.0))

    monkeypatch.setattr(pipeline, "find_pose", astray)
    code, _, err = run(capsys, "pose", view, "--out", tmp_path / "out")
    assert code == 1
    line = one_line(err)
    assert str(view) in line and "estimated from the image puts the assembly outside" in line
    assert listing(tmp_path) == []
    # The estimate's own check, on its records.
    from unseeable.pipeline import estimate_files
    from unseeable.render.view import load_view

    est, _ = estimate_files([inputs / "view.json"])
    moved = [load_view(view)]
    record = dataclasses_replace(est.views[0], pose=GridPose(3000.0, 3000.0, 0.0))
    with pytest.raises(Exception, match="estimated from the image puts"):
        check_estimated_poses(dataclasses_replace(est, views=(record,)), moved, [view])


def dataclasses_replace(obj, **fields):
    import dataclasses

    return dataclasses.replace(obj, **fields)


def test_render_refuses_a_pose_that_puts_the_assembly_off_the_image(capsys, inputs, tmp_path,
                                                                   monkeypatch):
    from unseeable.render.workspace import Workspace

    monkeypatch.setattr(Workspace, "observe", lambda *a, **k: pytest.fail("rendered"))
    code, out, err = run(capsys, "render", inputs / "house.json", "--angles", "90,150",
                         "--pose", "3000,3000,0", "--out", tmp_path / "out")
    assert code == 1 and out == ""
    line = one_line(err)
    assert "--pose" in line and "from the arm at 90°" in line and "outside the image" in line
    assert listing(tmp_path) == []


def test_the_joint_cost_is_held_to_a_sane_range(capsys, inputs, tmp_path):
    code, _, err = run(capsys, "estimate", inputs / "ev.json", "--out", tmp_path / "o",
                       "--joint-cost", "1e300")
    assert code == 1 and "joint_cost" in one_line(err) and "1e+300" in err
    assert listing(tmp_path) == []


@pytest.mark.parametrize("option, value, needle", [
    ("--time-limit", "1e9", "time_limit: must be at most 86400 seconds"),
    ("--threads", "100000", "threads: must be at most 256"),
])
def test_limits_beyond_sense_are_refused(capsys, inputs, tmp_path, option, value, needle):
    code, _, err = run(capsys, "estimate", inputs / "ev.json", "--out", tmp_path / "o",
                       option, value)
    assert code == 1 and needle in one_line(err)
    assert listing(tmp_path) == []


def test_a_grid_too_large_to_estimate_is_refused_at_once(capsys, tmp_path):
    from unseeable.pipeline.files import MAX_ESTIMATE_POSITIONS

    big = tmp_path / "big.json"
    big.write_text(json.dumps({"format": "unseeable/evidence@1", "extent": [16, 16, 16],
                               "features": []}))
    code, _, err = run(capsys, "estimate", big, "--out", tmp_path / "o")
    assert code == 1
    line = one_line(err)
    assert str(big) in line and "4096 grid positions" in line
    assert str(MAX_ESTIMATE_POSITIONS) in line
    assert listing(tmp_path) == ["big.json"]


def test_no_structure_within_the_time_limit_is_exit_code_3_and_no_file(capsys, inputs,
                                                                      tmp_path, monkeypatch):
    import dataclasses

    import unseeable.pipeline as pipeline
    from unseeable.solve.result import SolveStatus

    real = pipeline.estimate_files

    def timed_out(*args, **options):
        est, pictures = real(*args, **options)
        result = dataclasses.replace(est.result, structure=None, status=SolveStatus.TIMEOUT)
        return dataclasses.replace(est, result=result), pictures

    monkeypatch.setattr(pipeline, "estimate_files", timed_out)
    code, out, err = run(capsys, "estimate", inputs / "ev.json", "--out", tmp_path / "o",
                         "--time-limit", "5")
    assert code == EXIT_TIME_LIMIT == 3 and out == ""
    line = one_line(err)
    assert "no structure found within the time limit (5 s per solve" in line
    assert listing(tmp_path) == []


def test_the_estimate_help_documents_the_exit_codes_and_fits_one_screen(capsys, monkeypatch):
    monkeypatch.setenv("COLUMNS", "100")
    code, out, _ = run(capsys, "estimate", "--help")
    assert code == 0
    assert len(out.splitlines()) <= 40, out
    assert "3 no structure found within the time limit" in " ".join(out.split())
    # On/off flags show both spellings and no type; the advanced options sit apart.
    flags = [ln for ln in out.splitlines() if "--force-pose" in ln or "--tolerance" in ln]
    assert flags and all("<bool>" not in ln for ln in flags)
    assert any("--no-force-pose" in ln for ln in flags)
    assert "Advanced" in out and "Photographs" in out
    assert out.index("--joint-cost") > out.index("Advanced") > out.index("--time-limit")


def test_a_library_warning_is_one_logged_line(tmp_path):
    # A library's RuntimeWarning (numpy's, say) reaches the terminal as one log line, not as
    # a dump with its source line.
    code = ("import warnings, sys; import unseeable.grammar as g\n"
            "def noisy(extent, **options):\n"
            "    warnings.warn('invalid value\\nencountered in divide', RuntimeWarning)\n"
            "    return 5\n"
            "g.count_valid = noisy\n"
            "from unseeable.cli import main\n"
            "sys.exit(main(['grammar', 'count', '--extent', '2,1,1']))\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          cwd=tmp_path, timeout=300)
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines()[-1] == "5"
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1, done.stderr
    assert lines[0].startswith("WARNING py.warnings: RuntimeWarning: invalid value "
                               "encountered in divide ("), lines[0]


# ---- long counts --------------------------------------------------------------------------

def test_grammar_count_stops_when_it_would_overrun_its_time_limit(capsys):
    code, out, err = run(capsys, "grammar", "count", "--extent", "4,8,4", "--time-limit", "0.5")
    assert code == EXIT_TIME_LIMIT and out == ""
    line = one_line(err)
    assert "would take about" in line and "--time-limit 0.5 s" in line


def test_grammar_count_refuses_an_extent_it_cannot_hold(capsys):
    code, _, err = run(capsys, "grammar", "count", "--extent", "4,64,5")
    assert code == 1
    line = one_line(err)
    assert "GiB of memory" in line and "[4, 64, 5]" in line


def test_the_count_clock_stops_at_the_limit_and_not_before():
    import time

    from unseeable.cli import TimeLimitReached
    from unseeable.cli.grammar import CountClock

    reports = []
    clock = CountClock(0.05, lambda done, total: reports.append(done))
    clock(0, 100)
    clock(1, 100)  # too early to project
    time.sleep(0.06)
    with pytest.raises(TimeLimitReached, match="stopped at the time limit"):
        clock(2, 100)
    clock(100, 100)  # a count that is done is never stopped
    assert reports == [0, 1, 2, 100]


# ---- numba's cache for any user ------------------------------------------------------------

def test_the_numba_cache_moves_where_the_user_can_write(tmp_path):
    from unseeable import numba_cache_dir

    package = tmp_path / "package"
    package.mkdir()
    cache = tmp_path / "cache"
    blocked = tmp_path / "a-file"
    blocked.write_text("")
    locked = {package}
    writable = lambda p: p not in locked and os.access(p, os.W_OK)  # noqa: E731
    env = {"XDG_CACHE_HOME": str(cache), "HOME": str(blocked / "home")}
    assert numba_cache_dir(package, env, writable=writable) == cache / "unseeable" / "numba"
    assert (cache / "unseeable" / "numba").is_dir()
    # Neither XDG_CACHE_HOME nor HOME usable (HOME still root's after `su`): another place.
    env = {"XDG_CACHE_HOME": str(blocked / "xdg"), "HOME": str(blocked / "home")}
    chosen = numba_cache_dir(package, env, writable=writable)
    assert chosen is not None and writable(chosen) and blocked not in chosen.parents
    # A writable package, or a NUMBA_CACHE_DIR set by the user: left alone.
    assert numba_cache_dir(package, env) is None
    assert numba_cache_dir(package, {**env, "NUMBA_CACHE_DIR": "/x"}, writable=writable) is None


@pytest.mark.skipif(not _unshare_works(), reason="needs `unshare -m` (mount namespaces)")
def test_the_kernels_load_from_a_package_nobody_may_write_to(tmp_path):
    # The package folder mounted read-only, as an install by root is for another user: the
    # kernels still compile, and cache where that user can write.
    import unseeable

    package = Path(unseeable.__file__).parent
    cache = tmp_path / "xdg"
    code = ("import os, numpy as np; from unseeable.visibility.rays import "
            "count_ray_cylinder_hits as hits; "
            "print(hits(np.zeros((1, 1, 3)), np.ones((1, 1), bool), np.array([0., 100, 0]), "
            "np.array([[[0., 5, -10], [0, 5, 10]]]), 5.0)); "
            "print(os.environ['NUMBA_CACHE_DIR'])")
    script = (f"mount --bind {package} {package} && mount -o remount,bind,ro {package} && "
              f"exec env -u NUMBA_CACHE_DIR XDG_CACHE_HOME={cache} "
              f"{sys.executable} -c \"{code}\"")
    done = subprocess.run(["unshare", "-m", "sh", "-c", script], capture_output=True,
                          text=True, timeout=600)
    if "mount:" in done.stderr:
        pytest.skip(f"cannot mount here: {done.stderr.strip()}")
    assert done.returncode == 0, done.stderr
    hits, folder = done.stdout.strip().splitlines()
    assert hits == "[1]" and folder == str(cache / "unseeable" / "numba")
    assert any((cache / "unseeable" / "numba").rglob("*.nbi")), done.stderr
