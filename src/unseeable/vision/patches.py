"""Rectified appearance patches of every feature, and a small CNN that judges them.

The detectors (:mod:`unseeable.vision.detectors`) summarise each feature's
neighbourhood in hand-made edge statistics and profiles. This module cuts the
same neighbourhood out as a small image, rectified by the pose so that every
feature looks alike whatever the camera: the log's band, sampled in units of
the log's width in the image, rows across the band (top row: above the upper
silhouette) and columns along the log's axis.

Log end
    ``(C, 20, 20)``: along the axis from three radii inside the end to two
    outside it (columns, left to right: inward to outward), across the band
    from three quarters of a width below the lower silhouette to three
    quarters above the upper one (rows, top to bottom: upper to lower).
Segment (``u``, ``v``, ``w``)
    ``(C, 32, 12)``: along the stretch a segment detector looks at (columns,
    grid-frame start to stop), across from a width and a half below the lower
    silhouette of the log at the segment's layer to a width and a half above
    its upper one (rows, top to bottom): the log at ``j`` and the one at
    ``j - 2`` below it, whichever makes the segment present.

Channels are CIE Lab lightness (``"grey"``, one channel) or lightness and
both colour-opponent channels (``"lab"``, three) of the image blurred by one
pixel, each centred on its patch's mean and divided by its patch's spread
(plus a floor, so that a flat patch stays flat): the patch's look, not the
photograph's exposure or the wood's colour.

:class:`PatchNetwork` is a small convolutional network (3×3 convolutions,
ReLU and 2×2 max pooling, then a hidden dense layer and a logit) run with
numpy alone, vectorised over patches; :func:`load_patch_networks` reads one
per detector group from an ``.npz`` file
(:mod:`unseeable.training.patch_classifier` trains and writes them).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from unseeable.camera import Camera
from unseeable.domain import Extent, GridPose, LogGeometry, feature_axes
from unseeable.errors import InputError
from unseeable.vision.detectors import (
    band_grid,
    check_feature_mask,
    detector_stretch,
    feature_kind_groups,
    silhouette_lines,
)
from unseeable.vision.edges import as_rgb_image, sample_maps
from unseeable.vision.projection import project_features
from unseeable.vision.scale import working_view

__all__ = [
    "PATCH_CHANNELS",
    "END_PATCH_ALONG",
    "END_PATCH_ACROSS",
    "SEGMENT_PATCH_ALONG",
    "SEGMENT_PATCH_ACROSS",
    "FeaturePatches",
    "PatchNetwork",
    "feature_patches",
    "normalise_patches",
    "load_patch_networks",
    "save_patch_networks",
    "patch_logits",
]

logger = logging.getLogger(__name__)

#: Channel sets a patch can have: name → number of channels.
PATCH_CHANNELS = {"grey": 1, "lab": 3}
#: Where an end patch's columns sample the log's axis, in radii from the end's centre.
END_PATCH_ALONG = tuple(float(t) for t in np.linspace(-3.0, 2.0, 20))
#: Where an end patch's rows sample across the band (0: lower silhouette, 1: upper), top
#: row first.
END_PATCH_ACROSS = tuple(float(t) for t in np.linspace(1.75, -0.75, 20))
#: Where a segment patch's columns sample its stretch (0: its start, 1: its stop).
SEGMENT_PATCH_ALONG = tuple(float(t) for t in (np.arange(12) + 0.5) / 12)
#: Where a segment patch's rows sample across the band of the segment's layer, top first.
SEGMENT_PATCH_ACROSS = tuple(float(t) for t in np.linspace(2.5, -1.5, 32))
#: Floor added to a channel's spread when a patch is normalised (Lab units).
SPREAD_FLOOR = 2.0

_FORMAT = "unseeable-patch-cnn/1"
_GROUPS = ("end", "short", "long")


@dataclass(frozen=True, eq=False)
class FeaturePatches:
    """The rectified patches of the judged features of one view.

    Attributes
    ----------
    index : (M,) int
        Feature numbers (:func:`unseeable.domain.feature_index` order) of the patches.
    group : (M,) str
        Detector group of each (``"end"``, ``"short"`` for u/v, ``"long"`` for w).
    end : (E, C, 20, 20) float32
        Patches of the ends among them, in ``index`` order (raw Lab, not normalised).
    segment : (S, C, 32, 12) float32
        Patches of the segments among them, in ``index`` order.
    end_index, segment_index : (E,), (S,) int
        Feature numbers of ``end`` and ``segment``'s rows.
    segment_group : (S,) str
        ``"short"`` or ``"long"``: the group of each row of ``segment``.
    """

    index: np.ndarray
    group: np.ndarray
    end: np.ndarray
    segment: np.ndarray
    end_index: np.ndarray
    segment_index: np.ndarray
    segment_group: np.ndarray


def _lab_image(image: np.ndarray, channels: str) -> np.ndarray:
    """``(H, W, C) float32`` Lab of an RGB uint8 image blurred by one pixel."""
    rgb = cv2.GaussianBlur(image.astype(np.float32) / 255.0, (0, 0), 1.0)
    lab = cv2.cvtColor(rgb, cv2.COLOR_RGB2Lab)
    return np.ascontiguousarray(lab[..., :PATCH_CHANNELS[channels]])


def feature_patches(image: np.ndarray, camera: Camera, pose: GridPose, extent: Extent, *,
                    mask: np.ndarray | None = None, channels: str = "grey",
                    geometry: LogGeometry = LogGeometry(), min_length_px: float = 3.0,
                    rescale: bool = True) -> FeaturePatches:
    """Cut the rectified patch of every requested feature that lies in the image.

    Parameters
    ----------
    image : (H, W, 3) uint8
        The photograph (RGB).
    camera : Camera
        Matching the image's size.
    pose : GridPose
        The assembly's pose (known, or polished as ``detect_features`` polishes it).
    extent : Extent
    mask : (N,) bool, optional
        Features to cut (all by default); those outside the image, and segments shorter
        than ``min_length_px``, are left out as the detectors leave them.
    channels : {"grey", "lab"}
    geometry : LogGeometry
    min_length_px : float
    rescale : bool
        Resample the photograph to the detectors' calibrated scale first
        (:func:`~unseeable.vision.scale.working_view`); ``pose`` and ``camera`` are then
        those of the original photograph.

    Returns
    -------
    FeaturePatches
    """
    if channels not in PATCH_CHANNELS:
        raise InputError(f"must be one of {sorted(PATCH_CHANNELS)}", field="channels",
                         value=channels)
    want = check_feature_mask(mask, extent)
    img = as_rgb_image(image)
    if rescale:
        img, camera = working_view(img, camera)
    proj = project_features(extent, pose, camera, geometry=geometry)
    ds = proj.detector_segments
    with np.errstate(invalid="ignore"):
        seg_len = np.linalg.norm(ds[:, 1] - ds[:, 0], axis=1)
        judged = want & proj.in_image & (proj.is_end | (seg_len >= min_length_px))
    lab = _lab_image(img, channels)
    axes = feature_axes(extent, geometry)
    e_idx = np.flatnonzero(judged & proj.is_end)
    s_idx = np.flatnonzero(judged & ~proj.is_end)
    r = geometry.radius
    c = PATCH_CHANNELS[channels]
    end = np.zeros((len(e_idx), c, len(END_PATCH_ACROSS), len(END_PATCH_ALONG)), np.float32)
    if len(e_idx):
        along = np.asarray(END_PATCH_ALONG)
        centre = axes[e_idx, 0]
        outward = axes[e_idx, 1] - axes[e_idx, 0]
        low, up, ok = silhouette_lines(camera, pose, centre + along[0] * r * outward,
                                        centre + along[-1] * r * outward, geometry)
        pts = band_grid(low, up, (along - along[0]) / (along[-1] - along[0]),
                         np.asarray(END_PATCH_ACROSS))  # (E, rows, cols, 2)
        end = np.moveaxis(sample_maps(lab, pts), -1, 1)
        end[~ok] = 0.0
    seg = np.zeros((len(s_idx), c, len(SEGMENT_PATCH_ACROSS), len(SEGMENT_PATCH_ALONG)),
                   np.float32)
    if len(s_idx):
        start, stop = detector_stretch(axes[s_idx], proj.kind[s_idx], geometry)
        low, up, ok = silhouette_lines(camera, pose, start, stop, geometry)
        pts = band_grid(low, up, np.asarray(SEGMENT_PATCH_ALONG),
                         np.asarray(SEGMENT_PATCH_ACROSS))
        seg = np.moveaxis(sample_maps(lab, pts), -1, 1)
        seg[~ok] = 0.0
    index = np.flatnonzero(judged)
    names = np.empty(len(proj), dtype=object)
    for g, member in feature_kind_groups(proj.kind).items():
        names[member] = g
    return FeaturePatches(index, names[index].astype(str), np.ascontiguousarray(end),
                          np.ascontiguousarray(seg), e_idx, s_idx,
                          names[s_idx].astype(str))


def normalise_patches(patches: np.ndarray, *, floor: float = SPREAD_FLOOR) -> np.ndarray:
    """Each patch's channels centred on their mean and divided by their spread + ``floor``.

    Parameters
    ----------
    patches : (M, C, H, W) float

    Returns
    -------
    (M, C, H, W) float32
    """
    p = np.asarray(patches, dtype=np.float32)
    mean = p.mean(axis=(2, 3), keepdims=True)
    spread = p.std(axis=(2, 3), keepdims=True)
    return (p - mean) / (spread + np.float32(floor))


# ---------------------------------------------------------------------------
# the network


def _conv3x3(x: np.ndarray, w: np.ndarray, b: np.ndarray) -> np.ndarray:
    """'Same' 3×3 cross-correlation, ``(M, C, H, W)`` → ``(M, F, H, W)``.

    ``w``: ``(F, C, 3, 3)``; ``b``: ``(F,)``. The 3×3 neighbourhoods are unfolded into
    rows (im2col) and multiplied by the filters at once.
    """
    m, c, h, wd = x.shape
    xp = np.pad(x, ((0, 0), (0, 0), (1, 1), (1, 1)))
    cols = np.lib.stride_tricks.sliding_window_view(xp, (3, 3), axis=(2, 3))  # (M,C,H,W,3,3)
    cols = cols.transpose(0, 2, 3, 1, 4, 5).reshape(m * h * wd, c * 9)
    out = cols @ w.reshape(len(w), -1).T + b
    return out.reshape(m, h, wd, -1).transpose(0, 3, 1, 2)


def _pool2(x: np.ndarray) -> np.ndarray:
    """2×2 max pooling, ``(M, F, H, W)`` → ``(M, F, H//2, W//2)`` (odd last row/column dropped)."""
    m, f, h, w = x.shape
    x = x[:, :, :h // 2 * 2, :w // 2 * 2]
    return x.reshape(m, f, h // 2, 2, w // 2, 2).max(axis=(3, 5))


@dataclass(frozen=True, eq=False)
class PatchNetwork:
    """A small CNN mapping normalised patches to the logit of a feature's presence.

    ``conv`` 3×3 'same' → ReLU → 2×2 max pool, for each convolution; flatten; dense →
    ReLU; dense → logit.

    Attributes
    ----------
    conv_weights : tuple of (F_k, C_k, 3, 3) float32
    conv_biases : tuple of (F_k,) float32
    hidden_weight : (D, K) float32
        ``D`` = last convolution's features × pooled rows × pooled columns.
    hidden_bias : (K,) float32
    out_weight : (K,) float32
    out_bias : float
    input_shape : (C, H, W)
    channels : str
        ``"grey"`` or ``"lab"``.
    """

    conv_weights: tuple[np.ndarray, ...]
    conv_biases: tuple[np.ndarray, ...]
    hidden_weight: np.ndarray
    hidden_bias: np.ndarray
    out_weight: np.ndarray
    out_bias: float
    input_shape: tuple[int, int, int]
    channels: str = "grey"

    @property
    def n_parameters(self) -> int:
        arrays = (*self.conv_weights, *self.conv_biases, self.hidden_weight, self.hidden_bias,
                  self.out_weight)
        return int(sum(a.size for a in arrays)) + 1

    def logits(self, patches: np.ndarray, *, normalised: bool = False,
               batch: int = 2048) -> np.ndarray:
        """Logits of presence.

        Parameters
        ----------
        patches : (M, C, H, W) float
            Raw patches (:func:`feature_patches`), or normalised ones with ``normalised``.
        batch : int
            Patches per matrix product (bounds memory).

        Returns
        -------
        (M,) float
        """
        x = np.asarray(patches, dtype=np.float32)
        if x.ndim != 4 or tuple(x.shape[1:]) != tuple(self.input_shape):
            raise InputError(f"must be (M, {', '.join(map(str, self.input_shape))}) patches",
                             field="patches", value=x.shape)
        if not normalised:
            x = normalise_patches(x)
        out = np.empty(len(x), np.float64)
        for s in range(0, len(x), batch):
            h = x[s:s + batch]
            for w, b in zip(self.conv_weights, self.conv_biases):
                h = _pool2(np.maximum(_conv3x3(h, w, b), 0.0))
            h = np.maximum(h.reshape(len(h), -1) @ self.hidden_weight + self.hidden_bias, 0.0)
            out[s:s + batch] = h @ self.out_weight + self.out_bias
        return out


def patch_logits(networks: dict[str, PatchNetwork], patches: FeaturePatches,
                 n_features: int) -> np.ndarray:
    """Every judged feature's logit from its group's network, ``(n_features,)``; NaN elsewhere."""
    out = np.full(n_features, np.nan)
    if len(patches.end_index) and "end" in networks:
        out[patches.end_index] = networks["end"].logits(patches.end)
    if len(patches.segment_index):
        for g in ("short", "long"):
            sel = patches.segment_group == g
            if sel.any() and g in networks:
                out[patches.segment_index[sel]] = networks[g].logits(patches.segment[sel])
    return out


def save_patch_networks(path: str | Path, networks: dict[str, PatchNetwork], *,
                        info: str = "") -> None:
    """Write networks (by detector group) to one ``.npz`` file (float32, compressed)."""
    arrays: dict[str, np.ndarray] = {"format": np.array(_FORMAT), "info": np.array(info)}
    for g, net in networks.items():
        arrays[f"{g}.channels"] = np.array(net.channels)
        arrays[f"{g}.input_shape"] = np.asarray(net.input_shape, np.int64)
        arrays[f"{g}.n_conv"] = np.array(len(net.conv_weights))
        for k, (w, b) in enumerate(zip(net.conv_weights, net.conv_biases)):
            arrays[f"{g}.conv{k}.weight"] = w.astype(np.float32)
            arrays[f"{g}.conv{k}.bias"] = b.astype(np.float32)
        arrays[f"{g}.hidden.weight"] = net.hidden_weight.astype(np.float32)
        arrays[f"{g}.hidden.bias"] = net.hidden_bias.astype(np.float32)
        arrays[f"{g}.out.weight"] = net.out_weight.astype(np.float32)
        arrays[f"{g}.out.bias"] = np.asarray(net.out_bias, np.float32)
    with open(path, "wb") as f:
        np.savez_compressed(f, **arrays)


def load_patch_networks(path: str | Path) -> dict[str, PatchNetwork]:
    """Read the networks :func:`save_patch_networks` wrote.

    Raises
    ------
    InputError
        Naming the file and the field: not such a file, a field missing, or arrays whose
        shapes do not chain.
    """
    path = Path(path)
    try:
        data = dict(np.load(path, allow_pickle=False))
    except (OSError, ValueError) as err:
        raise InputError(f"cannot be read as patch networks ({err})", file=path) from err

    def field(name: str) -> np.ndarray:
        if name not in data:
            raise InputError("missing", file=path, field=name)
        return data[name]

    if str(field("format")) != _FORMAT:
        raise InputError(f"must be {_FORMAT!r}", file=path, field="format",
                         value=str(data["format"]))
    out = {}
    for g in _GROUPS:
        if f"{g}.n_conv" not in data:
            continue
        shape = tuple(int(v) for v in field(f"{g}.input_shape"))
        channels = str(field(f"{g}.channels"))
        if channels not in PATCH_CHANNELS or len(shape) != 3 or shape[0] != PATCH_CHANNELS[
                channels]:
            raise InputError(f"must be ({PATCH_CHANNELS.get(channels, '?')}, H, W) for "
                             f"channels {channels!r}", file=path, field=f"{g}.input_shape",
                             value=shape)
        ws, bs = [], []
        c, h, w = shape
        for k in range(int(field(f"{g}.n_conv"))):
            wk = field(f"{g}.conv{k}.weight").astype(np.float32)
            bk = field(f"{g}.conv{k}.bias").astype(np.float32)
            if wk.ndim != 4 or wk.shape[1:] != (c, 3, 3):
                raise InputError(f"must be (F, {c}, 3, 3)", file=path,
                                 field=f"{g}.conv{k}.weight", value=wk.shape)
            if bk.shape != (wk.shape[0],):
                raise InputError(f"must be ({wk.shape[0]},)", file=path,
                                 field=f"{g}.conv{k}.bias", value=bk.shape)
            ws.append(wk)
            bs.append(bk)
            c, h, w = wk.shape[0], h // 2, w // 2
        hw = field(f"{g}.hidden.weight").astype(np.float32)
        if hw.ndim != 2 or hw.shape[0] != c * h * w:
            raise InputError(f"must be ({c * h * w}, K)", file=path, field=f"{g}.hidden.weight",
                             value=hw.shape)
        hb = field(f"{g}.hidden.bias").astype(np.float32)
        ow = field(f"{g}.out.weight").astype(np.float32)
        for name, arr in ((f"{g}.hidden.bias", hb), (f"{g}.out.weight", ow)):
            if arr.shape != (hw.shape[1],):
                raise InputError(f"must be ({hw.shape[1]},)", file=path, field=name,
                                 value=arr.shape)
        ob = float(field(f"{g}.out.bias"))
        out[g] = PatchNetwork(tuple(ws), tuple(bs), hw, hb, ow, ob, shape, channels)
    if not out:
        raise InputError(f"no network of any group {_GROUPS}", file=path, field="end.n_conv")
    return out
