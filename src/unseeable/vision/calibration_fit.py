"""Fitting the detector calibration's models (:class:`~unseeable.vision.calibration.Calibration`).

:func:`fit_calibration` fits every detector group's score model (one network,
or an ensemble of networks from different initial weights, :func:`fit_group`)
from training samples; :func:`fit_pose_quality` fits the pose quality model.
The training samples come from rendered scenes (:func:`unseeable.training.calibrate`).
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping

import numpy as np

from unseeable.errors import InputError, VisionError, check_whole_number
from unseeable.parallel import run_in_processes, single_blas_thread
from unseeable.vision.calibration import (
    CONTEXT_INPUTS,
    GROUPS,
    Calibration,
    GroupEnsemble,
    GroupModel,
    NetworkKey,
    PoseQualityModel,
    ScoreModel,
    group_features,
    sigmoid,
)

__all__ = ["fit_group", "fit_calibration", "fit_network", "fit_pose_quality"]

logger = logging.getLogger(__name__)


def fit_group(features: np.ndarray, labels: np.ndarray, *, hidden: int = 32,
              l2: float = 1e-4, seed: int = 0, max_iter: int = 1000) -> GroupModel:
    """Fit one group's model: cross-entropy plus an L2 penalty, by L-BFGS.

    Parameters
    ----------
    features : (M, F) float
        Model inputs (:func:`group_features`).
    labels : (M,) bool
        Whether each feature was present.
    hidden : int
        Hidden units.
    l2 : float
        Weight penalty (the mean loss is per sample).
    seed : int
        Initial weights (the fit is deterministic for a seed).
    max_iter : int
        L-BFGS iterations (1000: the detectors' profiles make the models large, and more
        iterations only fit the training scenes closer).

    Returns
    -------
    GroupModel
    """
    from scipy import optimize

    x = np.asarray(features, dtype=float)
    y = np.asarray(labels, dtype=float)
    if len(x) < 10 or y.min() == y.max():
        raise VisionError(f"too few or one-sided training samples ({len(x)}, "
                          f"{int(y.sum())} present) to calibrate a detector")
    mean = x.mean(axis=0)
    scale = x.std(axis=0)
    scale = np.where(scale > 1e-9, scale, 1.0)
    z = (x - mean) / scale
    n, d = z.shape
    rng = np.random.default_rng(seed)
    prior = float(np.clip(y.mean(), 1e-3, 1 - 1e-3))
    theta0 = np.concatenate([rng.normal(0.0, 1.0 / np.sqrt(d), d * hidden), np.zeros(hidden),
                             rng.normal(0.0, 1.0 / np.sqrt(hidden), hidden),
                             [np.log(prior / (1 - prior))]])

    def unpack(theta):
        w1 = theta[: d * hidden].reshape(d, hidden)
        b1 = theta[d * hidden: d * hidden + hidden]
        w2 = theta[d * hidden + hidden: d * hidden + 2 * hidden]
        return w1, b1, w2, theta[-1]

    def loss(theta):
        w1, b1, w2, b2 = unpack(theta)
        h = np.tanh(z @ w1 + b1)
        logit = h @ w2 + b2
        p = sigmoid(logit)
        value = np.mean(np.logaddexp(0.0, logit) - y * logit)
        value += l2 * (np.sum(w1**2) + np.sum(w2**2))
        g = (p - y) / n
        g_w2 = h.T @ g + 2 * l2 * w2
        g_h = np.outer(g, w2) * (1 - h**2)
        g_w1 = z.T @ g_h + 2 * l2 * w1
        return value, np.concatenate([g_w1.ravel(), g_h.sum(axis=0), g_w2, [g.sum()]])

    res = optimize.minimize(loss, theta0, jac=True, method="L-BFGS-B",
                            options={"maxiter": max_iter})
    w1, b1, w2, b2 = unpack(res.x)
    return GroupModel(mean, scale, w1, b1, w2, float(b2))


def fit_calibration(samples: dict[str, tuple[np.ndarray, ...]], *,
                    clip: tuple[float, float] = (0.02, 0.98), hidden: int = 32,
                    l2: float = 1e-4, info: dict | None = None,
                    plain: dict[str, ScoreModel] | None = None,
                    max_iter: int = 1000, members: int = 1, workers: int = 1,
                    fitted: Mapping[NetworkKey, GroupModel] | None = None,
                    on_fitted: Callable[[NetworkKey, GroupModel], None] | None = None
                    ) -> Calibration:
    """Fit every group's model from training samples.

    Parameters
    ----------
    samples : dict of str to (stats (M, S), present (M,) bool[, behind (M, C) float])
        Raw detector statistics of visible training features, per group; with
        ``behind`` (the first ``C`` columns of
        :func:`unseeable.visibility.background_context`, under the true
        structure or the pipeline's estimate of the scene) in every group, the
        context models are fitted too.
    clip : (float, float)
    hidden, l2, max_iter : see :func:`fit_group`
    info : dict, optional
        Stored with the calibration.
    plain : dict of str to ScoreModel, optional
        Keep these plain models and fit only the context models (the second
        stage of :func:`unseeable.training.calibrate`).
    members : int
        Networks per model, fitted from the initial weights of seeds
        ``0 .. members - 1`` (:class:`GroupEnsemble` when more than one; the
        first is the network a single fit gives).
    workers : int
        Processes fitting the networks. Every fit keeps BLAS to one thread, so
        the result does not depend on it.
    fitted : dict of ((group, prefix), seed) to GroupModel, optional
        Networks already fitted from these samples (by a run that stopped),
        taken as they are instead of fitted again. ``prefix`` is ``""`` for a
        plain model and ``"context_"`` for a context model.
    on_fitted : callable(((group, prefix), seed), GroupModel), optional
        Called with each network as it is fitted (not with those in ``fitted``),
        so that a caller can keep it.

    Returns
    -------
    Calibration
    """
    check_whole_number(members, field="members", minimum=1)
    details = dict(info or {})
    for group in GROUPS:
        if group not in samples:
            raise VisionError(f"no training samples for detector group {group!r}")
    with_context = all(len(samples[g]) == 3 for g in GROUPS)
    if plain is not None and (not with_context or set(plain) != set(GROUPS)):
        raise InputError("keeping the plain models needs context samples and a model for "
                         f"every group {GROUPS}", field="plain", value=sorted(plain))
    n_context = 0
    if with_context:
        widths = sorted({np.asarray(samples[g][2], float).reshape(len(samples[g][1]), -1).shape[1]
                         for g in GROUPS})
        n_context = widths[0] if len(widths) == 1 else -1
        if not 1 <= n_context <= len(CONTEXT_INPUTS):
            raise InputError(f"must have 1 to {len(CONTEXT_INPUTS)} columns, the same in "
                             "every group", field="samples.behind", value=widths)
    inputs: dict[tuple[str, str], tuple[np.ndarray, np.ndarray]] = {}
    for group in GROUPS:
        stats, present = samples[group][:2]
        present = np.asarray(present, bool)
        feats = group_features(group, stats)
        if plain is None:
            inputs[(group, "")] = (feats, present)
        if with_context:
            inputs[(group, "context_")] = (np.column_stack(
                [feats, np.asarray(samples[group][2], float).reshape(len(feats), n_context)]),
                present)
        details[f"{group}_samples"] = int(len(stats))
        details[f"{group}_present"] = int(np.sum(present))
    # The largest fits first, so that the processes finish together.
    networks = {k: v for k, v in (fitted or {}).items()
                if k[0] in inputs and k[1] < members}
    tasks = sorted(((key, seed, x, y, hidden, l2, max_iter)
                    for key, (x, y) in inputs.items() for seed in range(members)
                    if (key, seed) not in networks),
                   key=lambda t: -t[2].size)
    for name, network in run_in_processes(fit_network, tasks, workers=workers):
        networks[name] = network
        if on_fitted is not None:
            on_fitted(name, network)
    models, context = {}, {}
    for (group, prefix), (x, present) in inputs.items():
        nets = tuple(networks[((group, prefix), seed)] for seed in range(members))
        model = nets[0] if members == 1 else GroupEnsemble(nets)
        acc = float(np.mean((model.probability(x) > 0.5) == present))
        details[f"{prefix}{group}_train_accuracy"] = round(acc, 4)
        (context if prefix else models)[group] = model
        logger.info("calibrated %s%s: %d samples, %d network(s), training accuracy %.3f",
                    prefix, group, len(present), members, acc)
    if members > 1:
        details["members"] = int(members)
    if plain is not None:
        models = dict(plain)
    return Calibration(models, tuple(clip), details,
                       context_models=context if with_context else None,
                       context_inputs=CONTEXT_INPUTS[:max(n_context, 1)])


def fit_network(task: tuple) -> tuple[NetworkKey, GroupModel]:
    """One network of one model (a worker's task), BLAS on one thread whatever the caller's."""
    key, seed, x, y, hidden, l2, max_iter = task
    with single_blas_thread():
        return (key, seed), fit_group(x, y, hidden=hidden, l2=l2, seed=seed, max_iter=max_iter)


def fit_pose_quality(stats: np.ndarray, right: np.ndarray, *, l2: float = 1.0
                     ) -> PoseQualityModel:
    """Fit the pose quality model: fit statistics ``(M, 4)`` → whether the pose was right.

    Parameters
    ----------
    stats : (M, 4) float
        :attr:`unseeable.vision.PoseFit.stats` of estimated poses.
    right : (M,) bool
        Whether each was within 2 mm and 1° of the truth.
    l2 : float
        Penalty on the weights.
    """
    x = np.asarray(stats, dtype=float)
    y = np.asarray(right, dtype=float)
    if len(x) < 10 or y.min() == y.max():
        raise VisionError(f"too few or one-sided pose samples ({len(x)}, {int(y.sum())} right) "
                          "to fit the pose quality")
    mean = x.mean(axis=0)
    scale = np.where(x.std(axis=0) > 1e-9, x.std(axis=0), 1.0)
    design = np.concatenate([(x - mean) / scale, np.ones((len(x), 1))], axis=1)
    w = np.zeros(design.shape[1])
    penalty = np.r_[np.full(design.shape[1] - 1, l2), 0.0]
    for _ in range(100):
        p = sigmoid(design @ w)
        grad = design.T @ (p - y) + penalty * w
        hess = (design * (p * (1 - p))[:, None]).T @ design + np.diag(penalty + 1e-9)
        step = np.linalg.solve(hess, grad)
        w -= step
        if np.max(np.abs(step)) < 1e-8:
            break
    return PoseQualityModel(tuple(np.round(mean, 5)), tuple(np.round(scale, 5)),
                            tuple(np.round(w[:-1], 5)), round(float(w[-1]), 5))
