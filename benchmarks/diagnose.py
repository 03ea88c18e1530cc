"""Where a corpus's errors come from: per-view diagnostics of the estimator, one tool.

Every subcommand measures the views of a rendered corpus (``unseeable corpus
build``; ``--only`` designs, ``--every`` n-th view, ``--workers`` processes),
``census`` and ``oracle`` also the scenes of a rendered family (``--family F
--scenes N``: ``benchmarks/vision.py``'s held-out families or a training
family). The pose is the view's recorded one (polished on the image, as the
estimator does), visibility automatic, as ``unseeable experiment visibility
--known-pose`` runs it.

``oracle``
    Errors with perfect detectors on the features visible in the truth (p =
    0.95 present, 0.05 absent; ½ elsewhere), the MAP with the estimator's tie
    policy (``--ties`` for another): what no detector can remove from one view
    (hidden logs, and which member of a tie of hidden completions is kept).
``census``
    What kind of errors the estimate makes (``split``: the same notches in other
    logs; ``extra``; ``missing``; ``mixed``), against what perfect detectors
    leave, and the features it gets wrong by how the estimator saw them (hidden
    in both, seen in one only, a wrong call, outvoted), by feature kind.
``features``
    Per feature kind (ends ``E-``/``E+``, short segments ``u``/``v``, long ``w``),
    on the features visible in the truth: the detectors' calls the estimate was
    made under (judged, right, false positives and negatives) and how many the
    estimate gets wrong; ``--by-design`` per design too.
``blame``
    For given views (``NAME@ANGLE``), which wrong calls cost the errors: each
    wrong call on a visible feature set to the truth alone and all together, and
    whether the detections prefer the estimate or the truth (their
    log-probabilities as each implies itself): the evidence or the search.
``trust``
    Detector priors tempered in log-odds, ``p' = σ(τ · logit p)``, with the
    ground-truth visibility: would trusting the detectors less (τ < 1) or more
    help?
``better-detectors``
    Each wrong call on a visible feature put right (its prior mirrored, p → 1 − p)
    with probability ``R``, the same features at every step of the estimate's
    fixpoint: how much better the detectors must be for a given error goal.

Usage::

    python benchmarks/diagnose.py oracle --corpus C [--only lodge,hall] [--ties emptiest]
    python benchmarks/diagnose.py oracle --family validation-halls --scenes 60
    python benchmarks/diagnose.py census --corpus C [--only cabin-door] [--records F]
    python benchmarks/diagnose.py census --family validation-halls --scenes 60
    python benchmarks/diagnose.py features --corpus C [--by-design] [--calibration F]
    python benchmarks/diagnose.py blame --corpus C lodge@120 lodge@210
    python benchmarks/diagnose.py trust --corpus C --temperatures 0.5,0.7,1,1.4
    python benchmarks/diagnose.py better-detectors --corpus C --rates 0,0.3,0.6
"""

from __future__ import annotations

import argparse
import collections
import sys
import zlib
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from corpus_views import (  # noqa: E402  (the benchmarks' shared views and estimator adapter)
    ViewSource,
    add_view_arguments,
    fixpoint_on_detection,
    map_views,
    run_pipeline,
    views_from_args,
)

from unseeable.domain import Evidence, LogGeometry  # noqa: E402
from unseeable.domain.features import FeatureKind, feature_index, feature_values  # noqa: E402
from unseeable.evaluate.metric import (  # noqa: E402
    ERROR_KINDS,
    compare_structures,
    count_errors,
)
from unseeable.grammar import log_probability  # noqa: E402
from unseeable.grammar.priors import TIE_POLICY, StructurePrior  # noqa: E402
from unseeable.solve import TIES, StructureSolver  # noqa: E402

# ---- perfect detectors ------------------------------------------------------------------


def oracle_estimate(structure, visible, present, accuracy: float, ties: str):
    """The MAP estimate under perfect detections on the visible features."""
    extent = structure.extent
    p = np.where(visible, np.where(present, accuracy, 1 - accuracy), 0.5)
    # A fresh solver per view, as the estimator makes: which member of a tie a search
    # keeps depends on what the solver solved before.
    return StructureSolver(extent, ties=ties).solve(Evidence(extent, p), time_limit=60).structure


def oracle_errors(structure, visible, present, accuracy: float, ties: str) -> int:
    """Errors of the MAP estimate under perfect detections on the visible features."""
    return count_errors(structure, oracle_estimate(structure, visible, present, accuracy, ties))


def oracle_record(task: tuple[ViewSource, float, str]) -> int:
    source, accuracy, ties = task
    tv = source.load()
    return oracle_errors(tv.truth, tv.visible, tv.present, accuracy, ties)


def oracle_main(args, parser) -> int:
    views = views_from_args(parser, args)
    errors = np.array(map_views(oracle_record, [(v, args.accuracy, args.ties) for v in views],
                                workers=args.workers, description="solving"))
    if args.family is not None:
        print(f"Perfect detectors on visible features, {len(views)} scenes of {args.family}, "
              f"ties: {args.ties}")
        print(f"mean {errors.mean():.2f}, sum {errors.sum()}, max {errors.max()}, "
              f"share <= 12: {np.mean(errors <= 12):.3f}, exact: {np.mean(errors == 0):.3f}")
        return 0
    by_design: dict[str, list[str]] = collections.defaultdict(list)
    for v, e in zip(views, errors):
        by_design[v.group].append(f"{v.angle:g}°: {e}")
    print(f"Perfect detectors on visible features, {len(errors)} views of {len(by_design)} "
          f"designs, ties: {args.ties}")
    print(f"{'design':24s} errors per view (station angle: errors)")
    for name, v in by_design.items():
        print(f"{name:24s} {', '.join(v)}")
    print(f"mean {errors.mean():.2f}, max {errors.max()}, "
          f"share <= 12: {np.mean(errors <= 12):.3f}, exact: {np.mean(errors == 0):.3f}")
    return 0


# ---- census -----------------------------------------------------------------------------

#: How the estimator saw a feature whose value differs between truth and estimate.
SEEN = ("hidden in both", "seen in the truth only", "seen in the estimate only",
        "seen, call on the estimate's side", "seen, call on the truth's side",
        "seen, no reading (½)")


def _feature_group(kind: np.ndarray) -> np.ndarray:
    labels = {k.value: ("end" if k.label.startswith("end") else k.label) for k in FeatureKind}
    return np.array([labels[int(k)] for k in kind], dtype=object)


def differing_features(truth_present: np.ndarray, truth_visible: np.ndarray,
                       estimate_present: np.ndarray, estimate_visible: np.ndarray,
                       priors: np.ndarray) -> np.ndarray:
    """For each feature, the index into :data:`SEEN` of how it was seen, -1 where
    truth and estimate agree on its value.

    Examples
    --------
    >>> t = np.array([True, True, False, True])
    >>> e = np.array([True, False, True, False])
    >>> differing_features(t, np.array([1, 1, 1, 0], bool), e, np.array([1, 1, 1, 0], bool),
    ...                    np.array([0.9, 0.2, 0.3, 0.5])).tolist()
    [-1, 3, 4, 0]
    """
    seen_t, seen_e = truth_visible, estimate_visible
    call_estimate = (priors > 0.5) == estimate_present
    how = np.select(
        [~seen_t & ~seen_e, seen_t & ~seen_e, ~seen_t & seen_e, priors == 0.5, call_estimate],
        [0, 1, 2, 5, 3], default=4)
    return np.where(truth_present != estimate_present, how, -1)


def census_record(source: ViewSource) -> dict:
    """One view: errors by kind of the estimator and of perfect detectors, and how the
    estimator saw the features it got wrong."""
    tv = source.load()
    truth, visible = tv.truth, tv.visible
    extent = truth.extent
    est = run_pipeline(tv.view)
    present = feature_values(extent, truth.occupancy) > 0
    oracle = oracle_estimate(truth, visible, present, 0.95, TIE_POLICY)
    how = differing_features(present, visible,
                             feature_values(extent, est.structure.occupancy) > 0,
                             est.visible, est.priors)
    group = _feature_group(feature_index(extent).kind)
    seen = collections.Counter(f"{SEEN[h]}|{g}" for h, g in zip(how, group) if h >= 0)
    return {"view": source.label, "logs": len(truth.logs),
            "pipeline": compare_structures(truth, est.structure).errors_by_kind(),
            "perfect": compare_structures(truth, oracle).errors_by_kind(),
            "features": dict(seen)}


def census_summary(records: list[dict]) -> list[str]:
    """The census's tables as lines of text."""
    total = {side: {k: sum(r[side][k] for r in records) for k in ERROR_KINDS}
             for side in ("pipeline", "perfect")}
    n = len(records)
    lines = [f"{n} views, pose known; errors summed (per view)",
             f"{'kind':10s} {'pipeline':>16s} {'perfect detectors':>18s} {'difference':>12s}"]
    for k in (*ERROR_KINDS, "all"):
        a = sum(total["pipeline"].values()) if k == "all" else total["pipeline"][k]
        b = sum(total["perfect"].values()) if k == "all" else total["perfect"][k]
        lines.append(f"{k:10s} {a:8d} ({a / n:5.2f}) {b:10d} ({b / n:5.2f}) {a - b:+12d}")
    groups = ("end", "u", "v", "w")
    seen = collections.Counter()
    for r in records:
        seen.update(r["features"])
    lines += ["", "features whose value the estimate gets wrong, by how the pipeline saw them",
              f"{'':36s}" + "".join(f"{g:>7s}" for g in groups)]
    for how in SEEN:
        lines.append(f"{how:36s}" + "".join(f"{seen[f'{how}|{g}']:7d}" for g in groups))
    return lines


def census_main(args, parser) -> int:
    from unseeable.fileio import write_json

    records = map_views(census_record, views_from_args(parser, args), workers=args.workers)
    print("\n".join(census_summary(records)))
    if args.records is not None:
        write_json(args.records, records)
    return 0


# ---- features ---------------------------------------------------------------------------

COUNTS = ("judged", "wrong", "fp", "fn", "estimate_wrong")


def feature_record(task: tuple[ViewSource, Path | None]
                   ) -> tuple[int, dict[tuple[str, str], int]]:
    """The estimate's errors and ``{(kind label, count name): n}`` for one view
    (with the detectors' calibration from a file, default the shipped one)."""
    from unseeable.vision import load_calibration

    source, calibration_file = task
    tv = source.load()
    calibration = load_calibration(calibration_file) if calibration_file else None
    estimate = run_pipeline(tv.view, calibration=calibration)
    shown = tv.truth
    extent = shown.extent
    idx = feature_index(extent)
    present = feature_values(extent, shown.occupancy) > 0
    estimated = feature_values(extent, estimate.structure.occupancy) > 0
    visible = tv.visible
    p = estimate.priors
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
    errors = count_errors(shown, estimate.structure, truth_pose=tv.pose,
                          estimate_pose=estimate.pose)
    return errors, out


def _feature_table(title: str, counts: dict[tuple[str, str], int]):
    from rich.table import Table

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


def features_main(args, parser) -> int:
    from rich.console import Console

    if args.calibration is not None and not args.calibration.is_file():
        parser.error(f"--calibration: no such file {args.calibration}")
    views = views_from_args(parser, args)
    rows = map_views(feature_record, [(v, args.calibration) for v in views],
                     workers=args.workers)
    total: collections.Counter = collections.Counter()
    per_design: dict[str, collections.Counter] = collections.defaultdict(collections.Counter)
    errors: dict[str, list[int]] = collections.defaultdict(list)
    for v, (n_err, counts) in zip(views, rows):
        total.update(counts)
        per_design[v.group].update(counts)
        errors[v.group].append(n_err)
    console = Console()
    if args.by_design:
        for name in sorted(per_design):
            console.print(_feature_table(f"{name}: errors per view {errors[name]}",
                                         per_design[name]))
    all_errors = np.concatenate([np.asarray(e) for e in errors.values()])
    console.print(_feature_table(
        f"{len(views)} views, known pose, automatic visibility: mean errors "
        f"{all_errors.mean():.2f}, {100 * np.mean(all_errors <= 12):.1f} % within 12", total))
    return 0


# ---- blame ------------------------------------------------------------------------------

def blame_record(task: tuple[ViewSource, float]) -> dict:
    """The estimator's errors on one view and what correcting each wrong call does."""
    from unseeable.visibility.loop import DEFAULT_THRESHOLD

    source, margin = task
    tv = source.load()
    view = tv.view
    estimate = run_pipeline(view)
    shown = tv.truth
    extent = shown.extent
    p = estimate.priors
    present = feature_values(extent, shown.occupancy).astype(bool)
    visible = tv.visible
    index = feature_index(extent)
    # The estimator's structure prior, on the joints the estimate's final visibility sees.
    prior_of = StructurePrior().given_visibility(extent)
    prior = prior_of(estimate.visible) if prior_of else ()

    def errors(priors: np.ndarray) -> int:
        # A fresh solver each time, as the estimator makes one per view: which member of a
        # hidden tie a search keeps can depend on what the solver solved before.
        result = StructureSolver(extent, ties=TIE_POLICY).solve(
            [Evidence(extent, priors), *prior], time_limit=60)
        return count_errors(shown, result.structure)

    right = np.where(present, 0.95, 0.05)
    wrong = np.flatnonzero(visible & ((p > 0.5) != present) & (np.abs(p - 0.5) > margin))
    base = errors(p)
    single = []
    for f in wrong:
        q = p.copy()
        q[f] = right[f]
        change = errors(q) - base
        if change:
            single.append((change, f))
    single.sort()

    def corrected(features: list[int] | np.ndarray, value: np.ndarray | float) -> int:
        q = p.copy()
        q[features] = value if np.isscalar(value) else value[features]
        return errors(q)

    costly = [f for change, f in single if change < 0]
    # The estimator's own detections, to score any structure under the visibility and
    # context it implies itself.
    seen_as = estimate.view_evidence(view)
    geometry = LogGeometry()

    def self_consistent(s) -> float:
        value = seen_as.log_probability_of(s, shift=estimate.presence_shift)
        if prior_of:
            value += log_probability(prior_of(seen_as.visibility(
                s, geometry=geometry, threshold=DEFAULT_THRESHOLD)), s)
        return value

    return {
        "view": source.label,
        "self_consistent": {"estimate": self_consistent(estimate.structure),
                            "truth": self_consistent(shown)},
        "pipeline": count_errors(shown, estimate.structure),
        "resolved": base,
        "wrong_calls": len(wrong),
        "single": [(change, FeatureKind(index.kind[f]).label, tuple(int(x) for x in index.at[f]),
                    bool(present[f]), float(p[f])) for change, f in single],
        "all_corrected": corrected(wrong, right),
        "costly_corrected": corrected(costly, right) if costly else base,
        "costly_abstained": corrected(costly, 0.5) if costly else base,
    }


def blame_main(args, parser) -> int:
    from unseeable.corpus import load_corpus
    from unseeable.errors import InputError

    if args.workers < 1:
        parser.error("--workers must be at least 1")
    corpus = load_corpus(args.corpus)
    sources = []
    for spec in args.views:
        name, sep, angle = spec.partition("@")
        try:
            view = corpus[name].view(float(angle)) if sep else None
        except (InputError, ValueError):
            view = None
        if view is None:
            parser.error(f"{spec}: no such view in {args.corpus} (give NAME@ANGLE of a "
                         "corpus view, e.g. lodge@120)")
        sources.append(ViewSource(spec, name, float(view.angle), view.view, view.truth))
    for r in map_views(blame_record, [(s, args.margin) for s in sources],
                       workers=args.workers):
        name, _, angle = r["view"].partition("@")
        print(f"{name} at {angle}°: {r['pipeline']} errors (re-solved: {r['resolved']}); "
              f"{r['wrong_calls']} wrong calls on visible features")
        for change, kind, at, is_present, prior in r["single"]:
            print(f"  {change:+d}  {kind} {at}  truth {'present' if is_present else 'absent'}, "
                  f"p {prior:.2f}")
        print(f"  all wrong calls corrected: {r['all_corrected']}; those that cost errors "
              f"corrected: {r['costly_corrected']}, left at ½: {r['costly_abstained']}")
        est, tru = r["self_consistent"]["estimate"], r["self_consistent"]["truth"]
        verdict = ("the detections prefer the estimate: its errors are the evidence's"
                   if est >= tru else "the truth is the better account: the fixpoint stopped "
                   "short of it")
        print(f"  log-probability as each implies itself: estimate {est:.2f}, truth {tru:.2f} "
              f"nats; {verdict}")
    return 0


# ---- trust ------------------------------------------------------------------------------

def tempered(p: np.ndarray, temperature: float) -> np.ndarray:
    """``σ(τ · logit p)`` for priors ``p`` in (0, 1).

    Examples
    --------
    >>> np.round(tempered(np.array([0.5, 0.9]), 0.0), 3).tolist()
    [0.5, 0.5]
    """
    p = np.clip(np.asarray(p, float), 1e-6, 1 - 1e-6)
    return 1.0 / (1.0 + np.exp(-temperature * np.log(p / (1 - p))))


def trust_record(task: tuple[ViewSource, tuple[float, ...]]) -> list[int]:
    """One view's errors under each temperature, with the ground-truth visibility."""
    from unseeable.vision import default_calibration, detect_features

    source, temperatures = task
    tv = source.load()
    view = tv.view
    det = detect_features(view.image, view.camera, tv.pose, view.extent,
                          calibration=default_calibration())
    extent = tv.truth.extent
    # One solver for the view's temperatures, a fresh one per view: which member of a tie
    # a search keeps can depend on what the solver solved before.
    solver = StructureSolver(extent, ties=TIE_POLICY)
    seen = tv.visible & det.judged
    out = []
    for t in temperatures:
        evidence = Evidence(extent, np.where(seen, tempered(det.p, t), 0.5))
        result = solver.solve(evidence, time_limit=60)
        out.append(count_errors(tv.truth, result.structure, truth_pose=tv.pose,
                                estimate_pose=det.pose))
    return out


def _numbers(parser, text: str, option: str, *, low: float | None = None,
             high: float | None = None) -> tuple[float, ...]:
    try:
        values = tuple(float(x) for x in text.split(","))
    except ValueError:
        parser.error(f"{option} must be comma-separated numbers, got {text!r}")
    if any((low is not None and v < low) or (high is not None and v > high) for v in values):
        parser.error(f"{option} must be numbers in [{low}, {high}], got {text!r}")
    return values


def trust_main(args, parser) -> int:
    temperatures = _numbers(parser, args.temperatures, "--temperatures", low=0.0)
    views = views_from_args(parser, args)
    rows = np.array(map_views(trust_record, [(v, temperatures) for v in views],
                              workers=args.workers))
    print(f"Tempered detector priors, manual visibility, {len(views)} views")
    print(f"{'tau':>5s} {'mean errors':>12s} {'<= 12':>7s} {'max':>5s}")
    for n, t in enumerate(temperatures):
        e = rows[:, n]
        print(f"{t:5.2f} {e.mean():12.2f} {np.mean(e <= 12):7.3f} {e.max():5d}")
    return 0


# ---- better detectors -------------------------------------------------------------------

def better_record(task: tuple[ViewSource, tuple[float, ...]]) -> list[tuple[int, int, int]]:
    """Per rate: the view's errors, and the right and judged visible calls behind them."""
    source, rates = task
    tv = source.load()
    view, shown = tv.view, tv.truth
    present = feature_values(shown.extent, shown.occupancy) > 0
    visible = tv.visible
    # The same draw for a view at every rate: a higher rate fixes a superset.
    draw = np.random.default_rng(zlib.crc32(source.key.encode())).random(len(present))
    # The estimator's detections at the view's pose (shipped calibration), corrected below.
    detection = run_pipeline(view, confidence=False).detection
    out = []
    for rate in rates:
        fixed = visible & (draw < rate) & detection.judged

        def correct(p: np.ndarray, fixed: np.ndarray = fixed) -> np.ndarray:
            # A wrong call put right: as sure as it was, now on the truth's side.
            return np.where(fixed & ((p > 0.5) != present), 1.0 - p, p)

        est = fixpoint_on_detection(view, detection, correct=correct)
        judged = visible & (est.priors != 0.5)
        right = int(((est.priors > 0.5) == present)[judged].sum())
        errors = count_errors(shown, est.structure, truth_pose=tv.pose, estimate_pose=est.pose)
        out.append((errors, right, int(judged.sum())))
    return out


def better_main(args, parser) -> int:
    rates = _numbers(parser, args.rates, "--rates", low=0.0, high=1.0)
    views = views_from_args(parser, args)
    rows = map_views(better_record, [(v, rates) for v in views], workers=args.workers)
    print(f"{len(views)} views, known pose, automatic visibility")
    print(f"{'R':>5s} {'detectors right':>16s} {'mean errors':>12s} {'<= 12':>7s} {'max':>5s}")
    for n, rate in enumerate(rates):
        errors = np.array([r[n][0] for r in rows])
        right = sum(r[n][1] for r in rows) / max(sum(r[n][2] for r in rows), 1)
        print(f"{rate:5.2f} {100 * right:15.1f}% {errors.mean():12.2f} "
              f"{100 * np.mean(errors <= 12):6.1f}% {errors.max():5d}")
    return 0


# ---- command line -----------------------------------------------------------------------

def _subcommand_help(name: str) -> str:
    """The subcommand's paragraph of this module's docstring."""
    text = __doc__.split(f"``{name}``\n", 1)[1]
    lines = []
    for line in text.splitlines():
        if not line.startswith("    "):
            break
        lines.append(line.strip())
    return " ".join(lines)


_SHORT_HELP = {
    "oracle": "errors with perfect detectors on the visible features",
    "census": "kinds of errors, and how the estimator saw the features it got wrong",
    "features": "the detectors' calls and the estimate's errors per feature kind",
    "blame": "which wrong calls cost given views their errors",
    "trust": "errors with the detector priors tempered in log-odds",
    "better-detectors": "errors if a share of the wrong calls were right",
}


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)

    def add(name: str, main, *, families: bool = False, workers: bool = True):
        p = sub.add_parser(name, help=_SHORT_HELP[name], description=_subcommand_help(name))
        if workers:
            add_view_arguments(p, families=families)
        p.set_defaults(main=main, parser=p)
        return p

    p = add("oracle", oracle_main, families=True)
    p.add_argument("--accuracy", type=float, default=0.95,
                   help="probability given to the true value of a visible feature")
    p.add_argument("--ties", choices=TIES, default=TIE_POLICY,
                   help=f"tie policy (default: the estimator's, {TIE_POLICY})")
    p = add("census", census_main, families=True)
    p.add_argument("--records", type=Path, help="also write every view's record here")
    p = add("features", features_main)
    p.add_argument("--by-design", action="store_true", help="a table per design too")
    p.add_argument("--calibration", type=Path, default=None,
                   help="detector calibration file (default: the shipped one)")
    p = add("blame", blame_main, workers=False)
    p.add_argument("--corpus", type=Path, required=True, help="corpus folder")
    p.add_argument("--workers", type=int, default=2, help="processes")
    p.add_argument("--margin", type=float, default=0.05,
                   help="a call is wrong when on the wrong side of ½ by more than this")
    p.add_argument("views", nargs="+", help="views as NAME@ANGLE, e.g. lodge@120")
    p = add("trust", trust_main)
    p.add_argument("--temperatures", default="0.5,0.7,1,1.4",
                   help="comma-separated log-odds factors τ")
    p = add("better-detectors", better_main)
    p.add_argument("--rates", default="0,0.3,0.6",
                   help="comma-separated shares R of wrong calls put right")
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    return args.main(args, args.parser)


if __name__ == "__main__":
    raise SystemExit(main())
