"""The corpus's designs seen otherwise: camera size, looks, renderer, a miscalibrated camera.

The shipped figures are measured on one corpus build (Mitsuba, 640×480, one
look per design, the arm's cameras exactly as the views name them). This
script makes the other builds the same 160 views can be seen in, and prints
one line of figures per experiment run on them.

Variants ``unseeable corpus build`` makes itself::

    unseeable corpus build --out C1024 --size 1024x768          # another camera size
    unseeable corpus build --out CRAND --randomise --seed 1     # other looks, and the
        # camera jittered (5 mm, 0.5° per axis): the view names the arm's nominal camera

Variants made here from a built corpus::

    python benchmarks/corpus_variants.py make raster --corpus C --out CRASTER
        # every view drawn again by the flat-shaded renderer (unseeable.render.raster),
        # one random look per design
    python benchmarks/corpus_variants.py make true-camera --corpus CRAND --out CCAM
        # each view told the camera that really took it (its truth's): the looks
        # without the calibration error

    python benchmarks/corpus_variants.py jittered --position-mm 1 --rotation-deg 0.1 \
        --seed 1 --out CJIT
        # as --randomise --seed 1 (the same looks and the same jitter directions), with
        # the camera jitter scaled to the given standard deviations

Then, for each corpus and with or without ``--known-pose``::

    unseeable experiment visibility --corpus CX --workers 2 --out RX
    unseeable experiment confidence --corpus CX --workers 2 --out RX
    python benchmarks/corpus_variants.py summary RX [RY ...]

A jittered camera puts every pose found for it some millimetres off the truth, and
the experiments count an estimate whose grid does not line up with the truth's as
wrong in every log. What the estimator makes of the *structure* there::

    python benchmarks/corpus_variants.py structures --corpus CX [--known-pose]
        # each view estimated as the experiments do; its errors counted as they count
        # them, and with the estimate's grid snapped onto the truth's nearest alignment
        # (compare_structures(..., on_misaligned="snap")), and the confident wrong of each
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import zlib
from pathlib import Path

import numpy as np

from unseeable.errors import UnseeableError


def _views(corpus: Path) -> list[Path]:
    views = sorted(p for p in corpus.glob("*/view*.json")
                   if not p.name.endswith((".truth.json", ".stamp.json")))
    if not views:
        raise SystemExit(f"error: {corpus}: no view*.json files (build it with "
                         "'unseeable corpus build')")
    return views


def _copy_corpus(corpus: Path, out: Path) -> Path:
    """``corpus`` without its images, into a partial folder beside ``out``."""
    if out.exists():
        raise SystemExit(f"error: {out}: already exists; give a new folder")
    tmp = out.with_name(out.name + ".partial")
    shutil.rmtree(tmp, ignore_errors=True)
    shutil.copytree(corpus, tmp, ignore=shutil.ignore_patterns("*.png"))
    return tmp


def make_raster(corpus: Path, out: Path) -> None:
    """Every view of ``corpus`` drawn again by the flat-shaded renderer, into ``out``."""
    import cv2

    from unseeable.render.raster import random_raster_look, rasterise_view
    from unseeable.render.view import load_truth

    views = _views(corpus)
    tmp = _copy_corpus(corpus, out)
    for n, vf in enumerate(views, 1):
        # One look per design, as the corpus has; seeded by names, not by order.
        look = random_raster_look(np.random.default_rng(zlib.crc32(vf.parent.name.encode())))
        truth = load_truth(vf.with_name(vf.stem + ".truth.json"))
        image = rasterise_view(truth.shown, truth.pose, truth.camera, look=look,
                               seed=zlib.crc32(f"{vf.parent.name}/{vf.name}".encode()))
        target = tmp / vf.parent.name / json.loads(vf.read_text())["image"]
        cv2.imwrite(str(target), cv2.cvtColor(image, cv2.COLOR_RGB2BGR))
        print(f"\r{n}/{len(views)} {vf.parent.name}/{vf.name}", end="", file=sys.stderr)
    print(file=sys.stderr)
    tmp.rename(out)


def make_true_camera(corpus: Path, out: Path) -> None:
    """A copy of ``corpus`` whose views name the camera that really took them."""
    views = _views(corpus)
    tmp = _copy_corpus(corpus, out)
    for vf in views:
        data = json.loads(vf.read_text())
        shutil.copy(vf.parent / data["image"], tmp / vf.parent.name / data["image"])
        data["camera"] = json.loads(vf.with_name(vf.stem + ".truth.json").read_text())["camera"]
        (tmp / vf.parent.name / vf.name).write_text(json.dumps(data, indent=2))
    tmp.rename(out)


def build_jittered(out: Path, *, position_mm: float, rotation_deg: float, seed: int,
                   workers: int) -> None:
    """The corpus with randomised looks and cameras jittered by the given standard
    deviations (the views name the arm's nominal cameras)."""
    from unseeable.corpus.build import build_corpus
    from unseeable.render.settings import RenderSettings, SceneRandomisation

    jitter = SceneRandomisation(camera_position_mm=position_mm,
                                camera_rotation_deg=rotation_deg)
    # 24 samples per pixel, as `unseeable corpus build` renders.
    report = build_corpus(out, settings=RenderSettings(spp=24, randomisation=jitter),
                          seed=seed, workers=workers)
    print(f"{out}: {len(report.rendered)} views rendered, {len(report.skipped)} already there",
          file=sys.stderr)


def summary(result: Path) -> str:
    """One line of figures of an experiment folder (``unseeable experiment visibility``)."""
    records = [json.loads(f.read_text()) for f in sorted((result / "images").rglob("*.json"))]
    if not records:
        raise SystemExit(f"error: {result}: no images/*/*.json records (run "
                         "'unseeable experiment visibility --out' there)")
    done = [r for r in records if "errors_auto" in r]
    auto = np.array([r["errors_auto"] for r in done])
    manual = np.array([r["errors_manual"] for r in done])
    confident = np.array([bool(r["confident"]) for r in done])
    wrong_pose = sum(1 for r in done if (r.get("pose_error_mm") or 0) > 2
                     or (r.get("pose_error_deg") or 0) > 1)
    seconds = np.array([r["seconds"] for r in done])
    return (f"{result}: {len(done)} of {len(records)} estimated | automatic mean "
            f"{auto.mean():.2f}, <= 12: {np.sum(auto <= 12)}, exact {np.sum(auto == 0)}, max "
            f"{auto.max()} | manual mean {manual.mean():.2f}, <= 12: {np.sum(manual <= 12)} | "
            f"FP {int(np.sum(confident & (auto > 0)))}, FN {int(np.sum(~confident & (auto == 0)))}"
            f" | poses over 2 mm or 1° from the truth: {wrong_pose} | seconds per image mean "
            f"{seconds.mean():.2f}, median {np.median(seconds):.2f}")


def structure_record(task: tuple[Path, bool]) -> dict:
    """One view estimated as ``unseeable experiment visibility`` estimates it; its errors
    as the experiments count them, and with the grids snapped (a worker's task)."""
    from unseeable.evaluate import compare_structures
    from unseeable.evaluate.experiments import EvaluationSettings
    from unseeable.pipeline import estimate_view
    from unseeable.render.view import load_truth, load_view

    view_file, known_pose = task
    view = load_view(view_file)
    truth = load_truth(view_file.with_name(view_file.stem + ".truth.json"))
    row = {"view": f"{view_file.parent.name}/{view_file.stem}"}
    try:
        est = estimate_view(view, EvaluationSettings().estimate, use_recorded_pose=known_pose)
    except UnseeableError as err:
        return {**row, "failed": str(err)}
    kw = {"truth_pose": truth.pose, "estimate_pose": est.pose}
    return {**row, "failed": None, "confident": bool(est.confident),
            "counted": compare_structures(truth.shown, est.structure, on_misaligned="count",
                                          **kw).errors,
            "snapped": compare_structures(truth.shown, est.structure, on_misaligned="snap",
                                          **kw).errors}


def structures(corpus: Path, *, known_pose: bool, workers: int) -> str:
    """Errors counted as the experiments count them and with the grids snapped, and each
    one's confident wrong estimates, over every view of ``corpus``."""
    from unseeable.parallel import run_in_processes

    tasks = [(v, known_pose) for v in _views(corpus)]
    rows = []
    for n, row in enumerate(run_in_processes(structure_record, tasks, workers=workers), 1):
        rows.append(row)
        print(f"\r{n}/{len(tasks)}", end="", file=sys.stderr)
    print(file=sys.stderr)
    done = [r for r in rows if r["failed"] is None]
    confident = np.array([r["confident"] for r in done], dtype=bool)
    out = [f"{corpus} ({'pose known' if known_pose else 'pose estimated'}): {len(done)} of "
           f"{len(rows)} estimated"]
    for key in ("counted", "snapped"):
        e = np.array([r[key] for r in done])
        wrong = sorted(r["view"] for r in done if r["confident"] and r[key] > 0)
        out.append(f"  {key}: mean {e.mean():.2f}, <= 12: {np.sum(e <= 12)}, exact "
                   f"{np.sum(e == 0)} | confident {int(confident.sum())}, of them wrong "
                   f"{len(wrong)}: {', '.join(wrong)}")
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    make = sub.add_parser("make", help="make a variant of a built corpus")
    make.add_argument("variant", choices=("raster", "true-camera"))
    make.add_argument("--corpus", type=Path, required=True)
    make.add_argument("--out", type=Path, required=True)
    jit = sub.add_parser("jittered", help="build the corpus with scaled camera jitter")
    jit.add_argument("--position-mm", type=float, required=True)
    jit.add_argument("--rotation-deg", type=float, required=True)
    jit.add_argument("--seed", type=int, default=1)
    jit.add_argument("--workers", type=int, default=2)
    jit.add_argument("--out", type=Path, required=True)
    summ = sub.add_parser("summary", help="one line per experiment folder")
    summ.add_argument("results", type=Path, nargs="+")
    struct = sub.add_parser("structures",
                            help="errors of each view's structure, its grid snapped too")
    struct.add_argument("--corpus", type=Path, required=True)
    struct.add_argument("--known-pose", action="store_true")
    struct.add_argument("--workers", type=int, default=2)
    args = parser.parse_args(argv)
    try:
        return _run(args)
    except UnseeableError as err:
        print(f"error: {err}", file=sys.stderr)
        return 1


def _run(args: argparse.Namespace) -> int:
    if args.command == "make":
        (make_raster if args.variant == "raster" else make_true_camera)(args.corpus, args.out)
    elif args.command == "jittered":
        build_jittered(args.out, position_mm=args.position_mm, rotation_deg=args.rotation_deg,
                       seed=args.seed, workers=args.workers)
    elif args.command == "structures":
        print(structures(args.corpus, known_pose=args.known_pose, workers=args.workers))
    else:
        for result in args.results:
            print(summary(result))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
