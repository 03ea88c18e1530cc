"""The pose quality model refitted with wide-look training scenes: refusals and wrong poses.

The quality model (:class:`unseeable.vision.PoseQualityModel`) says how likely a fitted
pose is right; the pipeline refuses a pose below 0.5. It ships fitted on the
calibration's training scenes. This script samples the fit statistics of the pose the
pipeline would choose, and whether it came out within 2 mm and 1°
(:func:`unseeable.training.fit.pose_sample`), on the cached training families
``train``, ``train-looks``, ``train-walls`` and ``train-wide``; fits the model on the
first three alone (A) and with ``train-wide`` added (B); and judges every family of
``--families`` under the shipped model, A and B: poses refused (of them right) and
wrong poses accepted.

Usage::

    python benchmarks/pose_quality.py --out DIR [--families validation held-out-looks …]
        [--scenes 40] [--workers 2]

Samples are kept in ``DIR`` (``samples.json``), so a rerun only adds what is missing.
"""

from __future__ import annotations

import argparse
import json
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

#: Training families (cached scenes) and how many of each.
TRAINING = {"train": 63, "train-looks": 62, "train-walls": 62, "train-wide": 186}
DEFAULT_FAMILIES = ("validation", "seamed-tables-dev", "defocus-dev", "held-out-looks",
                    "held-out-looks-2", "held-out-looks-3")


def _spec(family: str):
    from unseeable.training import TRAIN, TRAIN_LOOKS, TRAIN_WALLS
    from unseeable.training.scenes import TRAIN_WIDE
    from vision import FAMILIES

    specs = {s.name: s for s in (TRAIN, TRAIN_LOOKS, TRAIN_WALLS, TRAIN_WIDE)}
    return specs.get(family) or FAMILIES[family]


def sample(task: tuple[str, int]) -> tuple[str, int, list[float] | None, bool]:
    """(family, scene, fit statistics or None when no pose could be fitted, right)."""
    from unseeable.errors import VisionError
    from unseeable.training.fit import pose_sample
    from unseeable.training.scenes import make_scene
    from unseeable.vision.calibration import default_calibration

    family, n = task
    scene = make_scene(_spec(family), n)
    try:
        stats, right = pose_sample(scene, calibration=default_calibration())
    except VisionError:
        return family, n, None, False
    return family, n, [float(x) for x in stats], bool(right)


def main(argv: list[str] | None = None) -> int:
    from unseeable.vision.calibration import default_calibration
    from unseeable.vision.calibration_fit import fit_pose_quality

    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--out", type=Path, required=True, help="folder for the samples")
    parser.add_argument("--families", nargs="*", default=list(DEFAULT_FAMILIES))
    parser.add_argument("--scenes", type=int, default=40, help="scenes per judged family")
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "samples.json"
    records = [tuple(r) for r in json.loads(path.read_text())] if path.exists() else []
    done = {(r[0], r[1]) for r in records}
    tasks = [(f, n) for f, count in TRAINING.items() for n in range(count)]
    tasks += [(f, n) for f in args.families for n in range(args.scenes)]
    todo = [t for t in tasks if t not in done]
    with ProcessPoolExecutor(args.workers) as pool:
        for n, record in enumerate(pool.map(sample, todo, chunksize=2)):
            records.append(record)
            if n % 20 == 19:
                path.write_text(json.dumps(records))
                print(f"{len(records)} of {len(tasks)} poses sampled", flush=True)
    path.write_text(json.dumps(records))

    def arrays(families):
        rows = [r for r in records if r[0] in families and r[2] is not None]
        return np.array([r[2] for r in rows]), np.array([r[3] for r in rows], bool)

    base = [f for f in TRAINING if f != "train-wide"]
    models = {"shipped": default_calibration().pose_quality,
              "A": fit_pose_quality(*arrays(base)),
              "B (+ train-wide)": fit_pose_quality(*arrays(list(TRAINING)))}
    print("refused (of them right) / wrong poses accepted, quality threshold 0.5")
    for family in [*TRAINING, *args.families]:
        x, right = arrays([family])
        line = f"{family:18s} right {int(right.sum())}/{len(right)}"
        for name, model in models.items():
            kept = model.probability(x) >= 0.5
            line += (f" | {name}: {int((~kept).sum())} ({int((~kept & right).sum())}) / "
                     f"{int((kept & ~right).sum())}")
        print(line)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
