"""Learned patch classifiers against the shipped detectors, on looks held out from training.

Three commands:

``train``
    Gather the rectified patches (:mod:`unseeable.vision.patches`) of the
    visible features of rendered training scenes (families and numbers as
    ``NAME:START:COUNT``; renders cached), train one small CNN per detector
    group with numpy (:mod:`unseeable.training.patch_classifier`) and write
    them to an ``.npz``; prints the samples, each group's training time and
    the file's size. ``--patches F`` keeps the gathered patches, so that
    another training of the same scenes skips the gathering.
``evaluate``
    On scenes of ``benchmarks/vision.py``'s families (and a rendered corpus
    with ``--corpus``), pose known (the scene's placement polished on the
    image, as ``detect_features`` polishes it), on the features visible in
    the truth that both judge: ROC AUC and accuracy at p = 0.5 per detector
    group and overall, of the shipped detectors + calibration, of the CNN
    (its logit's sign), and of the two averaged in logit; and the time per
    image of cutting the patches and running the CNNs (numpy).
``trainer-speed``
    Seconds per epoch of the numpy trainer and, when PyTorch can be imported,
    of the same network and optimiser in PyTorch, both on one thread, on
    random patches: the measurement behind the trainer's choice.

Never train on a ``held-out-looks*`` family or on the corpus.

Usage::

    nice -n 10 python benchmarks/patch_classifier.py train --out nets.npz \\
        --scenes train-wide:0:300 train:0:50 train-looks:0:50 train-walls:0:50
    nice -n 10 python benchmarks/patch_classifier.py evaluate --nets nets.npz \\
        --family validation held-out-looks held-out-looks-2 --scenes 40 --corpus DIR
    python benchmarks/patch_classifier.py trainer-speed
"""

from __future__ import annotations

import argparse
import logging
import os
import time
from pathlib import Path

import numpy as np

from unseeable.training.patch_classifier import (
    GROUPS,
    PatchSamples,
    TrainSettings,
    gather_patches,
    train_network,
    train_networks,
)
from unseeable.training.scenes import make_scene, scene_spec
from unseeable.vision import default_calibration, detect_features
from unseeable.vision.detectors import feature_kind_groups
from unseeable.vision.patches import (
    feature_patches,
    load_patch_networks,
    patch_logits,
    save_patch_networks,
)
from vision import FAMILIES, roc_auc


def _jobs(items: list[str]) -> list:
    jobs = []
    for item in items:
        name, start, count = item.split(":")
        if name.startswith("held-out") or name not in {"train", "train-walls", "train-tall",
                                                       "train-looks", "train-halls",
                                                       "train-wide"}:
            raise SystemExit(f"{name}: not a training family")
        jobs += [(scene_spec(name), n) for n in range(int(start), int(start) + int(count))]
    return jobs


def cmd_train(args: argparse.Namespace) -> None:
    if args.patches and args.patches.is_file():
        data = np.load(args.patches)
        samples = {g: PatchSamples(data[f"{g}.x"], data[f"{g}.y"], data[f"{g}.scene"])
                   for g in GROUPS}
        print(f"patches read from {args.patches}")
    else:
        jobs = _jobs(args.scenes)
        t0 = time.perf_counter()
        samples = gather_patches(jobs, channels=args.channels)
        print(f"gathered {len(jobs)} scenes in {time.perf_counter() - t0:.0f} s")
        if args.patches:
            np.savez(args.patches, **{f"{g}.{k}": getattr(s, k) for g, s in samples.items()
                                      for k in ("x", "y", "scene")})
    settings = TrainSettings(conv=tuple(args.conv), hidden=args.hidden, epochs=args.epochs,
                             seed=args.seed)
    # The last tenth of the scenes is kept out of training, to report how well each
    # network fits scenes of its own looks that it did not see.
    kept, held = {}, {}
    for g, s in samples.items():
        cut = np.quantile(s.scene, 0.9) if args.check else np.inf
        tr = s.scene < cut
        kept[g] = PatchSamples(s.x[tr], s.y[tr], s.scene[tr])
        held[g] = PatchSamples(s.x[~tr], s.y[~tr], s.scene[~tr])
    nets, seconds = train_networks(kept, channels=args.channels, settings=settings)
    save_patch_networks(args.out, nets, info=f"scenes {' '.join(args.scenes)}; {settings}")
    print(f"{'group':6s} {'samples':>8s} {'present':>8s} {'params':>7s} {'train s':>8s}"
          + (f" {'check AUC':>10s} {'acc':>6s}" if args.check else ""))
    for g in GROUPS:
        line = (f"{g:6s} {len(kept[g].y):8d} {kept[g].y.mean():8.3f} "
                f"{nets[g].n_parameters:7d} {seconds[g]:8.1f}")
        if args.check and len(held[g].y):
            z = nets[g].logits(held[g].x)
            line += f" {roc_auc(z, held[g].y):10.3f} {np.mean((z > 0) == held[g].y):6.3f}"
        print(line)
    print(f"total training {sum(seconds.values()):.0f} s; {args.out}: "
          f"{os.path.getsize(args.out)} bytes; load {os.getloadavg()[0]:.2f}")


def _views(family: str, scenes: int, start: int):
    for n in range(start, start + scenes):
        s = make_scene(FAMILIES[family], n)
        yield s.image, s.camera, s.pose, s.extent, s.visible, s.present


def _corpus_views(root: Path):
    from unseeable.corpus import load_corpus

    for item in load_corpus(root):
        for cv in item.views:
            view, truth = cv.load_view(), cv.load_truth()
            yield view.image, view.camera, truth.pose, view.extent, truth.visible, truth.present


def _logit(p: np.ndarray) -> np.ndarray:
    p = np.clip(p, 1e-6, 1 - 1e-6)
    return np.log(p / (1 - p))


def evaluate(views, nets, cal) -> dict:
    """Per-group shipped probabilities, CNN logits, truth and per-image times."""
    out = {g: {"p": [], "z": [], "y": []} for g in GROUPS}
    t_det, t_cut, t_cnn = [], [], []
    for image, camera, pose, extent, visible, present in views:
        t0 = time.perf_counter()
        det = detect_features(image, camera, pose, extent, mask=visible, calibration=cal)
        t_det.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        fp = feature_patches(image, camera, det.pose, extent, mask=visible)
        t_cut.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        z = patch_logits(nets, fp, len(visible))
        t_cnn.append(time.perf_counter() - t0)
        sel = det.judged & visible & np.isfinite(z)
        for g, member in feature_kind_groups(det.scores.kind).items():
            m = member & sel
            out[g]["p"].append(det.p[m])
            out[g]["z"].append(z[m])
            out[g]["y"].append(present[m])
    res = {g: {k: np.concatenate(v) if v else np.zeros(0) for k, v in d.items()}
           for g, d in out.items()}
    res["times"] = {"detect": np.asarray(t_det), "cut": np.asarray(t_cut),
                    "cnn": np.asarray(t_cnn)}
    return res


def print_table(name: str, res: dict) -> None:
    print(f"\n{name}: {len(res['times']['cnn'])} views; per image: detectors (with polish) "
          f"median {np.median(res['times']['detect']):.3f} s, patches median "
          f"{np.median(res['times']['cut']):.3f} s + CNNs median "
          f"{np.median(res['times']['cnn']):.3f} s; load {os.getloadavg()[0]:.2f}")
    print(f"{'group':6s} {'features':>8s} {'present':>8s}   {'shipped AUC':>11s} {'acc':>6s}   "
          f"{'CNN AUC':>8s} {'acc':>6s}   {'mean AUC':>8s} {'acc':>6s}")
    rows = [(g, res[g]) for g in GROUPS]
    rows.append(("all", {k: np.concatenate([res[g][k] for g in GROUPS]) for k in "pzy"}))
    for g, d in rows:
        y = d["y"].astype(bool)
        if not len(y):
            continue
        sp, z = _logit(d["p"]), d["z"]
        mean = 0.5 * (sp + z)
        print(f"{g:6s} {len(y):8d} {y.mean():8.3f}   {roc_auc(sp, y):11.3f} "
              f"{np.mean((sp > 0) == y):6.3f}   {roc_auc(z, y):8.3f} {np.mean((z > 0) == y):6.3f}"
              f"   {roc_auc(mean, y):8.3f} {np.mean((mean > 0) == y):6.3f}")


def _pooled(res: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Shipped logits, CNN logits and truth of every group, concatenated."""
    return (_logit(np.concatenate([res[g]["p"] for g in GROUPS])),
            np.concatenate([res[g]["z"] for g in GROUPS]),
            np.concatenate([res[g]["y"] for g in GROUPS]).astype(bool))


def fit_stack(res: dict, *, steps: int = 50) -> np.ndarray:
    """Weights ``(a, b, c)`` of ``a·logit(p) + b·z + c`` by logistic regression (Newton)."""
    sp, z, y = _pooled(res)
    x = np.stack([sp, z, np.ones_like(z)], axis=1)
    w = np.array([1.0, 0.0, 0.0])
    for _ in range(steps):
        q = 1.0 / (1.0 + np.exp(-(x @ w)))
        grad = x.T @ (q - y) + 1e-3 * w
        hess = (x * (q * (1 - q))[:, None]).T @ x + 1e-3 * np.eye(3)
        w -= np.linalg.solve(hess, grad)
    return w


def cmd_evaluate(args: argparse.Namespace) -> None:
    nets = load_patch_networks(args.nets)
    cal = default_calibration()
    runs = [(f, _views(f, args.scenes, args.start)) for f in args.family]
    if args.corpus:
        runs.append(("corpus", _corpus_views(args.corpus)))
    results = {}
    for name, views in runs:
        res = results[name] = evaluate(views, nets, cal)
        print_table(name, res)
        if args.records:
            args.records.mkdir(parents=True, exist_ok=True)
            np.savez(args.records / f"{name}.npz",
                     **{f"{g}.{k}": res[g][k] for g in GROUPS for k in "pzy"},
                     **{f"time.{k}": v for k, v in res["times"].items()})
    if "validation" in results:
        # The two combined by weights fitted on the validation family (in-sample there).
        w = fit_stack(results["validation"])
        print(f"\nstacked a·logit(p) + b·z + c, fitted on validation: a={w[0]:.3f} "
              f"b={w[1]:.3f} c={w[2]:.3f}")
        print(f"{'family':18s} {'shipped acc':>11s} {'stacked AUC':>11s} {'acc':>6s}")
        for name, res in results.items():
            sp, z, y = _pooled(res)
            s = w[0] * sp + w[1] * z + w[2]
            print(f"{name:18s} {np.mean((sp > 0) == y):11.4f} {roc_auc(s, y):11.4f} "
                  f"{np.mean((s > 0) == y):6.4f}")


def cmd_speed(args: argparse.Namespace) -> None:
    rng = np.random.default_rng(0)
    shape = (1, 32, 12)
    x = (rng.random((args.samples, *shape)) * 100).astype(np.float32)
    y = rng.random(args.samples) < 0.5
    settings = TrainSettings(epochs=1)
    t0 = time.perf_counter()
    train_network(PatchSamples(x, y, np.zeros(len(y), int)), settings=settings,
                  flip_along=True)
    print(f"numpy: {time.perf_counter() - t0:.2f} s per epoch of {args.samples} "
          f"{shape} patches (load {os.getloadavg()[0]:.2f})")
    try:
        import torch
    except ImportError:
        print("PyTorch: not installed")
        return
    from unseeable.vision.patches import normalise_patches

    torch.set_num_threads(1)
    c, h, w = shape
    model = torch.nn.Sequential(
        torch.nn.Conv2d(c, 8, 3, padding=1), torch.nn.ReLU(), torch.nn.MaxPool2d(2),
        torch.nn.Conv2d(8, 16, 3, padding=1), torch.nn.ReLU(), torch.nn.MaxPool2d(2),
        torch.nn.Flatten(), torch.nn.Linear(16 * (h // 4) * (w // 4), 16), torch.nn.ReLU(),
        torch.nn.Linear(16, 1))
    opt = torch.optim.Adam(model.parameters(), lr=2e-3, weight_decay=1e-4)
    loss_fn = torch.nn.BCEWithLogitsLoss()
    t0 = time.perf_counter()
    order = rng.permutation(len(y))
    for s in range(0, len(y), settings.batch):
        idx = order[s:s + settings.batch]
        # the same per-batch look changes as the numpy trainer (numpy, then to tensors)
        xb = torch.from_numpy(normalise_patches(x[idx]))
        yb = torch.from_numpy(y[idx].astype(np.float32))
        opt.zero_grad()
        loss = loss_fn(model(xb)[:, 0], yb)
        loss.backward()
        opt.step()
    print(f"PyTorch {torch.__version__}: {time.perf_counter() - t0:.2f} s per epoch "
          f"(load {os.getloadavg()[0]:.2f})")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    tr = sub.add_parser("train")
    tr.add_argument("--out", type=Path, required=True)
    tr.add_argument("--scenes", nargs="+", default=["train-wide:0:300", "train:0:50",
                                                    "train-looks:0:50", "train-walls:0:50"])
    tr.add_argument("--patches", type=Path, default=None)
    tr.add_argument("--channels", choices=("grey", "lab"), default="grey")
    tr.add_argument("--conv", type=int, nargs="+", default=[8, 16])
    tr.add_argument("--hidden", type=int, default=16)
    tr.add_argument("--epochs", type=int, default=12)
    tr.add_argument("--seed", type=int, default=0)
    tr.add_argument("--check", action="store_true",
                    help="keep the last tenth of the scenes out and report on it")
    ev = sub.add_parser("evaluate")
    ev.add_argument("--nets", type=Path, required=True)
    ev.add_argument("--family", nargs="*", default=["validation", "held-out-looks",
                                                    "held-out-looks-2"],
                    choices=sorted(FAMILIES))
    ev.add_argument("--scenes", type=int, default=40)
    ev.add_argument("--start", type=int, default=0)
    ev.add_argument("--corpus", type=Path, default=None)
    ev.add_argument("--records", type=Path, default=None,
                    help="folder for each family's probabilities, logits and truth (.npz)")
    sp = sub.add_parser("trainer-speed")
    sp.add_argument("--samples", type=int, default=8192)
    args = parser.parse_args(argv)
    # Training reports each epoch's loss; evaluation only warnings.
    logging.basicConfig(level=logging.INFO if args.command == "train" else logging.WARNING,
                        format="%(asctime)s %(message)s")
    {"train": cmd_train, "evaluate": cmd_evaluate, "trainer-speed": cmd_speed}[args.command](args)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
