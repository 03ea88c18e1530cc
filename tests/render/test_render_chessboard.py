"""A printed chessboard on the simulated table: drawn where its board frame says, by both
renderers and in the workspace's views; not a log; absent unless asked for."""

from __future__ import annotations

import numpy as np
import pytest

from unseeable.camera.calibrate import BoardPlacement, Chessboard, find_chessboard
from unseeable.domain import Extent, GridPose, Log, Structure
from unseeable.errors import InputError
from unseeable.render.chessboard import MIN_THICKNESS_MM, TableChessboard
from unseeable.render.raster import RasterLook, rasterise_view
from unseeable.render.renderer import render
from unseeable.render.settings import RenderSettings, recorded_fields
from unseeable.render.workspace import PendulumArm, Workspace

BOARD = Chessboard(7, 4, 40.0)
SHEET = TableChessboard(BOARD, BoardPlacement(x=-150.0, z=-20.0, yaw_deg=-30.0,
                                              thickness_mm=0.5))
EMPTY = Structure(Extent(1, 1, 1), [])


def test_the_print_has_a_dark_top_left_square_and_a_light_border():
    tex = SHEET.texture()
    n, m = SHEET.texels_per_square, SHEET.margin_texels
    assert tex.shape == ((BOARD.rows + 1) * n + 2 * m, (BOARD.cols + 1) * n + 2 * m)
    assert m == n  # the default border is one square
    squares = tex[m:-m, m:-m].reshape(BOARD.rows + 1, n, BOARD.cols + 1, n)[:, 0, :, 0]
    j, i = np.mgrid[0:BOARD.rows + 1, 0:BOARD.cols + 1]
    np.testing.assert_array_equal(squares == SHEET.ink, (i + j) % 2 == 0)
    assert np.all(tex[:m] == SHEET.paper) and np.all(tex[:, -m:] == SHEET.paper)
    dark = SHEET.dark_squares_board()
    assert len(dark) == ((BOARD.rows + 1) * (BOARD.cols + 1) + 1) // 2
    np.testing.assert_allclose(dark[0, 0], [-40.0, -40.0, 0.0])  # the top-left square


def test_mitsuba_draws_the_board_where_its_corners_are_and_calls_it_table():
    cam = PendulumArm(width=480, height=360).camera(120.0)
    r = render(EMPTY, GridPose(), cam, settings=RenderSettings(spp=8, chessboard=SHEET), seed=2)
    corners = find_chessboard(r.image, BOARD, oriented=True)
    truth = cam.project(SHEET.corners_table())
    assert corners is not None
    error = np.linalg.norm(corners - truth, axis=1)
    assert error.mean() < 0.15 and error.max() < 0.5
    assert np.all(r.ids == -1)  # not a log
    # The depth on the sheet is that of its printed surface, thickness_mm above the table.
    u, v = np.round(cam.project(SHEET.corners_table()[[0, 10, 27]])).astype(int).T
    rays = cam.pixel_rays(np.stack([u, v], axis=1).astype(float))
    hit = cam.centre + rays * ((SHEET.placement.thickness_mm - cam.centre[1]) / rays[:, 1:2])
    np.testing.assert_allclose(r.depth[v, u], cam.depth(hit), rtol=1e-5)


def test_the_raster_renderer_draws_the_board_too_under_the_logs_shadows():
    cam = PendulumArm().camera(150.0)
    look = RasterLook(noise=0.0, blur_px=0.0, light_azimuth_deg=160.0, light_elevation_deg=30.0)
    image = rasterise_view(EMPTY, GridPose(), cam, chessboard=SHEET, look=look)
    corners = find_chessboard(image, BOARD, oriented=True)
    assert np.abs(corners - cam.project(SHEET.corners_table())).max() < 0.3
    # A log lying on the sheet: its shadow darkens the paper by the look's ambient share.
    log = Structure(Extent(3, 1, 1), [Log(0, (0, 0), 3)])
    centre = SHEET.corners_table().mean(axis=0)
    shaded = rasterise_view(log, GridPose(centre[0] - 64.0, centre[2], 0.0), cam,
                            chessboard=SHEET, look=look)
    paper = round(SHEET.srgb()[0] * 255)
    was_paper = np.all(np.abs(image.astype(int) - paper) <= 1, axis=2)
    in_shadow = np.all(np.abs(shaded.astype(int) - paper * look.ambient) <= 1.5, axis=2)
    assert (was_paper & in_shadow).sum() > 50


def test_the_workspace_shows_the_board_in_every_view():
    s = Structure(Extent(2, 1, 1), [Log(0, (0, 0), 2)])
    ws = Workspace(s, pose=GridPose(150.0, 150.0, 0.0), arm=PendulumArm(width=480, height=360),
                   settings=RenderSettings(spp=4, chessboard=SHEET))
    view = ws.observe(180.0)
    corners = find_chessboard(view.image, BOARD, oriented=True)
    assert corners is not None
    assert np.abs(corners - view.camera.project(SHEET.corners_table())).max() < 0.5
    assert np.any(ws.truth(view).ids == 0)  # and the log, with its id


def test_settings_without_a_board_are_recorded_as_before():
    # Corpora built before boards existed keep their settings hash.
    assert "chessboard" not in {f.name for f in recorded_fields(RenderSettings())}
    assert "chessboard" in {f.name for f in recorded_fields(RenderSettings(chessboard=SHEET))}


def test_bad_boards_are_input_errors():
    with pytest.raises(InputError, match="thickness"):
        TableChessboard(BOARD, BoardPlacement(thickness_mm=MIN_THICKNESS_MM / 2))
    with pytest.raises(InputError, match="darker"):
        TableChessboard(BOARD, ink=0.8, paper=0.5)
    with pytest.raises(InputError, match="chessboard"):
        RenderSettings(chessboard=BOARD)
    with pytest.raises(InputError, match="chessboard.cols"):
        Chessboard(1, 4, 20.0)
