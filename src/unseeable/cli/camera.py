"""Your own photographs, step by step: ``unseeable camera calibrate``, ``unseeable camera
locate`` and ``unseeable view new``."""

from __future__ import annotations

from pathlib import Path

import typer

from unseeable.cli import app
from unseeable.cli.options import GroupWithDefault
from unseeable.errors import InputError

__all__ = ["camera_app", "view_app"]

camera_app = typer.Typer(help="Your own camera: calibrate it on a printed chessboard, then "
                              "locate it on the table.", no_args_is_help=True)
app.add_typer(camera_app, name="camera")
view_app = typer.Typer(help="View files (a photograph, its camera and the grid to estimate "
                            "in), and estimates shown in 3-D: `unseeable view ESTIMATE.json`.",
                       no_args_is_help=True, cls=GroupWithDefault)
app.add_typer(view_app, name="view")

_CHESSBOARD_HELP = ("Inner corners COLSxROWS (where four squares meet): COLS along the printed "
                    "board's width, ROWS down it, e.g. 9x6.")


def _pair(text: str, *, field: str) -> tuple[float, float]:
    try:
        a, b = (float(p) for p in text.split(","))
    except ValueError:
        raise InputError("must be two numbers X,Z (mm)", field=field, value=text) from None
    return a, b


@camera_app.command("calibrate")
def calibrate_command(
    images: list[Path] = typer.Argument(..., help="Photographs of the chessboard (at least 3 "
                                                  "with the whole board), all of one size."),
    chessboard: str = typer.Option(..., "--chessboard", help=_CHESSBOARD_HELP),
    square: float = typer.Option(..., "--square", help="Side of a square (mm)."),
    out: Path = typer.Option(..., "--out", help="Intrinsics file to write "
                                                "(unseeable/intrinsics@1)."),
    distortion: str = typer.Option("radial", "--distortion",
                                   help="Lens distortion to fit: none, radial (k1, k2), "
                                        "radial-tangential (k1, k2, p1, p2) or full "
                                        "(k1, k2, p1, p2, k3)."),
) -> None:
    """Calibrate a camera: its focal lengths, principal point and lens distortion.

    Photograph a printed chessboard 5 to 20 times at the resolution you will use,
    tilting it differently each time and reaching into the image's corners. A
    photograph without the whole board is skipped with a warning.
    """
    from unseeable.camera.calibrate import Chessboard, calibrate_files, save_intrinsics
    from unseeable.fileio import check_output_file

    check_output_file(out)
    board = Chessboard.parse(chessboard, square_mm=square)
    result = calibrate_files(images, board, distortion=distortion)
    intr = result.intrinsics
    save_intrinsics(intr, out, rms_px=result.rms_px, images=len(result.used))
    K = intr.K
    typer.echo(f"calibrated on {len(result.used)} of {len(images)} photographs "
               f"({intr.width}x{intr.height}): RMS reprojection error {result.rms_px:.3f} px")
    typer.echo(f"  fx={K[0, 0]:.2f} fy={K[1, 1]:.2f} cx={K[0, 2]:.2f} cy={K[1, 2]:.2f} px; "
               f"dist=[{', '.join(f'{d:.4f}' for d in intr.dist)}]")
    for name, rms in zip(result.used, result.image_rms_px):
        typer.echo(f"  {name}: {rms:.3f} px")
    if result.skipped:
        typer.echo(f"  skipped (no whole board): {', '.join(result.skipped)}")
    typer.echo(f"written to {out}")


@camera_app.command("locate")
def locate_command(
    photo: Path = typer.Argument(..., help="Photograph of the chessboard lying flat on the "
                                           "table, from where the camera will stay."),
    intrinsics: Path = typer.Option(..., "--intrinsics",
                                    help="Intrinsics file (from `unseeable camera calibrate`)."),
    chessboard: str = typer.Option(..., "--chessboard",
                                   help=_CHESSBOARD_HELP + " COLS + ROWS must be odd."),
    square: float = typer.Option(..., "--square", help="Side of a square (mm)."),
    out: Path = typer.Option(..., "--out", help="Camera file to write (unseeable/camera@1)."),
    origin: str = typer.Option("0,0", "--origin",
                               help="X,Z (mm): where the board's top-left inner corner lies in "
                                    "the table frame (default: it is the table frame's "
                                    "origin)."),
    yaw: float = typer.Option(0.0, "--yaw",
                              help="Turn of the board on the table (degrees, counter-clockwise "
                                   "seen from above); 0: its width along the table's x."),
    thickness: float = typer.Option(0.0, "--thickness",
                                    help="Height of the board's surface above the table (mm)."),
    max_error: float = typer.Option(2.0, "--max-error",
                                    help="Refuse when the corners reproject worse than this "
                                         "(px, RMS)."),
) -> None:
    """Locate the camera in the table frame from one photograph of a chessboard on the table.

    The board's top-left inner corner (next to the dark corner square) is the
    origin, its width runs along the table's x, down the board along z, and y
    points up; --origin, --yaw and --thickness place it elsewhere.
    """
    import numpy as np

    from unseeable.camera import save_camera
    from unseeable.camera.calibrate import (
        BoardPlacement,
        Chessboard,
        load_intrinsics,
        locate_file,
    )
    from unseeable.fileio import check_output_file

    check_output_file(out)
    board = Chessboard.parse(chessboard, square_mm=square)
    x, z = _pair(origin, field="--origin")
    placement = BoardPlacement(x, z, yaw, thickness)
    intr = load_intrinsics(intrinsics)
    location = locate_file(photo, intr, board, placement=placement, max_rms_px=max_error)
    cam = location.camera
    save_camera(cam, out)
    centre = cam.centre
    forward = cam.R[2]
    elevation = float(np.degrees(np.arcsin(np.clip(-forward[1], -1.0, 1.0))))
    typer.echo(f"camera located: reprojection error {location.rms_px:.3f} px RMS, "
               f"{location.max_px:.3f} px at most")
    typer.echo(f"  centre x={centre[0]:.1f} y={centre[1]:.1f} z={centre[2]:.1f} mm (table "
               f"frame), {np.linalg.norm(centre):.1f} mm from its origin, looking "
               f"{elevation:.1f}° down")
    typer.echo(f"written to {out}")


@view_app.command("new")
def new_view_command(
    photo: Path = typer.Argument(..., help="Photograph of the assembly, taken by the located "
                                           "camera."),
    camera: Path = typer.Option(..., "--camera", help="Camera file (from `unseeable camera "
                                                      "locate`)."),
    extent: str = typer.Option(..., "--extent",
                               help="I,J,K: the smallest grid that covers the assembly (I and "
                                    "K positions along the table, J layers)."),
    out: Path = typer.Option(..., "--out", help="View file to write (unseeable/view@1)."),
    pose: str | None = typer.Option(None, "--pose",
                                    help="X,Z,YAW (mm, mm, degrees): the assembly's pose when "
                                         "known; else it is estimated from the photograph."),
) -> None:
    """Make a view file of your photograph, for `unseeable estimate`."""
    from unseeable.camera import check_photo, load_camera
    from unseeable.cli.options import parse_pose
    from unseeable.domain import Extent
    from unseeable.fileio import check_output_file
    from unseeable.render.view import View, save_view

    check_output_file(out)
    grid = Extent.parse(extent, field="--extent")
    grid_pose = parse_pose(pose) if pose is not None else None
    cam = load_camera(camera)
    image = check_photo(photo, cam, camera_file=camera)
    save_view(View(image, cam, grid, grid_pose, image_path=photo), out)
    typer.echo(f"view of {photo} ({cam.width}x{cam.height}) on a {grid} grid"
               + (f" at x={grid_pose.x:g} z={grid_pose.z:g} yaw={grid_pose.yaw_deg:g}"
                  if grid_pose is not None else "")
               + f" written to {out}")
