"""One active-vision step on the lodge: δ′ over every station × disassembly level.

Estimates the corpus's lodge from one photograph (not timed), then times
:func:`unseeable.active.plan_action` over every action the robot has — each arm
station, alone and after each disassembly level — and, for comparison, the paper's
per-action binary searches to 0.005 (:func:`unseeable.active.per_action_search`) on the
same estimate: re-solves and seconds of each, and whether they choose alike.

``--add A,B`` first adds the corpus's photographs from those stations to the estimate
(a later step of the loop, where the estimate's exact tie-mates are settled and δ′
must be searched).

Usage::

    python benchmarks/active_step.py --corpus /path/to/corpus [--start 150] [--repeat 3]
        [--add 90] [--known-pose] [--no-per-action]
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

from unseeable.active import Action, per_action_search, plan_action
from unseeable.corpus.build import load_corpus
from unseeable.pipeline import EstimateSettings, Observation, estimate, extend_estimate
from unseeable.render.workspace import PendulumArm


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--corpus", required=True)
    ap.add_argument("--design", default="lodge")
    ap.add_argument("--start", type=float, default=150.0)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--add", default="", help="stations whose photographs are added first")
    ap.add_argument("--known-pose", action="store_true")
    ap.add_argument("--no-per-action", action="store_true")
    args = ap.parse_args(argv)

    corpus = load_corpus(args.corpus)
    item = corpus[args.design]
    view = item.view(args.start).load_view()
    t0 = time.perf_counter()
    added = [float(a) for a in args.add.split(",") if a.strip()]
    observations = [Observation.of(v, use_recorded_pose=args.known_pose) for v in
                    [view, *(item.view(a).load_view() for a in added)]]
    est = estimate(observations[:1], EstimateSettings())
    if added:
        est = extend_estimate(est, observations[1:])
    print(f"{args.design} from {args.start:g}°"
          + "".join(f" + {a:g}°" for a in added) + f": {len(est.structure.logs)} logs, confident "
          f"{est.confident}, estimate {time.perf_counter() - t0:.1f} s")
    arm = PendulumArm(width=view.camera.width, height=view.camera.height)
    top = item.structure.extent.J
    actions = [Action(f"{a:g}" + ("" if lv is None else f" L{lv}"), arm.camera(a),
                      removed_from_layer=lv, station=a)
               for lv in [None, *range(1, top)] for a in corpus.angles
               if lv is not None or a not in (args.start, *added)]
    times, plan = [], None
    for _ in range(args.repeat):
        t1 = time.perf_counter()
        plan = plan_action(est, actions)
        times.append(time.perf_counter() - t1)
    print(f"one step over {len(actions)} actions ({plan.groups} distinct): chose "
          f"{plan.action.name if plan.action else None} (δ′ in "
          f"[{plan.candidates[plan.chosen].low:.4f}, {plan.candidates[plan.chosen].high:.4f}]"
          f"{', a tie' if plan.tie else ''}) in {plan.solves} re-solves; median "
          f"{statistics.median(times):.2f} s over {args.repeat} (min {min(times):.2f})"
          if plan.chosen is not None else f"nothing to learn ({plan.solves} re-solves)")
    if not args.no_per_action:
        t2 = time.perf_counter()
        delta, solves = per_action_search(est, actions)
        seconds = time.perf_counter() - t2
        best = float(delta.min())
        agree = plan.chosen is not None and delta[plan.chosen] <= best + 0.005
        print(f"per-action binary searches to 0.005: {solves} re-solves, {seconds:.2f} s; "
              f"smallest δ′ {best:.4f}; the simultaneous choice is within 0.005 of it: {agree}")
    print(f"load {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
