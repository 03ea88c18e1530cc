"""Do the estimates of every corpus view stay the same? Record them, or compare with a record.

For every view of a rendered corpus this runs the single-view estimate twice,
with the view's recorded pose and with the pose estimated from the image, and
records per view and mode: the estimated structure's logs, the pose used, the
log-probability, whether the estimate is confident, its tolerance and its
errors against the truth. ``--record FILE`` writes the record; ``--against
FILE`` compares the estimates made now with a record written earlier (e.g. by
an older commit) and prints, per mode, how many views kept the same structure,
pose and log-probability, and every view that changed, with its errors before
and after. The exit code is 1 when any view's structure changed.

The estimate is asked for through the one entry point every version keeps,
``unseeable.pipeline.estimate_view(view)``, with the view's pose removed for
the estimated mode, so a record written by one commit compares with another.

Run: ``python benchmarks/regression.py --corpus DIR --record FILE`` and later
``python benchmarks/regression.py --corpus DIR --against FILE``
(``--workers 2`` by default; ``--only NAME,NAME`` for a subset).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from rich.console import Console
from rich.progress import track
from rich.table import Table

from unseeable.corpus.build import load_corpus
from unseeable.domain.io import structure_to_json
from unseeable.errors import UnseeableError
from unseeable.parallel import run_in_processes

MODES = ("known", "estimated")


def _estimate_one(task: tuple[str, float, str, str, str]) -> dict:
    """One view in one mode: what the record keeps of its estimate."""
    from unseeable.evaluate.metric import compare_structures
    from unseeable.pipeline import estimate_view
    from unseeable.render.view import View, load_truth, load_view

    name, angle, view_path, truth_path, mode = task
    view = load_view(view_path)
    truth = load_truth(truth_path)
    if mode == "estimated":
        view = View(view.image_path, view.camera, view.extent, pose=None,
                    removed_from_layer=view.removed_from_layer,
                    removed_logs=view.removed_logs)
    key = f"{name}@{angle:g}:{mode}"
    t0 = time.perf_counter()
    try:
        est = estimate_view(view)
    except UnseeableError as err:
        return {"key": key, "failed": str(err)}
    seconds = time.perf_counter() - t0
    s = est.structure
    errors = None
    if s is not None:
        errors = compare_structures(truth.shown, s, truth_pose=truth.pose,
                                    estimate_pose=est.pose, on_misaligned="count").errors
    pose = None if est.pose is None else est.pose.to_json()
    return {"key": key, "failed": None,
            "logs": None if s is None else structure_to_json(s)["logs"],
            "pose": pose, "log_probability": est.result.log_probability,
            "confident": est.confident,
            "tolerance": None if est.confidence is None else est.confidence.tolerance,
            "errors": errors, "seconds": seconds}


def _tasks(corpus_dir: Path, only: set[str] | None) -> list[tuple]:
    tasks = []
    for item in load_corpus(corpus_dir):
        if only and item.name not in only:
            continue
        for view in item.views:
            for mode in MODES:
                tasks.append((item.name, float(view.angle), str(view.view), str(view.truth),
                              mode))
    return tasks


def _same_pose(a: dict | None, b: dict | None) -> bool:
    if a is None or b is None:
        return a is b
    return all(abs(a[k] - b[k]) < 1e-6 for k in ("x", "z", "yaw_deg"))


def _compare(now: dict[str, dict], before: dict[str, dict], console: Console) -> int:
    changed_structures = 0
    table = Table(title="estimates against the record")
    for col in ("mode", "views", "same structure", "same pose", "same log-prob",
                "errors before", "errors now"):
        table.add_column(col, justify="right")
    changes = []
    for mode in MODES:
        keys = sorted(k for k in now if k.endswith(":" + mode) and k in before)
        same_s = same_p = same_lp = 0
        err_before = err_now = 0
        for k in keys:
            a, b = before[k], now[k]
            if a.get("failed") or b.get("failed"):
                if bool(a.get("failed")) == bool(b.get("failed")):
                    same_s += 1
                    same_p += 1
                    same_lp += 1
                else:
                    changes.append((k, "failed" if b.get("failed") else "ok",
                                    a.get("errors"), b.get("errors")))
                continue
            s_ok = a["logs"] == b["logs"]
            same_s += s_ok
            same_p += _same_pose(a["pose"], b["pose"])
            same_lp += abs(a["log_probability"] - b["log_probability"]) < 1e-6
            err_before += a["errors"] or 0
            err_now += b["errors"] or 0
            if not s_ok:
                changes.append((k, "structure", a["errors"], b["errors"]))
        changed_structures += len(keys) - same_s
        table.add_row(mode, str(len(keys)), str(same_s), str(same_p), str(same_lp),
                      str(err_before), str(err_now))
    console.print(table)
    for k, what, e0, e1 in changes:
        console.print(f"changed {k}: {what}, errors {e0} -> {e1}")
    missing = sorted(set(before) - set(now))
    if missing:
        console.print(f"{len(missing)} recorded views not estimated now (e.g. {missing[0]})")
    return changed_structures


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--corpus", type=Path, required=True)
    group = parser.add_mutually_exclusive_group(required=True)
    group.add_argument("--record", type=Path, help="write the estimates to this file")
    group.add_argument("--against", type=Path, help="compare with this record")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--only", default=None, help="comma-separated structure names")
    args = parser.parse_args(argv)
    console = Console()
    only = set(args.only.split(",")) if args.only else None
    tasks = _tasks(args.corpus, only)
    t0 = time.perf_counter()
    now = {}
    for rec in track(run_in_processes(_estimate_one, tasks, workers=args.workers),
                     total=len(tasks), description="estimating", console=console):
        now[rec["key"]] = rec
    console.print(f"{len(tasks)} estimates in {time.perf_counter() - t0:.0f} s")
    if args.record:
        args.record.write_text(json.dumps({"estimates": now}, indent=1, sort_keys=True))
        console.print(f"recorded to {args.record}")
        return 0
    before = json.loads(args.against.read_text())["estimates"]
    return 1 if _compare(now, before, console) else 0


if __name__ == "__main__":
    sys.exit(main())
