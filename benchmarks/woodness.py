"""How well the wood colour model tells the logs' pixels from the rest, pixel by pixel.

For every view of a corpus (``unseeable corpus build``, or a variant made by
``corpus_variants.py``) the wood model the detectors use
(:func:`unseeable.vision.edges.woodness_map`, learnt on the photograph itself)
is run in the assembly's image region at the true pose, as the detectors run
it, and compared with the rendered log ids. It prints, for each lightness
weight asked for (the weight of lightness against the two colour axes):

* the AUC of woodness for log pixels against the other pixels of the region
  (table, shadows, the room seen between logs);
* the share of log pixels called wood (woodness > ½), and of the brightest
  tenth of each view's log pixels (specular highlights, where a pale log top
  looks like a light table);
* the share of the region's other pixels called wood.

The detectors' calibration was fitted with the default weight; another one
changes every woodness statistic the calibration reads (and the pose search's
wood cues), so it is a change to make with a refit.

Usage::

    python benchmarks/woodness.py --corpus DIR [--every 4] [--weights 0.35 0.1 0]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import cv2
import numpy as np

from unseeable.parallel import run_in_processes
from unseeable.render.view import load_truth, load_view
from unseeable.vision.detectors import _region_mask  # the detectors' own image region
from unseeable.vision.edges import WOOD_LIGHTNESS_WEIGHT, as_rgb_image, woodness_map
from unseeable.vision.projection import project_features

sys.path.insert(0, str(Path(__file__).resolve().parent))
from vision import roc_auc  # noqa: E402  (the vision benchmark's AUC)


def view_pixels(task: tuple[Path, tuple[float, ...]]) -> tuple[np.ndarray, np.ndarray,
                                                                 np.ndarray] | None:
    """One view's region pixels: (is log, is highlight, woodness per weight ``(W, P)``).

    None when the truth has no rendered ids of the photograph's size.
    """
    view_file, weights = task
    view = load_view(view_file)
    truth = load_truth(view_file.with_name(view_file.stem + ".truth.json"))
    image = as_rgb_image(view.image)
    if truth.ids is None or truth.ids.shape != image.shape[:2]:
        return None
    projection = project_features(truth.shown.extent, truth.pose, view.camera)
    region = _region_mask(projection, image.shape[:2])
    is_log = truth.ids[region] >= 0
    lightness = image[region].astype(float) @ np.array([0.299, 0.587, 0.114])
    highlight = is_log & (lightness >= np.percentile(lightness[is_log], 90)) \
        if is_log.any() else is_log
    lab = cv2.cvtColor(image, cv2.COLOR_RGB2Lab)  # converted once for every weight
    wood = np.stack([woodness_map(image, region, lab=lab, lightness_weight=w)[region]
                     for w in weights])
    return is_log, highlight, wood


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--corpus", type=Path, required=True, help="corpus folder")
    parser.add_argument("--every", type=int, default=1, help="every n-th view only")
    parser.add_argument("--weights", type=float, nargs="+",
                        default=[WOOD_LIGHTNESS_WEIGHT, 0.1, 0.0],
                        help="lightness weights to compare (the first is the baseline)")
    parser.add_argument("--workers", type=int, default=2, help="processes")
    args = parser.parse_args(argv)
    if args.every < 1 or args.workers < 1:
        parser.error("--every and --workers must be at least 1")
    if any(not np.isfinite(w) or w < 0 for w in args.weights):
        parser.error(f"--weights must be finite and >= 0 (got {args.weights})")
    views = sorted(p for p in args.corpus.glob("*/view*.json")
                   if not p.name.endswith((".truth.json", ".stamp.json")))[::args.every]
    if not views:
        parser.error(f"{args.corpus}: no view*.json files (build it with "
                     "'unseeable corpus build')")
    tasks = [(v, tuple(args.weights)) for v in views]
    parts = []
    for n, result in enumerate(run_in_processes(view_pixels, tasks, workers=args.workers), 1):
        if result is not None:
            parts.append(result)
        print(f"\r{n}/{len(tasks)} views", end="", file=sys.stderr, flush=True)
    print(file=sys.stderr)
    if not parts:
        parser.error(f"{args.corpus}: no view has rendered log ids of its image's size")
    is_log = np.concatenate([p[0] for p in parts])
    highlight = np.concatenate([p[1] for p in parts])
    wood = np.concatenate([p[2] for p in parts], axis=1)
    print(f"Wood model on {len(parts)} views of {args.corpus} "
          f"({is_log.sum()} log pixels, {(~is_log).sum()} others in the regions)")
    print("lightness weight | AUC   | log px wood | highlights wood | other px wood")
    for w, score in zip(args.weights, wood):
        called = score > 0.5
        print(f"{w:16.3g} | {roc_auc(score, is_log):.4f} | {called[is_log].mean():11.3f} | "
              f"{called[highlight].mean():15.3f} | {called[~is_log].mean():13.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
