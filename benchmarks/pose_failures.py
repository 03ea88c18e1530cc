"""Where the pose search goes wrong: the search's candidates against the true pose.

For every view of a corpus (``unseeable corpus build``, or a variant made by
``corpus_variants.py``), the pose is searched as ``unseeable estimate`` searches
it (:func:`unseeable.vision.estimate_pose`, before the structure-based choice),
and the true pose is aligned and scored on the same edges
(:func:`unseeable.vision.align_pose`). Each view is then one of:

* ``right``: the search's best pose is within 2 mm and 1° of the truth;
* ``offered``: it is not, but one of its candidates is (the choice among
  candidates by the structure they imply may still take it);
* ``search``: no candidate is near the truth, and the truth, aligned, scores
  above every candidate: the edges prefer the truth, the search missed it;
* ``edges``: no candidate is near the truth, and one scores above it: the
  edges prefer a wrong pose (a depth alias, a quarter turn);
* ``refused``: no pose hypothesis could be aligned at all.

With ``--result`` (an ``unseeable experiment visibility`` folder run on the
same corpus without ``--known-pose``), each failure also shows how far the
pipeline's final pose was off.

With ``--family NAME`` instead of ``--corpus``, the scenes are the first
``--scenes`` of one of the held-out families of ``vision.py`` (rendered on
demand into the cache, as ``vision.py`` and ``families.py`` do), judged in
``--workers`` processes.

``--set FIELD=VALUE`` (repeatable) searches with that field of
:class:`~unseeable.vision.PoseSettings` changed, e.g. ``--set verify_keep=20``,
to see which failures a setting moves before the whole pipeline is run on it
(``families.py``, ``unseeable experiment``): the search's classes are not the
pipeline's poses, which the structure choice picks among the candidates.

Usage::

    python benchmarks/pose_failures.py --corpus DIR [--step N] [--result RDIR]
    python benchmarks/pose_failures.py --family validation-halls [--scenes 60] [--workers 2]
    python benchmarks/pose_failures.py --family other-renderer --set verify_keep=20
"""

from __future__ import annotations

import argparse
import collections
import dataclasses
import json
import sys
from pathlib import Path

import numpy as np

from unseeable.camera import Camera
from unseeable.domain import Extent, GridPose
from unseeable.errors import UnseeableError
from unseeable.parallel import run_in_processes
from unseeable.render import load_truth
from unseeable.render.view import load_view
from unseeable.training.scenes import make_scene
from unseeable.vision import PoseSettings, align_pose, estimate_pose, pose_equivalent
from unseeable.vision.edges import as_rgb_image
from unseeable.vision.scale import view_edge_maps

sys.path.insert(0, str(Path(__file__).resolve().parent))
from vision import FAMILIES  # noqa: E402  (the vision benchmark's held-out families)

#: Within this (mm, degrees) of the truth a pose is right (as the experiments count it).
RIGHT = (2.0, 1.0)


def _near(error: tuple[float, float]) -> bool:
    return error[0] <= RIGHT[0] and error[1] <= RIGHT[1]


def classify(view_file: Path, settings: PoseSettings = PoseSettings()) -> dict:
    """One corpus view's class, the search's best pose error, and the scores compared."""
    view = load_view(view_file)
    truth = load_truth(view_file.with_name(view_file.stem + ".truth.json"))
    return classify_image(view.image, view.camera, view.extent, truth.pose, settings=settings)


def classify_scene(task: tuple[str, int, PoseSettings]) -> tuple[int, dict]:
    """One scene of a held-out family (``vision.py``'s ``FAMILIES``): a worker's task."""
    family, n, settings = task
    scene = make_scene(FAMILIES[family], n)
    return n, classify_image(scene.image, scene.camera, scene.extent, scene.pose,
                             settings=settings)


def classify_image(image: np.ndarray, camera: Camera, extent: Extent, true_pose: GridPose,
                   *, settings: PoseSettings = PoseSettings()) -> dict:
    """The class of one photograph whose true pose is known (see the module's text)."""
    maps = view_edge_maps(as_rgb_image(image), camera, pose=True)
    try:
        fit = estimate_pose(image, camera, extent, strict=False, maps=maps, settings=settings)
    except UnseeableError as exc:
        return {"class": "refused", "why": str(exc)}
    errors = [pose_equivalent(p, true_pose, extent) for p, _ in fit.candidates]
    best = pose_equivalent(fit.pose, true_pose, extent)
    row = {"best_error": [round(float(v), 1) for v in best], "quality": round(fit.quality, 2),
           "candidates": len(fit.candidates)}
    if _near(best):
        return {"class": "right", **row}
    if any(_near(e) for e in errors):
        return {"class": "offered", **row}
    _, truth_score = align_pose(maps, camera, extent, true_pose, settings=settings)
    top = max(score for _, score in fit.candidates)
    row.update(truth_score=round(truth_score, 1), best_candidate_score=round(top, 1))
    return {"class": "search" if truth_score > top else "edges", **row}


def pose_settings(changes: list[str]) -> PoseSettings:
    """:class:`PoseSettings` with ``FIELD=VALUE`` changes (a tuple's VALUE: commas).

    >>> pose_settings(["verify_keep=20", "turned_twin=true"]).verify_keep
    20
    """
    fields = {f.name for f in dataclasses.fields(PoseSettings)}
    values = {}
    for change in changes:
        name, sep, text = change.partition("=")
        if not sep or name not in fields:
            raise ValueError(f"{change!r}: expected FIELD=VALUE with FIELD one of "
                             f"{sorted(fields)}")
        default = getattr(PoseSettings(), name)
        try:
            if isinstance(default, bool):
                if text.lower() not in ("true", "false"):
                    raise ValueError
                values[name] = text.lower() == "true"
            elif isinstance(default, tuple):
                values[name] = tuple(float(v) for v in text.split(",") if v.strip())
            else:
                values[name] = type(default)(text)
        except ValueError:
            raise ValueError(f"{name}: {text!r} is not a valid {type(default).__name__} "
                             f"(the default is {default!r})") from None
    return PoseSettings(**values)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    where = parser.add_mutually_exclusive_group(required=True)
    where.add_argument("--corpus", type=Path, help="corpus folder")
    where.add_argument("--family", choices=sorted(FAMILIES),
                       help="a held-out scene family of vision.py instead of a corpus")
    parser.add_argument("--step", type=int, default=1, help="every STEP-th view only")
    parser.add_argument("--scenes", type=int, default=60, help="with --family: scenes 0..N-1")
    parser.add_argument("--workers", type=int, default=2, help="with --family: processes")
    parser.add_argument("--set", dest="changes", action="append", default=[],
                        metavar="FIELD=VALUE",
                        help="search with this PoseSettings field changed (repeatable)")
    parser.add_argument("--result", type=Path,
                        help="an 'unseeable experiment visibility' folder on the same corpus")
    args = parser.parse_args(argv)
    for name in ("step", "scenes", "workers"):
        if getattr(args, name) < 1:
            raise SystemExit(f"error: --{name}: must be 1 or more (got {getattr(args, name)})")
    try:
        settings = pose_settings(args.changes)
    except ValueError as exc:
        raise SystemExit(f"error: --set: {exc}") from None
    if args.result is not None and not (args.result / "images").is_dir():
        raise SystemExit(f"error: {args.result}: no images/ folder (not the output of "
                         "'unseeable experiment visibility')")
    rows = {}
    if args.family is not None:
        tasks = [(args.family, n, settings) for n in range(args.scenes)]
        by_scene = {}
        for done, (n, row) in enumerate(run_in_processes(classify_scene, tasks,
                                                         workers=args.workers), 1):
            by_scene[n] = row
            print(f"\r{done}/{len(tasks)} scenes", end="", file=sys.stderr, flush=True)
        # In the scenes' order, whichever finished first.
        rows = {f"{args.family}/{n}": by_scene[n] for n in sorted(by_scene)}
        source = f"the first {args.scenes} scenes of {args.family}"
    else:
        views = sorted(p for p in args.corpus.glob("*/view*.json")
                       if not p.name.endswith((".truth.json", ".stamp.json")))[::args.step]
        if not views:
            raise SystemExit(f"error: {args.corpus}: no view*.json files (build it with "
                             "'unseeable corpus build')")
        for n, vf in enumerate(views, 1):
            rows[f"{vf.parent.name}/{vf.stem}"] = classify(vf, settings)
            print(f"\r{n}/{len(views)} views", end="", file=sys.stderr, flush=True)
        source = str(args.corpus)
    print(file=sys.stderr)
    counts = collections.Counter(r["class"] for r in rows.values())
    changed = f" ({', '.join(args.changes)})" if args.changes else ""
    print(f"Pose search{changed} on {len(rows)} views of {source}: "
          + ", ".join(f"{k} {counts[k]}" for k in
                      ("right", "offered", "search", "edges", "refused")))
    for name, r in rows.items():
        if r["class"] == "right":
            continue
        final = ""
        if args.result is not None:
            record = args.result / "images" / f"{name}.json"
            if record.exists():
                data = json.loads(record.read_text())
                if data.get("pose_error_mm") is not None:
                    final = (f"; pipeline's pose {data['pose_error_mm']:.1f} mm "
                             f"{data['pose_error_deg']:.1f}°")
        detail = {k: v for k, v in r.items() if k != "class"}
        print(f"  {r['class']:8s} {name:34s} {detail}{final}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
