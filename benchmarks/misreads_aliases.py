"""Prototype: segment readings explained away by a parallel log edge within a detector's reach.

A segment detector searches a few pixels across its stretch for the strongest edge.
Where another log's silhouette runs beside the stretch within that reach
(:func:`unseeable.vision.projection.parallel_edge_pairs`), the detector answers to that
edge when the feature's own edge is absent (``benchmarks/misreads_census.py``). Like
the image-line aliases (:class:`unseeable.visibility.loop.LineAliases`), this
prototype re-weighs a reading under each estimate: a feature the estimate leaves
absent, beside which the estimate puts a visible log edge, reads ``½`` (``--mode
half``) or at most ``½`` (``--mode cap``: a reading of "absent" still counts); or,
whatever the estimate, every reading with such an edge possible beside it has its
log-odds multiplied by ``--factor`` (``--mode shrink``).

The rule is patched into this process's estimator (:meth:`ViewEvidence.priors_under`
and the pipeline's ``line_aliases``), so the measure runs in one process.

Usage::

    python benchmarks/misreads_aliases.py --family validation --scenes 40 [--off]
    python benchmarks/misreads_aliases.py --corpus DIR [--reach 4 --mode cap]
"""

from __future__ import annotations

import argparse
import json
import sys
import weakref
from dataclasses import dataclass
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from unseeable.domain import Structure  # noqa: E402
from unseeable.domain.features import FeatureKind, feature_index  # noqa: E402
from unseeable.domain.grid import EMPTY, SPANS_NEXT  # noqa: E402
from unseeable.visibility.loop import LineAliases, ViewEvidence  # noqa: E402

SETTINGS = {"reach": 4.0, "mode": "half", "angle": 3.0, "factor": 0.5}


def edge_presence(structure: Structure) -> np.ndarray:
    """``(N, 2) bool``: per feature, whether the log at its layer draws its lower edge
    along the feature's stretch (column 0), and whether the log two layers below draws
    the upper edge there (column 1). A segment feature is present when either is."""
    extent = structure.extent
    idx = feature_index(extent)
    occ = np.asarray(structure.occupancy)
    I, J, K = extent.shape
    out = np.zeros((len(idx), 2), dtype=bool)
    seg = np.flatnonzero(idx.kind >= FeatureKind.U)
    i, j, k = idx.at[seg, 0], idx.at[seg, 1], idx.at[seg, 2]
    is_w = idx.kind[seg] == FeatureKind.W
    for col, layer in ((0, j), (1, j - 2)):
        ok = (layer >= 0) & (layer < J)
        z = np.full(len(seg), EMPTY)
        z[ok] = occ[i[ok], layer[ok], k[ok]]
        here = np.where(is_w, SPANS_NEXT[z], z != EMPTY)
        out[seg, col] = here & ok
    return out


@dataclass(frozen=True, eq=False)
class NearAliases(LineAliases):
    """Line aliases plus parallel edges within a detector's reach."""

    near_first: np.ndarray = None
    near_second: np.ndarray = None
    near_upper: np.ndarray = None
    segment_start: int = 0


def feature_index_offset(aliases, n: int) -> int:
    """Index of the first segment feature (the ends come first)."""
    return int(aliases.segment_start)


def shrink_near(priors, aliases: NearAliases, *, factor: float):
    """Log-odds of every feature with any parallel edge within reach times ``factor``
    (whatever the estimate: the structure-free variant)."""
    hit = np.zeros(len(priors), dtype=bool)
    hit[aliases.near_first] = True
    if SETTINGS["mode"] == "shrink-all":  # control: every segment feature
        n = len(priors)
        hit = np.arange(n) >= feature_index_offset(aliases, n)
    p = np.clip(np.asarray(priors, float), 1e-9, 1 - 1e-9)
    z = np.log(p / (1 - p))
    return np.where(hit, 1 / (1 + np.exp(-factor * z)), p)


def explain_near(priors, structure, visible, aliases: NearAliases, *, mode: str):
    """Readings of features absent under ``structure`` beside a visible log edge it puts
    there: ``½`` (mode ``half``) or ``min(p, ½)`` (``cap``)."""
    present = edge_presence(structure)
    feat = present.any(axis=1)
    f, g, up = aliases.near_first, aliases.near_second, aliases.near_upper
    edge = present[g, up.astype(int)]
    held = edge & visible[g] & ~feat[f] & visible[f]
    hit = np.zeros(len(priors), dtype=bool)
    hit[f[held]] = True
    if mode == "half":
        return np.where(hit, 0.5, priors)
    return np.where(hit, np.minimum(priors, 0.5), priors)


_CACHE: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
_ORIGINAL_PRIORS_UNDER = ViewEvidence.priors_under


def _near_line_aliases(det, camera):
    from unseeable.pipeline.evidence_checks import line_aliases
    from unseeable.vision.projection import parallel_edge_pairs

    base = line_aliases(det, camera)
    kept = _CACHE.get(base)
    if kept is not None:
        return kept
    f, g, up = parallel_edge_pairs(det.scores.projection, det.judged,
                                   reach_px=SETTINGS["reach"], angle_deg=SETTINGS["angle"])
    out = NearAliases(base.first, base.second, base.distance, f, g, up,
                      int(np.argmax(~det.scores.projection.is_end)))
    _CACHE[base] = out
    return out


def _priors_under(self, structure, *, geometry, threshold=None, visible=None):
    kwargs = {"geometry": geometry, "visible": visible}
    if threshold is not None:
        kwargs["threshold"] = threshold
    p = _ORIGINAL_PRIORS_UNDER(self, structure, **kwargs)
    aliases = self.line_aliases
    if not isinstance(aliases, NearAliases) or not len(aliases.near_first):
        return p
    if SETTINGS["mode"] in ("shrink", "shrink-all"):
        if self.context_priors is None:
            return p  # the start priors were shrunk already
        return shrink_near(p, aliases, factor=SETTINGS["factor"])
    if visible is None:
        visible = self.visibility(structure, geometry=geometry,
                                  **({"threshold": threshold} if threshold is not None
                                     else {}))
    seen = self._seen(structure)
    return explain_near(p, seen, np.asarray(visible, bool) & self.judged, aliases,
                        mode=SETTINGS["mode"])


_ORIGINAL_POST_INIT = ViewEvidence.__post_init__


def _post_init(self) -> None:
    _ORIGINAL_POST_INIT(self)
    aliases = self.line_aliases
    if (SETTINGS["mode"] in ("shrink", "shrink-all") and isinstance(aliases, NearAliases)
            and len(aliases.near_first)):
        object.__setattr__(self, "priors",
                           shrink_near(self.priors, aliases, factor=SETTINGS["factor"]))


def install() -> None:
    """Patch the rule into this process's estimator."""
    import unseeable.pipeline.posing as posing

    posing.line_aliases = _near_line_aliases
    ViewEvidence.priors_under = _priors_under
    ViewEvidence.__post_init__ = _post_init


def measure(task):
    """Errors and the δ* test of one view estimated as ``unseeable experiment`` does."""
    from corpus_views import run_pipeline

    from unseeable.errors import UnseeableError
    from unseeable.evaluate.metric import count_errors

    source = task
    tv = source.load()
    try:
        est = run_pipeline(tv.view, known_pose=True)
    except UnseeableError as err:
        return {"view": source.label, "failed": str(err)}
    errors = count_errors(tv.truth, est.structure, truth_pose=tv.pose,
                          estimate_pose=est.pose, on_misaligned="count")
    return {"view": source.label, "failed": None, "errors": int(errors),
            "confident": bool(est.confident)}


def main(argv=None) -> int:
    from corpus_views import add_view_arguments, map_views, views_from_args

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_view_arguments(parser, families=True, workers=1)
    parser.add_argument("--off", action="store_true", help="the shipped estimator (baseline)")
    parser.add_argument("--reach", type=float, default=SETTINGS["reach"], help="px")
    parser.add_argument("--angle", type=float, default=SETTINGS["angle"], help="degrees")
    parser.add_argument("--mode", choices=("half", "cap", "shrink", "shrink-all"),
                        default=SETTINGS["mode"])
    parser.add_argument("--factor", type=float, default=SETTINGS["factor"],
                        help="log-odds factor of --mode shrink")
    parser.add_argument("--out", type=Path, help="JSON records")
    args = parser.parse_args(argv)
    if args.workers != 1:
        parser.error("the patched rule runs in this process only: --workers 1")
    SETTINGS.update(reach=args.reach, mode=args.mode, angle=args.angle, factor=args.factor)
    if not args.off:
        install()
    views = views_from_args(parser, args)
    recs = map_views(measure, views, workers=1)
    ok = [r for r in recs if r["failed"] is None]
    e = np.array([r["errors"] for r in ok])
    conf = np.array([r["confident"] for r in ok])
    label = "shipped" if args.off else f"near edges (reach {args.reach} px, {args.mode}" + (
        f" {args.factor})" if args.mode.startswith("shrink") else ")")
    print(f"{label}: {len(ok)}/{len(recs)} views, mean {e.mean():.3f} errors, "
          f"exact {np.mean(e == 0):.1%}, δ* FP {int(np.sum(conf & (e > 0)))} "
          f"(errors {int(e[conf & (e > 0)].sum())}) / FN {int(np.sum(~conf & (e == 0)))}")
    if args.out:
        args.out.write_text(json.dumps(recs, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
