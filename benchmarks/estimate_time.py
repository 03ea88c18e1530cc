"""Time to estimate one photograph, one image at a time (what ``unseeable estimate`` costs).

The corpus experiments time each image while another worker process runs
beside it (two images at once on two cores). This script times the other
use: a single photograph estimated on an otherwise idle machine, the pose
search and its choice on ``--threads`` threads (the CLI's default is 2),
as ``unseeable estimate`` makes it for a view that records no pose (the
corpus views record theirs; it is not used unless ``--known-pose``). It
prints the
median, mean, 90th percentile and largest time per image, the share under
a second, and the median of each stage (``Estimate.timings``).

Run: ``python benchmarks/estimate_time.py --corpus DIR [--threads 2] [--every 1]
[--known-pose]`` with ``DIR`` from ``unseeable corpus build``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.progress import track
from rich.table import Table

from unseeable.errors import UnseeableError
from unseeable.pipeline import estimate_view
from unseeable.render.view import load_view


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--corpus", type=Path, required=True, help="A rendered corpus folder.")
    parser.add_argument("--threads", type=int, default=2, help="Threads per image.")
    parser.add_argument("--every", type=int, default=1, help="Every n-th image only.")
    parser.add_argument("--known-pose", action="store_true",
                        help="Use the recorded pose instead of estimating it.")
    args = parser.parse_args(argv)
    console = Console()
    views = sorted(p for p in args.corpus.glob("*/view*.json") if p.name.count(".") == 1)
    if not views:
        console.print(f"{args.corpus}: no view files (view*.json) in its design folders")
        return 1
    if args.every < 1 or args.threads < 1:
        console.print("--every and --threads must be at least 1")
        return 1
    views = views[:: args.every]
    # The first estimates compile (or load) the numba kernels: not timed. One view of each
    # of a few designs, since some kernels are first needed by other extents (a wall's yaw
    # steps, the pitch check); the first run after an install is still a little slower.
    warm = {p.parent: p for p in reversed(views)}
    for path in list(warm.values())[:4]:
        estimate_view(load_view(path), use_view_pose=args.known_pose, strict_pose=False,
                      threads=args.threads)
    seconds, stages, refused = [], {}, 0
    for path in track(views, description="estimating", console=console):
        view = load_view(path)
        t0 = time.perf_counter()
        try:
            est = estimate_view(view, use_view_pose=args.known_pose, threads=args.threads)
        except UnseeableError:
            refused += 1  # a poor pose fit is refused, as the CLI does without --force-pose
            continue
        seconds.append(time.perf_counter() - t0)
        for name, value in est.timings.items():
            stages.setdefault(name, []).append(value)
    a = np.array(seconds)
    console.print(f"{len(a)} images of {args.corpus}, one at a time "
                  f"({'known' if args.known_pose else 'estimated'} pose, {args.threads} "
                  f"thread(s)); {refused} refused")
    table = Table()
    for column in ("median s", "mean s", "p90 s", "max s", "under 1 s"):
        table.add_column(column, justify="right")
    table.add_row(f"{np.median(a):.2f}", f"{a.mean():.2f}", f"{np.percentile(a, 90):.2f}",
                  f"{a.max():.2f}", f"{100 * np.mean(a < 1.0):.1f} %")
    console.print(table)
    console.print("stage medians: " + ", ".join(
        f"{name} {np.median(v):.3f} s" for name, v in stages.items() if name != "total_s"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
