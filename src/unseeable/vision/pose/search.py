"""Step 3 of the pose search: translations whose silhouettes and rims lie on edges.

Near each wood-based placement (:func:`~unseeable.vision.pose.placement.footprint_search`),
every translation on a grid is scored by how many samples of the *upper*
silhouettes (the top edges of every log the grid could hold, whose image
edges are sharp; the lower ones sit a few pixels off, where a crevice's
shading or a contact shadow ends) and of the end-disc rims facing the camera
lie near edges of their own direction (distance transforms; one numba pass
per yaw, :func:`dense_candidates`). :class:`PoseSearch` holds what the search
knows of one image, shared by its steps.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numba
import numpy as np

from unseeable.camera import Camera
from unseeable.domain import Extent, GridPose, LogGeometry
from unseeable.parallel import map_in_threads
from unseeable.vision.calibration import PoseQualityModel
from unseeable.vision.edges import EdgeMaps
from unseeable.vision.pose.lines import (
    centre_grid,
    end_rims,
    pose_from_centre,
    sample_lines,
    upper_lines,
)
from unseeable.vision.pose.placement import (
    CannyEdges,
    FamilyEdges,
    family_edges,
    footprint_search,
    line_families,
)
from unseeable.vision.pose.settings import PoseSettings
from unseeable.vision.pose.yaw import yaw_gap

__all__ = ["PoseSearch", "family_for", "dense_searches", "dense_candidates"]


@dataclass(frozen=True, eq=False)
class PoseSearch:
    """What the pose search knows of one image, shared by its steps.

    Attributes
    ----------
    image : (H, W, 3) uint8
        The image at the pose search's scale (:func:`~unseeable.vision.scale.pose_view`).
    maps : EdgeMaps
        Its edge maps.
    camera : Camera
        The camera of ``image``.
    extent : Extent
    geometry : LogGeometry
    settings : PoseSettings
    mm_per_px : float
        Millimetres per pixel at the table's centre, at the assembly's mid-height.
    threads : int
        Threads for the translation searches and the alignments.
    canny : CannyEdges
        The image's edge pixels.
    any_dist : (H, W) float32
        Distance to the nearest of them.
    wood : (H, W) float32
        How wood-coloured each pixel looks (the colour model learnt where the edges crowd).
    quality_model : PoseQualityModel or None
        None: the shipped calibration's (or the built-in defaults).
    families : dict
        Edge families by yaw modulo 90° (rounded), filled as yaws are looked at
        (:func:`family_for`).
    placements : dict
        Footprint centres ``(2,)`` (None: no such wood cluster) by (quarter-turn family,
        yaw peak, wood cluster rank), filled by :func:`dense_searches`.
    support_cache : dict
        The translation search's support maps by (edge families, truncation).
    placement_wood : (H, W) float32 or None
        The wood map the footprint search places by
        (:func:`~unseeable.vision.pose.placement.placement_wood`; None: ``wood``).
    """

    image: np.ndarray
    maps: EdgeMaps
    camera: Camera
    extent: Extent
    geometry: LogGeometry
    settings: PoseSettings
    mm_per_px: float
    threads: int
    canny: CannyEdges
    any_dist: np.ndarray
    wood: np.ndarray
    quality_model: PoseQualityModel | None
    families: dict
    placements: dict
    support_cache: dict
    placement_wood: np.ndarray | None = None


def family_for(search: PoseSearch, yaw: float) -> FamilyEdges:
    """The edge families of ``yaw``: those of the nearest yaw looked at so far, unless it is
    more than 3° away (then made, and kept in ``search.families``)."""
    key = round(yaw % 90.0, 3)
    families = search.families
    base = min(families, key=lambda b: yaw_gap(b, key))
    if yaw_gap(base, key) > 3.0:
        families[key] = family_edges(search.canny, search.camera, yaw,
                                     tol_deg=search.settings.orientation_tol_deg)
        base = key
    return families[base]


def dense_searches(search: PoseSearch, jobs: list, rank: int, region_scores: list) -> list:
    """The best translations for each ``(yaw, o, peak)`` of ``jobs``, in their order: the
    placements first, one by one, then the searches (on threads).

    ``o`` is the quarter-turn family of the yaw, ``peak`` the yaw peak it was drawn
    near, ``rank`` the wood cluster (0: the most wood). ``region_scores[o]`` is raised
    to the wood each new placement of family ``o`` covers. Each entry of the result is
    a list of ``(score, GridPose)``, best first (empty when there is no such cluster).
    """
    searches = []
    for yaw, o, peak in jobs:
        # One placement per yaw peak: a degree or two hardly moves the footprint's centre.
        if (o, peak, rank) not in search.placements:
            wood = search.wood if search.placement_wood is None else search.placement_wood
            found = footprint_search(wood, search.camera, search.extent, yaw,
                                     search.geometry, rank=rank)
            if found is not None:
                coarse, covered = found
                region_scores[o] = max(region_scores[o], covered)
                found = coarse.grid_to_world(centre_grid(search.extent, search.geometry))[[0, 2]]
            search.placements[(o, peak, rank)] = found
        centre = search.placements[(o, peak, rank)]
        searches.append(None if centre is None else (family_for(search, yaw), centre, yaw))
    return map_in_threads(functools.partial(_translations, search), searches,
                          threads=search.threads)


def _translations(search: PoseSearch, job: tuple | None) -> list:
    """:func:`dense_candidates` of one ``(families, centre, yaw)`` job (None: none)."""
    if job is None:
        return []
    fam_y, centre, yaw = job
    st = search.settings
    return dense_candidates(fam_y, search.any_dist, search.camera, search.extent,
                            search.geometry, centre, yaw, reach_mm=st.local_reach_mm,
                            step_mm=st.dense_step_mm, spacing=st.sample_spacing_px,
                            truncation=st.dense_truncation_px, keep=st.verify_keep,
                            separation_mm=st.candidate_spacing_mm,
                            cache=search.support_cache, fine_step_mm=st.fine_step_mm)


@numba.njit(cache=True, nogil=True)
def _support_kernel(points, channel, shifts, kmat, support):  # pragma: no cover
    """Σ_samples support[channel, v, u] for camera-frame points shifted by each of ``shifts``.

    ``support`` holds, per channel (edges of one direction), 255 on an edge
    falling linearly to 0 at the truncation distance (uint8, to stay in cache).
    """
    n_shift = shifts.shape[0]
    n_pts = points.shape[0]
    h = support.shape[1]
    w = support.shape[2]
    fx = kmat[0, 0]
    skew = kmat[0, 1]
    cx = kmat[0, 2]
    fy = kmat[1, 1]
    cy = kmat[1, 2]
    out = np.zeros(n_shift)
    for c in range(n_shift):
        acc = 0
        sx = shifts[c, 0]
        sy = shifts[c, 1]
        sz = shifts[c, 2]
        for m in range(n_pts):
            z = points[m, 2] + sz
            if z <= 1e-6:
                continue
            iz = 1.0 / z
            x = points[m, 0] + sx
            y = points[m, 1] + sy
            u = (fx * x + skew * y) * iz + cx
            v = fy * y * iz + cy
            if u < -0.5 or v < -0.5:
                continue
            ui = int(u + 0.5)
            vi = int(v + 0.5)
            if ui >= w or vi >= h:
                continue
            acc += support[channel[m], vi, ui]
        out[c] = acc / 255.0
    return out


def _support_maps(dist: np.ndarray, truncation: float) -> np.ndarray:
    """``(C, H, W) uint8``: 255 at distance 0 falling to 0 at ``truncation`` pixels."""
    return np.ascontiguousarray(
        np.clip(255.0 * (1.0 - dist / truncation), 0, 255).astype(np.uint8))


def dense_candidates(fam: FamilyEdges, any_dist: np.ndarray, camera: Camera, extent: Extent,
                     geometry: LogGeometry, centre_xz: np.ndarray, yaw_deg: float, *,
                     reach_mm: float, step_mm: float, spacing: float, truncation: float,
                     keep: int, separation_mm: float, cache: dict | None = None,
                     fine_step_mm: float = 0.0) -> list[tuple[float, GridPose]]:
    """Best translations near ``centre_xz`` by edge support of upper silhouettes and end rims."""
    pose0 = pose_from_centre(centre_xz, yaw_deg, extent, geometry)
    lines, axis, _ = upper_lines(extent, pose0, camera, geometry)
    pts, _, lid = sample_lines(lines, camera, spacing)
    channel = line_families(axis, yaw_deg, fam.yaw_base)[lid]
    rim_grid = end_rims(extent, pose0, camera, geometry, points=8)[0]
    rim_pts = pose0.grid_to_world(rim_grid)
    pts = np.concatenate([pts, rim_pts])
    channel = np.concatenate([channel, np.full(len(rim_pts), 2)])
    key = (id(fam), float(truncation))
    if cache is not None and key in cache:
        support = cache[key]
    else:
        support = _support_maps(np.concatenate([fam.dist, any_dist[None]], axis=0), truncation)
        if cache is not None:
            cache[key] = support
    pts_cam = np.ascontiguousarray(pts @ camera.R.T + camera.t)
    channel = channel.astype(np.int64)
    kmat = np.ascontiguousarray(camera.K)

    def grid(half: float, step: float) -> np.ndarray:
        steps = np.arange(-half, half + 1e-9, step)
        gx, gz = np.meshgrid(steps, steps, indexing="ij")
        return np.stack([gx.ravel(), np.zeros(gx.size), gz.ravel()], axis=1)

    def score(offsets: np.ndarray) -> np.ndarray:
        shifts = np.ascontiguousarray(offsets @ camera.R.T)
        return _support_kernel(pts_cam, channel, shifts, kmat, support)

    def peaks(offsets: np.ndarray, scores: np.ndarray, count: int) -> list[int]:
        # The best translations, ``separation_mm`` apart at least: each one taken hides
        # every translation within that distance of it.
        out: list[int] = []
        hidden = np.zeros(len(offsets), dtype=bool)
        xz = offsets[:, [0, 2]]
        for b in np.argsort(-scores):
            if hidden[b]:
                continue
            out.append(int(b))
            if len(out) == count:
                break
            hidden |= np.hypot(*(xz - xz[b]).T) <= separation_mm
        return out

    offsets = grid(reach_mm, step_mm)
    scores = score(offsets)
    if fine_step_mm and fine_step_mm < step_mm:
        # The coarse grid can miss a peak by ``step_mm / 2`` per axis, about the
        # alignment's reach: its best peaks are looked at again more finely.
        top = peaks(offsets, scores, 2 * keep)
        local = grid(step_mm / 2.0, fine_step_mm)
        offsets = (offsets[top][:, None, :] + local[None, :, :]).reshape(-1, 3)
        scores = score(offsets)
    return [(float(scores[b]), GridPose(pose0.x + offsets[b, 0], pose0.z + offsets[b, 2], yaw_deg))
            for b in peaks(offsets, scores, keep)]
