"""What running an experiment on Dask costs: the same batch of the visibility experiment's
per-image evaluations on 1 and 2 local processes and on a 2-worker Dask LocalCluster.

Each run evaluates the images of the first ``--structures`` structures of the corpus
(default 8: 40 images, a quarter of the visibility experiment), or of ``--only``, into a
fresh results folder (nothing cached), with the settings of ``unseeable experiment
visibility`` (the pose found from the image unless ``--known-pose``). It prints, per
executor, the wall time of the batch, the time to start the executor (the LocalCluster's
scheduler and workers) and the work (the images' own estimate times, summed), and checks
that every executor gives the same records (the clock's fields aside).

The Dask overhead is the LocalCluster's extra wall time over two local processes doing
the same work, as a share of the latter, without and with the cluster's start (a
``tcp://`` scheduler is started once for many jobs; ``local:N`` starts one per command);
and the processor time of all the processes (this one and its workers) on each, which a
busy machine disturbs less than the wall time.
Target: under 10 %. With ``--repeats R`` the 2-worker runs alternate R times and the
medians are compared. Timings on a shared machine are noisy: the load average is printed.

Run: ``nice -n 10 python benchmarks/executor.py --corpus DIR [--structures 8 | --only a,b]
[--known-pose] [--repeats 1]`` with ``DIR`` from ``unseeable corpus build``.
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
from pathlib import Path

from unseeable.corpus.build import load_corpus
from unseeable.evaluate.experiments import EvaluationSettings, evaluate_corpus
from unseeable.evaluate.jobs import without_timings
from unseeable.executor import open_executor
from unseeable.pipeline import EstimateSettings


def run_once(spec: str, corpus: Path, only: list[str], settings: EvaluationSettings
             ) -> dict:
    """One batch on ``spec``'s executor: wall seconds (start, batch, total) and records."""
    with tempfile.TemporaryDirectory(prefix="executor-bench-") as out:
        c0, t0 = os.times(), time.perf_counter()
        with open_executor(spec) as executor:
            t1 = time.perf_counter()
            records = evaluate_corpus(corpus, Path(out), settings=settings,
                                      executor=executor, only=only)
            t2 = time.perf_counter()
        t3, c3 = time.perf_counter(), os.times()
    # Processor time of this process and of its worker processes (reaped when the executor
    # closes): the work and every executor's own, less disturbed by a busy machine.
    cpu = sum(b - a for a, b in zip(c0[:4], c3[:4]))
    system = c3[1] + c3[3] - c0[1] - c0[3]
    return {"spec": spec, "start": t1 - t0, "batch": t2 - t1, "total": t3 - t0, "cpu": cpu,
            "system": system,
            "work": sum(r.get("seconds") or 0.0 for r in records),
            "images": len(records), "failed": sum(bool(r.get("failed")) for r in records),
            "records": without_timings(records)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--corpus", type=Path, default=Path("/work/corpus"))
    parser.add_argument("--structures", type=int, default=8,
                        help="The first N structures of the corpus (default %(default)s).")
    parser.add_argument("--only", help="Comma-separated structures instead.")
    parser.add_argument("--known-pose", action="store_true")
    parser.add_argument("--repeats", type=int, default=1,
                        help="Alternating runs of the two 2-worker executors.")
    args = parser.parse_args()
    only = ([n.strip() for n in args.only.split(",") if n.strip()] if args.only
            else load_corpus(args.corpus).names[:args.structures])
    settings = EvaluationSettings(estimate=EstimateSettings.from_options(time_limit=30.0),
                                  known_pose=args.known_pose)
    load = os.getloadavg()
    print(f"corpus {args.corpus}, structures {', '.join(only)}, "
          f"{'known' if args.known_pose else 'estimated'} pose; "
          f"load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} on {os.cpu_count()} cores")
    runs = [run_once("processes:1", args.corpus, only, settings)]
    for _ in range(args.repeats):
        runs.append(run_once("processes:2", args.corpus, only, settings))
        runs.append(run_once("local:2", args.corpus, only, settings))
    print(f"{'executor':14s} {'images':>6s} {'start s':>8s} {'batch s':>8s} {'total s':>8s} "
          f"{'work s':>8s} {'cpu s':>8s}")
    for r in runs:
        print(f"{r['spec']:14s} {r['images']:6d} {r['start']:8.2f} {r['batch']:8.2f} "
              f"{r['total']:8.2f} {r['work']:8.2f} {r['cpu']:8.2f}"
              + (f"  ({r['failed']} failed)" if r["failed"] else ""))
    same = all(r["records"] == runs[0]["records"] for r in runs)
    print(f"records identical on every executor: {same}")

    def median(spec: str, key: str) -> float:
        return statistics.median(r[key] for r in runs if r["spec"] == spec)

    proc2 = median("processes:2", "total")
    dask_batch, dask_total = median("local:2", "batch"), median("local:2", "total")
    print(f"speed-up of 2 local processes over 1: {runs[0]['total'] / proc2:.2f}x")
    print(f"Dask overhead (LocalCluster of 2 vs 2 local processes): "
          f"{(dask_batch - proc2) / proc2:+.1%} of the work without the cluster's start "
          f"({median('local:2', 'start'):.2f} s), {(dask_total - proc2) / proc2:+.1%} with it")
    cpu2, dask_cpu = median("processes:2", "cpu"), median("local:2", "cpu")
    print(f"processor time, LocalCluster of 2 vs 2 local processes: {dask_cpu:.1f} s vs "
          f"{cpu2:.1f} s ({(dask_cpu - cpu2) / cpu2:+.1%})")
    load = os.getloadavg()
    print(f"load average at the end {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}")


if __name__ == "__main__":
    main()
