"""Make the example of ``examples/README.md`` on the simulated table, with the commands a
user runs on real photographs.

Renders what a user would photograph — calibration photographs of a printed 9x6
chessboard (25 mm squares), an A3 9x6 chessboard (40 mm squares) lying at the table's
centre, then the corpus's ``cabin-door`` standing there — and runs the three steps on them
through the command line: ``unseeable camera calibrate``, ``unseeable camera locate``,
``unseeable view new``. The board photographs go to ``--photos`` (a temporary folder
unless given); ``intrinsics.json``, ``camera.json``, ``cabin.jpg`` and ``view.json`` to
this folder.

Usage: ``python examples/make_example.py [--photos FOLDER]``
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np
from PIL import Image

import unseeable.cli.camera  # noqa: F401 (registers the commands)
from unseeable.camera import Camera
from unseeable.camera.calibrate import BoardPlacement, Chessboard
from unseeable.cli import main as unseeable
from unseeable.corpus import load_design
from unseeable.domain import Extent, GridPose, Structure
from unseeable.render.chessboard import TableChessboard
from unseeable.render.renderer import render
from unseeable.render.settings import RenderSettings
from unseeable.render.workspace import PendulumArm, Workspace

HERE = Path(__file__).resolve().parent
EMPTY = Structure(Extent(1, 1, 1), [])
STATION_DEG = 150.0
SPP = 24


def save_jpeg(path: Path, image: np.ndarray) -> None:
    Image.fromarray(image).save(path, quality=92)


def calibration_cameras(camera: Camera, n: int) -> list[Camera]:
    """Hand-held views of a board lying at the table's centre: from around it, tilted
    20..50° from square, aimed off its centre, rolled."""
    rng = np.random.default_rng(0)
    cams = []
    for k in range(n):
        a = np.deg2rad(360.0 * k / n + 20.0)
        e = np.deg2rad((40.0, 55.0, 70.0)[k % 3])
        eye = 450.0 * np.array([np.cos(e) * np.cos(a), np.sin(e), -np.cos(e) * np.sin(a)])
        target = [rng.uniform(-50, 50), 0.0, rng.uniform(-35, 35)]
        upright = Camera.look_at(eye=eye, target=target, width=camera.width,
                                 height=camera.height, fx=camera.K[0, 0])
        roll = np.deg2rad(rng.uniform(-25, 25))
        c, s = np.cos(roll), np.sin(roll)
        R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]) @ upright.R
        cams.append(Camera(camera.width, camera.height, camera.K, R, -R @ eye))
    return cams


def run(*args: str) -> None:
    print("$ unseeable " + " ".join(args))
    code = unseeable(list(args))
    if code:
        sys.exit(code)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--photos", type=Path, default=None)
    args = parser.parse_args()
    photos = args.photos or Path(tempfile.mkdtemp(prefix="unseeable-photos-"))
    photos.mkdir(parents=True, exist_ok=True)
    arm = PendulumArm()
    camera = arm.camera(STATION_DEG)

    # Step 1's photographs: a 9x6 board of 25 mm squares, ten ways.
    a4 = TableChessboard(Chessboard(9, 6, 25.0), BoardPlacement(-100.0, -62.5, 0.0, 0.2))
    for k, cam in enumerate(calibration_cameras(camera, 10)):
        image = render(EMPTY, GridPose(), cam, settings=RenderSettings(spp=SPP, chessboard=a4),
                       seed=k).image
        save_jpeg(photos / f"board{k:02d}.jpg", image)
    # Step 2's: the camera in place, an A3 9x6 board of 40 mm squares at the table's centre.
    a3 = TableChessboard(Chessboard(9, 6, 40.0), BoardPlacement(-160.0, -100.0, 0.0, 0.2))
    board = Workspace(EMPTY, arm=arm, settings=RenderSettings(spp=SPP, chessboard=a3))
    save_jpeg(photos / "table-board.jpg", board.observe(STATION_DEG).image)
    # Step 3's: the board taken away, the cabin standing at the table's centre.
    entry = load_design("cabin-door")
    cabin = Workspace(entry.structure, pose=entry.pose, arm=arm, settings=RenderSettings(spp=SPP))
    save_jpeg(HERE / "cabin.jpg", cabin.observe(STATION_DEG).image)

    run("camera", "calibrate", *sorted(str(p) for p in photos.glob("board*.jpg")),
        "--chessboard", "9x6", "--square", "25", "--out", str(HERE / "intrinsics.json"))
    run("camera", "locate", str(photos / "table-board.jpg"), "--intrinsics",
        str(HERE / "intrinsics.json"), "--chessboard", "9x6", "--square", "40",
        "--origin", "-160,-100", "--thickness", "0.2", "--out", str(HERE / "camera.json"))
    run("view", "new", str(HERE / "cabin.jpg"), "--camera", str(HERE / "camera.json"),
        "--extent", "5,6,4", "--out", str(HERE / "view.json"))
    print(f"true camera centre {np.round(camera.centre, 1).tolist()} mm; the cabin stands at "
          f"x={entry.pose.x:g} z={entry.pose.z:g} yaw={entry.pose.yaw_deg:g}; board photographs "
          f"in {photos}")


if __name__ == "__main__":
    main()
