"""The pose search: the assembly's :class:`~unseeable.domain.GridPose` from one image.

:func:`estimate_pose` runs the steps of :mod:`unseeable.vision.pose` in order:
the yaw hypotheses and the wood they are learnt from (:func:`yaw_hypotheses`),
then around each wood cluster the placements, translation searches and
alignments (:func:`~unseeable.vision.pose.candidates.fit_at_cluster`), and
for the fit it returns the near-symmetric poses the structure choice decides
between (:func:`~unseeable.vision.pose.candidates.offered_aliases`).
"""

from __future__ import annotations

import dataclasses
import logging
from typing import NamedTuple

import cv2
import numpy as np

from unseeable.camera import Camera
from unseeable.domain import Extent, LogGeometry
from unseeable.errors import VisionError, check_whole_number
from unseeable.parallel import single_blas_thread
from unseeable.vision.calibration import PoseQualityModel
from unseeable.vision.edges import EdgeMaps, edge_maps, sample_maps
from unseeable.vision.pose.aliases import canonical_pose
from unseeable.vision.pose.candidates import fit_at_cluster, offered_aliases
from unseeable.vision.pose.fit import PoseFit
from unseeable.vision.pose.placement import (
    CannyEdges,
    FamilyEdges,
    canny_edges,
    concentrated_wood,
    family_edges,
    placement_wood,
)
from unseeable.vision.pose.refinement import checked_view
from unseeable.vision.pose.search import PoseSearch
from unseeable.vision.pose.settings import PoseSettings
from unseeable.vision.pose.yaw import (
    axis_yaws,
    collinear_length,
    concentration,
    crowd_map,
    dominant_yaw,
    line_segments,
    segment_directions,
    yaw_gap,
)
from unseeable.vision.scale import table_point

__all__ = ["YawHypotheses", "yaw_hypotheses", "without_segments", "estimate_pose"]

logger = logging.getLogger(__name__)


class YawHypotheses(NamedTuple):
    """The search's first look at an image (:func:`yaw_hypotheses`)."""

    #: The yaw modulo 90° (degrees) the votes weighted by the wood beside them give.
    yaw0: float
    #: Yaw hypotheses (degrees modulo 90) for the translation search, ``yaw0`` first.
    yaws: list
    #: (H, W) float32: how wood-coloured each pixel looks.
    wood: np.ndarray
    #: The edge families of ``yaw0``.
    family: FamilyEdges
    #: The image's edge pixels.
    canny: CannyEdges
    #: Millimetres per pixel at the table's centre, at the assembly's mid-height.
    mm_per_px: float
    #: (H, W) float32 in [0, 1]: how near each pixel lies to the segments whose direction
    #: crowds there (:func:`~unseeable.vision.pose.yaw.crowd_map`); None: not made.
    crowded: np.ndarray | None = None
    #: The edge maps the search matches features with: ``maps`` without the edges of the
    #: segments whose direction runs all over the view (None: ``maps`` itself).
    maps: EdgeMaps | None = None


def without_segments(maps: EdgeMaps, segments: np.ndarray, width_px: float) -> EdgeMaps:
    """``maps`` with the edges along ``segments`` ``(S, 2, 2)`` taken out (a band
    ``width_px`` wide around each, where the edge maps are set to 0)."""
    mask = np.zeros(maps.shape, np.uint8)
    thick = max(1, int(round(width_px)))
    for a, b in np.asarray(segments, dtype=float):
        cv2.line(mask, (int(round(a[0])), int(round(a[1]))),
                 (int(round(b[0])), int(round(b[1]))), 1, thick)
    keep = (mask == 0)[..., None].astype(np.float32)
    return EdgeMaps(maps.tensor * keep, maps.gradient * keep, maps.contrast, maps.sigma)


def yaw_hypotheses(image: np.ndarray, camera: Camera, extent: Extent, geometry: LogGeometry,
                   maps: EdgeMaps, settings: PoseSettings) -> YawHypotheses:
    """Step 1 of the search: the yaw modulo 90° from vanishing directions, where the wood is,
    and the yaw hypotheses the translation search tries.

    Parameters
    ----------
    image : (H, W, 3) uint8
        At the pose search's scale (:func:`~unseeable.vision.pose.refinement.checked_view`).
    camera : Camera
        Of ``image``.
    extent : Extent
    geometry : LogGeometry
    maps : EdgeMaps
        Of ``image``.
    settings : PoseSettings

    Returns
    -------
    YawHypotheses

    Raises
    ------
    VisionError
        No straight edges, no edges along two perpendicular directions, or the camera
        does not see the table.
    """
    img, st = image, settings
    centre_pt = table_point(camera, np.array([[camera.width / 2, camera.height / 2]]),
                            float(geometry.layer_height(extent.J - 1)) / 2)[0]
    if not np.all(np.isfinite(centre_pt)):
        raise VisionError("the camera does not see the table")
    mm_per_px = float(camera.depth(centre_pt[None])[0]) / float(camera.K[0, 0])
    segs = line_segments(img, min_length=st.min_segment_px)
    psi, reliable = segment_directions(segs, camera)
    length = np.linalg.norm(segs[:, 1] - segs[:, 0], axis=1) if len(segs) else np.zeros(0)
    weights = length * reliable**2
    crowded = masked = None
    if st.spread_excess > 0 and len(segs):
        # A seamed or tiled table's lines run the same directions all over the view; the
        # assembly's crowd within its own image size. Votes count by how much their
        # direction crowds near them beyond its rate over the whole view (unless hardly
        # any does: an assembly filling the view, or no clutter to tell it from).
        g = geometry
        side = np.array([(extent.I - 1) * g.l1, (extent.K - 1) * g.l1]) + 2 * g.l3
        half_px = float(np.hypot(*side)) / 2.0 / mm_per_px  # the footprint's half-diagonal
        crowd = concentration(segs, psi, weights, radius_px=half_px,
                              image_area=float(img.shape[0] * img.shape[1]),
                              excess=st.spread_excess)
        if np.sum(crowd > 0.5) >= st.min_crowded_segments:
            # A gate, not a weight: the assembly's own edges keep their votes as they were
            # (its long, precise edges can crowd less than its short ones).
            weights = weights * np.clip(crowd / st.crowd_full, 0.0, 1.0)
            if st.crowd_floor < 1.0:
                crowded = crowd_map(segs, crowd, img.shape[:2], radius_px=half_px)
            if st.spread_mask_px > 0:
                # Their edges are no log's: the search does not match features with them.
                # Only those on an image line longer in the world than any log edge can be
                # (the total of the spread segments along it, each measured on the plane
                # of the assembly's top, where an image segment is shortest): a log edge
                # along a seam's direction crowds no more than the seams there.
                top = float(geometry.layer_height(extent.J - 1)) + geometry.radius
                spread = crowd < st.spread_crowd
                ends = table_point(camera, segs[spread].reshape(-1, 2), top).reshape(-1, 2, 3)
                world = np.nan_to_num(np.linalg.norm(ends[:, 1] - ends[:, 0], axis=1),
                                      nan=1e9, posinf=1e9)  # beyond the horizon
                spread[spread] = (collinear_length(segs[spread], world)
                                  > st.spread_length * side.max())
                if spread.any():
                    maps = without_segments(maps, segs[spread], st.spread_mask_px)
                    masked = maps
    yaw0, yaw_strength = dominant_yaw(psi, weights, sigma_deg=st.yaw_sigma_deg)
    logger.debug("yaw mod 90: %.2f° (strength %.3f, %d segments)", yaw0, yaw_strength, len(segs))

    canny = canny_edges(maps)
    # The colour model of the wood is learnt where the edges of a yaw hypothesis crowd. The
    # first vote can be the table's planks' (long parallel lines, often joined at the far
    # end by the perpendicular seams): then the "wood" learnt is the table's grain, spread
    # all over it. The next peaks are tried too, and a model that marks far less of the
    # image as wood replaces it (the assembly's wood covers at most its footprint).
    first_peaks, _ = dominant_yaw(psi, weights, sigma_deg=st.yaw_sigma_deg,
                                  peaks=st.yaw_peaks)
    wood_yaws = [yaw0]
    for y in first_peaks:
        if len(wood_yaws) < st.wood_yaw_tries and all(yaw_gap(y, o) > 5.0 for o in wood_yaws):
            wood_yaws.append(y)
    wood, fam, yaw0 = concentrated_wood(img, canny, camera, wood_yaws,
                                        tol_deg=st.orientation_tol_deg,
                                        rare_colours=st.rare_colour_wood)
    # Again, with each segment's vote weighted by how much wood lies beside it: the
    # assembly's edges count, the table's grain and the room's lines do not.
    if len(segs):
        near_wood = cv2.dilate(wood, np.ones((7, 7), np.uint8))
        t = np.linspace(0.0, 1.0, 7)
        pts = segs[:, 0, None, :] + t[None, :, None] * (segs[:, 1] - segs[:, 0])[:, None, :]
        on_wood = sample_maps(near_wood[..., None], pts)[..., 0].mean(axis=1)
        if np.sum(on_wood > 0.5) >= 4:
            weights = weights * on_wood**2
            yaw0, yaw_strength = dominant_yaw(psi, weights, sigma_deg=st.yaw_sigma_deg)
            fam = family_edges(canny, camera, yaw0, tol_deg=st.orientation_tol_deg)

    # The yaw hypotheses of step 2: the best peaks of the vanishing-direction votes.
    yaws, _ = dominant_yaw(psi, weights, sigma_deg=st.yaw_sigma_deg, peaks=st.yaw_peaks)
    if not any(yaw_gap(y, yaw0) < 0.5 for y in yaws):
        yaws = [yaw0, *yaws[:-1]]
    # One axis's edges along the horizon vote for nothing: the other axis's peaks go on too.
    yaws += [y for y in axis_yaws(psi, weights, sigma_deg=st.yaw_sigma_deg,
                                  peaks=st.axis_peaks)
             if all(yaw_gap(y, o) > 1.0 for o in yaws)]
    if st.thin_yaw_step_deg > 0 and min(extent.I, extent.K) == 1:
        # A single wall: its cross-axis edges (log ends) are too short to vote, and its
        # long lines can be few and short; yaws every few degrees go on to the search.
        yaws += [y for y in np.arange(0.0, 90.0, st.thin_yaw_step_deg)
                 if all(yaw_gap(y, o) > st.thin_yaw_step_deg / 2 for o in yaws)]
    return YawHypotheses(yaw0, yaws, wood, fam, canny, mm_per_px, crowded, masked)


@single_blas_thread()
def estimate_pose(image: np.ndarray, camera: Camera, extent: Extent, *,
                  geometry: LogGeometry = LogGeometry(),
                  settings: PoseSettings = PoseSettings(), strict: bool = True,
                  maps: EdgeMaps | None = None,
                  quality_model: PoseQualityModel | None = None,
                  threads: int = 1) -> PoseFit:
    """Estimate the assembly's ``GridPose`` from one image.

    Parameters
    ----------
    image : (H, W, 3) uint8
    camera : Camera
        Intrinsics and extrinsics relative to the table (world) frame.
    extent : Extent
        The assembly's extent (its logs occupy ``0..I-1``, ``0..J-1``, ``0..K-1``).
    geometry : LogGeometry
    settings : PoseSettings
    strict : bool
        Raise :class:`VisionError` when the image contradicts the extent: the
        wood outside its box alone takes the fit's quality below
        ``settings.min_quality`` (:attr:`PoseFit.wood_factor`). A fit that is
        only weak is returned either way, its quality below that bar.
    maps : EdgeMaps, optional
        Precomputed edge maps of ``image`` (``sigma = settings.sigma``).
    quality_model : PoseQualityModel, optional
        Default: the one in the shipped calibration (or built-in defaults).
    threads : int
        Threads for the yaw hypotheses' translation searches and the candidates'
        alignments (each independent of the others); the result is the same for
        any number.

    Returns
    -------
    PoseFit

    Raises
    ------
    VisionError
        No usable straight edges, the assembly is not in view, or (``strict``) the
        wood outside the extent's box contradicts the extent.
    """
    # A weak fit's second search starts from the caller's view, not the working one.
    given_camera, given_maps = camera, maps
    img, camera = checked_view(image, camera, extent)
    threads = check_whole_number(threads, field="threads", minimum=1)
    st = settings
    if maps is None or maps.shape != img.shape[:2]:
        maps = edge_maps(img, sigma=st.sigma)

    # 1. The yaw modulo 90° from vanishing directions, and where the wood is.
    look = yaw_hypotheses(img, camera, extent, geometry, maps, st)
    if look.maps is not None:
        maps = look.maps
    # 2., 3. For each yaw hypothesis and quarter turn: coarse placement from the wood the
    #    footprint covers, then the translations near it whose upper silhouettes and end
    #    rims lie on the most image edges of their own direction; the best candidates are
    #    aligned precisely.
    any_dist = cv2.distanceTransform((~look.canny.edges).astype(np.uint8), cv2.DIST_L2, 3)
    search = PoseSearch(image=img, maps=maps, camera=camera, extent=extent, geometry=geometry,
                        settings=st, mm_per_px=look.mm_per_px, threads=threads,
                        canny=look.canny, any_dist=any_dist, wood=look.wood,
                        quality_model=quality_model,
                        families={round(look.yaw0 % 90.0, 3): look.family}, placements={},
                        support_cache={},
                        placement_wood=placement_wood(
                            look.wood, 2 * geometry.radius / look.mm_per_px,
                            width_share=st.thin_wood_share, background=st.wood_background,
                            near=look.crowded, floor=st.crowd_floor))

    # A poor fit may have searched the wrong wood (a table plank of the logs' colour can
    # outweigh a small assembly): the next clusters are searched too, the best fit kept.
    fits = [fit_at_cluster(search, look.yaws, 0)]
    if fits[0] is None:
        raise VisionError("no pose hypothesis could be aligned with the image's edges")
    for rank in range(1, st.other_placements + 1):
        if max(f.quality for f in fits) >= max(st.min_quality, st.placement_quality):
            break
        found = fit_at_cluster(search, look.yaws, rank)
        if found is None:
            break
        logger.debug("wood cluster %d: quality %.3f", rank, found.quality)
        fits.append(found)
    best = max(fits, key=lambda f: f.quality)
    # A weak fit may have searched the wrong yaws (a small assembly casts few votes):
    # the search again over more of the votes' peaks, the better fit kept.
    wider_fit = None
    if best.quality < st.min_quality and (st.weak_yaw_peaks > st.yaw_peaks
                                          or st.weak_yaw_keep > st.yaw_keep):
        wider = dataclasses.replace(st, yaw_peaks=max(st.yaw_peaks, st.weak_yaw_peaks),
                                    yaw_keep=max(st.yaw_keep, st.weak_yaw_keep),
                                    weak_yaw_peaks=0, weak_yaw_keep=0)
        again = estimate_pose(image, given_camera, extent, geometry=geometry, settings=wider,
                              strict=False, maps=given_maps, quality_model=quality_model,
                              threads=threads)
        logger.debug("weak fit (quality %.3f): with more yaws %.3f", best.quality, again.quality)
        if again.quality > best.quality:
            wider_fit = again
    kept = best if wider_fit is None else wider_fit
    # Only what the image contradicts is refused: wood well outside the extent's box. A fit
    # that is merely weak (a small assembly shows few edges) is returned with its quality:
    # most such poses are right, and an estimate on one is never confident
    # (docs/decisions.md, "The fit's quality, refusal and the wood outside the box").
    if strict and kept.wood_factor < st.min_quality:
        raise VisionError(f"poor pose fit (quality {kept.quality:.2f} < {st.min_quality}): "
                          f"wood-coloured pixels lie well outside the extent's box; is the "
                          f"whole assembly in view and the extent {extent} right?")
    if wider_fit is not None:
        return wider_fit  # (with its own candidates)

    # 4. The grid's near-symmetries, for the grammar to decide between. (Only for a fit
    #    that is returned: a refused or replaced one needs none.)
    aliases = offered_aliases(search, best)
    # The edge-best pose stays first (an alias refined onto stray edges can outscore it).
    candidates = [(best.pose, float(best.best_score))] + [
        (canonical_pose(p, extent, geometry), float(sc)) for p, sc in aliases]
    return PoseFit(best.pose, best.quality, float(best.margin), best.aligned_share,
                   best.present, float(best.best_score), float(look.yaw0),
                   tuple(best.alternatives), tuple(candidates), wood_factor=best.wood_factor)
