"""Step 2 of the pose search: where the wood is.

Canny edge pixels (:func:`canny_edges`) are sorted into the grid's two
horizontal directions at a yaw hypothesis (:func:`family_edges`). Where they
crowd, a colour model learns the wood against the background
(:func:`concentrated_wood`, :func:`unseeable.vision.edges.woodness_map`); the
wood map is warped onto the table plane at the assembly's mid-height and a
box filter of the extent's footprint places each yaw and quarter-turn
hypothesis where it covers the most wood (:func:`footprint_search`).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import cv2
import numpy as np

from unseeable.camera import Camera
from unseeable.domain import Extent, GridPose, LogGeometry
from unseeable.errors import InputError, VisionError
from unseeable.vision.edges import EdgeMaps, woodness_map
from unseeable.vision.pose.yaw import horizontal_direction
from unseeable.vision.scale import table_point

__all__ = [
    "CannyEdges",
    "FamilyEdges",
    "canny_edges",
    "family_edges",
    "line_families",
    "concentrated_wood",
    "rare_colour_region",
    "placement_wood",
    "footprint_search",
]

logger = logging.getLogger(__name__)


@dataclass(frozen=True, eq=False)
class FamilyEdges:
    """Edge pixels along each of the grid's two horizontal directions at one yaw
    (:func:`family_edges`)."""

    edges: np.ndarray  # (2, H, W) bool: edge pixels consistent with family 0 / 1
    dist: np.ndarray  # (2, H, W) float32 distance to the nearest such edge pixel
    strong: np.ndarray  # (H, W) bool strong edges of either family
    yaw_base: float  # family 0 runs along d(yaw_base), family 1 along d(yaw_base - 90)


@dataclass(frozen=True, eq=False)
class CannyEdges:
    """Canny edge pixels of an image (any direction) with their gradient directions."""

    edges: np.ndarray  # (H, W) bool
    xs: np.ndarray  # (P,) int
    ys: np.ndarray
    nx: np.ndarray  # (P,) unit gradient direction
    ny: np.ndarray
    strength: np.ndarray  # (H, W) float32
    high: float  # the hysteresis high threshold (strength units)


def canny_edges(maps: EdgeMaps) -> CannyEdges:
    """Edges of the colour gradient, with thresholds set by the image itself.

    Hysteresis thresholds lie between the noise floor (median strength:
    sensor noise and fine texture) and the contrast of the strongest edges
    (the assembly's outlines).
    """
    strength = maps.strength
    sxx, sxy, syy = (maps.tensor[..., i] for i in range(3))
    angle = 0.5 * np.arctan2(2 * sxy, sxx - syy)  # gradient direction
    floor = float(np.median(strength))
    top = float(np.percentile(strength, 99.7))
    high = max(0.25 * top, 5.0 * floor)
    scale = 1000.0 / max(top, 1e-6)
    dx = np.clip(strength * np.cos(angle) * scale, -32000, 32000).astype(np.int16)
    dy = np.clip(strength * np.sin(angle) * scale, -32000, 32000).astype(np.int16)
    edges = cv2.Canny(dx, dy, 0.5 * high * scale, high * scale, L2gradient=True) > 0
    ys, xs = np.nonzero(edges)
    return CannyEdges(edges, xs, ys, np.cos(angle[ys, xs]), np.sin(angle[ys, xs]), strength, high)


def family_edges(maps: EdgeMaps | CannyEdges, camera: Camera, yaw_base_deg: float, *,
                 tol_deg: float) -> FamilyEdges:
    """Edge pixels along each of the grid's two horizontal directions at ``yaw_base_deg``.

    A pixel belongs to a family when its edge runs towards that direction's
    vanishing point (within ``tol_deg``); distance transforms of each family follow.
    """
    e = maps if isinstance(maps, CannyEdges) else canny_edges(maps)
    h, w = e.edges.shape
    fam = np.zeros((2, h, w), dtype=bool)
    sin_tol = np.sin(np.deg2rad(tol_deg))
    for f in range(2):
        d = horizontal_direction(np.deg2rad(yaw_base_deg - 90.0 * f))
        v = camera.K @ (camera.R @ d)  # vanishing point (homogeneous pixels)
        tx = v[0] - e.xs * v[2]
        ty = v[1] - e.ys * v[2]
        tn = np.hypot(tx, ty)
        ok = np.abs(e.nx * tx + e.ny * ty) < sin_tol * np.maximum(tn, 1e-12)
        fam[f, e.ys[ok], e.xs[ok]] = True
    dist = np.stack([
        cv2.distanceTransform((~fam[f]).astype(np.uint8), cv2.DIST_L2, 3) for f in range(2)
    ])
    strong = (fam[0] | fam[1]) & (e.strength > e.high)
    return FamilyEdges(fam, dist, strong, float(yaw_base_deg))


def line_families(layer_axis: np.ndarray, yaw_deg: float, yaw_base_deg: float) -> np.ndarray:
    """Edge family of each line: 0 when it runs along ``d(yaw_base)``, else 1."""
    along_base = abs(float(horizontal_direction(np.deg2rad(yaw_deg))
                           @ horizontal_direction(np.deg2rad(yaw_base_deg))))
    i_family = 0 if along_base > 0.7 else 1
    return np.where(np.asarray(layer_axis) == 0, i_family, 1 - i_family)


def _saliency_region(fam: FamilyEdges, *, blur_px: float = 15.0,
                     level: float = 0.35) -> np.ndarray:
    """``(H, W) bool``: where edges along the grid's two directions crowd (the assembly)."""
    strong = (fam.edges[0] | fam.edges[1]).astype(np.float32)
    density = cv2.GaussianBlur(strong, (0, 0), blur_px)
    top = float(density.max())
    if top <= 0:
        raise VisionError("no edges along two perpendicular horizontal directions: "
                          "is an assembly in view?")
    return density > level * top


def rare_colour_region(lab: np.ndarray, *, bins: int = 16, max_share: float = 0.002,
                       blur_px: float = 15.0, level: float = 0.35) -> np.ndarray | None:
    """``(H, W) bool``: where the image's rarest colours crowd, or None where none do.

    A pixel's colour is rare when its bin of the image's own ``bins``³ Lab histogram
    holds less than ``max_share`` of the pixels. A small assembly on a large table is
    made of the colours the table is not, wherever the table's lines crowd; the
    region is where the rare pixels' density (a Gaussian of ``blur_px``) reaches
    ``level`` of its peak.

    Parameters
    ----------
    lab : (H, W, 3) uint8
        ``cv2.cvtColor(image, cv2.COLOR_RGB2Lab)``.

    Examples
    --------
    >>> lab = np.full((200, 300, 3), 128, np.uint8)
    >>> lab[95:105, 145:155] = (90, 160, 170)  # 0.17 % of the image
    >>> region = rare_colour_region(lab, blur_px=3.0)
    >>> bool(region[100, 150]), bool(region[20, 20])
    (True, False)
    """
    lab = np.asarray(lab)
    if lab.ndim != 3 or lab.shape[2] != 3 or lab.dtype != np.uint8:
        raise InputError("must be an (H, W, 3) uint8 Lab image", field="lab",
                         value=(lab.shape, str(lab.dtype)))
    if isinstance(bins, bool) or bins not in (2, 4, 8, 16, 32):
        raise InputError("must be 2, 4, 8, 16 or 32", field="bins", value=bins)
    step = 256 // bins
    q = (lab // step).astype(np.uint16)
    idx = (q[..., 0] * bins + q[..., 1]) * bins + q[..., 2]
    counts = np.bincount(idx.ravel(), minlength=bins**3)
    rare = (counts < max_share * idx.size).astype(np.float32)[idx]
    if not rare.any():
        return None
    density = cv2.GaussianBlur(rare, (0, 0), blur_px)
    return density > level * float(density.max())


def concentrated_wood(image: np.ndarray, canny: CannyEdges, camera: Camera, yaws: list[float], *,
                      tol_deg: float, mass_ratio: float = 2.0, rare_colours: bool = False
                      ) -> tuple[np.ndarray, FamilyEdges, float]:
    """The wood map (:func:`woodness_map`) learnt in the saliency region of one of
    ``yaws``, the one that marks the least of the image as wood: ``(wood, family
    edges, yaw)``.

    A model learnt where the table's planks, seams or tiles crowd takes the table
    for the wood and marks much of the image; the assembly's own wood covers at
    most its footprint. The first yaw's model is kept unless another's wood
    (the map's sum) is less than its by a factor ``mass_ratio`` or more. With
    ``rare_colours``, a model learnt where the image's rarest colours crowd
    (:func:`rare_colour_region`) competes the same way, with the best yaw's edge
    families: a small assembly far off on a tiled table crowds fewer edges than
    the tiles do, but its colour is the table's rarest.
    """
    best = None
    lab = cv2.cvtColor(image, cv2.COLOR_RGB2Lab)  # once for every yaw's model
    for yaw in yaws:
        fam = family_edges(canny, camera, yaw, tol_deg=tol_deg)
        wood = woodness_map(image, _saliency_region(fam), lab=lab)
        mass = float(wood.sum())
        logger.debug("wood learnt at yaw %.1f°: %.0f px of it", yaw, mass)
        if best is None or mass * mass_ratio < best[0]:
            best = (mass, wood, fam, yaw)
    assert best is not None
    if rare_colours:
        region = rare_colour_region(lab)
        if region is not None:
            wood = woodness_map(image, region, lab=lab)
            mass = float(wood.sum())
            logger.debug("wood learnt where the rarest colours crowd: %.0f px of it", mass)
            if mass * mass_ratio < best[0]:
                best = (mass, wood, best[2], best[3])
    return best[1], best[2], best[3]


def placement_wood(wood: np.ndarray, log_px: float, *, width_share: float = 0.5,
                   background: bool = True, near: np.ndarray | None = None,
                   floor: float = 1.0, near_level: float = 0.3) -> np.ndarray | None:
    """``(H, W) float32``: the wood map as the footprint search weighs it.

    Wood narrower than ``width_share`` of a log's diameter in the image
    (``log_px``) is taken off by a morphological opening: a table's seams or
    grout lines, dark and thin, read as wood to a colour model learnt against
    the table, and across a footprint they add up to more than a sparse
    assembly's logs. With ``background``, the map's median (the level the
    table itself reaches; a table of the logs' colour, a tiled one's glaze) is
    taken off too, so that a footprint scores the wood standing out of the
    table and not the table's own shade summed over its area. With ``near``
    (``(H, W)`` in [0, 1], where the assembly's edges crowd), the wood counts
    fully where ``near`` reaches ``near_level`` and down to ``floor`` where it
    is 0: wood-coloured table far from every crowd of edges counts less.
    None when nothing changes the map.
    """
    if width_share <= 0 and not background and (near is None or floor >= 1.0):
        return None
    size = int(round(width_share * log_px))
    out = np.asarray(wood, dtype=np.float32)
    if size >= 2:
        size += 1 - size % 2
        kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (size, size))
        out = cv2.morphologyEx(out, cv2.MORPH_OPEN, kernel)
    if background:
        out = np.maximum(out - float(np.median(out)), 0.0)
    if near is not None and floor < 1.0:
        # A gate, not a weight: the wood near the crowded edges counts fully, so that the
        # footprint's placement is not pulled towards where they crowd most.
        out = out * (floor + (1.0 - floor) * np.clip(near / near_level, 0.0, 1.0))
    return out.astype(np.float32)


def footprint_search(wood: np.ndarray, camera: Camera, extent: Extent, yaw_deg: float,
                     geometry: LogGeometry, *, mm_per_cell: float = 3.0,
                     half_mm: float = 900.0, plateau: float = 0.98, rank: int = 0,
                     min_share: float = 0.3) -> tuple[GridPose, float] | None:
    """Place the extent's footprint where it covers the most wood.

    The woodness map is warped onto the horizontal plane at the assembly's
    mid-height, in a frame aligned with the grid at ``yaw_deg``; a box
    filter of the footprint's size scores every placement at once. The
    footprint is larger than the wood it covers in places (sparse layers),
    so the placements within ``plateau`` of the best are averaged.

    ``rank > 0`` asks for the ``rank``-th other wood cluster instead: the
    best placement at least a footprint away (along either axis) from every
    better one, if it covers ``min_share`` of the best's wood (else None).
    A wood-coloured stretch of table (or logs laid aside) can outweigh a small assembly.

    Returns
    -------
    pose : GridPose
    score : float
        Wood covered (rectified cells).
    """
    g = geometry
    I, J, K = extent.shape
    h = float(g.layer_height(J - 1)) / 2.0
    i_dir = horizontal_direction(np.deg2rad(yaw_deg))
    k_dir = np.array([np.sin(np.deg2rad(yaw_deg)), 0.0, np.cos(np.deg2rad(yaw_deg))])
    c0 = table_point(camera, np.array([[camera.width / 2.0, camera.height / 2.0]]), h)[0]
    if not np.all(np.isfinite(c0)):
        raise VisionError("the camera does not see the table")
    u0 = float(c0 @ i_dir) - half_mm
    v0 = float(c0 @ k_dir) - half_mm
    n = int(round(2 * half_mm / mm_per_cell))
    cell_to_uv = np.array([[mm_per_cell, 0.0, u0], [0.0, mm_per_cell, v0], [0.0, 0.0, 1.0]])
    uv_to_xz = np.array([[i_dir[0], k_dir[0], 0.0], [i_dir[2], k_dir[2], 0.0], [0.0, 0.0, 1.0]])
    R, t = camera.R, camera.t
    xz_to_image = camera.K @ np.stack([R[:, 0], R[:, 2], R[:, 1] * h + t], axis=1)
    warp = xz_to_image @ uv_to_xz @ cell_to_uv
    rect = cv2.warpPerspective(wood.astype(np.float32), warp, (n, n),
                               flags=cv2.WARP_INVERSE_MAP | cv2.INTER_LINEAR, borderValue=0.0)
    fu = max(1, int(round(((I - 1) * g.l1 + 2 * g.l3) / mm_per_cell)))
    fv = max(1, int(round(((K - 1) * g.l1 + 2 * g.l3) / mm_per_cell)))
    integral = cv2.integral(rect)
    boxes = (integral[fv:, fu:] - integral[:-fv, fu:] - integral[fv:, :-fu]
             + integral[:-fv, :-fu])
    best = float(boxes.max())
    if best <= 0:
        raise VisionError("no wood-coloured region where the assembly could stand")
    def overlapping(r: int, c: int) -> tuple[slice, slice]:
        # The placements whose footprint overlaps the one at (r, c).
        return slice(max(r - fv, 0), r + fv + 1), slice(max(c - fu, 0), c + fu + 1)

    window = np.ones(boxes.shape, bool)
    for _ in range(rank):
        # Take out every placement overlapping the better cluster's best one.
        window[overlapping(*np.unravel_index(np.argmax(np.where(window, boxes, -1.0)),
                                             boxes.shape))] = False
    if rank:
        if not window.any():
            return None
        r0, c0_ = np.unravel_index(np.argmax(np.where(window, boxes, -1.0)), boxes.shape)
        if boxes[r0, c0_] < min_share * best:
            return None
        best = float(boxes[r0, c0_])
        # The plateau of that cluster only (within a footprint of its best placement).
        near = np.zeros(boxes.shape, bool)
        near[overlapping(r0, c0_)] = True
        boxes = np.where(near & window, boxes, -1.0)
    rows, cols = np.nonzero(boxes >= plateau * best)
    u = u0 + (float(cols.mean()) + 0.5) * mm_per_cell + g.l3
    v = v0 + (float(rows.mean()) + 0.5) * mm_per_cell + g.l3
    origin = u * i_dir + v * k_dir
    return GridPose(float(origin[0]), float(origin[2]), float(yaw_deg)), best
