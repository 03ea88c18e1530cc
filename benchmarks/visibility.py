"""Speed of the visibility ray caster (unseeable.visibility).

Prints, for full structures of several extents seen by a workspace-like
camera (0.9 m away, 35° elevation, 30° azimuth):

* raw segment–cylinder tests per second: every (ray, cylinder) pair tested,
  no pruning, no early exit (``count_ray_cylinder_hits``; single-threaded,
  as is the library's kernel);
* the time of one ``feature_visibility`` call (median of repeats), and what
  that is in brute-force-equivalent tests per second (rays × logs / time);
* the plain-numpy reference on the same scene.

Run: ``python benchmarks/visibility.py``
"""

from __future__ import annotations

import time

import numpy as np
from rich.console import Console
from rich.table import Table

from unseeable.domain import Extent, GridPose, LogGeometry
from unseeable.grammar import full_structure
from unseeable.visibility import (
    blocked_rays,
    blocked_rays_reference,
    count_ray_cylinder_hits,
    feature_own_logs,
    feature_sample_points,
    feature_visibility,
    log_cylinders,
)

G = LogGeometry()




def camera_centre(extent: Extent) -> np.ndarray:
    centre = np.array([(extent.I - 1) * G.l1 / 2, 0.0, (extent.K - 1) * G.l1 / 2])
    el, az = np.deg2rad(35.0), np.deg2rad(30.0)
    return centre + 900.0 * np.array([-np.cos(el) * np.sin(az), np.sin(el),
                                      -np.cos(el) * np.cos(az)])


def best_of(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


def measure(extent: Extent) -> list[str]:
    """One table row for the full structure of ``extent``."""
    s = full_structure(extent)
    cam = camera_centre(extent)
    pose = GridPose()
    pts, ok = feature_sample_points(extent, cam)
    cyl = log_cylinders(s)
    own = feature_own_logs(s)
    rays = int(ok.sum())
    pairs = rays * len(cyl)
    # compile (cached on disk after the first run) and warm up
    count_ray_cylinder_hits(pts, ok, cam, cyl, G.radius)
    feature_visibility(s, cam, pose)
    raw = pairs / best_of(lambda: count_ray_cylinder_hits(pts, ok, cam, cyl, G.radius), 5)
    t_vis = best_of(lambda: feature_visibility(s, cam, pose), 10)
    t_kernel = best_of(lambda: blocked_rays(pts, ok, cam, cyl, G.radius, exclude=own), 10)
    t_ref = best_of(lambda: blocked_rays_reference(pts, ok, cam, cyl, G.radius, exclude=own), 1)
    return [str(extent), str(len(cyl)), str(len(own)), str(rays), f"{raw / 1e6:.1f} M",
            f"{t_vis * 1e3:.1f} ms", f"{pairs / t_vis / 1e6:.1f} M", f"{t_kernel * 1e3:.1f} ms",
            f"{t_ref * 1e3:.0f} ms"]


def main() -> None:
    table = Table(title="visibility ray casting (single thread)")
    for col in ("extent", "logs", "features", "rays", "raw tests/s", "feature_visibility",
                "equiv. tests/s", "kernel only", "numpy reference"):
        table.add_column(col, justify="right")
    for shape in ((4, 4, 4), (8, 10, 8)):
        table.add_row(*measure(Extent(*shape)))
    Console(width=200).print(table)


if __name__ == "__main__":
    main()
