"""Seconds per rendered view (image + ground truth) at the default quality.

Renders 640x480 views from the default pendulum arm at the default settings
(``RenderSettings()``: 16 samples per pixel, path depth 3) and prints a table:
the first (cold) render of each scene, which includes Mitsuba's kernel
compilation, and the mean of the warm ones, split into scene building, path
tracing, ground-truth ray casting and developing. Target: <= 3 s per warm
image on 2 cores.

Usage: ``python benchmarks/render.py [--repeats N] [--spp N] [--randomise]``
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from strategies import build_random_structure  # noqa: E402
from unseeable.domain import Extent, Log, Structure  # noqa: E402
from unseeable.render.renderer import render  # noqa: E402
from unseeable.render.settings import RenderSettings, SceneRandomisation  # noqa: E402
from unseeable.render.workspace import PendulumArm, default_pose  # noqa: E402


def cabin() -> Structure:
    L = Log
    return Structure(Extent(3, 6, 3), [
        L(0, (0, 0), 1), L(0, (2, 0), 1), L(0, (0, 2), 3), L(1, (0, 0), 3), L(1, (2, 0), 3),
        L(2, (0, 0), 1), L(2, (2, 0), 1), L(2, (0, 2), 3), L(3, (0, 0), 1), L(3, (0, 2), 1),
        L(3, (2, 0), 3), L(4, (0, 0), 3), L(4, (0, 2), 3), L(5, (0, 0), 3), L(5, (2, 0), 3)])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--spp", type=int, default=RenderSettings().spp)
    parser.add_argument("--randomise", action="store_true")
    args = parser.parse_args()
    settings = RenderSettings(spp=args.spp,
                              randomisation=SceneRandomisation() if args.randomise else None)
    scenes = [("cabin 3x6x3", cabin()),
              ("random 6x6x6", build_random_structure(Extent(6, 6, 6), 1, 0.7)),
              ("random 8x8x8", build_random_structure(Extent(8, 8, 8), 2, 0.7))]
    arm = PendulumArm()
    print(f"cores: {os.cpu_count()}, load average {os.getloadavg()[0]:.1f}, 640x480, "
          f"spp {settings.spp}, "
          f"randomised: {args.randomise}")
    header = (f"{'scene':<14}{'logs':>5}{'cold s':>8}{'warm s':>8}{'scene':>7}{'trace':>7}"
              f"{'truth':>7}{'develop':>8}  variant")
    print(header)
    print("-" * len(header))
    warm_all = []
    for name, structure in scenes:
        pose = default_pose(structure.extent)
        t0 = time.perf_counter()
        first = render(structure, pose, arm.camera(90.0), settings=settings, seed=0)
        cold = time.perf_counter() - t0
        runs = []
        for n in range(args.repeats):
            angle = arm.stations_deg[(n + 1) % len(arm.stations_deg)]
            runs.append(render(structure, pose, arm.camera(angle), settings=settings,
                               seed=n + 1))
        warm = float(np.mean([r.seconds for r in runs]))
        warm_all.append(warm)
        parts = {k: float(np.mean([r.timings[k] for r in runs])) for k in runs[0].timings}
        print(f"{name:<14}{len(structure.logs):>5}{cold:>8.2f}{warm:>8.2f}"
              f"{parts['scene']:>7.2f}{parts['path_tracing']:>7.2f}"
              f"{parts['ground_truth']:>7.2f}{parts['develop']:>8.2f}  {first.variant}")
    print(f"mean warm seconds per 640x480 image: {np.mean(warm_all):.2f} (target <= 3 s)")


if __name__ == "__main__":
    main()
