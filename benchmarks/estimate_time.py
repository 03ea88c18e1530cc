"""Time to estimate one photograph, one image at a time (what ``unseeable estimate`` costs).

The corpus experiments time each image while another worker process runs
beside it (two images at once on two cores). This script times the other
use: a single photograph estimated on an otherwise idle machine, the pose
search and its choice on ``--threads`` threads (the CLI's default is 2),
as ``unseeable estimate`` makes it for a view that records no pose (the
corpus views record theirs; it is not used unless ``--known-pose``). It
prints the median, mean, 90th percentile and largest time per image, the
share under a second, the mean processor time per image (every thread's
work; the wall time also counts the waits, and how much two threads overlap)
and the median of each stage (``Estimate.timings``).

With ``--workers W`` (W > 1) it times the other way of using two cores: a
batch of photographs, W at a time in W processes of one thread each (as the
corpus experiments run them), and prints the wall time of the whole batch per
image (the throughput) beside each image's own time. The workers load the
numba kernels before the clock starts.

With ``--design NAME`` (and ``--angle A``) only that design's views are timed, each
``--repeat`` times: e.g. the lodge from 150° with its pose known, median of 9
(``--design lodge --angle 150 --known-pose --repeat 9``).

Run: ``python benchmarks/estimate_time.py --corpus DIR [--threads 2] [--every 1]
[--known-pose] [--workers 1] [--no-presence-shift] [--no-lines-once] [--joint-cost C]
[--design NAME] [--angle A] [--repeat N]`` with ``DIR`` from ``unseeable corpus build``.
"""

from __future__ import annotations

import argparse
import multiprocessing
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.progress import track
from rich.table import Table

from unseeable.errors import UnseeableError
from unseeable.grammar.priors import StructurePrior
from unseeable.render.view import load_view

sys.path.insert(0, str(Path(__file__).resolve().parent))
from corpus_views import run_pipeline  # noqa: E402  (the benchmarks' adapter to the estimator)


def _warm(paths: list[Path], known_pose: bool, threads: int = 1) -> None:
    """The first estimates load (or compile) the numba kernels: run untimed (also as the
    batch workers' initialiser)."""
    for path in paths:
        run_pipeline(load_view(path), known_pose=known_pose, strict_pose=False,
                     threads=threads)


def _ready() -> bool:
    return True


def _estimate_one(task: tuple[Path, bool, int, bool, bool, float]
                  ) -> tuple[float | None, float, dict]:
    """One image's estimate: (seconds, processor seconds, stage timings); None seconds
    when refused."""
    path, known_pose, threads, shift, lines_once, joint_cost = task
    view = load_view(path)
    t0, c0 = time.perf_counter(), time.process_time()
    try:
        est = run_pipeline(view, known_pose=known_pose, threads=threads,
                           presence_shift=shift, lines_once=lines_once, joint_cost=joint_cost)
    except UnseeableError:
        return None, 0.0, {}  # a poor pose fit is refused, as the CLI does without --force-pose
    return time.perf_counter() - t0, time.process_time() - c0, est.timings


def _batch(views: list[Path], warm: list[Path], args: argparse.Namespace
           ) -> tuple[list, float]:
    """Every view on ``args.workers`` processes of one thread: results and wall seconds."""
    context = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(max_workers=args.workers, mp_context=context,
                             initializer=_warm, initargs=(warm, args.known_pose)) as pool:
        # One task per worker first, so that every worker has started (and warmed up).
        for future in [pool.submit(_ready) for _ in range(args.workers)]:
            future.result()
        t0 = time.perf_counter()
        tasks = [(p, args.known_pose, 1, args.presence_shift, args.lines_once, args.joint_cost)
                 for p in views]
        results = list(track(pool.map(_estimate_one, tasks), total=len(views),
                             description="estimating"))
        return results, time.perf_counter() - t0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--corpus", type=Path, required=True, help="A rendered corpus folder.")
    parser.add_argument("--threads", type=int, default=2, help="Threads per image.")
    parser.add_argument("--every", type=int, default=1, help="Every n-th image only.")
    parser.add_argument("--known-pose", action="store_true",
                        help="Use the recorded pose instead of estimating it.")
    parser.add_argument("--no-presence-shift", dest="presence_shift", action="store_false",
                        help="Without the re-estimate under the shifted detections.")
    parser.add_argument("--no-lines-once", dest="lines_once", action="store_false",
                        help="Every segment detection counted on its own, even where "
                             "several features share an image line.")
    parser.add_argument("--joint-cost", type=float, default=StructurePrior().joint_cost,
                        help="The structure prior's cost of a joint (nats; 0 with the "
                             "prior's other costs: the paper's uniform prior).")
    parser.add_argument("--workers", type=int, default=1,
                        help="Above 1: a batch, this many images at a time in processes of "
                             "one thread each (--threads is then not used).")
    parser.add_argument("--design", help="Only this design's views (its folder's name).")
    parser.add_argument("--angle", type=float,
                        help="Only the views from this angle (degrees; view<angle>.json).")
    parser.add_argument("--repeat", type=int, default=1,
                        help="Time each view this many times (one after the other).")
    args = parser.parse_args(argv)
    console = Console()
    views = sorted(p for p in args.corpus.glob("*/view*.json") if p.name.count(".") == 1)
    if args.design is not None:
        views = [p for p in views if p.parent.name == args.design]
    if args.angle is not None:
        views = [p for p in views if p.stem == f"view{args.angle:g}"]
    if not views:
        console.print(f"{args.corpus}: no view files (view*.json) in its design folders"
                      + (f" for design {args.design!r}" if args.design is not None else "")
                      + (f" from {args.angle:g}°" if args.angle is not None else ""))
        return 1
    if min(args.every, args.threads, args.workers, args.repeat) < 1:
        console.print("--every, --threads, --workers and --repeat must be at least 1")
        return 1
    views = [p for p in views[:: args.every] for _ in range(args.repeat)]
    # The first estimates compile (or load) the numba kernels: not timed. One view of each
    # of a few designs, since some kernels are first needed by other extents (a wall's yaw
    # steps, the pitch check); the first run after an install is still a little slower.
    warm = list({p.parent: p for p in reversed(views)}.values())[:4]
    wall = None
    if args.workers > 1:
        results, wall = _batch(views, warm, args)
        how = f"{args.workers} at a time, one thread each"
    else:
        _warm(warm, args.known_pose, args.threads)
        results = [_estimate_one((p, args.known_pose, args.threads, args.presence_shift,
                                  args.lines_once, args.joint_cost))
                   for p in track(views, description="estimating", console=console)]
        how = f"one at a time, {args.threads} thread(s)"
    seconds = [s for s, _, _ in results if s is not None]
    processor = [c for s, c, _ in results if s is not None]
    refused = len(results) - len(seconds)
    stages: dict[str, list[float]] = {}
    for _, _, timings in results:
        for name, value in timings.items():
            stages.setdefault(name, []).append(value)
    a = np.array(seconds)
    console.print(f"{len(a)} images of {args.corpus}, {how} "
                  f"({'known' if args.known_pose else 'estimated'} pose); {refused} refused")
    if wall is not None:
        console.print(f"batch: {wall:.1f} s wall for {len(views)} images, "
                      f"[bold]{wall / len(views):.2f} s per image[/bold] (throughput); "
                      "each image's own time below")
    table = Table()
    for column in ("median s", "mean s", "p90 s", "max s", "under 1 s", "processor s (mean)"):
        table.add_column(column, justify="right")
    table.add_row(f"{np.median(a):.2f}", f"{a.mean():.2f}", f"{np.percentile(a, 90):.2f}",
                  f"{a.max():.2f}", f"{100 * np.mean(a < 1.0):.1f} %",
                  f"{np.mean(processor):.2f}")
    console.print(table)
    console.print("stage medians: " + ", ".join(
        f"{name} {np.median(v):.3f} s" for name, v in stages.items() if name != "total_s"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
