"""How far to trust a fitted pose: the wood outside the extent's box, and the quality model."""

from __future__ import annotations

import cv2
import numpy as np

from unseeable.camera import Camera
from unseeable.domain import Extent, GridPose, LogGeometry
from unseeable.vision.calibration import PoseQualityModel, default_calibration
from unseeable.vision.pose.lines import box_mask

__all__ = ["wood_outside", "default_quality_model"]


def wood_outside(wood: np.ndarray, camera: Camera, extent: Extent, pose: GridPose,
                 geometry: LogGeometry, *, image: np.ndarray | None = None,
                 margin_px: int = 4, band_px: int = 40, far_px: int = 120,
                 min_chroma_gap: float = 0.06, shadow_lightness: float = 0.6,
                 open_px: int = 2) -> float:
    """Share of the assembly's wood-coloured pixels that lie outside the extent's box seen
    at ``pose``: the larger of two measures.

    Near 0 when the extent and pose are right; large when the assembly does
    not fit the extent.

    * *The ring*: wood-coloured pixels in the ring ``band_px`` around the
      box count only in excess of the rate at which the ring beyond it (out
      to ``far_px``) looks wood-coloured: a table of the logs' colour looks
      like wood all around the box, logs outside the box only next to it.
    * *The connected wood*: the wood-coloured regions (opened by a
      ``2 open_px + 1`` square, which takes off the table's thin grain) that
      reach into the box, outside it. The ring alone misses an assembly much
      larger than the extent: its wood fills the ring beyond too and reads
      as a wood-coloured table (docs/results.md: extents of half the
      assembly's width passed the fit's quality bar in 45 of 263 corpus and
      family views with the ring alone, 19 with both). Left out when those
      regions touch the image's border, as a table of the logs' colour does.

    With ``image`` (RGB), pixels outside the box whose chromaticity
    (``rgb / sum``) is nearer the table's than the wood's inside the box do
    not count: the assembly's shadow on the table, darker but of the table's
    hue, reads as wood to the colour model (which weighs lightness too), and
    beside a one-log-deep wall it outweighs the wall. When the two
    chromaticities are less than ``min_chroma_gap`` apart (a table of the
    logs' colour), hue cannot tell the shadow from wood, and the shares
    count only the wood lit brighter than ``shadow_lightness`` times the
    table's median (``r + g + b``), inside the box and out; the regions
    reaching into the box are still the whole wood's. A hard shadow is the
    table darkened and is never lit; logs outside the box show lit faces in
    about the proportion the logs inside do, as their shaded faces are left
    out on both sides.
    """
    mask = box_mask(extent, pose, camera, wood.shape, geometry)
    if mask is None:
        return 1.0
    inside = cv2.dilate(mask, np.ones((2 * margin_px + 1,) * 2, np.uint8)) > 0
    near = cv2.dilate(mask, np.ones((2 * band_px + 1,) * 2, np.uint8)) > 0
    far = cv2.dilate(mask, np.ones((2 * far_px + 1,) * 2, np.uint8)) > 0
    woody = wood > 0.5
    counted = woody  # the wood-coloured pixels counted (the regions are the wood's)
    ring, beyond = near & ~inside, far & ~near
    if image is not None and (woody & inside).any() and (~woody & beyond).any():
        rgb = np.asarray(image)

        def chroma(where: np.ndarray) -> np.ndarray:
            # Only the pixels asked for: the whole image's took 25 ms per fit.
            px = rgb[where].astype(np.float32)
            return px[:, :2] / np.maximum(px.sum(axis=1, keepdims=True), 1.0)

        wood_c = np.median(chroma(woody & inside), axis=0)
        table_c = np.median(chroma(~woody & beyond), axis=0)
        if np.hypot(*(wood_c - table_c)) >= min_chroma_gap:
            # Only wood-coloured pixels outside the box can change.
            doubt = woody & ~inside
            c = chroma(doubt)
            shade = np.linalg.norm(c - table_c, axis=1) < np.linalg.norm(c - wood_c, axis=1)
            woody = woody.copy()
            woody[doubt] = ~shade
            counted = woody
        elif shadow_lightness > 0:
            table_l = np.median(rgb[~woody & beyond].astype(np.float32).sum(axis=1))
            # Only the wood-coloured pixels' lightness, as chroma above: the rest is not lit.
            lit = np.zeros_like(woody)
            lit[woody] = rgb[woody].astype(np.float32).sum(axis=1) >= shadow_lightness * table_l
            if (lit & far).any():  # else nothing is lit: lightness tells nothing
                counted = lit
    table_rate = float(counted[beyond].mean()) if beyond.any() else 0.0
    excess = max(float(np.count_nonzero(counted & ring)) - table_rate * np.count_nonzero(ring),
                 0.0)
    in_box = float(np.count_nonzero(counted & inside))
    total = in_box + excess
    ring_share = excess / total if total else 0.0
    solid = cv2.morphologyEx(woody.astype(np.uint8), cv2.MORPH_OPEN,
                             np.ones((2 * open_px + 1,) * 2, np.uint8))
    _, labels = cv2.connectedComponents(solid, connectivity=4)
    reached = np.unique(labels[(solid > 0) & inside])
    reached = reached[reached > 0]
    edge_labels = np.concatenate([labels[0], labels[-1], labels[:, 0], labels[:, -1]])
    if not len(reached) or np.isin(reached, edge_labels).any():
        return ring_share
    connected = float(np.count_nonzero(np.isin(labels, reached) & ~inside & counted))
    return max(ring_share, connected / (in_box + connected)) if in_box + connected else ring_share


def default_quality_model() -> PoseQualityModel:
    """The shipped calibration's pose quality model, or the built-in defaults without one."""
    try:
        model = default_calibration().pose_quality
    except Exception:  # no shipped calibration: the built-in defaults
        model = None
    return model if model is not None else PoseQualityModel()
