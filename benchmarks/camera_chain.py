"""Your own camera, measured on renders: calibration, location on the table, and what a
camera error costs the single-view estimate.

1. Calibration: ``--calibration-photos`` photographs (at ``--size``) of a 9x6 board with
   25 mm squares, from around it, tilted 20..50° from square, aimed off its centre and
   rolled, by the pendulum arm's camera: the intrinsics found against the truth.
2. Location: the pendulum arm photographs a 9x6 board with 40 mm squares lying at the
   table's centre (``--origin -160,-100``) from each station; the camera is located with
   the true intrinsics (at every size of ``--sizes``) and with the calibrated ones (at
   ``--size``): its centre's error (mm) and its rotation's (degrees).
3. Estimates: from the same stations the arm photographs corpus designs (the board taken
   away), and ``estimate_view`` estimates each with the assembly's true pose given, seen
   through the true camera, the located one (calibrated intrinsics) and the true camera
   moved by 1, 2, 5 mm (in a random direction) or turned by 0.1, 0.25, 0.5° (about a random
   axis): the paper's error count per image, and how far each camera puts the assembly's
   grid points in the image (px, mean over the grid) from where the true camera does.

Usage: ``python benchmarks/camera_chain.py [--designs a,b,..] [--stations 120,150,180]
[--size 640x480] [--sizes 640x480,960x720,1280x960] [--spp 16] [--calibration-photos 10]``
"""

from __future__ import annotations

import argparse
import logging
import os
import time

import cv2
import numpy as np

from unseeable.camera import Camera
from unseeable.camera.calibrate import (
    BoardPlacement,
    Chessboard,
    calibrate_camera,
    locate_camera,
)
from unseeable.corpus import load_design
from unseeable.domain import Extent, GridPose, LogGeometry, Structure
from unseeable.pipeline import errors_against_truth, estimate_view
from unseeable.render.chessboard import TableChessboard
from unseeable.render.renderer import render
from unseeable.render.settings import RenderSettings
from unseeable.render.view import View
from unseeable.render.workspace import PendulumArm, Workspace

EMPTY = Structure(Extent(1, 1, 1), [])
CAL_BOARD = Chessboard(9, 6, 25.0)
CAL_SHEET = TableChessboard(CAL_BOARD, BoardPlacement(-100.0, -62.5, 0.0, 0.2))
LOC_BOARD = Chessboard(9, 6, 40.0)
LOC_PLACEMENT = BoardPlacement(-160.0, -100.0, 0.0, 0.2)
POSITION_ERRORS_MM = (1.0, 2.0, 5.0)
ROTATION_ERRORS_DEG = (0.1, 0.25, 0.5)


def rotation_error_deg(Ra: np.ndarray, Rb: np.ndarray) -> float:
    return float(np.degrees(np.linalg.norm(cv2.Rodrigues(Ra @ Rb.T)[0])))


def calibration_camera(k: int, n: int, K: np.ndarray, size, rng) -> Camera:
    a = np.deg2rad(360.0 * k / n + 20.0)
    e = np.deg2rad((40.0, 55.0, 70.0)[k % 3])
    eye = 450.0 * np.array([np.cos(e) * np.cos(a), np.sin(e), -np.cos(e) * np.sin(a)])
    target = np.array([rng.uniform(-50, 50), 0.0, rng.uniform(-35, 35)])
    upright = Camera.look_at(eye=eye, target=target, width=size[0], height=size[1],
                             fx=K[0, 0])
    roll = np.deg2rad(rng.uniform(-25, 25))
    c, s = np.cos(roll), np.sin(roll)
    R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]) @ upright.R
    return Camera(size[0], size[1], K, R, -R @ eye)


def moved(camera: Camera, axis: np.ndarray, *, mm: float = 0.0, deg: float = 0.0) -> Camera:
    """``camera`` moved by ``mm`` along the unit vector ``axis`` or turned by ``deg`` about
    it (through the camera's centre)."""
    R = cv2.Rodrigues(np.deg2rad(deg) * axis)[0] @ camera.R
    centre = camera.centre + mm * axis
    return Camera(camera.width, camera.height, camera.K, R, -R @ centre, camera.dist)


def grid_points(extent: Extent, pose: GridPose, g: LogGeometry = LogGeometry()) -> np.ndarray:
    i, j, k = np.meshgrid(range(extent.I), range(extent.J), range(extent.K), indexing="ij")
    pts = np.stack([i.ravel() * g.l1, g.layer_height(0) + j.ravel() * g.l2 / 2,
                    k.ravel() * g.l1], axis=1)
    return pose.grid_to_world(pts)


def parse_size(text: str) -> tuple[int, int]:
    w, h = (int(v) for v in text.lower().split("x"))
    return w, h


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--designs", default="cabin-door,cabin-window,tower-3,l-cabin,"
                                             "wall-door,u-walls")
    parser.add_argument("--stations", default="120,150,180")
    parser.add_argument("--size", default="640x480")
    parser.add_argument("--sizes", default="640x480,960x720,1280x960")
    parser.add_argument("--spp", type=int, default=16)
    parser.add_argument("--calibration-photos", type=int, default=10)
    args = parser.parse_args()
    # The estimator's warnings (e.g. log ends on the extent's boundary) are not this
    # benchmark's subject.
    logging.basicConfig(level=logging.ERROR)
    size = parse_size(args.size)
    stations = [float(a) for a in args.stations.split(",")]
    designs = [d.strip() for d in args.designs.split(",") if d.strip()]
    arm = PendulumArm(width=size[0], height=size[1])
    K_true = arm.camera(stations[0]).K
    print(f"cores: {os.cpu_count()}, load average {os.getloadavg()[0]:.1f}, spp {args.spp}, "
          f"estimates at {size[0]}x{size[1]}")

    # 1. calibration ------------------------------------------------------------
    t0 = time.perf_counter()
    rng = np.random.default_rng(0)
    settings = RenderSettings(spp=args.spp, chessboard=CAL_SHEET)
    photos = [render(EMPTY, GridPose(), calibration_camera(k, args.calibration_photos, K_true,
                                                           size, rng),
                     settings=settings, seed=k).image for k in range(args.calibration_photos)]
    calibration = calibrate_camera(photos, CAL_BOARD)
    K = calibration.intrinsics.K
    print(f"\n1. calibration on {len(calibration.used)} of {len(photos)} photographs "
          f"({time.perf_counter() - t0:.0f} s): RMS {calibration.rms_px:.3f} px")
    print(f"   fx {K[0, 0]:.2f} (true {K_true[0, 0]:.2f}, "
          f"{100 * (K[0, 0] / K_true[0, 0] - 1):+.3f} %)"
          f"  fy {K[1, 1]:.2f} ({100 * (K[1, 1] / K_true[1, 1] - 1):+.3f} %)"
          f"  cx {K[0, 2] - K_true[0, 2]:+.2f} px  cy {K[1, 2] - K_true[1, 2]:+.2f} px"
          f"  dist {np.round(calibration.intrinsics.dist[:2], 4).tolist()}")

    # 2. location -----------------------------------------------------------------
    print(f"\n2. location from a {LOC_BOARD} board of {LOC_BOARD.square_mm:g} mm squares at "
          "the table's centre")
    header = f"{'size':>10}{'intrinsics':>12}" \
        + "".join(f"{f'{a:g}° mm/deg':>15}" for a in stations) \
        + f"{'mean mm':>10}{'max mm':>9}{'max deg':>9}"
    print(header)
    print("-" * len(header))
    located: dict[float, Camera] = {}
    loc_settings = RenderSettings(spp=args.spp, chessboard=TableChessboard(LOC_BOARD,
                                                                            LOC_PLACEMENT))
    for text in args.sizes.split(","):
        w, h = parse_size(text)
        size_arm = PendulumArm(width=w, height=h)
        rows = {"true": []}
        if (w, h) == size:
            rows["calibrated"] = []
        for a in stations:
            truth = size_arm.camera(a)
            image = Workspace(EMPTY, arm=size_arm, settings=loc_settings).observe(a).image
            for name, intr in (("true", truth), ("calibrated", calibration.intrinsics)):
                if name not in rows:
                    continue
                loc = locate_camera(image, intr, LOC_BOARD, placement=LOC_PLACEMENT)
                rows[name].append((np.linalg.norm(loc.camera.centre - truth.centre),
                                   rotation_error_deg(loc.camera.R, truth.R)))
                if name == "calibrated":
                    located[a] = loc.camera
        for name, errs in rows.items():
            e = np.array(errs)
            cells = "".join(f"{f'{mm:.2f}/{deg:.3f}':>15}" for mm, deg in errs)
            print(f"{text:>10}{name:>12}{cells}{e[:, 0].mean():>10.2f}{e[:, 0].max():>9.2f}"
                  f"{e[:, 1].max():>9.3f}")

    # 3. estimates ----------------------------------------------------------------
    columns = ["true", "located"] + [f"{m:g} mm" for m in POSITION_ERRORS_MM] \
        + [f"{d:g}°" for d in ROTATION_ERRORS_DEG]
    print("\n3. errors of the single-view estimate (truth pose given) per camera; "
          "below each, the grid's mean displacement in the image (px)")
    header = f"{'design':<16}{'station':>8}" + "".join(f"{c:>9}" for c in columns)
    print(header)
    print("-" * len(header))
    all_errors, all_shift = [], []
    t0 = time.perf_counter()
    for d_index, name in enumerate(designs):
        entry = load_design(name)
        ws = Workspace(entry.structure, pose=entry.pose, arm=arm,
                       settings=RenderSettings(spp=args.spp))
        for a in stations:
            view = ws.observe(a)
            truth = view.camera
            # One random direction and one random axis per image, so that the errors grow
            # with the step.
            direction, axis = np.random.default_rng([d_index, int(a)]).normal(size=(2, 3))
            direction, axis = direction / np.linalg.norm(direction), axis / np.linalg.norm(axis)
            cams = [truth, located[a] if a in located else truth]
            cams += [moved(truth, direction, mm=m) for m in POSITION_ERRORS_MM]
            cams += [moved(truth, axis, deg=d) for d in ROTATION_ERRORS_DEG]
            pts = grid_points(entry.structure.extent, entry.pose)
            errors, shift = [], []
            for cam in cams:
                est = estimate_view(View(view.image, cam, view.extent, view.pose))
                errors.append(errors_against_truth(est, entry.structure,
                                                   truth_pose=entry.pose))
                shift.append(float(np.linalg.norm(cam.project(pts) - truth.project(pts),
                                                  axis=1).mean()))
            all_errors.append(errors)
            all_shift.append(shift)
            print(f"{name:<16}{a:>8g}" + "".join(f"{e:>9}" for e in errors))
            print(f"{'':<16}{'px':>8}" + "".join(f"{s:>9.2f}" for s in shift))
    errs = np.array(all_errors, dtype=float)
    shifts = np.array(all_shift)
    print("-" * len(header))
    print(f"{'mean errors':<24}" + "".join(f"{e:>9.2f}" for e in errs.mean(axis=0)))
    print(f"{'images worse than true':<24}"
          + "".join(f"{int(n):>9}" for n in (errs > errs[:, :1]).sum(axis=0)))
    print(f"{'images better than true':<24}"
          + "".join(f"{int(n):>9}" for n in (errs < errs[:, :1]).sum(axis=0)))
    print(f"{'mean displacement px':<24}" + "".join(f"{s:>9.2f}" for s in shifts.mean(axis=0)))
    print(f"({len(errs)} images, {time.perf_counter() - t0:.0f} s)")


if __name__ == "__main__":
    main()
