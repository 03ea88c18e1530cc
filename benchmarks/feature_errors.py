"""Where a corpus's errors come from, feature kind by feature kind.

For every view of a corpus (``unseeable corpus build``), the pipeline
estimates the structure at the view's recorded pose with automatic
visibility (as ``unseeable experiment visibility --known-pose`` does). On the
features visible in the truth it counts, per feature kind (ends ``E-``/``E+``,
short segments ``u``/``v``, long segment ``w``):

* the detectors' calls (the priors the estimate was made under: shifted to agree
  with it, ``estimate_view``'s ``presence_shift``) — judged, wrong, false
  positives (p > ½, absent) and false negatives (p ≤ ½, present);
* the estimate's values — how many it gets wrong (against the truth), for
  comparison: an estimate wrong on more of a kind than the detectors were is
  led there by other kinds' evidence through the grammar.

With ``--by-design`` the same per design. A detector change meant to lower
the errors of issue 5 should lower the wrong calls where the estimate goes
wrong; this prints both.

Usage::

    python benchmarks/feature_errors.py --corpus DIR [--only tower-3,crib] [--by-design]
"""

from __future__ import annotations

import argparse
import collections
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.progress import track
from rich.table import Table

from unseeable.domain.features import FeatureKind, feature_index, feature_values
from unseeable.evaluate.metric import count_errors
from unseeable.pipeline import estimate_view
from unseeable.render.view import load_truth, load_view
from unseeable.vision import load_calibration

COUNTS = ("judged", "wrong", "fp", "fn", "estimate_wrong")


def view_counts(view_file: Path, truth_file: Path, calibration=None
                ) -> tuple[int, dict[tuple[str, str], int]]:
    """The estimate's errors and ``{(kind label, count name): n}`` for one corpus view
    (``calibration``: the detectors', default the shipped one)."""
    view = load_view(view_file)
    truth = load_truth(truth_file)
    estimate = estimate_view(view, use_view_pose=True, calibration=calibration)
    shown = truth.shown
    extent = shown.extent
    idx = feature_index(extent)
    present = feature_values(extent, shown.occupancy) > 0
    estimated = feature_values(extent, estimate.structure.occupancy) > 0
    visible = np.asarray(truth.visible, bool)
    p = np.asarray(estimate.priors, float)
    judged = visible & (p != 0.5)
    says = p > 0.5
    out: dict[tuple[str, str], int] = {}
    for kind in FeatureKind:
        of_kind = idx.kind == kind
        j = judged & of_kind
        v = visible & of_kind
        out[(kind.label, "judged")] = int(j.sum())
        out[(kind.label, "wrong")] = int((says != present)[j].sum())
        out[(kind.label, "fp")] = int((says & ~present)[j].sum())
        out[(kind.label, "fn")] = int((~says & present)[j].sum())
        out[(kind.label, "estimate_wrong")] = int((estimated != present)[v].sum())
    errors = count_errors(shown, estimate.structure, truth_pose=truth.pose,
                          estimate_pose=estimate.pose)
    return errors, out


def _table(title: str, counts: dict[tuple[str, str], int]) -> Table:
    table = Table(title=title)
    table.add_column("kind")
    for name in ("judged visible", "detector right", "false positives", "false negatives",
                 "estimate wrong (visible)"):
        table.add_column(name, justify="right")
    for kind in FeatureKind:
        c = {name: counts.get((kind.label, name), 0) for name in COUNTS}
        right = f"{100 * (1.0 - c['wrong'] / c['judged']):.1f} %" if c["judged"] else "–"
        table.add_row(kind.label, str(c["judged"]), right, str(c["fp"]),
                      str(c["fn"]), str(c["estimate_wrong"]))
    return table


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--corpus", type=Path, required=True, help="corpus folder")
    parser.add_argument("--only", default="", help="comma-separated design names")
    parser.add_argument("--by-design", action="store_true", help="a table per design too")
    parser.add_argument("--calibration", type=Path, default=None,
                        help="detector calibration file (default: the shipped one)")
    args = parser.parse_args(argv)
    calibration = load_calibration(args.calibration) if args.calibration else None
    only = {n for n in args.only.split(",") if n}
    files = sorted((f for f in args.corpus.glob("*/view*.truth.json")
                    if not only or f.parent.name in only),
                   key=lambda f: (f.parent.name, float(f.name[4:].split(".truth")[0])))
    if not files:
        parser.error(f"no view*.truth.json files under {args.corpus}"
                     + (f" for {sorted(only)}" if only else ""))
    total: collections.Counter = collections.Counter()
    per_design: dict[str, collections.Counter] = collections.defaultdict(collections.Counter)
    errors: dict[str, list[int]] = collections.defaultdict(list)
    for f in track(files, description="estimating"):
        n_err, counts = view_counts(f.with_name(f.name.replace(".truth.json", ".json")), f,
                                    calibration)
        total.update(counts)
        per_design[f.parent.name].update(counts)
        errors[f.parent.name].append(n_err)
    console = Console()
    if args.by_design:
        for name in sorted(per_design):
            console.print(_table(f"{name}: errors per view {errors[name]}", per_design[name]))
    all_errors = np.concatenate([np.asarray(e) for e in errors.values()])
    console.print(_table(f"{len(files)} views, known pose, automatic visibility: mean errors "
                         f"{all_errors.mean():.2f}, {100 * np.mean(all_errors <= 12):.1f} % "
                         "within 12", total))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
