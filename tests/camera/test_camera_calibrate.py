"""Your own camera, step by step, on rendered photographs: calibrate on a chessboard, locate
the camera on the table, make a view file — each step against the renderer's truth."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from unseeable.camera import Camera, load_camera
from unseeable.camera.calibrate import (
    BoardPlacement,
    Chessboard,
    Intrinsics,
    calibrate_camera,
    calibrate_files,
    check_photo,
    find_chessboard,
    load_intrinsics,
    locate_camera,
    read_photo,
    save_intrinsics,
)
from unseeable.domain import Extent, GridPose, Structure
from unseeable.errors import InputError
from unseeable.render.chessboard import TableChessboard
from unseeable.render.raster import rasterise_view
from unseeable.render.renderer import render
from unseeable.render.settings import RenderSettings
from unseeable.render.view import load_view, read_image, write_image
from unseeable.render.workspace import PendulumArm

W, H = 640, 480
FX = W / 2 / np.tan(np.deg2rad(25.0))
#: The camera to calibrate: principal point off the image's centre, as real ones are.
K_TRUE = np.array([[FX, 0.0, 331.0], [0.0, FX, 235.0], [0.0, 0.0, 1.0]])
EMPTY = Structure(Extent(1, 1, 1), [])

#: An A4 print of OpenCV's 9x6 pattern, 25 mm squares, centred on the table.
CAL_BOARD = Chessboard(9, 6, 25.0)
CAL_SHEET = TableChessboard(CAL_BOARD, BoardPlacement(x=-100.0, z=-62.5, thickness_mm=0.2))
#: An A3 print, 40 mm squares, turned and off the table's centre, for locating.
LOC_BOARD = Chessboard(9, 6, 40.0)
LOC_PLACEMENT = BoardPlacement(x=-120.0, z=-150.0, yaw_deg=25.0, thickness_mm=0.2)
LOC_SHEET = TableChessboard(LOC_BOARD, LOC_PLACEMENT)


def _rotation_error_deg(Ra: np.ndarray, Rb: np.ndarray) -> float:
    return float(np.degrees(np.linalg.norm(cv2.Rodrigues(Ra @ Rb.T)[0])))


def _calibration_camera(k: int, n: int, rng: np.random.Generator) -> Camera:
    """The k-th of n hand-held views of the board: around it, tilted 20..50° from square,
    aimed off its centre and rolled, as a person photographs a calibration board."""
    a = np.deg2rad(360.0 * k / n + 20.0)
    e = np.deg2rad((40.0, 55.0, 70.0)[k % 3])
    eye = 450.0 * np.array([np.cos(e) * np.cos(a), np.sin(e), -np.cos(e) * np.sin(a)])
    target = np.array([rng.uniform(-50, 50), 0.0, rng.uniform(-35, 35)])
    upright = Camera.look_at(eye=eye, target=target, width=W, height=H, fx=FX)
    roll = np.deg2rad(rng.uniform(-25, 25))
    c, s = np.cos(roll), np.sin(roll)
    R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]) @ upright.R
    return Camera(W, H, K_TRUE, R, -R @ eye)


@pytest.fixture(scope="module")
def calibration_photos(tmp_path_factory):
    """8 photographs of the board, as files, rendered by the path tracer."""
    folder = tmp_path_factory.mktemp("calibration")
    settings_ = RenderSettings(spp=16, chessboard=CAL_SHEET)
    rng = np.random.default_rng(0)
    paths = []
    for k in range(8):
        image = render(EMPTY, GridPose(), _calibration_camera(k, 8, rng), settings=settings_,
                       seed=k).image
        paths.append(folder / f"board{k}.png")
        write_image(paths[-1], image)
    return paths


@pytest.fixture(scope="module")
def calibration(calibration_photos):
    return calibrate_files(calibration_photos, CAL_BOARD)


@pytest.mark.slow
def test_calibration_recovers_the_intrinsics(calibration):
    intr = calibration.intrinsics
    assert intr.size == (W, H)
    assert len(calibration.used) == 8 and not calibration.skipped
    assert calibration.rms_px < 0.25
    assert calibration.image_rms_px.shape == (8,) and calibration.image_rms_px.max() < 0.4
    # Focal lengths within 0.3 %, principal point within 1.5 px; the renders have no
    # distortion, and the radial coefficients found barely bend the image.
    np.testing.assert_allclose(np.diag(intr.K)[:2], [FX, FX], rtol=3e-3)
    np.testing.assert_allclose(intr.K[:2, 2], K_TRUE[:2, 2], atol=1.5)
    corner = np.array([[0.0, 0.0]])
    undistorted = cv2.undistortPoints(corner.reshape(1, 1, 2), intr.K, intr.dist, P=intr.K)
    assert np.linalg.norm(undistorted.ravel() - corner) < 3.0


@pytest.mark.slow
def test_calibration_skips_a_photograph_without_the_board(calibration_photos, tmp_path,
                                                          caplog):
    blank = tmp_path / "blank.png"
    write_image(blank, np.full((H, W, 3), 128, np.uint8))
    result = calibrate_files([calibration_photos[0], blank, *calibration_photos[1:4]],
                             CAL_BOARD)
    assert result.skipped == (str(blank),) and len(result.used) == 4
    assert any("blank.png" in r.message and "skipped" in r.message for r in caplog.records)


@pytest.mark.slow
def test_calibration_needs_three_photographs_of_one_size(calibration_photos):
    images = [cv2.imread(str(p))[..., ::-1] for p in calibration_photos[:3]]
    with pytest.raises(InputError, match="found in 2 of 3") as err:
        calibrate_camera([images[0], images[1], np.zeros_like(images[2])], CAL_BOARD,
                         names=["a.png", "b.png", "c.png"])
    assert "c.png" in str(err.value)
    with pytest.raises(InputError) as err:
        calibrate_camera([images[0], images[1][:240, :320]], CAL_BOARD,
                         names=["a.png", "small.png"])
    assert err.value.file == "small.png" and err.value.field == "size"


@pytest.mark.slow
def test_intrinsics_file_round_trips_and_names_bad_fields(calibration, tmp_path):
    path = tmp_path / "intrinsics.json"
    save_intrinsics(calibration.intrinsics, path, rms_px=calibration.rms_px, images=8)
    data = json.loads(path.read_text())
    assert data["format"] == "unseeable/intrinsics@1" and data["images"] == 8
    back = load_intrinsics(path)
    np.testing.assert_array_equal(back.K, calibration.intrinsics.K)
    np.testing.assert_array_equal(back.dist, calibration.intrinsics.dist)
    for change, field in (({"K": [[0, 0, 1], [0, 1, 1], [0, 0, 1]]}, "K"),
                          ({"width": 0}, "width"), ({"format": "unseeable/camera@1"}, "format"),
                          ({"dist": [1, 2]}, "dist"), ({"rms_px": -1}, "rms_px")):
        path.write_text(json.dumps({**data, **change}))
        with pytest.raises(InputError) as err:
            load_intrinsics(path)
        assert err.value.file == str(path) and err.value.field == field
    del data["height"]
    path.write_text(json.dumps(data))
    with pytest.raises(InputError, match="missing"):
        load_intrinsics(path)


# --------------------------------------------------------------------------
# locating


@pytest.fixture(scope="module")
def station_photos():
    """The board photographed from two opposite sides by the pendulum arm, at 960x720
    (the size at which the location meets 1 mm and 0.1°)."""
    arm = PendulumArm(width=960, height=720)
    settings_ = RenderSettings(spp=16, chessboard=LOC_SHEET)
    return [(arm.camera(a), render(EMPTY, GridPose(), arm.camera(a), settings=settings_,
                                   seed=int(a)).image) for a in (90.0, 180.0)]


@pytest.mark.slow
def test_locate_recovers_the_camera_within_a_millimetre_and_a_tenth_of_a_degree(
        station_photos):
    for truth, image in station_photos:
        location = locate_camera(image, truth, LOC_BOARD, placement=LOC_PLACEMENT)
        assert location.rms_px < 0.3 and location.max_px < 1.0
        assert np.linalg.norm(location.camera.centre - truth.centre) < 1.0
        assert _rotation_error_deg(location.camera.R, truth.R) < 0.1
        np.testing.assert_array_equal(location.camera.K, truth.K)


def test_a_board_seen_from_any_side_is_numbered_from_its_own_origin():
    # Oriented corners are the board's, whatever side the camera stands on.
    for angle in (0.0, 90.0, 180.0, 270.0):
        cam = PendulumArm().camera(angle)
        image = rasterise_view(EMPTY, GridPose(), cam, chessboard=LOC_SHEET, supersample=2)
        corners = find_chessboard(image, LOC_BOARD, oriented=True)
        truth = cam.project(LOC_SHEET.corners_table())
        assert np.abs(corners - truth).max() < 0.5, angle


@pytest.mark.slow
@pytest.mark.parametrize("renumber", [
    lambda g: g, lambda g: g[:, ::-1], lambda g: g[::-1], lambda g: g[::-1, ::-1]],
    ids=["as-is", "mirrored-rows", "mirrored-columns", "half-turn"])
def test_any_numbering_opencv_may_return_is_brought_to_the_board_frame(station_photos,
                                                                        renumber):
    from unseeable.camera.calibrate import _orient

    truth, image = station_photos[0]
    grid = truth.project(LOC_SHEET.corners_table()).reshape(LOC_BOARD.rows, LOC_BOARD.cols, 2)
    grey = cv2.cvtColor(image, cv2.COLOR_RGB2GRAY)
    np.testing.assert_array_equal(_orient(renumber(grid), grey), grid)


@pytest.mark.slow
def test_locate_refuses_what_it_cannot_trust(station_photos):
    truth, image = station_photos[0]
    with pytest.raises(InputError) as err:
        locate_camera(image, truth, Chessboard(8, 6, 40.0), name="board.png")
    assert err.value.field == "--chessboard" and "odd number" in str(err.value)
    with pytest.raises(InputError) as err:
        locate_camera(image, truth, Chessboard(7, 4, 40.0), name="board.png")
    assert err.value.file == "board.png" and err.value.field == "chessboard"
    with pytest.raises(InputError) as err:
        locate_camera(image[:480, :640], truth, LOC_BOARD, name="board.png")
    assert err.value.field == "size"
    with pytest.raises(InputError) as err:
        locate_camera(image, truth, LOC_BOARD, placement=LOC_PLACEMENT, max_rms_px=0.01)
    assert err.value.field == "reprojection"


@settings(max_examples=30, deadline=None)
@given(x=st.floats(-500, 500), z=st.floats(-500, 500), yaw=st.floats(-360, 360),
       u=st.floats(0, 300), v=st.floats(0, 300), thickness=st.floats(0, 5))
def test_board_frame_is_a_grid_frame_lying_on_the_table(x, z, yaw, u, v, thickness):
    """The board's (u, v) lies where a grid pose of the same x, z, yaw puts (u, ·, v): the
    board's width along the grid's i, down the board along k, up out of the table."""
    placement = BoardPlacement(x, z, yaw, thickness)
    got = placement.to_table(np.array([[u, v, 0.0]]))
    want = GridPose(x, z, yaw).grid_to_world(np.array([[u, thickness, v]]))
    np.testing.assert_allclose(got, want, atol=1e-9)
    R = placement.rotation
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(R) == pytest.approx(1.0)
    np.testing.assert_allclose(R[:, 2], [0.0, -1.0, 0.0], atol=1e-12)  # w into the table


# --------------------------------------------------------------------------
# the whole chain, through the command line


@pytest.mark.slow
def test_the_three_steps_make_a_view_the_estimator_accepts(calibration_photos, tmp_path,
                                                           capsys):
    import unseeable.cli.camera  # noqa: F401 (registers the commands)
    from unseeable.cli import main

    board_args = ["--chessboard", "9x6", "--square", "25"]
    code = main(["camera", "calibrate", *map(str, calibration_photos), *board_args,
                 "--out", str(tmp_path / "intrinsics.json")])
    out, err = capsys.readouterr()
    assert code == 0, err
    assert "calibrated on 8 of 8 photographs (640x480)" in out and "RMS" in out

    # The camera on the arm (with the calibrated camera's intrinsics) photographs the board,
    # then the assembly.
    arm_cam = PendulumArm().camera(150.0)
    truth = Camera(W, H, K_TRUE, arm_cam.R, arm_cam.t)
    photo = render(EMPTY, GridPose(), truth,
                   settings=RenderSettings(spp=16, chessboard=LOC_SHEET), seed=5).image
    write_image(tmp_path / "board.png", photo)
    code = main(["camera", "locate", str(tmp_path / "board.png"), "--intrinsics",
                 str(tmp_path / "intrinsics.json"), "--chessboard", "9x6", "--square", "40",
                 "--origin", "-120,-150", "--yaw", "25", "--thickness", "0.2",
                 "--out", str(tmp_path / "camera.json")])
    out, err = capsys.readouterr()
    assert code == 0, err
    assert "camera located" in out
    located = load_camera(tmp_path / "camera.json")
    # With calibrated intrinsics, the camera sits a few mm off (a focal length 0.1 % long
    # puts it 0.1 % further away), but it sees the workspace where the truth does.
    assert np.linalg.norm(located.centre - truth.centre) < 3.0
    assert _rotation_error_deg(located.R, truth.R) < 0.3
    g = np.linspace(-200, 200, 9)
    xs, ys, zs = np.meshgrid(g, [0.0, 60.0, 120.0], g)
    workspace = np.stack([xs.ravel(), ys.ravel(), zs.ravel()], axis=1)
    assert np.abs(located.project(workspace) - truth.project(workspace)).max() < 0.3

    write_image(tmp_path / "house.png", np.full((H, W, 3), 90, np.uint8))
    code = main(["view", "new", str(tmp_path / "house.png"), "--camera",
                 str(tmp_path / "camera.json"), "--extent", "4,5,3", "--pose", "-96,-64,0",
                 "--out", str(tmp_path / "views" / "view.json")])
    out, err = capsys.readouterr()
    assert code == 0, err
    view = load_view(tmp_path / "views" / "view.json")
    assert view.extent == Extent(4, 5, 3) and view.pose == GridPose(-96.0, -64.0, 0.0)
    np.testing.assert_array_equal(view.camera.R, located.R)
    np.testing.assert_array_equal(view.camera.dist, located.dist)
    assert view.image.shape == (H, W, 3)
    data = json.loads((tmp_path / "views" / "view.json").read_text())
    assert data["image"] == "../house.png"


def test_the_shipped_example_is_a_view_of_its_located_camera():
    from pathlib import Path

    examples = Path(__file__).resolve().parents[2] / "examples"
    view = load_view(examples / "view.json")
    camera = load_camera(examples / "camera.json")
    intrinsics = load_intrinsics(examples / "intrinsics.json")
    assert view.image.shape == (camera.height, camera.width, 3)
    np.testing.assert_array_equal(view.camera.R, camera.R)
    np.testing.assert_array_equal(camera.K, intrinsics.K)
    assert view.extent == Extent(5, 6, 4) and view.pose is None
    assert (examples / "cabin.jpg").stat().st_size <= 200_000


def test_a_photograph_is_checked_against_its_camera_and_read_as_views_read_it(tmp_path):
    cam = Intrinsics(W, H, K_TRUE, np.zeros(5)).camera(np.eye(3), np.array([0, 0, 900.0]))
    write_image(tmp_path / "small.png", np.zeros((240, 320, 3), np.uint8))
    with pytest.raises(InputError) as err:
        check_photo(tmp_path / "small.png", cam, camera_file="camera.json")
    assert err.value.file == str(tmp_path / "small.png") and err.value.field == "size"
    assert "camera.json" in str(err.value)
    rgba = np.random.default_rng(1).integers(0, 256, (H, W, 4), dtype=np.uint8)
    cv2.imwrite(str(tmp_path / "photo.png"), rgba)
    image = check_photo(tmp_path / "photo.png", cam)
    np.testing.assert_array_equal(image, read_image(tmp_path / "photo.png"))
    np.testing.assert_array_equal(read_photo(tmp_path / "photo.png"), image)
    assert image.shape == (H, W, 3)
