"""From detector statistics to priors p_f (issue item 3; the paper's "Mapping evidence to priors").

Each detector group (log ends; short segments ``u``/``v``; long segments
``w``) has its own model: a small network (one hidden layer of 32 units: a
logistic regression that can combine its inputs; 12 units with ten times the
weight penalty were 1–4 points less accurate on structures unlike the
training scenes) on the detector's transformed statistics — the
hand-made ones and the rectified profile of the log's band around the
feature, which carries most of what the model learns — fitted on
rendered *training* scenes (random valid structures, poses, lighting,
materials, JPEG compression) using only the features that are visible there,
and clipped to ``[0.02, 0.98]`` so that no single detector can veto a
structure. A fit's models are each five such networks fitted from
different initial weights, their logits averaged (:class:`GroupEnsemble`):
one network fits its training scenes almost perfectly and errs on new ones
in its own way, and the mean of five is right more often on every held-out
set. The shipped models average ten: the five of the default fit and the
five of a fit with 200 big multi-room cabins among its scenes
(:func:`merge_calibrations`; docs/benchmarks.md).

Each group also has a *context* model with two more inputs
(:func:`unseeable.visibility.background_context`): the share of the
feature's camera rays that meet another log behind it, and the share of its
sample points with a log's silhouette right behind its line. Both are
computed under the current estimate in the visibility fixpoint, and so,
when fitting, under the pipeline's own estimate of each training scene
(:func:`unseeable.training.calibrate`): context models told the
truth's background trusted it more than an estimate's deserves. The
detectors judge a place with wood behind it (an empty place inside a cabin,
seen over the near wall against the far one) differently from one in front
of the table, and a far log's edge along a segment's line looks like the
segment. The plain models serve where no structure is known yet
(``unseeable detect``, the first estimate, the pose choice).

The fitted parameters are package data (about 5 MB: the profiles make the
first layers wide)
(``unseeable/data/calibration.json``, format ``unseeable/vision-calibration@1``);
:func:`default_calibration` loads them,
:func:`~unseeable.vision.calibration_fit.fit_calibration` refits them
(``unseeable calibrate``).
"""

from __future__ import annotations

import functools
import logging
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from unseeable.errors import InputError, VisionError
from unseeable.fileio import check_format, read_json, require, write_json
from unseeable.vision.detectors import (
    END_PROFILE_STATS,
    END_STATS,
    SEGMENT_PROFILE_STATS,
    SEGMENT_STATS,
    FeatureScores,
    feature_kind_groups,
)

__all__ = [
    "CALIBRATION_FORMAT",
    "GROUPS",
    "CONTEXT_INPUTS",
    "NetworkKey",
    "GroupModel",
    "GroupEnsemble",
    "ScoreModel",
    "PoseQualityModel",
    "POSE_QUALITY_STATS",
    "Calibration",
    "group_features",
    "sigmoid",
    "default_calibration",
    "load_calibration",
    "save_calibration",
    "calibration_from_json",
    "merge_calibrations",
    "training_parts",
]


logger = logging.getLogger(__name__)

CALIBRATION_FORMAT = "unseeable/vision-calibration@1"
#: Detector groups calibrated separately.
GROUPS = ("end", "short", "long")
#: One network of a fit: ((group, "" or "context_"), seed).
NetworkKey = tuple[tuple[str, str], int]
#: Inputs the context models take besides the detector statistics (the columns of
#: :func:`unseeable.visibility.background_context`). Calibrations fitted before the
#: second existed have the first alone.
CONTEXT_INPUTS = ("behind", "behind_edges")

# How each statistic enters the model: "log" = log(value + offset), "lin" = as is.
_TRANSFORMS: dict[str, dict[str, tuple[str, float]]] = {
    "end": {"strength": ("log", 0.02), "coverage": ("lin", 0.0), "outer": ("log", 0.02),
            "inner": ("log", 0.02), "flux": ("log", 0.01), "polarity": ("lin", 0.0),
            "minor_px": ("log", 0.5), "band_in": ("log", 0.02), "band_out": ("log", 0.02),
            "wood_disc": ("lin", 0.0), "wood_in": ("lin", 0.0), "wood_out": ("lin", 0.0),
            "shade_in": ("lin", 0.0), "shade_out": ("lin", 0.0),
            "rim_alignment": ("lin", 0.0), "quadrant_min": ("log", 0.02),
            "quadrant_spread": ("lin", 0.0), "radial_peak": ("log", 0.001),
            "axial_peak": ("log", 0.001), "rim_in": ("log", 0.02), "rim_out": ("log", 0.02)},
    "segment": {"strength": ("log", 0.02), "coverage": ("lin", 0.0), "run": ("lin", 0.0),
                "alignment": ("lin", 0.0), "peak": ("log", 0.05), "polarity": ("lin", 0.0),
                "length_px": ("log", 1.0), "upper": ("lin", 0.0),
                "band_here": ("log", 0.02), "band_below": ("log", 0.02),
                "band_max": ("log", 0.02), "wood_here": ("lin", 0.0),
                "wood_below": ("lin", 0.0), "wood_max": ("lin", 0.0),
                "lower_strength": ("log", 0.02), "upper_strength": ("log", 0.02),
                "lower_run": ("lin", 0.0), "upper_run": ("lin", 0.0),
                "lower_alignment": ("lin", 0.0), "upper_alignment": ("lin", 0.0),
                "interior_here": ("log", 0.02), "interior_below": ("log", 0.02)},
}


def _profile_transform(name: str) -> tuple[str, float]:
    """Edge energies and the width in pixels by their logarithm, the rest as they are."""
    if name == "profile_width":
        return ("log", 1.0)
    return ("log", 0.02) if name.startswith(("profile_edge", "profile_trace")) else ("lin", 0.0)


_TRANSFORMS["end"].update({name: _profile_transform(name) for name in END_PROFILE_STATS})
_TRANSFORMS["segment"].update({name: _profile_transform(name) for name in SEGMENT_PROFILE_STATS})


def _stat_names(group: str) -> tuple[str, ...]:
    return END_STATS if group == "end" else SEGMENT_STATS


def _transform_table(group: str) -> dict[str, tuple[str, float]]:
    return _TRANSFORMS["end" if group == "end" else "segment"]


def sigmoid(logit: np.ndarray) -> np.ndarray:
    """Probabilities from log-odds, clipped to ±40 so that exp never overflows."""
    return 1.0 / (1.0 + np.exp(-np.clip(logit, -40.0, 40.0)))


@functools.cache
def _transform_arrays(group: str) -> tuple[np.ndarray, np.ndarray]:
    """Which columns of a group's statistics enter by their logarithm, and the offsets."""
    table = _transform_table(group)
    names = _stat_names(group)
    return (np.array([table[n][0] == "log" for n in names]),
            np.array([table[n][1] for n in names]))


def group_features(group: str, stats: np.ndarray) -> np.ndarray:
    """Model inputs ``(M, F)`` from raw detector statistics ``(M, S)`` of one group."""
    is_log, offset = _transform_arrays(group)
    v = np.nan_to_num(np.asarray(stats, dtype=float), nan=0.0, posinf=0.0, neginf=0.0)
    # The linear columns' logarithm is computed and dropped; offset 1 keeps it finite.
    return np.where(is_log, np.log(np.maximum(v, 0.0) + np.where(is_log, offset, 1.0)), v)


@dataclass(frozen=True)
class GroupModel:
    """Score model of one detector group: a one-hidden-layer network.

    ``p = sigmoid(b2 + w2 · tanh(W1ᵀ x + b1))`` with ``x`` the standardised
    transformed statistics (:func:`group_features`). Its few hidden units
    let it combine statistics the way the features are defined (a segment
    is present when *either* of two logs is there; an end when a log runs
    in from the disc *and* does not run on past it), which a logistic
    regression on the statistics cannot.
    """

    mean: np.ndarray
    scale: np.ndarray
    w1: np.ndarray  # (F, H)
    b1: np.ndarray  # (H,)
    w2: np.ndarray  # (H,)
    b2: float

    def logit(self, features: np.ndarray) -> np.ndarray:
        x = (np.asarray(features, dtype=float) - self.mean) / self.scale
        return np.tanh(x @ self.w1 + self.b1) @ self.w2 + self.b2

    def probability(self, features: np.ndarray) -> np.ndarray:
        """``(M,)`` probabilities from model inputs ``(M, F)``."""
        return sigmoid(self.logit(features))

    def to_json(self) -> dict[str, Any]:
        def r(a):
            return np.round(np.asarray(a, dtype=float), 5).tolist()

        return {"mean": r(self.mean), "scale": r(self.scale), "w1": r(self.w1), "b1": r(self.b1),
                "w2": r(self.w2), "b2": round(float(self.b2), 5)}


@dataclass(frozen=True)
class GroupEnsemble:
    """Several networks of one group, fitted from different initial weights, as one model.

    The logit is the mean of the members' logits. Each network fits its
    training scenes almost perfectly (98–100 %) and generalises a few points
    worse, each in its own way; their mean is right more often than any one
    of them on every held-out set (docs/benchmarks.md).

    Examples
    --------
    >>> import numpy as np
    >>> one = GroupModel(np.zeros(1), np.ones(1), np.ones((1, 1)), np.zeros(1), np.ones(1), 0.0)
    >>> two = GroupModel(np.zeros(1), np.ones(1), np.ones((1, 1)), np.zeros(1), np.ones(1), 2.0)
    >>> GroupEnsemble((one, two)).logit(np.zeros((1, 1))).tolist()
    [1.0]
    """

    members: tuple[GroupModel, ...]

    def __post_init__(self) -> None:
        if not self.members:
            raise InputError("must hold at least one network", field="members",
                             value=self.members)

    @functools.cached_property
    def _stacked(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
        # The members as one wider network: each one's standardisation folded into its
        # first layer, their hidden units side by side, the mean taken by the output
        # weights. One matrix product instead of one per member (5x faster on a
        # photograph's features; the same logits to 1e-13).
        w1 = np.concatenate([m.w1 / m.scale[:, None] for m in self.members], axis=1)
        b1 = np.concatenate([m.b1 - (m.mean / m.scale) @ m.w1 for m in self.members])
        w2 = np.concatenate([m.w2 for m in self.members]) / len(self.members)
        return w1, b1, w2, float(np.mean([m.b2 for m in self.members]))

    def logit(self, features: np.ndarray) -> np.ndarray:
        w1, b1, w2, b2 = self._stacked
        return np.tanh(np.asarray(features, dtype=float) @ w1 + b1) @ w2 + b2

    def probability(self, features: np.ndarray) -> np.ndarray:
        """``(M,)`` probabilities from model inputs ``(M, F)``."""
        return sigmoid(self.logit(features))

    def to_json(self) -> list[dict[str, Any]]:
        return [m.to_json() for m in self.members]


#: A group's score model: one network, or an ensemble of them.
ScoreModel = GroupModel | GroupEnsemble

@dataclass(frozen=True)
class PoseQualityModel:
    """Probability that a fitted pose comes out right, from its fit statistics.

    Right: the structure choice among the fit's candidates ends within 2 mm
    and 1° of the truth (the shipped calibration's model; the built-in
    defaults below describe the edge-best pose alone).

    A logistic regression on :data:`POSE_QUALITY_STATS` (``margin``,
    ``aligned``, ``present``, ``log(1 + score)``), fitted on rendered training
    scenes (:func:`unseeable.training.calibrate`; shipped in the
    calibration file). The defaults were fitted on 120 training scenes.
    """

    mean: tuple[float, ...] = (0.2621, 0.2799, 0.738, 5.1105)
    scale: tuple[float, ...] = (0.2379, 0.0794, 0.1795, 0.6418)
    weights: tuple[float, ...] = (0.8258, 2.0073, -1.111, 1.3178)
    bias: float = 1.381

    def probability(self, stats: np.ndarray) -> np.ndarray:
        """``(..., 4)`` statistics → ``(...)`` probabilities."""
        z = (np.asarray(stats, dtype=float) - np.asarray(self.mean)) / np.asarray(self.scale)
        return 1.0 / (1.0 + np.exp(-(z @ np.asarray(self.weights) + self.bias)))

    def to_json(self) -> dict:
        return {"stats": list(POSE_QUALITY_STATS), "mean": list(self.mean),
                "scale": list(self.scale), "weights": list(self.weights), "bias": self.bias}


#: Fit statistics the pose quality model reads, in order.
POSE_QUALITY_STATS = ("margin", "aligned", "present", "log_score")



@dataclass(frozen=True)
class Calibration:
    """Score → probability maps of every detector group.

    Attributes
    ----------
    models : dict of str to ScoreModel
        Keys from :data:`GROUPS`.
    clip : (float, float)
        Probabilities are clipped to this range.
    info : dict
        How the calibration was fitted (scene count, samples, training accuracy).
    pose_quality : PoseQualityModel, optional
        Fit statistics → probability that an estimated pose is right.
    context_models : dict of str to ScoreModel, optional
        Per group, the model whose inputs also include ``context_inputs``
        (what lies behind each feature); None in calibrations fitted without.
    context_inputs : tuple of str
        The context models' extra inputs: :data:`CONTEXT_INPUTS` or its first name alone.
    """

    models: dict[str, ScoreModel]
    clip: tuple[float, float] = (0.02, 0.98)
    info: dict = field(default_factory=dict)
    pose_quality: PoseQualityModel | None = None
    context_models: dict[str, ScoreModel] | None = None
    context_inputs: tuple[str, ...] = CONTEXT_INPUTS

    @property
    def has_context(self) -> bool:
        """Whether :meth:`probabilities` accepts ``behind``."""
        return self.context_models is not None

    def probabilities(self, scores: FeatureScores, *,
                      behind: np.ndarray | None = None) -> np.ndarray:
        """p_f for every feature; ½ for features the detectors did not judge.

        Parameters
        ----------
        scores : FeatureScores
        behind : (N, C) or (N,) float, optional
            What lies behind each feature: the columns of
            :func:`unseeable.visibility.background_context` (the first
            ``len(context_inputs)`` are used; ``(N,)``: the share of rays that
            meet a log alone, for calibrations with that one input). Given,
            the context models are used (the calibration must have them).

        Returns
        -------
        (N,) float
        """
        n = len(scores.kind)
        p = np.full(n, 0.5)
        models = self.models
        if behind is not None:
            self._require_context()
            behind = self._context_columns(behind, n)
            models = self.context_models
        for sel, model, x in _group_inputs(scores, models):
            if behind is not None:
                x = np.column_stack([x, behind[sel]])
            p[sel] = model.probability(x)
        lo, hi = self.clip
        p[scores.judged] = np.clip(p[scores.judged], lo, hi)
        return p

    def context_priors(self, scores: FeatureScores) -> Callable[[np.ndarray], np.ndarray]:
        """:meth:`probabilities` of ``scores`` given ``behind``, as a function of ``behind``.

        The detector statistics' share of each context model's first layer (hundreds of
        columns against ``behind``'s two) is computed once, here; each call then costs
        a fifth of :meth:`probabilities` (the visibility fixpoint re-weighs a view's
        detections under each estimate). The same probabilities up to float round-off:
        the first layer's sum is split in two.
        """
        self._require_context()
        n = len(scores.kind)
        parts = []
        for sel, model, x in _group_inputs(scores, self.context_models):
            w1, b1, w2, b2 = _folded(model)
            k = x.shape[1]
            parts.append((sel, x @ w1[:k] + b1, w1[k:], w2, b2))
        judged, (lo, hi) = scores.judged, self.clip

        def priors(behind: np.ndarray) -> np.ndarray:
            behind = self._context_columns(behind, n)
            p = np.full(n, 0.5)
            for sel, hidden, w_behind, w2, b2 in parts:
                p[sel] = sigmoid(np.tanh(hidden + behind[sel] @ w_behind) @ w2 + b2)
            p[judged] = np.clip(p[judged], lo, hi)
            return p

        return priors

    def _require_context(self) -> None:
        if self.context_models is None:
            raise VisionError("this calibration has no context models (refit it with "
                              "'unseeable calibrate') to use what lies behind features")

    def _context_columns(self, behind: np.ndarray, n: int) -> np.ndarray:
        """``behind`` checked as ``(n, C)`` (or ``(n,)``), its first ``len(context_inputs)``
        columns."""
        behind = np.asarray(behind, dtype=float)
        if behind.ndim == 1:
            behind = behind[:, None]
        c = len(self.context_inputs)
        if behind.ndim != 2 or behind.shape[0] != n or behind.shape[1] < c:
            raise InputError(f"must have shape ({n}, {c}): {', '.join(self.context_inputs)}",
                             field="behind", value=behind.shape)
        return behind[:, :c]

    def to_json(self) -> dict[str, Any]:
        data = {"format": CALIBRATION_FORMAT, "clip": list(self.clip),
                "stats": {g: list(_stat_names(g)) for g in self.models},
                "groups": {g: m.to_json() for g, m in self.models.items()},
                "info": self.info}
        if self.pose_quality is not None:
            data["pose_quality"] = self.pose_quality.to_json()
        if self.context_models is not None:
            data["context"] = list(self.context_inputs)
            data["context_groups"] = {g: m.to_json() for g, m in self.context_models.items()}
        return data


def _group_inputs(scores: FeatureScores, models: dict[str, ScoreModel]):
    """For each detector group with judged features: which features (``(N,)`` bool), its
    model in ``models`` and its model inputs (:func:`group_features`)."""
    for name, member in feature_kind_groups(scores.kind).items():
        sel = member & scores.judged
        if not sel.any():
            continue
        model = models.get(name)
        if model is None:
            raise VisionError(f"the calibration has no model for detector group {name!r}")
        stats = scores.end_stats if name == "end" else scores.segment_stats
        yield sel, model, group_features(name, stats[sel])


def _folded(model: ScoreModel) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """``model`` as one network on its raw inputs: ``(w1, b1, w2, b2)`` with
    ``logit = tanh(x @ w1 + b1) @ w2 + b2`` (:attr:`GroupEnsemble._stacked`: the
    standardisation folded into ``w1``, ``b1``; an ensemble's members side by side)."""
    return (model if isinstance(model, GroupEnsemble) else GroupEnsemble((model,)))._stacked


def _networks(model: ScoreModel) -> tuple[GroupModel, ...]:
    return model.members if isinstance(model, GroupEnsemble) else (model,)


def merge_calibrations(calibrations: Sequence[Calibration], *,
                       names: Sequence[str] | None = None) -> Calibration:
    """One calibration whose every model averages the networks of all those given.

    Calibrations fitted on different training scenes (say, one with big
    multi-room cabins among its scenes and one without) err in different
    places. Averaging the logits of all their networks, as one
    :class:`GroupEnsemble` per model, is a bigger ensemble across training
    sets. Each network weighs the same, so a calibration of five networks
    counts five times one of a single network. The pose-quality model is the
    first calibration that has one. ``info`` records each fit's own info
    under ``"parts"`` (a merged calibration's parts are taken as they are).

    Parameters
    ----------
    calibrations : sequence of Calibration
        Two or more. They must agree on the clip range and on the context
        inputs, and either all have context models or none do.
    names : sequence of str, optional
        What errors call each calibration (its file); default
        ``calibrations[n]``.

    Returns
    -------
    Calibration

    Examples
    --------
    >>> import numpy as np
    >>> net = GroupModel(np.zeros(1), np.ones(1), np.ones((1, 1)), np.zeros(1), np.ones(1), 0.0)
    >>> cal = Calibration({g: net for g in GROUPS}, info={"scenes": 3})
    >>> both = merge_calibrations([cal, cal])
    >>> len(both.models["end"].members), both.info["members"], len(both.info["parts"])
    (2, 2, 2)
    """
    cals = list(calibrations)
    if len(cals) < 2 or not all(isinstance(c, Calibration) for c in cals):
        raise InputError("give two or more calibrations", field="calibrations",
                         value=[type(c).__name__ for c in cals])
    if names is not None and len(names) != len(cals):
        raise InputError(f"must name each of the {len(cals)} calibrations", field="names",
                         value=list(names))
    first = cals[0]

    def context_of(c: Calibration) -> list[str]:
        return list(c.context_inputs) if c.has_context else []

    for n, c in enumerate(cals[1:], start=1):
        file, prefix = (names[n], "") if names is not None else (None, f"calibrations[{n}].")
        if c.clip != first.clip:
            raise InputError(f"clips probabilities to {list(c.clip)}, the first to "
                             f"{list(first.clip)}", file=file, field=prefix + "clip",
                             value=list(c.clip))
        if context_of(c) != context_of(first):
            raise InputError(f"must have the first's context inputs {context_of(first)}",
                             file=file, field=prefix + "context", value=context_of(c))

    def merged(models: list[dict[str, ScoreModel]]) -> dict[str, ScoreModel]:
        return {g: GroupEnsemble(tuple(net for m in models for net in _networks(m[g])))
                for g in GROUPS}

    models = merged([c.models for c in cals])
    context = merged([c.context_models for c in cals]) if first.has_context else None
    pose_quality = next((c.pose_quality for c in cals if c.pose_quality is not None), None)
    info = {"members": len(models["end"].members),
            "parts": [dict(part) for c in cals for part in training_parts(c)]}
    return Calibration(models, first.clip, info, pose_quality, context, first.context_inputs)


def training_parts(calibration: Calibration) -> list[dict]:
    """The ``info`` of each fit a calibration holds: its own, or its parts' when merged
    (:func:`merge_calibrations`)."""
    parts = calibration.info.get("parts")
    return list(parts) if isinstance(parts, list) else [calibration.info]


def calibration_from_json(data: Any, *, file: Any = None) -> Calibration:
    """Validate parsed calibration JSON."""
    check_format(data, CALIBRATION_FORMAT, file=file)
    clip = require(data, "clip", file=file)
    if not (isinstance(clip, list) and len(clip) == 2 and 0 < clip[0] < clip[1] < 1):
        raise InputError("must be [low, high] with 0 < low < high < 1", file=file, field="clip",
                         value=clip)
    models = _group_models(data, "groups", 0, file)
    context_models = None
    context_inputs = CONTEXT_INPUTS
    if "context_groups" in data:
        names = data.get("context")
        known = [list(CONTEXT_INPUTS[:k]) for k in range(1, len(CONTEXT_INPUTS) + 1)]
        if names not in known:
            raise InputError(f"must be one of {known}", file=file, field="context", value=names)
        context_inputs = tuple(names)
        context_models = _group_models(data, "context_groups", len(context_inputs), file)
    pose_quality = None
    if "pose_quality" in data:
        entry = data["pose_quality"]
        try:
            values = {k: tuple(float(v) for v in entry[k]) for k in ("mean", "scale", "weights")}
            bias = float(entry["bias"])
        except (KeyError, TypeError, ValueError):
            raise InputError("must hold mean, scale, weights and bias", file=file,
                             field="pose_quality") from None
        if any(len(v) != len(POSE_QUALITY_STATS) for v in values.values()):
            raise InputError(f"must have {len(POSE_QUALITY_STATS)} values each", file=file,
                             field="pose_quality", value={k: len(v) for k, v in values.items()})
        pose_quality = PoseQualityModel(values["mean"], values["scale"], values["weights"], bias)
    return Calibration(models, (float(clip[0]), float(clip[1])), dict(data.get("info", {})),
                       pose_quality, context_models, context_inputs)


def _group_models(data: Any, key: str, extra: int, file: Any) -> dict[str, ScoreModel]:
    """Validated models of every group under ``data[key]``, each with ``extra`` inputs
    beyond its detector statistics: one network (an object) or an ensemble (a list)."""
    groups = require(data, key, file=file)
    models: dict[str, ScoreModel] = {}
    for g in GROUPS:
        entry = require(groups, g, file=file, prefix=f"{key}.")
        n_feat = len(_stat_names(g)) + extra
        if isinstance(entry, list):
            if not entry:
                raise InputError("must hold at least one network", file=file,
                                 field=f"{key}.{g}", value=entry)
            models[g] = GroupEnsemble(tuple(_network(e, n_feat, f"{key}.{g}[{i}]", file)
                                            for i, e in enumerate(entry)))
        else:
            models[g] = _network(entry, n_feat, f"{key}.{g}", file)
    return models


def _network(entry: Any, n_feat: int, field: str, file: Any) -> GroupModel:
    try:
        arrays = {k: np.asarray(entry[k], dtype=float) for k in ("mean", "scale", "w1", "b1", "w2")}
        b2 = float(entry["b2"])
    except (KeyError, TypeError, ValueError):
        raise InputError("must hold mean, scale, w1, b1, w2 and b2", file=file,
                         field=field) from None
    hidden = arrays["b1"].shape[0] if arrays["b1"].ndim == 1 else -1
    if (arrays["mean"].shape != (n_feat,) or arrays["scale"].shape != (n_feat,)
            or arrays["w1"].shape != (n_feat, hidden) or arrays["w2"].shape != (hidden,)):
        raise InputError(f"does not match the detector's {n_feat} inputs (refit with "
                         "'unseeable calibrate')", file=file, field=field,
                         value=[list(a.shape) for a in arrays.values()])
    return GroupModel(arrays["mean"], arrays["scale"], arrays["w1"], arrays["b1"],
                      arrays["w2"], b2)


def load_calibration(path: str | Path) -> Calibration:
    return calibration_from_json(read_json(path), file=path)


def save_calibration(calibration: Calibration, path: str | Path) -> None:
    write_json(path, calibration.to_json(), indent=None)


_DEFAULT: Calibration | None = None


def default_calibration() -> Calibration:
    """The calibration shipped with the package (``unseeable/data/calibration.json``)."""
    global _DEFAULT
    if _DEFAULT is None:
        ref = resources.files("unseeable").joinpath("data/calibration.json")
        try:
            text = ref.read_text(encoding="utf-8")
        except (FileNotFoundError, OSError):
            raise VisionError("no shipped detector calibration (unseeable/data/calibration.json);"
                              " run 'unseeable calibrate --out FILE' and pass it") from None
        import json

        _DEFAULT = calibration_from_json(json.loads(text), file=str(ref))
    return _DEFAULT
