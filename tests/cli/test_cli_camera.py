"""``unseeable camera calibrate|locate`` and ``unseeable view new`` as a user meets them:
a summary on success; on bad input one line naming the file and field, exit code 1 and
nothing written."""

from __future__ import annotations

import json

import numpy as np
import pytest

import unseeable.cli.camera  # noqa: F401 (registers the commands)
from unseeable.camera import Camera, save_camera
from unseeable.camera.calibrate import BoardPlacement, Chessboard, Intrinsics, save_intrinsics
from unseeable.cli import main
from unseeable.domain import Extent, GridPose, Structure
from unseeable.render.chessboard import TableChessboard
from unseeable.render.raster import rasterise_view
from unseeable.render.view import load_view, write_image

W, H = 320, 240
BOARD = Chessboard(9, 6, 25.0)
SHEET = TableChessboard(BOARD, BoardPlacement(x=-100.0, z=-62.5, thickness_mm=0.2))
BOARD_ARGS = ["--chessboard", "9x6", "--square", "25"]


def _camera(angle_deg: float, height_mm: float = 380.0) -> Camera:
    a = np.deg2rad(angle_deg)
    eye = [420 * np.cos(a), height_mm, -420 * np.sin(a)]
    return Camera.look_at(eye=eye, target=[0.0, 0.0, 0.0], width=W, height=H, fov_deg=50)


@pytest.fixture(scope="module")
def photos(tmp_path_factory):
    """Board photographs from three sides (flat raster renders), a blank photograph, one of
    another size, a file that is no image, and the first camera's intrinsics."""
    folder = tmp_path_factory.mktemp("photos")
    empty = Structure(Extent(1, 1, 1), [])
    paths = {}
    for n, (angle, height) in enumerate(((70.0, 380.0), (150.0, 250.0), (250.0, 600.0))):
        paths[f"board{n}"] = folder / f"board{n}.png"
        write_image(paths[f"board{n}"], rasterise_view(empty, GridPose(), _camera(angle, height),
                                                       chessboard=SHEET, supersample=2))
    paths["blank"] = folder / "blank.png"
    write_image(paths["blank"], np.full((H, W, 3), 120, np.uint8))
    paths["large"] = folder / "large.png"
    write_image(paths["large"], np.full((2 * H, 2 * W, 3), 120, np.uint8))
    paths["text"] = folder / "notes.png"
    paths["text"].write_text("not an image")
    paths["intrinsics"] = folder / "intrinsics.json"
    save_intrinsics(Intrinsics.of(_camera(70.0)), paths["intrinsics"])
    paths["camera"] = folder / "camera.json"
    save_camera(_camera(70.0), paths["camera"])
    return paths


def run(capsys, *args):
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


def assert_one_line_error(code, out, err, *needles):
    assert code == 1, (out, err)
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    for needle in needles:
        assert str(needle) in lines[0], (needle, lines[0])


# -- calibrate ----------------------------------------------------------------


def test_calibrate_writes_intrinsics_and_reports_the_error(capsys, caplog, photos, tmp_path):
    out_file = tmp_path / "intrinsics.json"
    code, out, err = run(capsys, "camera", "calibrate", photos["board0"], photos["blank"],
                         photos["board1"], photos["board2"], *BOARD_ARGS, "--out", out_file)
    assert code == 0, err
    assert "calibrated on 3 of 4 photographs (320x240): RMS reprojection error" in out
    assert f"skipped (no whole board): {photos['blank']}" in out
    assert any("blank.png: no 9x6 chessboard found; skipped" in r.getMessage()
               for r in caplog.records)
    data = json.loads(out_file.read_text())
    assert data["format"] == "unseeable/intrinsics@1" and data["images"] == 3
    assert (data["width"], data["height"]) == (W, H)
    assert data["K"][0][0] == pytest.approx(_camera(0).K[0, 0], rel=0.05)
    assert data["dist"][2:] == [0.0, 0.0, 0.0]  # radial model: k1, k2 only


@pytest.mark.parametrize("inputs, options, needles", [
    (["board0", "board1", "missing"], [], ["missing.png", "no such image file"]),
    (["board0", "text", "board1"], [], ["notes.png", "cannot be read as an image"]),
    (["board0", "large", "board1"], [], ["large.png", "size", "640x480"]),
    (["board0", "blank", "board1"], [], ["found in 2 of 3", "blank.png", "images"]),
    (["board0", "board1", "board2"], ["--chessboard", "9by6"], ["--chessboard", "9by6"]),
    (["board0", "board1", "board2"], ["--square", "0"], ["--square"]),
    (["board0", "board1", "board2"], ["--distortion", "fisheye"], ["--distortion"]),
])
def test_calibrate_bad_input_is_one_line_and_writes_nothing(capsys, photos, tmp_path, inputs,
                                                            options, needles):
    files = [photos.get(name, photos["board0"].with_name(f"{name}.png")) for name in inputs]
    args = BOARD_ARGS + options
    # A later option overrides an earlier one.
    out_file = tmp_path / "intrinsics.json"
    code, out, err = run(capsys, "camera", "calibrate", *files, *args, "--out", out_file)
    err = "\n".join(line for line in err.splitlines() if not line.startswith("WARNING"))
    assert_one_line_error(code, out, err, *needles)
    assert not out_file.exists() and not list(tmp_path.iterdir())


# -- locate -------------------------------------------------------------------


def test_locate_writes_the_camera_in_the_table_frame(capsys, photos, tmp_path):
    out_file = tmp_path / "camera.json"
    code, out, err = run(capsys, "camera", "locate", photos["board0"], "--intrinsics",
                         photos["intrinsics"], *BOARD_ARGS, "--origin", "-100,-62.5",
                         "--thickness", "0.2", "--out", out_file)
    assert code == 0, err
    assert "camera located: reprojection error" in out and "mm (table frame)" in out
    data = json.loads(out_file.read_text())
    assert data["format"] == "unseeable/camera@1"
    centre = -np.asarray(data["R"]).T @ np.asarray(data["t"])
    np.testing.assert_allclose(centre, _camera(70.0).centre, atol=3.0)


def _bad_intrinsics(tmp_path):
    path = tmp_path.parent / f"{tmp_path.name}-bad-intrinsics.json"
    path.write_text(json.dumps({"format": "unseeable/camera@1"}))
    return path


@pytest.mark.parametrize("photo, options, needles", [
    ("blank", [], ["blank.png", "chessboard", "no 9x6 chessboard found"]),
    ("board0", ["--chessboard", "8x6"], ["--chessboard", "odd number"]),
    ("large", [], ["large.png", "size", "320x240"]),
    ("text", [], ["notes.png", "cannot be read"]),
    ("board0", ["--origin", "1;2"], ["--origin"]),
    ("board0", ["--max-error", "0.0001"], ["board0.png", "reprojection"]),
    ("board0", ["--intrinsics", "BAD"], ["bad-intrinsics.json", "format"]),
    ("board0", ["--intrinsics", "MISSING"], ["nowhere.json", "no such file"]),
])
def test_locate_bad_input_is_one_line_and_writes_nothing(capsys, photos, tmp_path, photo,
                                                         options, needles):
    replace = {"BAD": str(_bad_intrinsics(tmp_path)), "MISSING": str(tmp_path / "nowhere.json")}
    options = [replace.get(o, o) for o in options]
    out_file = tmp_path / "camera.json"
    code, out, err = run(capsys, "camera", "locate", photos[photo], "--intrinsics",
                         photos["intrinsics"], *BOARD_ARGS, *options, "--out", out_file)
    assert_one_line_error(code, out, err, *needles)
    assert not list(tmp_path.iterdir())


# -- view new -----------------------------------------------------------------


def test_view_new_writes_a_view_of_the_photograph(capsys, photos, tmp_path):
    out_file = tmp_path / "view.json"
    code, out, err = run(capsys, "view", "new", photos["board1"], "--camera", photos["camera"],
                         "--extent", "3,4,5", "--out", out_file)
    assert code == 0, err
    assert f"written to {out_file}" in out
    view = load_view(out_file)
    assert view.extent == Extent(3, 4, 5) and view.pose is None
    assert view.image_path.resolve() == photos["board1"].resolve()
    np.testing.assert_array_equal(view.camera.K, _camera(70.0).K)


@pytest.mark.parametrize("photo, options, needles", [
    ("large", [], ["large.png", "size", "640x480", "camera.json"]),
    ("board0", ["--extent", "3,0,3"], ["extent"]),
    ("board0", ["--extent", "3,3"], ["--extent"]),
    ("board0", ["--pose", "1,2"], ["--pose"]),
    ("board0", ["--camera", "MISSING"], ["nowhere.json", "no such file"]),
    ("missing", [], ["missing.png", "no such image file"]),
])
def test_view_new_bad_input_is_one_line_and_writes_nothing(capsys, photos, tmp_path, photo,
                                                           options, needles):
    options = [str(tmp_path / "nowhere.json") if o == "MISSING" else o for o in options]
    image = photos.get(photo, photos["board0"].with_name(f"{photo}.png"))
    out_file = tmp_path / "view.json"
    code, out, err = run(capsys, "view", "new", image, "--camera", photos["camera"],
                         "--extent", "3,3,3", *options, "--out", out_file)
    assert_one_line_error(code, out, err, *needles)
    assert not list(tmp_path.iterdir())
