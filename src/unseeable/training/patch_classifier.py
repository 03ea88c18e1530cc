"""Train the patch classifiers (:mod:`unseeable.vision.patches`) on rendered scenes.

Samples: every feature of a training scene that is visible in its truth and that
the detectors would judge, its rectified patch cut at the scene's pose polished
on the image (as :func:`~unseeable.vision.detect_features` polishes it), labelled
present or not. One network per detector group (ends, u/v segments, w
segments), trained with numpy alone: 3×3 convolutions as matrix products of
unfolded patches (im2col), backpropagation by hand, Adam, binary
cross-entropy on the logit, and random changes of look on every batch
(lightness gamma, noise, and for segments a flip along the log, which is
symmetric there) so that the networks learn the shape of a log's band more
than the look of the training renders.

A heavy framework was measured against this and not kept: see
``benchmarks/patch_classifier.py``.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from unseeable.domain import LogGeometry
from unseeable.errors import check_whole_number
from unseeable.training.scenes import Scene, SceneSpec, make_scene
from unseeable.vision.edges import edge_maps
from unseeable.vision.patches import (
    FeaturePatches,
    PatchNetwork,
    feature_patches,
    normalise_patches,
)
from unseeable.vision.pose import PoseSettings, refine_pose
from unseeable.vision.scale import working_view

__all__ = [
    "GROUPS",
    "PatchSamples",
    "TrainSettings",
    "scene_patches",
    "gather_patches",
    "train_network",
    "train_networks",
]

logger = logging.getLogger(__name__)

GROUPS = ("end", "short", "long")


@dataclass(frozen=True, eq=False)
class PatchSamples:
    """Raw patches and labels of one detector group.

    Attributes
    ----------
    x : (M, C, H, W) float32
    y : (M,) bool
        Present in the truth.
    scene : (M,) int
        Which scene (running number in the gathering) each came from.
    """

    x: np.ndarray
    y: np.ndarray
    scene: np.ndarray


@dataclass(frozen=True)
class TrainSettings:
    """How a patch network is shaped and trained.

    Attributes
    ----------
    conv : tuple of int
        Filters of each 3×3 convolution (each followed by ReLU and 2×2 max pooling).
    hidden : int
        Units of the dense hidden layer.
    epochs : int
    batch : int
    learning_rate : float
        Adam's step.
    weight_decay : float
        L2 penalty on the weights (not the biases).
    gamma : (float, float)
        Range of the random gamma applied to a patch's lightness (augmentation).
    noise : float
        Largest standard deviation of the Gaussian noise added (Lab units).
    seed : int
    """

    conv: tuple[int, ...] = (8, 16)
    hidden: int = 16
    epochs: int = 12
    batch: int = 128
    learning_rate: float = 2e-3
    weight_decay: float = 1e-4
    gamma: tuple[float, float] = (0.6, 1.7)
    noise: float = 3.0
    seed: int = 0


def scene_patches(scene: Scene, *, channels: str = "grey",
                  geometry: LogGeometry = LogGeometry(),
                  refine: bool = True) -> tuple[FeaturePatches, np.ndarray]:
    """The patches of a scene's visible features, at its pose polished on the image.

    Returns
    -------
    patches : FeaturePatches
    present : (N,) bool
        The scene's truth, per feature.
    """
    pose = scene.pose
    if refine:
        img, camera = working_view(scene.image, scene.camera)
        pose = refine_pose(edge_maps(img, sigma=1.0), camera, scene.extent, pose,
                           geometry=geometry, settings=PoseSettings(sigma=1.0))
    return (feature_patches(scene.image, scene.camera, pose, scene.extent, mask=scene.visible,
                            channels=channels, geometry=geometry), scene.present)


def gather_patches(jobs: Iterable[tuple[SceneSpec, int]], *, channels: str = "grey",
                   geometry: LogGeometry = LogGeometry(),
                   progress: Callable[[int], None] | None = None) -> dict[str, PatchSamples]:
    """Patches and labels of the visible features of scenes, per detector group.

    Parameters
    ----------
    jobs : iterable of (SceneSpec, int)
        Scene family and number (rendered, or read from the render cache).
    channels : {"grey", "lab"}
    progress : callable(done), optional

    Returns
    -------
    dict of str to PatchSamples
    """
    parts: dict[str, list] = {g: [] for g in GROUPS}
    for n, (spec, index) in enumerate(jobs):
        scene = make_scene(spec, index, geometry=geometry)
        fp, present = scene_patches(scene, channels=channels, geometry=geometry)
        parts["end"].append((fp.end, present[fp.end_index], n))
        for g in ("short", "long"):
            sel = fp.segment_group == g
            parts[g].append((fp.segment[sel], present[fp.segment_index[sel]], n))
        if progress is not None:
            progress(n + 1)
    out = {}
    for g, items in parts.items():
        out[g] = PatchSamples(np.concatenate([x for x, _, _ in items]).astype(np.float32),
                              np.concatenate([y for _, y, _ in items]).astype(bool),
                              np.concatenate([np.full(len(y), n) for _, y, n in items]))
    return out


# ---------------------------------------------------------------------------
# numpy CNN with backpropagation


def _im2col(x: np.ndarray) -> np.ndarray:
    """``(M, C, H, W)`` → ``(M·H·W, C·9)``: the 3×3 neighbourhoods ('same' padding)."""
    m, c, h, w = x.shape
    xp = np.pad(x, ((0, 0), (0, 0), (1, 1), (1, 1)))
    cols = np.lib.stride_tricks.sliding_window_view(xp, (3, 3), axis=(2, 3))
    return np.ascontiguousarray(cols.transpose(0, 2, 3, 1, 4, 5)).reshape(m * h * w, c * 9)


def _col2im(dcols: np.ndarray, shape: tuple[int, int, int, int]) -> np.ndarray:
    """Adjoint of :func:`_im2col`: ``(M·H·W, C·9)`` → ``(M, C, H, W)``."""
    m, c, h, w = shape
    d = dcols.reshape(m, h, w, c, 3, 3)
    dxp = np.zeros((m, c, h + 2, w + 2), dcols.dtype)
    for di in range(3):
        for dj in range(3):
            dxp[:, :, di:di + h, dj:dj + w] += d[:, :, :, :, di, dj].transpose(0, 3, 1, 2)
    return dxp[:, :, 1:-1, 1:-1]


class _Net:
    """Parameters and a forward/backward pass of :class:`PatchNetwork`'s architecture."""

    def __init__(self, shape: tuple[int, int, int], settings: TrainSettings,
                 rng: np.random.Generator) -> None:
        c, h, w = shape
        self.shape = shape
        self.params: list[np.ndarray] = []
        for f in settings.conv:
            self.params += [rng.normal(0, np.sqrt(2.0 / (9 * c)), (f, c, 3, 3)).astype(np.float32),
                            np.zeros(f, np.float32)]
            c, h, w = f, h // 2, w // 2
        d = c * h * w
        self.params += [rng.normal(0, np.sqrt(2.0 / d), (d, settings.hidden)).astype(np.float32),
                        np.zeros(settings.hidden, np.float32),
                        rng.normal(0, np.sqrt(1.0 / settings.hidden),
                                   settings.hidden).astype(np.float32),
                        np.zeros(1, np.float32)]
        self.n_conv = len(settings.conv)

    def loss_and_grads(self, x: np.ndarray, y: np.ndarray) -> tuple[float, list[np.ndarray]]:
        """Mean binary cross-entropy of logits and its gradients (same order as ``params``)."""
        cache = []
        h = x
        for k in range(self.n_conv):
            w, b = self.params[2 * k], self.params[2 * k + 1]
            m, c, hh, ww = h.shape
            cols = _im2col(h)
            z = (cols @ w.reshape(len(w), -1).T + b).reshape(m, hh, ww, -1).transpose(0, 3, 1, 2)
            a = np.maximum(z, 0.0)
            a = a[:, :, :hh // 2 * 2, :ww // 2 * 2]
            r = a.reshape(m, len(w), hh // 2, 2, ww // 2, 2)
            p = r.max(axis=(3, 5))
            # (ties share the gradient; they are ReLU's zeros, whose gradient is zero anyway)
            mask = r == p[:, :, :, None, :, None]
            cache.append((h.shape, cols, z, mask))
            h = p
        hw, hb, ow, ob = self.params[-4:]
        flat = h.reshape(len(h), -1)
        hz = flat @ hw + hb
        ha = np.maximum(hz, 0.0)
        logit = ha @ ow + ob[0]
        prob = 1.0 / (1.0 + np.exp(-logit))
        yf = y.astype(np.float32)
        loss = float(np.mean(np.maximum(logit, 0) - logit * yf + np.log1p(np.exp(-np.abs(logit)))))
        dl = (prob - yf) / len(y)
        g_ow = ha.T @ dl
        g_ob = np.array([dl.sum()], np.float32)
        dha = np.outer(dl, ow) * (hz > 0)
        g_hw = flat.T @ dha
        g_hb = dha.sum(axis=0)
        dh = (dha @ hw.T).reshape(h.shape)
        grads: list[np.ndarray] = [None] * len(self.params)  # type: ignore[list-item]
        for k in reversed(range(self.n_conv)):
            shape, cols, z, mask = cache[k]
            w = self.params[2 * k]
            m, c, hh, ww = shape
            dr = mask * dh[:, :, :, None, :, None]
            dz = np.zeros_like(z)
            dz[:, :, :hh // 2 * 2, :ww // 2 * 2] = dr.reshape(m, len(w), hh // 2 * 2,
                                                               ww // 2 * 2)
            dz *= z > 0
            dzf = dz.transpose(0, 2, 3, 1).reshape(-1, len(w))
            grads[2 * k] = (dzf.T @ cols).reshape(w.shape)
            grads[2 * k + 1] = dzf.sum(axis=0)
            if k:
                dh = _col2im(dzf @ w.reshape(len(w), -1), shape)
        grads[-4:] = [g_hw, g_hb, g_ow, g_ob]
        return loss, grads

    def network(self, channels: str) -> PatchNetwork:
        p = self.params
        k = self.n_conv
        return PatchNetwork(tuple(p[2 * i].copy() for i in range(k)),
                            tuple(p[2 * i + 1].copy() for i in range(k)),
                            p[-4].copy(), p[-3].copy(), p[-2].copy(), float(p[-1][0]),
                            self.shape, channels)


def _augment(x: np.ndarray, rng: np.random.Generator, settings: TrainSettings, *,
             flip_along: bool) -> np.ndarray:
    """Random look changes of raw Lab patches ``(M, C, H, W)``, then normalised."""
    x = x.copy()
    m = len(x)
    gamma = np.exp(rng.uniform(*np.log(settings.gamma), size=m)).astype(np.float32)
    light = np.clip(x[:, 0], 0.0, 100.0) / 100.0
    x[:, 0] = 100.0 * light ** gamma[:, None, None]
    x += rng.normal(0, 1, x.shape).astype(np.float32) * (
        rng.uniform(0, settings.noise, size=(m, 1, 1, 1)).astype(np.float32))
    if flip_along:
        flip = rng.random(m) < 0.5
        x[flip] = x[flip, :, :, ::-1]
    return normalise_patches(x)


def train_network(samples: PatchSamples, *, channels: str = "grey",
                  settings: TrainSettings = TrainSettings(), flip_along: bool = False,
                  progress: Callable[[int, float], None] | None = None) -> PatchNetwork:
    """Train one patch network on one group's samples (numpy, Adam).

    Parameters
    ----------
    samples : PatchSamples
        Raw patches ``(M, C, H, W)`` and labels.
    channels : {"grey", "lab"}
    settings : TrainSettings
    flip_along : bool
        Also flip patches along the log at random (segments: symmetric along it).
    progress : callable(epoch, mean loss), optional

    Returns
    -------
    PatchNetwork
    """
    check_whole_number(settings.epochs, field="epochs", minimum=1)
    rng = np.random.default_rng(settings.seed)
    net = _Net(tuple(samples.x.shape[1:]), settings, rng)
    m1 = [np.zeros_like(p) for p in net.params]
    m2 = [np.zeros_like(p) for p in net.params]
    b1, b2, eps = 0.9, 0.999, 1e-8
    step = 0
    n = len(samples.y)
    for epoch in range(settings.epochs):
        order = rng.permutation(n)
        losses = []
        # Step down the learning rate over the last third of the epochs.
        lr = settings.learning_rate * (0.2 if epoch >= 2 * settings.epochs // 3 else 1.0)
        for s in range(0, n, settings.batch):
            idx = order[s:s + settings.batch]
            xb = _augment(samples.x[idx], rng, settings, flip_along=flip_along)
            loss, grads = net.loss_and_grads(xb, samples.y[idx])
            losses.append(loss)
            step += 1
            for i, (p, g) in enumerate(zip(net.params, grads)):
                if p.ndim > 1:
                    g = g + settings.weight_decay * p
                m1[i] = b1 * m1[i] + (1 - b1) * g
                m2[i] = b2 * m2[i] + (1 - b2) * g * g
                p -= (lr * (m1[i] / (1 - b1**step))
                      / (np.sqrt(m2[i] / (1 - b2**step)) + eps)).astype(np.float32)
        if progress is not None:
            progress(epoch + 1, float(np.mean(losses)))
    return net.network(channels)


def train_networks(samples: dict[str, PatchSamples], *, channels: str = "grey",
                   settings: TrainSettings = TrainSettings(),
                   groups: Sequence[str] = GROUPS) -> tuple[dict[str, PatchNetwork],
                                                            dict[str, float]]:
    """One network per detector group; returns them and each one's training time (s)."""
    nets, seconds = {}, {}
    for g in groups:
        t0 = time.perf_counter()
        nets[g] = train_network(
            samples[g], channels=channels, settings=settings, flip_along=g != "end",
            progress=lambda e, loss, g=g: logger.info("%s epoch %d: loss %.4f", g, e, loss))
        seconds[g] = time.perf_counter() - t0
        logger.info("%s network: %d samples, %.1f s", g, len(samples[g].y), seconds[g])
    return nets, seconds
