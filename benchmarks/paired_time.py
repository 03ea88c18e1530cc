"""One photograph's estimate timed under two source trees, in pairs, for a fair comparison.

This machine's speed drifts by a third within an hour (the same code's lodge median has
read 0.9 s and 1.3 s on one day), so two checkouts timed one after the other compare the
machine as much as the code. Here each tree gets a worker process that loads the view's
estimate once (kernels, caches), and the two then estimate the same view in turn, the
order alternating, ``--pairs`` times: every pair sees the same machine. Printed per tree:
the median wall and processor time, the structure stage's median, the share under a
second; then the median of new / base over the pairs.

Run: ``python benchmarks/paired_time.py --base OLD/src --new NEW/src --view
CORPUS/lodge/view150.json [--pairs 24] [--threads 2] [--estimated-pose]``, e.g. with
``OLD`` a ``git worktree`` of the older commit.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
from pathlib import Path

_WORKER = """
import sys, time
sys.path.insert(0, {benchmarks!r})
from corpus_views import run_pipeline
from unseeable.render.view import load_view
path, known, threads = {view!r}, {known!r}, {threads!r}
run_pipeline(load_view(path), known_pose=known, threads=threads, strict_pose=False)
print("ready", flush=True)
for _ in sys.stdin:
    view = load_view(path)
    t0, c0 = time.perf_counter(), time.process_time()
    run = run_pipeline(view, known_pose=known, threads=threads, strict_pose=False)
    print(time.perf_counter() - t0, time.process_time() - c0, run.timings["structure_s"],
          flush=True)
"""


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--base", type=Path, required=True, help="The older tree's src folder.")
    parser.add_argument("--new", type=Path, required=True, help="The newer tree's src folder.")
    parser.add_argument("--view", type=Path, required=True, help="A corpus view file.")
    parser.add_argument("--pairs", type=int, default=24)
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--estimated-pose", action="store_true",
                        help="Find the pose instead of using the recorded one.")
    args = parser.parse_args(argv)
    for name in ("base", "new"):
        if not (getattr(args, name) / "unseeable").is_dir():
            print(f"error: --{name} {getattr(args, name)}: no unseeable package in it",
                  file=sys.stderr)
            return 1
    if not args.view.is_file():
        print(f"error: --view {args.view}: no such file", file=sys.stderr)
        return 1
    if args.pairs < 1 or args.threads < 1:
        print(f"error: --pairs and --threads must be at least 1 (got {args.pairs}, "
              f"{args.threads})", file=sys.stderr)
        return 1
    code = _WORKER.format(benchmarks=str(Path(__file__).resolve().parent),
                          view=str(args.view.resolve()), known=not args.estimated_pose,
                          threads=args.threads)
    workers = {}
    for name in ("base", "new"):
        env = dict(os.environ, PYTHONPATH=str(getattr(args, name).resolve()))
        proc = subprocess.Popen([sys.executable, "-c", code], stdin=subprocess.PIPE,
                                stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
                                env=env)
        if proc.stdout.readline().strip() != "ready":
            raise SystemExit(f"the {name} worker did not start (run it by hand to see why)")
        workers[name] = proc
    times: dict[str, list[list[float]]] = {name: [] for name in workers}
    for n in range(args.pairs):
        for name in (("base", "new") if n % 2 == 0 else ("new", "base")):
            proc = workers[name]
            proc.stdin.write("go\n")
            proc.stdin.flush()
            times[name].append([float(v) for v in proc.stdout.readline().split()])
    for proc in workers.values():
        proc.stdin.close()
        proc.wait()
    for name, rows in times.items():
        wall, cpu, structure = zip(*rows)
        print(f"{name}: wall {statistics.median(wall):.3f} s, processor "
              f"{statistics.median(cpu):.3f} s, structure {statistics.median(structure):.3f} s "
              f"(medians of {len(rows)}); under 1 s {sum(w < 1 for w in wall)}/{len(rows)}")
    ratio = [new[0] / base[0] for base, new in zip(times["base"], times["new"])]
    print(f"new / base, median over the pairs: {statistics.median(ratio):.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
