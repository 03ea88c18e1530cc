"""The assembly's pose on the table from one image (issue item 4; DESIGN.md §4 "Pose").

Given the camera (intrinsics and extrinsics relative to the table) and the
extent, the pose has three unknowns, ``GridPose(x, z, yaw)``:

1. **Yaw modulo 90°.** Every log edge is a horizontal line along one of the
   grid's two axes. Each image line segment (OpenCV's LSD) is the image of a
   horizontal line only for one horizontal direction ψ (its vanishing point
   must lie on the segment's line), so each segment votes for ψ. The
   assembly's two axes are 90° apart: a yaw scores the product of the votes
   for it and for it + 90°, which ignores clutter with one direction only
   (a wooden table's grain). Votes are weighted by how much wood lies
   beside each segment; the best few peaks are kept as hypotheses, with
   the peaks of either direction alone (:func:`axis_yaws`): an axis seen
   across the line of sight has its edges along the horizon, where they
   fit any direction and so carry no weight.
2. **Where the wood is.** A colour model learnt on the image itself
   (:func:`unseeable.vision.edges.woodness_map`: wood against background)
   is warped onto the table plane at the assembly's mid-height; a box
   filter of the extent's footprint places each yaw and quarter-turn
   hypothesis where it covers the most wood (within a couple of
   centimetres).
3. **Edge support.** Near that placement, every translation on a 4 mm grid
   is scored by how many samples of the *upper* silhouettes (the top edges
   of every log the grid could hold, whose image edges are sharp; the
   lower ones sit a few pixels off, where a crevice's shading or a contact
   shadow ends) and of the end-disc rims facing the camera lie near edges
   of their own direction (distance transforms).
4. **Precise alignment.** The best few candidates are aligned by robust
   least squares on the distances, along each sample's normal, to the
   strongest nearby edge (model-based edge tracking, RAPiD style: Tukey
   weights, features weighted by how present they look, shrinking search).
   The aligned pose whose features lie coherently on edges (whole lines and
   rims, not scattered samples) wins.

A half turn leaves the set of grid lines unchanged, so the pose is reported
with its yaw in ``[-90, 90)``. When the footprint is square (I = K) a
quarter turn fits the same lines after a translation; the best pose of
the other quarter turn is returned in ``PoseFit.alternatives``, and it and
its aliases join ``PoseFit.candidates`` for the structure-based choice.

The fit quality is the probability that the pose the structure choice
makes of the fit (:func:`~unseeable.vision.select_pose`, as ``unseeable
pose`` and the pipeline run it) is within 2 mm and 1° of the truth,
predicted from the fit statistics (score margin over the best different
pose, share of samples aligned, share of features that look present,
alignment score) by a logistic model fitted on training renders; a poor
fit raises :class:`~unseeable.errors.VisionError` instead of returning a
wrong pose.
"""

from __future__ import annotations

import functools
import logging
from dataclasses import dataclass, field

import cv2
import numba
import numpy as np

from unseeable.camera import Camera
from unseeable.domain import (
    Extent,
    FeatureKind,
    GridPose,
    LogGeometry,
    Structure,
    feature_axes,
    feature_index,
    lower_silhouette,
    symbolic_orientations,
)
from unseeable.errors import InputError, VisionError, check_whole_number
from unseeable.parallel import map_in_threads, single_blas_thread
from unseeable.vision.edges import (
    EdgeMaps,
    _profile_peak,
    _structure_tensor,
    as_rgb_image,
    edge_maps,
    fill_convex_hull,
    sample_maps,
    woodness_map,
)
from unseeable.vision.scale import camera_for, pose_view, table_point

__all__ = [
    "PoseSettings",
    "PoseFit",
    "estimate_pose",
    "line_segments",
    "segment_directions",
    "dominant_yaw",
    "axis_yaws",
    "pose_lines",
    "grid_lines",
    "pose_equivalent",
    "pose_aliases",
    "refine_pose",
    "refine_pose_on_structure",
    "rim_support",
    "PoseQualityModel",
    "POSE_QUALITY_STATS",
    "POLISH_REACH_PX",
    "POLISH_RIM_WEIGHT",
]

logger = logging.getLogger(__name__)

#: Where a log's upper silhouette shows in the image, relative to the projected line (px):
#: the strongest gradient of a top edge lies a little inside the log (the rim is rounded
#: and the optics blur it); measured on the training renders.
_EDGE_BIAS_PX = -0.15
#: Where an end disc's rim shows, relative to the projected rim (px, along its outward
#: normal): ``_RIM_BIAS_PX + _RIM_DROP_PX * n_v`` with ``n_v`` the normal's downward image
#: component. The strongest gradient lies a little inside the end face and a little low
#: (the top of the face borders the log's own lit top surface, not a step to the
#: background); measured at the true poses of the training renders (the flat-shaded ones
#: agree within 0.05 px). Applied where a structure's rims are aligned (the polish and
#: the pose choice); the search keeps the raw rims (see docs/decisions.md).
_RIM_BIAS_PX = -0.15
_RIM_DROP_PX = 0.17
#: In the polish on a structure, the rims' total weight relative to the silhouette
#: lines' (see :func:`refine_pose_on_structure`).
POLISH_RIM_WEIGHT = 4.0
#: How far (px) :func:`refine_pose_on_structure` and the edge alignment look for a line's
#: edge at first (then half of it).
POLISH_REACH_PX = 3.0


@dataclass(frozen=True)
class PoseSettings:
    """Constants of the pose search (pixels unless stated).

    Parameters
    ----------
    min_segment_px : float
        Shorter LSD segments do not vote for the yaw.
    yaw_sigma_deg : float
        Width of each vote in the yaw histogram.
    yaw_peaks : int
        Yaw hypotheses tried (the best peaks of the votes, 4° apart at least).
    axis_peaks : int
        Further yaw hypotheses from the peaks of either axis direction's votes
        alone (:func:`axis_yaws`), for views with one axis along the horizon.
    yaw_keep : int
        Yaw and quarter-turn hypotheses searched further (the best after a first look).
    yaw_offsets_deg : tuple of float
        Turns tried around each kept yaw hypothesis.
    orientation_tol_deg : float
        An edge pixel belongs to an axis family when its orientation is this
        close to the direction of that family's vanishing point.
    local_reach_mm, dense_step_mm : float
        Half-width and step of the translation search around the wood-based placement.
    dense_truncation_px : float
        Distance at which an edge stops supporting a feature sample in that search.
    fine_step_mm : float
        The best local maxima of that search are looked at again on this finer
        grid (0: not at all): a peak missed by half a coarse step is about as far
        as the alignment that follows reaches.
    verify_keep : int
        Candidates per quarter turn aligned precisely.
    candidate_spacing_mm : float
        Minimum distance between those candidates.
    cover_ratio : float
        A quarter turn whose footprint covers less than this share of the
        wood the other covers is not tried.
    screen_iterations : int
        Alignment steps given to every candidate before ranking them.
    align_keep : int
        Candidates aligned fully after that ranking.
    sample_spacing_px : float
        Spacing of samples along projected lines.
    min_quality : float
        Fits whose quality (probability of being right) is below this raise
        :class:`VisionError` (``estimate_pose``'s ``strict=True``).
    sigma : float
        Smoothing of the edge maps.
    wood_outside_ok : float
        Share of the assembly's wood-coloured pixels allowed outside the
        extent's box at the fitted pose (beyond the rate at which the
        surroundings look wood-coloured anyway, a table of the logs' colour,
        or connected to the wood inside the box); the quality falls to 0 at
        twice it.
    alias_layers : tuple of int
        Near-symmetric translations tried around the best pose: along each
        grid axis, by the horizontal distance that moves the image of a line
        as much as rising this many half-layers would (see :func:`pose_aliases`).
        Up to 6: a tall wall seen along its depth axis has aliases 5
        half-layers away (corpus screen-wall at 210°), and on the family
        renders 1–6 posed 4 more of 180 than 1–2 (validation 1 more).
    alias_keep : float
        Aliases whose alignment score reaches this share of the best pose's
        are returned in ``PoseFit.candidates`` for a structure-based choice.
    alias_screen : float
        Each alias is first aligned ``screen_iterations`` steps, and aligned
        fully only when it then scores this share of the best pose's.
    quarter_turn_aliases : bool
        On a square footprint (I = K), offer the other quarter turn's best
        pose and its aliases as candidates too (their edges can fit almost
        as well; the structure they imply decides).
    near_square_side : int
        With ``quarter_turn_aliases``: footprints whose sides differ by one
        grid position and whose shorter side has at least this many
        positions (a 5×6 cabin's) are screened as square ones are, both
        quarter turns of every kept yaw peak going on to the alignment. Their
        two turns fit nearly the same lines, and the first look kept only the
        wrong one on a held-out 5×7×6 cabin (whose truth, aligned, scores 851
        against the wrong turn's 654). On smaller footprints one position is
        a larger share of a side and the first look tells the turns apart:
        screening 4×5 and 3×4 ones too posed two small held-out structures a
        quarter turn and 30 mm off (docs/results.md, forty-sixth session).
        A large value: square footprints only.
    turned_twin : bool
        With ``quarter_turn_aliases``: also offer the edge-best pose turned a
        quarter in place, and its aliases (that turn's own search can miss
        it). Off: +2 of 240 validation views, but −2 of 160 corpus views (the
        towers, whose choice then prefers the twin), for 0.1 s more.
    finals_keep : float
        The other fully aligned candidates whose alignment score reaches this
        share of the best's are returned in ``PoseFit.candidates`` too (0:
        none). Edges score a sparse assembly's true grid below grids shifted
        onto the table's seams: the corpus's corner walls at 210° were posed
        a quarter turn off at 0.8, their truth's pitch-neighbour scoring 0.70
        of the best (docs/results.md).
    other_placements : int
        When the fit's quality is below ``placement_quality``, search around up
        to this many other wood clusters on the table (a plank of the table in
        the logs' colour, or an assembly's hard cast shadow, can hold more
        "wood" than a small assembly) and keep the best fit.
    placement_quality : float
        The quality below which the other wood clusters are searched too (at
        least ``min_quality``). A wrong fit on a shadow can pass the quality
        bar when nothing competes with it.
    wood_yaw_tries : int
        Yaw hypotheses (the first vote's best peaks, 5° apart) in whose edge
        regions a wood colour model is learnt (the first vote can be the
        table's planks'). Another replaces the first's only when half or more
        of its wood lies inside its own region, and 0.1 more than the first's.
    thin_yaw_step_deg : float
        For an extent one position deep (a single wall): further yaw
        hypotheses every this many degrees (0: none). A wall's ends are too
        short to vote for the cross axis, and seen face-on its long lines run
        nearly parallel to the image plane, so the votes can miss its yaw by
        several degrees; the edge alignment then decides among the steps.
    restart_mm : tuple of float
        The best ``restart_keep`` fully aligned candidates are aligned again from
        the 8 translations each of these distances around each (rings of a
        square grid in the candidate's own grid frame), and replaced by the
        best of those when it scores higher. The alignment reaches only a few
        millimetres, and the translation search's peaks can all miss the truth
        by more: on raster-drawn renders (hard cast shadows beside every log)
        every candidate of the 4×4 cabin at 150° sat 11–25 mm from a truth
        whose edges scored 36 % higher.
    restart_keep : int
        See ``restart_mm`` (0: no restarts).
    pitch_aliases : bool
        Also align the best pose moved one pitch (``l1``) along either grid
        axis or both (8 starts, three steps each, the best of them fully), and
        offer the result as a candidate for the structure choice (see
        ``pitch_keep``), the best pose staying first. On raster-drawn renders the
        translation search's candidates can all sit a pitch from the truth
        (cabin-4x4-hearth at 150°: the best 89 mm off, the truth scoring
        higher); replacing the best by such a pose when it scores higher (a
        pitch ring of ``restart_mm``, forty-second session) also moved right
        poses onto wrong ones, offering it did not (docs/results.md, fiftieth
        session).
    pitch_keep : float
        The best of the pitch-shifted poses is offered when its alignment
        score reaches this share of the best pose's. Where it rights a pose
        it scores 1.18-1.52 times the best; on big cabins, whose grid is
        periodic, a pitch shift of the right pose scores 0.80-0.84 of it,
        and offering those cost the structure choice 56 % more time there
        and changed no estimate.
    """

    min_segment_px: float = 12.0
    yaw_sigma_deg: float = 0.75
    yaw_peaks: int = 4
    axis_peaks: int = 2
    yaw_keep: int = 3
    yaw_offsets_deg: tuple[float, ...] = (-1.5, 0.0, 1.5)
    orientation_tol_deg: float = 12.0
    local_reach_mm: float = 40.0
    dense_step_mm: float = 4.0
    dense_truncation_px: float = 2.0
    fine_step_mm: float = 1.0
    verify_keep: int = 10
    candidate_spacing_mm: float = 6.0
    cover_ratio: float = 0.9
    screen_iterations: int = 3
    align_keep: int = 4
    sample_spacing_px: float = 3.0
    min_quality: float = 0.5
    sigma: float = 1.0
    wood_outside_ok: float = 0.2
    alias_layers: tuple[int, ...] = (1, 2, 3, 4, 5, 6)
    alias_keep: float = 0.8
    alias_screen: float = 0.6
    quarter_turn_aliases: bool = True
    near_square_side: int = 5
    other_placements: int = 2
    placement_quality: float = 0.9
    turned_twin: bool = False
    finals_keep: float = 0.6
    wood_yaw_tries: int = 3
    thin_yaw_step_deg: float = 2.0
    restart_mm: tuple[float, ...] = (12.0,)
    restart_keep: int = 1
    pitch_aliases: bool = True
    pitch_keep: float = 1.0


@dataclass(frozen=True)
class PoseQualityModel:
    """Probability that a fitted pose comes out right, from its fit statistics.

    Right: the structure choice among the fit's candidates ends within 2 mm
    and 1° of the truth (the shipped calibration's model, since the
    seventeenth session; the defaults below, from before, describe the
    edge-best pose alone).

    A logistic regression on :data:`POSE_QUALITY_STATS` (``margin``,
    ``aligned``, ``present``, ``log(1 + score)``), fitted on rendered training
    scenes (:func:`unseeable.vision.training.calibrate`; shipped in the
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
class PoseFit:
    """An estimated pose and how well it fits.

    Attributes
    ----------
    pose : GridPose
        Yaw reported in ``[-90, 90)``: the half-turned pose (``pose.turned(2,
        extent)``) fits exactly as well and describes the same grid lines.
    quality : float
        In [0, 1]: the probability that the structure choice among
        ``candidates`` ends within 2 mm and 1° of the truth, from the fit
        statistics below (:class:`PoseQualityModel`).
    margin : float
        Relative alignment-score margin over the best pose that is not the same
        (another quarter turn, or more than half a log diameter away).
    aligned : float
        Share of the pose's feature samples lying within 0.75 px of a strong edge.
    present : float
        Share of feature samples on lines and rims that look present.
    score : float
        Alignment score (see :func:`_alignment_score`).
    yaw_mod90_deg : float
        The yaw modulo 90° from the vanishing directions alone.
    alternatives : tuple of (GridPose, float)
        The best pose of the other quarter-turn hypothesis and its score.
        When the footprint is square (I = K) a quarter turn fits the same
        lines after a translation; the estimator should try this pose too.
    candidates : tuple of (GridPose, float)
        ``pose`` and its aliases (:func:`pose_aliases`, each aligned on the
        image) whose alignment score is close to the best, with their scores:
        edges alone cannot tell these apart reliably;
        :func:`unseeable.vision.select_pose` lets the grammar decide.
    choice_margin : float or None
        Set by :func:`~unseeable.vision.select_pose`: how far the chosen
        candidate's value is ahead of its best rival's (the units of the
        choice's value; a rival is a candidate more than 2 mm or 1° from the
        chosen pose). None when there was no rival (a single candidate, or
        the pitch check moved the choice by its own clear margin). Below
        :data:`~unseeable.vision.pose_choice.AMBIGUOUS_CHOICE_MARGIN` the
        choice is close to a coin toss (:attr:`ambiguous`).
    choice_rival : GridPose or None
        That best rival (unpolished), when there was one: where the grid
        lies if the choice was wrong — what another view could rule out.
    """

    pose: GridPose
    quality: float
    margin: float
    aligned: float
    present: float
    score: float
    yaw_mod90_deg: float
    alternatives: tuple = field(default=())
    candidates: tuple = field(default=())
    choice_margin: float | None = None
    choice_rival: GridPose | None = None

    @property
    def ambiguous(self) -> bool:
        """Whether the structure choice among the candidates was a near coin toss."""
        from unseeable.vision.pose_choice import AMBIGUOUS_CHOICE_MARGIN

        return self.choice_margin is not None and self.choice_margin < AMBIGUOUS_CHOICE_MARGIN

    @property
    def stats(self) -> np.ndarray:
        """The statistics of :data:`POSE_QUALITY_STATS`, ``(4,)``."""
        return np.array([self.margin, self.aligned, self.present, np.log1p(max(self.score, 0))])

    def to_json(self) -> dict:
        data = {**self.pose.to_json(), "quality": self.quality}
        if self.choice_margin is not None:
            data.update(choice_margin=self.choice_margin, ambiguous=self.ambiguous)
        if self.choice_rival is not None:
            data["rival"] = self.choice_rival.to_json()
        return data


# ---------------------------------------------------------------------------
# yaw from vanishing directions


def line_segments(image: np.ndarray, *, min_length: float = 12.0) -> np.ndarray:
    """Straight edge segments of an image (OpenCV's LSD).

    Parameters
    ----------
    image : (H, W, 3) uint8
    min_length : float
        Shorter segments are dropped.

    Returns
    -------
    (L, 2, 2) float
        End points ``(x, y)``.
    """
    img = as_rgb_image(image)
    grey = cv2.cvtColor(img, cv2.COLOR_RGB2GRAY)
    lsd = cv2.createLineSegmentDetector(cv2.LSD_REFINE_STD)
    lines = lsd.detect(grey)[0]
    if lines is None:
        return np.zeros((0, 2, 2))
    seg = lines.reshape(-1, 2, 2).astype(float)
    length = np.linalg.norm(seg[:, 1] - seg[:, 0], axis=1)
    return seg[length >= min_length]


def _direction(psi_rad: np.ndarray | float) -> np.ndarray:
    """World horizontal direction of angle ψ: ``(cos ψ, 0, -sin ψ)`` (grid i at yaw ψ)."""
    psi = np.asarray(psi_rad, dtype=float)
    return np.stack([np.cos(psi), np.zeros_like(psi), -np.sin(psi)], axis=-1)


def segment_directions(segments: np.ndarray, camera: Camera) -> tuple[np.ndarray, np.ndarray]:
    """The horizontal world direction each image segment would be the image of.

    A horizontal world line of direction ``d(ψ) = (cos ψ, 0, -sin ψ)`` has its
    vanishing point at ``R d(ψ)`` (normalised coordinates); the segment's
    line ``l`` contains it when ``(Rᵀ l) · d(ψ) = 0``.

    Parameters
    ----------
    segments : (L, 2, 2) float
    camera : Camera

    Returns
    -------
    psi_deg : (L,) float
        In ``[0, 180)``; a grid at yaw ψ has its axes at ψ and ψ - 90.
    reliability : (L,) float
        In [0, 1]: near 0 for segments along the horizon, which fit any ψ.
    """
    seg = np.asarray(segments, dtype=float)
    if len(seg) == 0:
        return np.zeros(0), np.zeros(0)

    def directions(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        norm = camera.normalised(points)
        h = np.concatenate([norm, np.ones(norm.shape[:-1] + (1,))], axis=-1)
        line = np.cross(h[:, 0], h[:, 1])
        line /= np.linalg.norm(line, axis=1, keepdims=True)
        m = line @ camera.R  # Rᵀ l for each row
        return np.degrees(np.arctan2(m[:, 0], m[:, 2])) % 180.0, m

    psi, m = directions(seg)
    reliability = np.hypot(m[:, 0], m[:, 2]) / np.maximum(np.linalg.norm(m, axis=1), 1e-12)
    return psi, reliability


def _yaw_gap(a: float, b: float) -> float:
    """Distance in degrees between two yaws modulo 90° (a grid's two axes look alike)."""
    return abs((a - b + 45.0) % 90.0 - 45.0)


def _separated_peaks(grid: np.ndarray, values: np.ndarray, *, count: int,
                     separation_deg: float, where: np.ndarray | None = None) -> list[float]:
    """The ``grid`` yaws of the highest ``values`` (only ``where`` set), each at least
    ``separation_deg`` (modulo 90°) from every higher one kept, at most ``count``."""
    allowed = np.ones(len(values), bool) if where is None else where
    found: list[float] = []
    for b in np.argsort(-np.where(allowed, values, -np.inf)):
        if not allowed[b]:
            break
        y = float(grid[b])
        if all(_yaw_gap(y, o) > separation_deg for o in found):
            found.append(y)
            if len(found) == count:
                break
    return found


def _vote_density(psi_deg: np.ndarray, weights: np.ndarray, *, period_deg: float,
                  sigma_deg: float, step: float = 0.1) -> tuple[np.ndarray, np.ndarray]:
    """Direction votes as a circular density: ``(grid, density)``, ``step`` degrees apart."""
    grid = np.arange(0.0, period_deg, step)
    hist = np.bincount(np.round(psi_deg / step).astype(int) % len(grid), weights=weights,
                       minlength=len(grid))
    # Circular Gaussian smoothing via the FFT.
    freq = np.fft.rfftfreq(len(grid), d=step)
    kernel = np.exp(-2 * (np.pi * sigma_deg * freq) ** 2)
    return grid, np.maximum(np.fft.irfft(np.fft.rfft(hist) * kernel, n=len(grid)), 0.0)


def dominant_yaw(psi_deg: np.ndarray, weights: np.ndarray, *, sigma_deg: float = 0.75,
                 peaks: int = 1, separation_deg: float = 4.0) -> tuple:
    """The yaw modulo 90° whose two axis directions both collect strong votes.

    Parameters
    ----------
    psi_deg : (L,) float
        Directions voted for, degrees in [0, 180).
    weights : (L,) float
    sigma_deg : float
        Vote width.
    peaks : int
        With ``peaks > 1``, return the ``peaks`` best yaws (at least
        ``separation_deg`` apart, unrefined) and the best product instead.

    Returns
    -------
    yaw_mod90 : float
        Degrees in [0, 90).
    strength : float
        Geometric mean of the two directions' vote mass near the peak,
        relative to the total vote mass (0 when a direction has no votes).

    Examples
    --------
    >>> psi = np.array([10.0, 10.2, 100.1, 99.9, 45.0, 45.0, 45.0])
    >>> bool(abs(dominant_yaw(psi, np.ones(7))[0] - 10.05) < 0.1)
    True
    """
    psi = np.asarray(psi_deg, dtype=float) % 180.0
    w = np.asarray(weights, dtype=float)
    if len(psi) == 0 or w.sum() <= 0:
        raise VisionError("no straight edges in the image to fix the assembly's yaw")
    grid, smooth = _vote_density(psi, w, period_deg=180.0, sigma_deg=sigma_deg)
    half = len(grid) // 2
    product = smooth[:half] * smooth[half:]
    best = int(np.argmax(product))
    if peaks > 1:
        return (_separated_peaks(grid[:half], product, count=peaks,
                                 separation_deg=separation_deg), float(product[best]))
    # Refine: weighted circular mean of the votes near either direction, folded to 90°.
    folded = psi % 90.0
    centre = grid[best]
    diff = (folded - centre + 45.0) % 90.0 - 45.0
    near = np.abs(diff) < 2.5 * sigma_deg
    if near.any() and w[near].sum() > 0:
        centre = centre + float(np.sum(diff[near] * w[near]) / np.sum(w[near]))
    mass_a = smooth[best] * np.sqrt(2 * np.pi) * sigma_deg
    mass_b = smooth[best + half] * np.sqrt(2 * np.pi) * sigma_deg
    strength = float(np.sqrt(max(mass_a, 0) * max(mass_b, 0)) / max(w.sum(), 1e-12))
    return float(centre % 90.0), strength


def axis_yaws(psi_deg: np.ndarray, weights: np.ndarray, *, sigma_deg: float = 0.75,
              peaks: int = 2, separation_deg: float = 2.0) -> list[float]:
    """Yaws modulo 90° at which *either* axis direction collects a peak of votes.

    :func:`dominant_yaw` wants both of the grid's directions; seen with one
    axis nearly across the line of sight, that axis's edges run along the
    horizon, where a segment fits any direction (its votes are weighed
    out), and the product of the two directions' votes peaks elsewhere.
    The local maxima of the folded sum still mark the other axis.

    Parameters
    ----------
    psi_deg : (L,) float
        Directions voted for, degrees in [0, 180).
    weights : (L,) float
    sigma_deg : float
        Vote width.
    peaks : int
        Yaws returned, strongest first.
    separation_deg : float
        Minimum distance between them (modulo 90°).

    Returns
    -------
    list of float
        Degrees in [0, 90); empty when there are no votes.

    Examples
    --------
    >>> psi = np.array([10.0, 10.2, 9.9, 137.0])
    >>> [round(y, 1) for y in axis_yaws(psi, np.ones(4))]
    [10.0, 47.0]
    """
    psi = np.asarray(psi_deg, dtype=float) % 90.0
    w = np.asarray(weights, dtype=float)
    if len(psi) == 0 or w.sum() <= 0 or peaks <= 0:
        return []
    grid, votes = _vote_density(psi, w, period_deg=90.0, sigma_deg=sigma_deg)
    is_max = (votes >= np.roll(votes, 1)) & (votes > np.roll(votes, -1)) & (votes > 0)
    return _separated_peaks(grid, votes, count=peaks, separation_deg=separation_deg,
                            where=is_max)


# ---------------------------------------------------------------------------
# grid lines of a pose hypothesis


def _stretches(i: np.ndarray, j: np.ndarray, k: np.ndarray, geometry: LogGeometry,
               trim_w: float = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Grid-frame axis stretches of the u, v, w segments at positions ``(i, j, k)`` (each (P,)).

    Returns ``(start (3P, 3), stop (3P, 3), kind (3P,))`` with kind 0/1/2 for u/v/w; u and v
    keep only the part outside the notch slot.
    """
    g = geometry
    centre = np.stack([i * g.l1, g.layer_height(j), k * g.l1], axis=1).astype(float)
    axis = np.zeros_like(centre)
    even = j % 2 == 0
    axis[even, 0] = 1.0
    axis[~even, 2] = 1.0
    lo = np.array([-g.l3, g.radius, g.l3 + trim_w])
    hi = np.array([-g.radius, g.l3, g.l1 - g.l3 - trim_w])
    start = centre[:, None, :] + lo[None, :, None] * axis[:, None, :]
    stop = centre[:, None, :] + hi[None, :, None] * axis[:, None, :]
    kind = np.broadcast_to(np.arange(3), (len(i), 3))
    return start.reshape(-1, 3), stop.reshape(-1, 3), kind.reshape(-1)


def grid_lines(extent: Extent, pose: GridPose, camera: Camera, *,
               geometry: LogGeometry = LogGeometry(),
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Silhouette lines of every log any assembly on the grid could have.

    For every grid position of layers ``0..J-1`` and each of its ``u``,
    ``v``, ``w`` stretches (``w`` past the last notch position left out;
    ``u`` and ``v`` only outside the notch slot, as the detectors do), the
    lower and the upper silhouette seen from the camera: together every
    horizontal edge a log of the grid can make.

    Parameters
    ----------
    extent : Extent
    pose : GridPose
    camera : Camera
    geometry : LogGeometry

    Returns
    -------
    lines : (L, 2, 3) float
        World end points: all lower silhouettes, then the upper ones of the
        same stretches in the same order.
    layer_axis : (L,) int
        0 for lines along grid i (even layers), 1 along grid k.
    upper : (L,) bool
        Upper silhouettes (False: lower silhouettes).
    """
    from unseeable.vision.projection import upper_silhouette

    wa, wb, axis = _world_stretches(extent, pose, geometry)
    la, lb = lower_silhouette(wa, wb, camera.centre, geometry.radius)
    ua, ub = upper_silhouette(wa, wb, camera.centre, geometry.radius)
    lines = np.concatenate([np.stack([la, lb], 1), np.stack([ua, ub], 1)])
    upper = np.repeat([False, True], len(wa))
    return lines, np.tile(axis, 2), upper


def _upper_lines(extent: Extent, pose: GridPose, camera: Camera, geometry: LogGeometry
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The upper silhouettes of :func:`grid_lines` ``(L, 2, 3)``, their layer axes ``(L,)``
    and the world midpoints of their logs' axis stretches ``(L, 3)`` (a point inside each
    log, for telling its outside)."""
    from unseeable.vision.projection import upper_silhouette

    wa, wb, axis = _world_stretches(extent, pose, geometry)
    ua, ub = upper_silhouette(wa, wb, camera.centre, geometry.radius)
    return np.stack([ua, ub], 1), axis, (wa + wb) / 2.0


def _world_stretches(extent: Extent, pose: GridPose, geometry: LogGeometry
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The axis stretches of :func:`_grid_stretches` in the world at ``pose`` (start,
    stop ``(L, 3)``) and their layer axes ``(L,)`` (0 along grid i, 1 along grid k)."""
    start, stop, along_k = _grid_stretches(extent, geometry)
    return pose.grid_to_world(start), pose.grid_to_world(stop), along_k.astype(int)


@functools.lru_cache(maxsize=64)
def _grid_stretches(extent: Extent, geometry: LogGeometry
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Grid-frame axis stretches of :func:`grid_lines` (start, stop ``(L, 3)``, and
    whether each runs along grid k ``(L,)``): the same for every pose, so made once per
    extent (read-only)."""
    I, J, K = extent.shape
    ii, jj, kk = (a.ravel() for a in np.meshgrid(np.arange(I), np.arange(J), np.arange(K),
                                                  indexing="ij"))
    start, stop, kind = _stretches(ii, jj, kk, geometry)
    pi, pj, pk = (np.repeat(a, 3) for a in (ii, jj, kk))
    even = pj % 2 == 0
    last = np.where(even, pi == I - 1, pk == K - 1)
    keep = ~((kind == 2) & last)
    out = (start[keep], stop[keep], ~even[keep])
    for a in out:
        a.setflags(write=False)
    return out


def pose_lines(extent: Extent, pose: GridPose, camera: Camera, *,
               geometry: LogGeometry = LogGeometry()) -> tuple[np.ndarray, np.ndarray]:
    """World end points ``(L, 2, 3)`` and layer axes ``(L,)`` of the extent's silhouette lines.

    See :func:`grid_lines`.
    """
    lines, axis, _ = grid_lines(extent, pose, camera, geometry=geometry)
    return lines, axis


def _sample_lines(lines: np.ndarray, camera: Camera, spacing_px: float,
                  max_per_line: int = 64) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points along world lines, about ``spacing_px`` apart in the image.

    Returns
    -------
    points : (M, 3), tangent : (M, 3) unit world directions, line : (M,) int index
    """
    uv = camera.project(lines)
    length = np.linalg.norm(uv[:, 1] - uv[:, 0], axis=1)
    length = np.nan_to_num(length, nan=0.0)
    counts = np.clip(np.ceil(length / spacing_px).astype(int), 1, max_per_line)
    line_id = np.repeat(np.arange(len(lines)), counts)
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    pos = np.arange(len(line_id)) - np.repeat(starts, counts)
    frac = (pos + 0.5) / np.repeat(counts, counts)
    a = lines[line_id, 0]
    b = lines[line_id, 1]
    pts = a + frac[:, None] * (b - a)
    d = b - a
    tangent = d / np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-12)
    return pts, tangent, line_id


# ---------------------------------------------------------------------------
# edge evidence for the search


@dataclass(frozen=True, eq=False)
class _FamilyEdges:
    edges: np.ndarray  # (2, H, W) bool: edge pixels consistent with family 0 / 1
    dist: np.ndarray  # (2, H, W) float32 distance to the nearest such edge pixel
    strong: np.ndarray  # (H, W) bool strong edges of either family
    yaw_base: float  # family 0 runs along d(yaw_base), family 1 along d(yaw_base - 90)


@dataclass(frozen=True, eq=False)
class _Edges:
    """Canny edge pixels of an image (any direction) with their gradient directions."""

    edges: np.ndarray  # (H, W) bool
    xs: np.ndarray  # (P,) int
    ys: np.ndarray
    nx: np.ndarray  # (P,) unit gradient direction
    ny: np.ndarray
    strength: np.ndarray  # (H, W) float32
    high: float  # the hysteresis high threshold (strength units)


def _canny(maps: EdgeMaps) -> _Edges:
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
    return _Edges(edges, xs, ys, np.cos(angle[ys, xs]), np.sin(angle[ys, xs]), strength, high)


def _family_edges(maps: EdgeMaps | _Edges, camera: Camera, yaw_base_deg: float, *,
                  tol_deg: float) -> _FamilyEdges:
    """Edge pixels along each of the grid's two horizontal directions at ``yaw_base_deg``.

    A pixel belongs to a family when its edge runs towards that direction's
    vanishing point (within ``tol_deg``); distance transforms of each family follow.
    """
    e = maps if isinstance(maps, _Edges) else _canny(maps)
    h, w = e.edges.shape
    fam = np.zeros((2, h, w), dtype=bool)
    sin_tol = np.sin(np.deg2rad(tol_deg))
    for f in range(2):
        d = _direction(np.deg2rad(yaw_base_deg - 90.0 * f))
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
    return _FamilyEdges(fam, dist, strong, float(yaw_base_deg))


def _line_families(layer_axis: np.ndarray, yaw_deg: float, yaw_base_deg: float) -> np.ndarray:
    """Edge family of each line: 0 when it runs along ``d(yaw_base)``, else 1."""
    along_base = abs(float(_direction(np.deg2rad(yaw_deg)) @ _direction(np.deg2rad(yaw_base_deg))))
    i_family = 0 if along_base > 0.7 else 1
    return np.where(np.asarray(layer_axis) == 0, i_family, 1 - i_family)


# ---------------------------------------------------------------------------
# the estimator


def _centre_grid(extent: Extent, geometry: LogGeometry) -> np.ndarray:
    return np.array([(extent.I - 1) * geometry.l1 / 2, 0.0, (extent.K - 1) * geometry.l1 / 2])


def _pose_from_centre(centre_xz: np.ndarray, yaw_deg: float, extent: Extent,
                      geometry: LogGeometry) -> GridPose:
    rot = GridPose(0.0, 0.0, yaw_deg).rotation
    origin = np.array([centre_xz[0], 0.0, centre_xz[1]]) - rot @ _centre_grid(extent, geometry)
    return GridPose(float(origin[0]), float(origin[2]), float(yaw_deg))


# ---------------------------------------------------------------------------
# verification: how well a pose's lines sit on image edges


# ---------------------------------------------------------------------------
# coarse placement: where the wood is


def _saliency_region(fam: _FamilyEdges, *, blur_px: float = 15.0,
                     level: float = 0.35) -> np.ndarray:
    """``(H, W) bool``: where edges along the grid's two directions crowd (the assembly)."""
    strong = (fam.edges[0] | fam.edges[1]).astype(np.float32)
    density = cv2.GaussianBlur(strong, (0, 0), blur_px)
    top = float(density.max())
    if top <= 0:
        raise VisionError("no edges along two perpendicular horizontal directions: "
                          "is an assembly in view?")
    return density > level * top


def _concentrated_wood(image: np.ndarray, canny: _Edges, camera: Camera, yaws: list[float], *,
                       tol_deg: float, lead: float = 0.1) -> tuple[np.ndarray, _FamilyEdges, float]:
    """The wood map (:func:`woodness_map`) learnt in the saliency region of one of
    ``yaws``, by how much of its wood lies inside that region: ``(wood, family edges, yaw)``.

    The first yaw is kept unless another's wood lies mostly (half or more) inside its
    region, and by a share at least ``lead`` more: where the colours of the logs and
    the table are close, every model is poor, and the planks' edges crowd most.
    """
    best = None
    lab = cv2.cvtColor(image, cv2.COLOR_RGB2Lab)  # once for every yaw's model
    for yaw in yaws:
        fam = _family_edges(canny, camera, yaw, tol_deg=tol_deg)
        region = _saliency_region(fam)
        wood = woodness_map(image, region, lab=lab)
        inside = float(wood[region].sum() / max(float(wood.sum()), 1e-9))
        logger.debug("wood learnt at yaw %.1f°: %.3f of it inside its region", yaw, inside)
        if best is None or (inside >= 0.5 and inside > best[0] + lead):
            best = (inside, wood, fam, yaw)
        if best[0] + lead >= 1.0:
            break  # nothing can displace it
    assert best is not None
    return best[1], best[2], best[3]


def _footprint_search(wood: np.ndarray, camera: Camera, extent: Extent, yaw_deg: float,
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
    i_dir = _direction(np.deg2rad(yaw_deg))
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


def _dense_candidates(fam: _FamilyEdges, any_dist: np.ndarray, camera: Camera, extent: Extent,
                      geometry: LogGeometry, centre_xz: np.ndarray, yaw_deg: float, *,
                      reach_mm: float, step_mm: float, spacing: float, truncation: float,
                      keep: int, separation_mm: float, cache: dict | None = None,
                      fine_step_mm: float = 0.0) -> list[tuple[float, GridPose]]:
    """Best translations near ``centre_xz`` by edge support of upper silhouettes and end rims."""
    pose0 = _pose_from_centre(centre_xz, yaw_deg, extent, geometry)
    lines, axis, _ = _upper_lines(extent, pose0, camera, geometry)
    pts, _, lid = _sample_lines(lines, camera, spacing)
    channel = _line_families(axis, yaw_deg, fam.yaw_base)[lid]
    rim_grid = _end_rims(extent, pose0, camera, geometry, points=8)[0]
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


def _shifted(pose: GridPose, dx_mm: float, dz_mm: float) -> GridPose:
    """``pose`` moved by ``(dx_mm, dz_mm)`` along its own grid axes."""
    shift = pose.rotation @ np.array([dx_mm, 0.0, dz_mm])
    return GridPose(pose.x + float(shift[0]), pose.z + float(shift[2]), pose.yaw_deg)


def _checked_view(image: np.ndarray, camera: Camera, extent: Extent
                  ) -> tuple[np.ndarray, Camera]:
    """The RGB image and camera the pose search looks at (:func:`pose_view`, which also
    checks that the image is the camera's size)."""
    view = pose_view(as_rgb_image(image), camera)
    if not isinstance(extent, Extent):
        raise InputError("must be an Extent", field="extent", value=extent)
    return view


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
        Raise :class:`VisionError` when the fit quality is below
        ``settings.min_quality`` (else return the poor fit).
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
        No usable straight edges, the assembly is not in view, or the fit is poor.
    """
    img, camera = _checked_view(image, camera, extent)
    threads = check_whole_number(threads, field="threads", minimum=1)
    st = settings
    if maps is None or maps.shape != img.shape[:2]:
        maps = edge_maps(img, sigma=st.sigma)

    # 1. yaw modulo 90° from vanishing directions.
    segs = line_segments(img, min_length=st.min_segment_px)
    psi, reliable = segment_directions(segs, camera)
    length = np.linalg.norm(segs[:, 1] - segs[:, 0], axis=1) if len(segs) else np.zeros(0)
    weights = length * reliable**2
    yaw0, yaw_strength = dominant_yaw(psi, weights, sigma_deg=st.yaw_sigma_deg)
    logger.debug("yaw mod 90: %.2f° (strength %.3f, %d segments)", yaw0, yaw_strength, len(segs))

    canny = _canny(maps)
    # The colour model of the wood is learnt where the edges of a yaw hypothesis crowd. The
    # first vote can be the table's planks' (long parallel lines, often joined at the far
    # end by the perpendicular seams): then the "wood" learnt is the table's grain, spread
    # all over it. The next peaks are tried too, and a model whose wood lies mostly inside
    # the region it was learnt from (clearly more than the first's) replaces it.
    first_peaks, _ = dominant_yaw(psi, weights, sigma_deg=st.yaw_sigma_deg,
                                  peaks=st.yaw_peaks)
    wood_yaws = [yaw0]
    for y in first_peaks:
        if len(wood_yaws) < st.wood_yaw_tries and all(_yaw_gap(y, o) > 5.0 for o in wood_yaws):
            wood_yaws.append(y)
    wood, fam, yaw0 = _concentrated_wood(img, canny, camera, wood_yaws,
                                         tol_deg=st.orientation_tol_deg)
    # Again, with each segment's vote weighted by how much wood lies beside it: the
    # assembly's edges count, the table's grain and the room's lines do not.
    if len(segs):
        near_wood = cv2.dilate(wood, np.ones((7, 7), np.uint8))
        t = np.linspace(0.0, 1.0, 7)
        pts = segs[:, 0, None, :] + t[None, :, None] * (segs[:, 1] - segs[:, 0])[:, None, :]
        on_wood = sample_maps(near_wood[..., None], pts)[..., 0].mean(axis=1)
        if np.sum(on_wood > 0.5) >= 4:
            weights = length * reliable**2 * on_wood**2
            yaw0, yaw_strength = dominant_yaw(psi, weights, sigma_deg=st.yaw_sigma_deg)
            fam = _family_edges(canny, camera, yaw0, tol_deg=st.orientation_tol_deg)
    centre_pt = table_point(camera, np.array([[camera.width / 2, camera.height / 2]]),
                             float(geometry.layer_height(extent.J - 1)) / 2)[0]
    if not np.all(np.isfinite(centre_pt)):
        raise VisionError("the camera does not see the table")
    mm_per_px = float(camera.depth(centre_pt[None])[0]) / float(camera.K[0, 0])

    # 2. For each yaw hypothesis (the best peaks of the vanishing-direction votes) and
    #    quarter turn: coarse placement from the wood the footprint covers, then the
    #    translations near it whose upper silhouettes and end rims lie on the most image
    #    edges of their own direction.
    yaws, _ = dominant_yaw(psi, weights, sigma_deg=st.yaw_sigma_deg, peaks=st.yaw_peaks)
    if not any(_yaw_gap(y, yaw0) < 0.5 for y in yaws):
        yaws = [yaw0, *yaws[:-1]]
    # One axis's edges along the horizon vote for nothing: the other axis's peaks go on too.
    yaws += [y for y in axis_yaws(psi, weights, sigma_deg=st.yaw_sigma_deg,
                                  peaks=st.axis_peaks)
             if all(_yaw_gap(y, o) > 1.0 for o in yaws)]
    if st.thin_yaw_step_deg > 0 and min(extent.I, extent.K) == 1:
        # A single wall: its cross-axis edges (log ends) are too short to vote, and its
        # long lines can be few and short; yaws every few degrees go on to the search.
        yaws += [y for y in np.arange(0.0, 90.0, st.thin_yaw_step_deg)
                 if all(_yaw_gap(y, o) > st.thin_yaw_step_deg / 2 for o in yaws)]
    any_dist = cv2.distanceTransform((~canny.edges).astype(np.uint8), cv2.DIST_L2, 3)
    placements: dict = {}
    families = {round(yaw0 % 90.0, 3): fam}
    support_cache: dict = {}

    def fam_for(yaw: float) -> _FamilyEdges:
        # Edge families are recomputed only when the yaw is a few degrees from every known one.
        key = round(yaw % 90.0, 3)
        base = min(families, key=lambda b: _yaw_gap(b, key))
        if _yaw_gap(base, key) > 3.0:
            families[key] = _family_edges(canny, camera, yaw, tol_deg=st.orientation_tol_deg)
            base = key
        return families[base]

    def dense(jobs: list, rank: int, region_scores: list) -> list:
        """The best translations for each ``(yaw, o, peak)`` of ``jobs``, in their order:
        the placements first, one by one, then the searches (on threads)."""
        searches = []
        for yaw, o, peak in jobs:
            # One placement per yaw peak: a degree or two hardly moves the footprint's centre.
            if (o, peak, rank) not in placements:
                found = _footprint_search(wood, camera, extent, yaw, geometry, rank=rank)
                if found is not None:
                    coarse, covered = found
                    region_scores[o] = max(region_scores[o], covered)
                    found = coarse.grid_to_world(_centre_grid(extent, geometry))[[0, 2]]
                placements[(o, peak, rank)] = found
            centre = placements[(o, peak, rank)]
            searches.append(None if centre is None else (fam_for(yaw), centre, yaw))

        def search(job: tuple | None) -> list:
            if job is None:
                return []
            fam_y, centre, yaw = job
            return _dense_candidates(fam_y, any_dist, camera, extent, geometry, centre, yaw,
                                     reach_mm=st.local_reach_mm, step_mm=st.dense_step_mm,
                                     spacing=st.sample_spacing_px,
                                     truncation=st.dense_truncation_px, keep=st.verify_keep,
                                     separation_mm=st.candidate_spacing_mm,
                                     cache=support_cache, fine_step_mm=st.fine_step_mm)

        return map_in_threads(search, searches, threads=threads)

    def align(pose_c: GridPose, iterations: int, *,
              screen: bool = False) -> tuple[float, GridPose, _EdgeMatches]:
        # A screen scores the refined pose with the samples of the pose it started from
        # (the same features a few millimetres away): one sampling of the grid saved.
        samples = (_feature_samples(extent, pose_c, camera, geometry,
                                    spacing=st.sample_spacing_px, edge_bias_px=_EDGE_BIAS_PX,
                                    use_ends=True) if screen else None)
        return _aligned(maps, camera, extent, geometry, pose_c, settings=st,
                        mm_per_px=mm_per_px, iterations=iterations, samples=samples)

    def ring_tops(centres: list[GridPose], steps_mm: tuple[float, ...]) -> list[GridPose]:
        """For each of ``centres``, the best of the screened alignments started at the 8
        translations each of ``steps_mm`` around it (rings of a square grid in its own
        grid frame)."""
        ring = [(dx, dz) for step in steps_mm
                for dx in (-step, 0.0, step) for dz in (-step, 0.0, step) if dx or dz]
        starts = [_shifted(c, dx, dz) for c in centres for dx, dz in ring]
        looked = map_in_threads(lambda p: align(p, st.screen_iterations, screen=True),
                                starts, threads=threads)
        # Each centre's starts are one block of ``len(ring)``.
        return [max(looked[k * len(ring):(k + 1) * len(ring)], key=lambda r: r[0])[1]
                for k in range(len(centres))]

    def restarted(finals: list) -> list:
        """The best ``restart_keep`` finals, each replaced by the best of the alignments
        started ``restart_mm`` around it when one scores higher (then re-sorted)."""
        if not st.restart_mm:
            return finals
        seeds = [n for n, c in enumerate(finals) if not c[4]][: st.restart_keep]
        tops = list(zip(seeds, ring_tops([finals[n][2] for n in seeds], st.restart_mm)))
        out = list(finals)
        for (n, _), (sc, refined, matches) in zip(
                tops, map_in_threads(lambda t: align(t[1], 8), tops, threads=threads)):
            if sc > out[n][0]:
                logger.debug("restart moved candidate %d by %.1f mm: score %.1f -> %.1f", n,
                             np.hypot(refined.x - out[n][2].x, refined.z - out[n][2].z),
                             out[n][0], sc)
                out[n] = (sc, out[n][1], refined, matches, out[n][4])
        out.sort(key=lambda c: -c[0])
        return out

    def fit_at(rank: int) -> tuple | None:
        """Steps 2 and 3 around the ``rank``-th wood cluster (None: there is no such cluster)."""
        region_scores = [0.0, 0.0]
        screened = []
        # ``o``: which of the two quarter-turn families the yaw belongs to (grid i nearer
        # world x, or nearer z), the same for every yaw peak.
        looks = [(y, turn, int(((y + 90.0 * turn + 45.0) % 180.0) // 90.0))
                 for y in yaws for turn in (0, 1)]
        for (y, turn, o), found in zip(looks, dense([(y + 90.0 * turn, o, y)
                                                     for y, turn, o in looks],
                                                    rank, region_scores)):
            screened.append((found[0][0] if found else 0.0, y, turn, o, found))
        screened.sort(key=lambda c: -c[0])
        pool: dict[int, list] = {0: [], 1: []}
        kept_yaws = screened[: st.yaw_keep]
        nearly_square = (abs(extent.I - extent.K) == 1
                         and min(extent.I, extent.K) >= st.near_square_side)
        if st.quarter_turn_aliases and (extent.I == extent.K or nearly_square):
            # On a square footprint the other quarter turn fits the same lines after a depth
            # shift (on a large, nearly square one nearly), and its first look is no guide:
            # both turns of every kept peak go on.
            peaks = {c[1] for c in kept_yaws}
            kept_yaws += [c for c in screened[st.yaw_keep:] if c[1] in peaks]
        deltas = [d for d in st.yaw_offsets_deg if d != 0.0]
        nearby = iter(dense([(y + d + 90.0 * turn, o, y) for _, y, turn, o, _ in kept_yaws
                             for d in deltas], rank, region_scores))
        for *_, o, found in kept_yaws:
            pool[o] += found
            for _ in deltas:
                pool[o] += next(nearby)
        candidates = []
        for o in (0, 1):
            kept: list = []
            for sc, p in sorted(pool[o], key=lambda c: -c[0]):
                if all(np.hypot(p.x - q.x, p.z - q.z) > st.candidate_spacing_mm
                       or abs(p.yaw_deg - q.yaw_deg) > 0.75 for _, q in kept):
                    kept.append((sc, p))
                if len(kept) == st.verify_keep:
                    break
            candidates += [(o, p) for _, p in kept]

        # 3. Each candidate is aligned precisely with its image edges; the pose whose features
        #    lie most coherently on edges wins.
        cover = np.asarray(region_scores)
        if cover.max() <= 0 or not candidates:
            return None

        # A few alignment steps for every candidate, all of them for the most promising.
        # (A quarter turn whose footprint covers clearly less wood than the other's
        # candidates is not aligned. Only turns with candidates compare: when the yaw peaks
        # kept are all of one turn, the other's cover must not rule them all out.)
        top_cover = max(cover[o] for o, _ in candidates)
        looked = [(o, pose_c) for o, pose_c in candidates
                  if cover[o] >= st.cover_ratio * top_cover]
        aligned = map_in_threads(lambda c: align(c[1], st.screen_iterations), looked,
                                 threads=threads)
        screened = [(sc, o, refined) for (o, _), (sc, refined, _) in zip(looked, aligned)]
        screened.sort(key=lambda c: -c[0])
        finals = []
        chosen = [(*c, False) for c in screened[: st.align_keep]]
        if st.quarter_turn_aliases and extent.I == extent.K:
            # A square footprint's other quarter turn fits the same lines after a translation;
            # its best candidate is aligned fully too, so that it (and its aliases) can compete.
            for o in {c[1] for c in screened} - {c[1] for c in chosen}:
                chosen.append((*next(c for c in screened if c[1] == o), True))
        for (_, o, _, forced), (sc, refined, matches) in zip(
                chosen, map_in_threads(lambda c: align(c[2], 8), chosen, threads=threads)):
            finals.append((sc, o, refined, matches, forced))
        if not finals:
            return None
        finals.sort(key=lambda c: -c[0])
        if st.restart_keep > 0:
            finals = restarted(finals)
        best_score, best_o, pose, best_matches, _ = finals[0]
        competitor = 0.0
        for sc, o, pose_c, _, forced in finals[1:]:
            # A candidate the screening dropped and that was brought back only to be offered
            # to the structure choice does not lower the fit's margin: aligned fully, the other
            # quarter turn always comes close, and counting it refused mostly right poses.
            far = np.hypot(pose_c.x - pose.x, pose_c.z - pose.z) > geometry.l2 / 2
            if not forced and (o != best_o or far):
                competitor = max(competitor, sc)
        margin = float((best_score - competitor) / max(abs(best_score), 1e-9))
        h2 = next((c for c in finals if c[1] != best_o), None)

        m = best_matches
        close = m.on_edges()
        aligned_share = float(close.mean()) if len(close) else 0.0
        present = float(np.mean(m.presence > 0.5)) if len(m.presence) else 0.0
        edge_best = pose
        pose = _canonical(pose, extent, geometry)
        alternatives = []
        if h2 is not None:
            alternatives.append((_canonical(h2[2], extent, geometry), h2[0]))
        stats = np.array([margin, aligned_share, present, np.log1p(max(best_score, 0.0))])
        model = quality_model if quality_model is not None else _default_quality_model()
        quality = float(model.probability(stats))
        # Wood well outside the extent's box: the extent (or the pose) cannot be right.
        outside = _wood_outside(wood, camera, extent, pose, geometry, image=img)
        quality *= float(np.clip(1.0 - (outside - st.wood_outside_ok) / st.wood_outside_ok, 0, 1))
        logger.debug("pose %s quality %.3f (margin %.3f, aligned %.3f, present %.3f)", pose,
                     quality, margin, aligned_share, present)
        return (quality, pose, edge_best, best_score, margin, aligned_share, present, h2,
                alternatives, finals)

    # A poor fit may have searched the wrong wood (a table plank of the logs' colour can
    # outweigh a small assembly): the next clusters are searched too, the best fit kept.
    fits = [fit_at(0)]
    if fits[0] is None:
        raise VisionError("no pose hypothesis could be aligned with the image's edges")
    for rank in range(1, st.other_placements + 1):
        if max(f[0] for f in fits) >= max(st.min_quality, st.placement_quality):
            break
        found = fit_at(rank)
        if found is None:
            break
        logger.debug("wood cluster %d: quality %.3f", rank, found[0])
        fits.append(found)
    (quality, pose, edge_best, best_score, margin, aligned_share, present, h2,
     alternatives, finals) = max(fits, key=lambda f: f[0])
    if strict and quality < st.min_quality:
        raise VisionError(f"poor pose fit (quality {quality:.2f} < {st.min_quality}); "
                          f"is the whole assembly in view and the extent {extent} right?")

    # 4. The grid's near-symmetries: translations along a grid axis that move the image of
    #    the other axis's lines as rising a half-layer or two would. Edges score them
    #    almost alike; the close ones go to the caller, for the grammar to decide. (Only
    #    for a fit that is returned: a refused one needs none.)
    aliases: list[tuple[GridPose, float]] = []
    # On a square footprint the other quarter turn's grid has the same lines after a
    # translation: its best pose and that pose's aliases compete too.
    tries = pose_aliases(edge_best, camera, extent, layers=st.alias_layers, geometry=geometry)
    if st.quarter_turn_aliases and extent.I == extent.K:
        if h2 is not None:
            tries += pose_aliases(h2[2], camera, extent, layers=st.alias_layers,
                                  geometry=geometry)
            if h2[0] >= st.alias_keep * best_score:
                aliases.append((h2[2], float(h2[0])))
        # The other quarter turn in the same place, and its aliases: that turn's own search
        # misses it when its yaw peak was poor.
        if st.turned_twin:
            turned, _ = edge_best.turned(1, extent, geometry)
            tries += [turned, *pose_aliases(turned, camera, extent, layers=st.alias_layers,
                                            geometry=geometry)]

    def novel(p: GridPose) -> bool:
        return all(np.hypot(p.x - q.x, p.z - q.z) > 1.0 or abs(p.yaw_deg - q.yaw_deg) > 0.3
                   for q in [edge_best, *(a for a, _ in aliases)])

    if st.finals_keep > 0:
        # The other fully aligned candidates that score nearly as well: edges alone cannot
        # tell them from the best (they are often the grid's near-symmetries at another
        # start), the structure they imply may.
        for sc, _, pose_c, _, forced in finals[1:]:
            if not forced and sc >= st.finals_keep * best_score and novel(pose_c):
                aliases.append((pose_c, float(sc)))
    # A few steps first: most aliases land on nothing and are dropped there.
    looked = map_in_threads(lambda p: align(p, st.screen_iterations, screen=True), tries,
                            threads=threads)
    passed = [refined for sc, refined, _ in looked if sc >= st.alias_screen * best_score]
    if st.pitch_aliases:
        # The grid a whole pitch off along either axis or both: its lines fall on the true
        # grid's, and the translation search's peaks can sit a pitch from the truth. Only
        # the best of those, and only when the edges prefer it to the best pose: on a big
        # periodic grid a pitch shift fits nearly as well (0.80-0.84 of the best on the
        # big cabins), and each candidate costs the structure choice a solve.
        (start,) = ring_tops([edge_best], (geometry.l1,))
        sc, refined, _ = align(start, 8)
        if sc >= st.pitch_keep * best_score and novel(refined):
            aliases.append((refined, sc))
    for sc, refined, _ in map_in_threads(lambda p: align(p, 8), passed, threads=threads):
        if sc >= st.alias_keep * best_score and novel(refined):
            aliases.append((refined, sc))
    aliases.sort(key=lambda c: -c[1])
    # The edge-best pose stays first (an alias refined onto stray edges can outscore it).
    candidates = [(pose, float(best_score))] + [(_canonical(p, extent, geometry), float(sc))
                                                 for p, sc in aliases]
    return PoseFit(pose, quality, float(margin), aligned_share, present, float(best_score),
                   float(yaw0), tuple(alternatives), tuple(candidates))


def pose_aliases(pose: GridPose, camera: Camera, extent: Extent, *,
                 layers: tuple[int, ...] = (1, 2),
                 geometry: LogGeometry = LogGeometry()) -> list[GridPose]:
    """Translations of ``pose`` whose grid lines nearly coincide with its own in the image.

    Seen from elevation ``e``, a horizontal line moved a distance ``s``
    across itself, along a direction at angle θ to the horizontal viewing
    direction, has the image it would have raised by ``s tan e / cos θ``
    (the motion keeps it in the plane through the line and the camera).
    Layers are ``l2 / 2`` apart, so a grid translated along one of its axes
    by ``n (l2 / 2) cos θ / tan e`` puts the other axis's lines ``n``
    half-layers up or down, onto lines the grid has too, while the lines
    along the axis itself only slide along themselves. Only the ends, the
    gaps at the notches and the bottom and top layers tell such poses apart.
    (``cos θ`` is kept at 0.7 or more: the alignment that follows finds the
    exact optimum from a few millimetres away.)

    Parameters
    ----------
    pose : GridPose
    camera : Camera
    extent : Extent
    layers : tuple of int
        Half-layer counts ``n``.
    geometry : LogGeometry

    Returns
    -------
    list of GridPose
        ``4 * len(layers)`` poses: ``± n`` along grid ``i``, then along ``k``.

    Examples
    --------
    >>> from unseeable.domain import Extent, GridPose
    >>> cam = Camera.look_at(eye=[0, 500, -600], target=[0, 0, 0], width=160, height=120,
    ...                      fov_deg=40)
    >>> len(pose_aliases(GridPose(-64, -64, 0), cam, Extent(3, 3, 3)))
    8
    """
    centre = pose.grid_to_world(_centre_grid(extent, geometry))
    centre[1] = float(geometry.layer_height(extent.J - 1)) / 2.0
    view = centre - camera.centre
    horizontal = np.hypot(view[0], view[2])
    if horizontal < 1e-9 or view[1] >= 0:
        return []  # looking straight down (or up): no such near-symmetry
    tan_e = -view[1] / horizontal
    out = []
    for axis in (0, 2):
        direction = pose.rotation[:, axis]
        cosine = max(abs(direction[0] * view[0] + direction[2] * view[2]) / horizontal, 0.7)
        for n in layers:
            step = n * geometry.radius * cosine / tan_e
            for sign in (-1.0, 1.0):
                move = sign * step * direction
                out.append(GridPose(pose.x + float(move[0]), pose.z + float(move[2]),
                                    pose.yaw_deg))
    return out


def _canonical(pose: GridPose, extent: Extent, geometry: LogGeometry) -> GridPose:
    """The pose or its half turn, whichever has its yaw in [-90, 90)."""
    y = (pose.yaw_deg + 180.0) % 360.0 - 180.0
    if -90.0 <= y < 90.0:
        return GridPose(pose.x, pose.z, y)
    turned, _ = pose.turned(2, extent, geometry)
    y2 = (turned.yaw_deg + 180.0) % 360.0 - 180.0
    return GridPose(turned.x, turned.z, y2)


def _disc_rims(centre: np.ndarray, normal: np.ndarray, pose: GridPose, camera: Camera,
               geometry: LogGeometry, points: int = 16
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Rims of the end discs ``(D, 3)`` (grid frame, outward ``normal``) facing the camera.

    Returns
    -------
    rim : (E*R, 3) points, tangent : (E*R, 3) unit rim directions,
    centre : (E*R, 3) the disc centre of each point, group : (E*R,) index among the
    facing discs, facing : (E,) indices of those discs in the input
    """
    cw = pose.grid_to_world(centre)
    facing = np.flatnonzero(
        np.sum((camera.centre - cw) * pose.directions_to_world(normal), axis=1) > 0)
    centre, normal = centre[facing], normal[facing]
    t = np.linspace(0.0, 2 * np.pi, points, endpoint=False)
    e1 = np.array([0.0, 1.0, 0.0])
    along_k = np.abs(normal[:, 2]) > 0.5
    e2 = np.where(along_k[:, None], np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0]))
    cos_t, sin_t = np.cos(t)[None, :, None], np.sin(t)[None, :, None]
    rim = centre[:, None, :] + geometry.radius * (cos_t * e1 + sin_t * e2[:, None, :])
    tangent = -sin_t * e1 + cos_t * e2[:, None, :]
    group = np.repeat(np.arange(len(centre)), points)
    return (rim.reshape(-1, 3), tangent.reshape(-1, 3), np.repeat(centre, points, axis=0),
            group, facing)


def _end_rims(extent: Extent, pose: GridPose, camera: Camera, geometry: LogGeometry,
              points: int = 16) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Rims of the extent's end discs facing the camera, in the grid frame.

    Returns
    -------
    rim, tangent, centre, group : as :func:`_disc_rims`
    """
    centre, normal = _end_discs(extent, geometry)
    rim, tangent, centre, group, _ = _disc_rims(centre, normal, pose, camera, geometry, points)
    return rim, tangent, centre, group


@functools.lru_cache(maxsize=64)
def _end_discs(extent: Extent, geometry: LogGeometry) -> tuple[np.ndarray, np.ndarray]:
    """Grid-frame centres and outward normals ``(E, 3)`` of every end feature's disc: the
    same for every pose, so made once per extent (read-only)."""
    idx = feature_index(extent)
    axes = feature_axes(extent, geometry)
    ends = np.flatnonzero(idx.kind <= FeatureKind.END_PLUS)
    out = (axes[ends, 0], axes[ends, 1] - axes[ends, 0])
    for a in out:
        a.setflags(write=False)
    return out


@dataclass(frozen=True, eq=False)
class _FeatureSamples:
    """Samples of a pose's upper silhouettes and end rims, in the grid frame.

    Rigid within one alignment: the silhouettes move with the pose only
    through the camera's viewing angle, which hardly changes over a few
    millimetres.
    """

    pts: np.ndarray  # (M, 3)
    tangent: np.ndarray  # (M, 3) unit direction of the line or rim at each sample
    reference: np.ndarray  # (M, 3) a point inside the log or disc (normals point away)
    group: np.ndarray  # (M,) line or rim index
    bias: np.ndarray  # (M,) px: where the image edge sits relative to the silhouette
    n_groups: int
    # (M,) known presence of each sample's line or rim (a structure's); None: judge it
    # from the image's edges
    weight: np.ndarray | None = None
    # (M,) bool: the sample lies on an end disc's rim (else on a silhouette line)
    rim: np.ndarray | None = None


def _feature_samples(extent: Extent, pose: GridPose, camera: Camera, geometry: LogGeometry, *,
                     spacing: float, edge_bias_px: float, use_ends: bool = True
                     ) -> _FeatureSamples:
    lines, _, inside = _upper_lines(extent, pose, camera, geometry)
    pts, tangent, lid = _sample_lines(lines, camera, spacing)
    ref = inside[lid]
    bias = np.full(len(pts), edge_bias_px)
    n_groups = len(lines)
    if use_ends:
        # The rims of end discs facing the camera: they fix positions along the logs.
        rim, r_tan, r_centre, r_group = _end_rims(extent, pose, camera, geometry)
        if len(rim):
            pts = np.concatenate([pts, pose.grid_to_world(rim)])
            tangent = np.concatenate([tangent, pose.directions_to_world(r_tan)])
            ref = np.concatenate([ref, pose.grid_to_world(r_centre)])
            lid = np.concatenate([lid, r_group + n_groups])
            bias = np.concatenate([bias, np.zeros(len(rim))])
            n_groups += int(r_group.max()) + 1
    return _FeatureSamples(pose.world_to_grid(pts), tangent @ pose.rotation,
                           pose.world_to_grid(ref), lid, bias, n_groups)


def _structure_samples(structure: Structure, pose: GridPose, camera: Camera,
                       geometry: LogGeometry, *, spacing: float, edge_bias_px: float,
                       rim_weight: float = POLISH_RIM_WEIGHT) -> _FeatureSamples:
    """Samples of the upper silhouettes and end rims a structure shows the camera.

    Unlike :func:`_feature_samples` (every line the grid could hold, each
    judged by how present it looks), only the stretches the structure's logs
    cover and the rims of its log ends facing the camera, each sample kept
    when its ray to the camera passes the structure's other logs (bounding
    cylinders, as in :mod:`unseeable.visibility`). Weights are 1: presence is
    known, except that the rims together weigh ``rim_weight`` times the lines.
    """
    from unseeable.visibility import blocked_rays, log_cylinders, log_id_grid
    from unseeable.vision.projection import upper_silhouette

    extent = structure.extent
    I, J, K = extent.shape
    ids = log_id_grid(structure)
    ii, jj, kk = (a.ravel() for a in np.meshgrid(np.arange(I), np.arange(J), np.arange(K),
                                                  indexing="ij"))
    start, stop, kind = _stretches(ii, jj, kk, geometry)
    pi, pj, pk = (np.repeat(a, 3) for a in (ii, jj, kk))
    own = ids[pi, pj, pk]
    # A w stretch runs to the next notch position: covered when the same log is there too.
    even = pj % 2 == 0
    ni, nk = np.where(even, pi + 1, pi), np.where(even, pk, pk + 1)
    inside = (ni < I) & (nk < K)
    after = np.full(len(pi), -2)
    after[inside] = ids[ni[inside], pj[inside], nk[inside]]
    covered = (own >= 0) & ((kind != 2) | (after == own))
    wa, wb = pose.grid_to_world(start[covered]), pose.grid_to_world(stop[covered])
    ua, ub = upper_silhouette(wa, wb, camera.centre, geometry.radius)
    if len(ua):
        pts, tangent, lid = _sample_lines(np.stack([ua, ub], axis=1), camera, spacing)
    else:
        pts, tangent, lid = np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, int)
    ref = ((wa + wb) / 2.0)[lid]
    owner = own[covered][lid]
    n_line_samples = len(pts)
    bias = np.full(len(pts), edge_bias_px)
    n_groups = int(covered.sum())
    cylinders = log_cylinders(structure, geometry=geometry)
    if len(cylinders):
        axis = cylinders[:, 1] - cylinders[:, 0]
        axis /= np.linalg.norm(axis, axis=1, keepdims=True)
        centre = np.concatenate([cylinders[:, 0], cylinders[:, 1]])
        normal = np.concatenate([-axis, axis])
        log_of = np.tile(np.arange(len(cylinders)), 2)
        rim, r_tan, r_centre, r_group, facing = _disc_rims(centre, normal, pose, camera,
                                                           geometry)
        pts = np.concatenate([pts, pose.grid_to_world(rim)])
        tangent = np.concatenate([tangent, pose.directions_to_world(r_tan)])
        ref = np.concatenate([ref, pose.grid_to_world(r_centre)])
        lid = np.concatenate([lid, n_groups + r_group])
        owner = np.concatenate([owner, log_of[facing][r_group]])
        bias = np.concatenate([bias, np.zeros(len(rim))])  # see _match_edges
    grid_pts = pose.world_to_grid(pts)
    if len(cylinders) and len(grid_pts):
        camera_grid = pose.world_to_grid(camera.centre[None])[0]
        seen = ~blocked_rays(grid_pts[:, None, :], np.ones((len(grid_pts), 1), bool),
                             camera_grid, cylinders, geometry.radius,
                             exclude=owner[:, None])[:, 0]
    else:
        seen = np.ones(len(grid_pts), bool)
    groups, lid = np.unique(lid[seen], return_inverse=True)
    rim = (np.arange(len(seen)) >= n_line_samples)[seen]
    # The rims outweigh the lines. Lines fix the pose across themselves but a depth
    # shift moves the lines of one layer onto those of the perpendicular logs half a
    # layer away, and on some logs the strongest edge near a top silhouette is the
    # highlight a pixel or two inside it; the rims' closed curves do neither. From the
    # true pose, the polish of the 240 validation renders stays within 2 mm/1° in 236
    # with rims at 4× the lines in total, 234 at 1× (100 of the first 120 with lines
    # alone), 232 with rims alone (docs/results.md); 239 once the rims' edge offsets
    # (_RIM_BIAS_PX, _RIM_DROP_PX) are taken off.
    n_rim, n_line = int(rim.sum()), int((~rim).sum())
    weight = np.where(rim, rim_weight * n_line / n_rim if n_rim and n_line else 1.0, 1.0)
    return _FeatureSamples(grid_pts[seen], tangent[seen] @ pose.rotation,
                           pose.world_to_grid(ref[seen]), lid, bias[seen], len(groups),
                           weight=weight, rim=rim)


@dataclass(frozen=True, eq=False)
class _EdgeMatches:
    """Where the image edges are, across every sample of a pose's present-looking features."""

    pts: np.ndarray  # (M, 3) world sample points
    uv: np.ndarray  # (M, 2)
    normals: np.ndarray  # (M, 2) unit, out of the log / disc
    offset: np.ndarray  # (M,) signed distance (px) to the strongest edge along the normal
    peak: np.ndarray  # (M,) that edge's strength
    presence: np.ndarray  # (M,) how present the sample's line or rim looks, [0, 1]
    ok: np.ndarray  # (M,) bool
    group: np.ndarray  # (M,) int: the line or rim each sample belongs to
    # (M, 3) derivatives of each sample's normal displacement (see _match_edges), when asked
    jacobian: np.ndarray | None = None

    def on_edges(self, *, tolerance_px: float = 0.75, strong: float = 0.3) -> np.ndarray:
        """(M,) bool: the sample's edge is within ``tolerance_px`` and stronger than ``strong``."""
        return (np.abs(self.offset) <= tolerance_px) & self.ok & (self.peak > strong)


def _kernel_samples(samples: _FeatureSamples) -> tuple[np.ndarray, ...]:
    """``samples`` as :func:`_edge_match_kernel` reads them: points, tangents,
    references and edge biases (contiguous float64) and which are rims (bool)."""
    # Only a structure's samples mark their rims (the search's grid rims stay raw): the rim
    # edge offsets depend on each sample's image normal, known only inside the kernel.
    rim = (np.zeros(len(samples.group), np.bool_) if samples.rim is None
           else np.ascontiguousarray(samples.rim, dtype=np.bool_))
    return (*(np.ascontiguousarray(a, dtype=np.float64) for a in (
        samples.pts, samples.tangent, samples.reference, samples.bias)), rim)


def _match_edges(maps: EdgeMaps, camera: Camera, extent: Extent, geometry: LogGeometry,
                 pose: GridPose, *, spacing: float, reach: float, edge_bias_px: float,
                 use_ends: bool, step: float = 0.25,
                 samples: _FeatureSamples | None = None,
                 jacobian_about: tuple[np.ndarray, float, float] | None = None
                 ) -> _EdgeMatches:
    """Sample the upper silhouettes (and end rims) of ``pose`` and find their image edges.

    With ``jacobian_about = (centre, angle, eps)`` the matches' ``jacobian`` holds the
    ``(M, 3)`` changes of each sample's normal displacement (px) when the pose moves by
    ``eps`` mm along world x, along world z, and turns by ``angle`` about ``centre``
    (world), each divided by ``eps`` (NaN and inf as :func:`numpy.nan_to_num` makes them):
    what each step of the alignment (:func:`_refine_edges`) has the kernel compute; here
    for checking it. The per-sample work is one numba pass (:func:`_edge_match_kernel`).
    """
    if samples is None:
        samples = _feature_samples(extent, pose, camera, geometry, spacing=spacing,
                                   edge_bias_px=edge_bias_px, use_ends=use_ends)
    lid, n_groups = samples.group, samples.n_groups
    offsets = np.arange(-reach, reach + 1e-9, step)
    centre, angle, eps = (jacobian_about if jacobian_about is not None
                          else (np.zeros(3), 0.0, 0.0))
    pts, uv, normals, d, peak, at_line, ok, jac = _edge_match_kernel(
        _structure_tensor(maps.tensor), *_kernel_samples(samples), _RIM_BIAS_PX, _RIM_DROP_PX,
        pose.rotation, pose.translation, camera.R, camera.t, camera.K, camera.dist,
        camera.has_distortion, offsets, int(np.argmin(np.abs(offsets))), float(step),
        np.asarray(centre, dtype=np.float64), float(angle), float(eps),
        jacobian_about is not None)
    mean_group = np.bincount(lid, weights=np.maximum(at_line, peak), minlength=n_groups) / \
        np.maximum(np.bincount(lid, minlength=n_groups), 1)
    presence = np.clip((mean_group - 0.15) / 0.3, 0.0, 1.0)[lid]
    return _EdgeMatches(pts, uv, normals, d, peak, presence, ok, lid,
                        jac if jacobian_about is not None else None)


@numba.njit(cache=True, inline="always")
def _project_world(cam_r, cam_t, k, dist, distorted, x, y, z):
    """:meth:`Camera.project` of one world point: ``(u, v)``, NaN behind the camera."""
    cx = cam_r[0, 0] * x + cam_r[0, 1] * y + cam_r[0, 2] * z + cam_t[0]
    cy = cam_r[1, 0] * x + cam_r[1, 1] * y + cam_r[1, 2] * z + cam_t[1]
    cz = cam_r[2, 0] * x + cam_r[2, 1] * y + cam_r[2, 2] * z + cam_t[2]
    if not cz > 1e-9:
        return np.nan, np.nan
    a = cx / cz
    b = cy / cz
    if distorted:
        k1, k2, p1, p2, k3 = dist[0], dist[1], dist[2], dist[3], dist[4]
        r2 = a * a + b * b
        radial = 1 + k1 * r2 + k2 * r2 ** 2 + k3 * r2 ** 3
        ad = a * radial + 2 * p1 * a * b + p2 * (r2 + 2 * a * a)
        bd = b * radial + p1 * (r2 + 2 * b * b) + 2 * p2 * a * b
        a, b = ad, bd
    return k[0, 0] * a + k[0, 1] * b + k[0, 2], k[1, 1] * b + k[1, 2]


@numba.njit(cache=True, inline="always")
def _finite_or(value, default):
    """:func:`numpy.nan_to_num` of one float: NaN → ``default``, ±inf → ± the largest float."""
    if np.isnan(value):
        return default
    if np.isinf(value):
        return 1.7976931348623157e308 if value > 0 else -1.7976931348623157e308
    return value


@numba.njit(cache=True, nogil=True)
def _edge_match_kernel(tensor, grid_pts, grid_tangent, grid_ref, bias, rim, rim_bias,
                       rim_drop, pose_r, pose_t, cam_r, cam_t, k, dist, distorted, offsets,
                       zero_index, step, centre, angle, eps, want_jacobian):
    """Every per-sample step of :func:`_match_edges` (and the refinement's Jacobian) in one
    pass: to the world, projected, the image normal (out of the log or disc), the edge
    peak along it, sub-pixel offset. Numerically the numpy steps it replaces."""
    m, n_off = grid_pts.shape[0], offsets.shape[0]
    pts = np.empty((m, 3))
    uv = np.empty((m, 2))
    normals = np.empty((m, 2))
    d = np.empty(m)
    peak = np.empty(m)
    at_line = np.empty(m)
    ok = np.empty(m, np.bool_)
    jac = np.zeros((m, 3) if want_jacobian else (0, 3))
    prof = np.empty(n_off)
    c, s = np.cos(angle), np.sin(angle)
    for i in range(m):
        g0, g1, g2 = grid_pts[i, 0], grid_pts[i, 1], grid_pts[i, 2]
        wx = pose_r[0, 0] * g0 + pose_r[0, 1] * g1 + pose_r[0, 2] * g2 + pose_t[0]
        wy = pose_r[1, 0] * g0 + pose_r[1, 1] * g1 + pose_r[1, 2] * g2 + pose_t[1]
        wz = pose_r[2, 0] * g0 + pose_r[2, 1] * g1 + pose_r[2, 2] * g2 + pose_t[2]
        pts[i, 0], pts[i, 1], pts[i, 2] = wx, wy, wz
        t0, t1, t2 = grid_tangent[i, 0], grid_tangent[i, 1], grid_tangent[i, 2]
        dx = pose_r[0, 0] * t0 + pose_r[0, 1] * t1 + pose_r[0, 2] * t2
        dy = pose_r[1, 0] * t0 + pose_r[1, 1] * t1 + pose_r[1, 2] * t2
        dz = pose_r[2, 0] * t0 + pose_r[2, 1] * t1 + pose_r[2, 2] * t2
        u, v = _project_world(cam_r, cam_t, k, dist, distorted, wx, wy, wz)
        u2, v2 = _project_world(cam_r, cam_t, k, dist, distorted, wx + dx * 2.0,
                                wy + dy * 2.0, wz + dz * 2.0)
        tu, tv = u2 - u, v2 - v
        norm = max(np.sqrt(tu * tu + tv * tv), 1e-12)
        nx, ny = -tv / norm, tu / norm
        r0, r1, r2 = grid_ref[i, 0], grid_ref[i, 1], grid_ref[i, 2]
        ru, rv = _project_world(
            cam_r, cam_t, k, dist, distorted,
            pose_r[0, 0] * r0 + pose_r[0, 1] * r1 + pose_r[0, 2] * r2 + pose_t[0],
            pose_r[1, 0] * r0 + pose_r[1, 1] * r1 + pose_r[1, 2] * r2 + pose_t[1],
            pose_r[2, 0] * r0 + pose_r[2, 1] * r1 + pose_r[2, 2] * r2 + pose_t[2])
        # Normals point out of the log or disc, so that the blur's pull of the edge into
        # the log can be taken off (a NaN comparison leaves them as they are).
        if (u - ru) * nx + (v - rv) * ny < 0:
            nx, ny = -nx, -ny
        uv[i, 0], uv[i, 1] = u, v
        normals[i, 0], normals[i, 1] = nx, ny
        ok[i] = np.isfinite(u) and np.isfinite(v)
        # The peak search sees NaN positions as numpy.nan_to_num makes them.
        kb, top, yl, yr, at_zero = _profile_peak(tensor, _finite_or(u, 0.0),
                                                 _finite_or(v, 0.0), nx, ny, offsets,
                                                 zero_index, prof)
        # Sub-pixel: the parabola through the peak and its neighbours.
        denom = yl - 2 * top + yr
        frac = 0.5 * (yl - yr) / denom if (denom < 0 and 0 < kb < n_off - 1) else 0.0
        b = bias[i] + (rim_bias + rim_drop * ny if rim[i] else 0.0)
        d[i] = offsets[kb] + frac * step - b
        peak[i] = top
        at_line[i] = at_zero
        if want_jacobian:
            # The normal displacement of the sample when the pose moves eps along world x,
            # along world z, and turns by ``angle`` about ``centre``.
            ax, az = wx - centre[0], wz - centre[2]
            for q in range(3):
                if q == 0:
                    mx, mz = wx + eps, wz
                elif q == 1:
                    mx, mz = wx, wz + eps
                else:
                    mx, mz = centre[0] + c * ax + s * az, centre[2] - s * ax + c * az
                mu, mv = _project_world(cam_r, cam_t, k, dist, distorted, mx, wy, mz)
                jac[i, q] = _finite_or(((mu - u) / eps) * nx + ((mv - v) / eps) * ny, 0.0)
    return pts, uv, normals, d, peak, at_line, ok, jac


def _alignment_score(matches: _EdgeMatches, *, tolerance_px: float = 0.75,
                     strong: float = 0.3, mode: str = "coherent") -> float:
    """How well a pose's features sit on image edges.

    ``"coherent"``: Σ over lines and rims of ``n_g · f_g²`` with ``f_g`` the
    share of the group's ``n_g`` samples lying within ``tolerance_px`` of a
    strong edge; whole features aligned end to end count, scattered
    coincidences with other edges much less. ``"sum"``: the plain count.
    """
    close = matches.on_edges(tolerance_px=tolerance_px, strong=strong)
    if mode == "sum":
        return float(np.sum(close))
    n = np.bincount(matches.group)
    hit = np.bincount(matches.group, weights=close.astype(float), minlength=len(n))
    frac = hit / np.maximum(n, 1)
    return float(np.sum(n * frac**2))


def _refine_edges(maps: EdgeMaps, camera: Camera, extent: Extent, geometry: LogGeometry,
                  start: GridPose, *, spacing: float, mm_per_px: float, iterations: int = 8,
                  reach_px: float = POLISH_REACH_PX, edge_bias_px: float = _EDGE_BIAS_PX,
                  use_ends: bool = True, samples: _FeatureSamples | None = None) -> GridPose:
    """Align the upper silhouettes and end rims with their image edges by robust least squares.

    Each sample along a present-looking upper silhouette (or the rim of an
    end disc facing the camera) looks along its image normal for the
    strongest matching edge (sub-pixel); the pose update ``(dx, dz, turn)``
    minimises the squared normal distances, with Tukey weights against
    edges that belong to something else, and the search narrows as the pose
    settles (model-based edge tracking, as in RAPiD). In rendered and real
    photographs alike the strongest gradient of a top edge lies a little
    inside the log (its rim is rounded and the optics blur it):
    ``edge_bias_px`` (:data:`_EDGE_BIAS_PX`) takes that off.

    ``samples`` (in ``start``'s grid frame) replaces the grid's lines and
    rims; their ``weight``, when set, replaces how present each looks.
    ``iterations`` steps at most (two with ``reach_px``, then half of it),
    fewer once a step moves the pose by less than 0.02 px. Each step is two
    numba calls that release the GIL (the edge matching and
    :func:`_alignment_step`): the pose search runs ~70 alignments per image
    on threads, and numpy work between the calls held them up (corpus pose
    search 2–5 % faster, timed side by side with the numpy steps).
    """
    if samples is None:
        samples = _feature_samples(extent, start, camera, geometry, spacing=spacing,
                                   edge_bias_px=edge_bias_px, use_ends=use_ends)
    tensor = _structure_tensor(maps.tensor)
    arrays = _kernel_samples(samples)
    group = np.ascontiguousarray(samples.group, dtype=np.int64)
    counts = np.bincount(group, minlength=samples.n_groups).astype(np.float64)
    weight = (np.zeros(0) if samples.weight is None
              else np.ascontiguousarray(samples.weight, dtype=np.float64))
    centre_g = _centre_grid(extent, geometry)
    lever = 0.5 * max(extent.I, extent.K) * geometry.l1
    eps = 0.5
    current = start
    # Two wide steps, then the narrow ones (the search narrows as the pose settles).
    for reach in [reach_px] * min(iterations, 2) + [reach_px / 2.0] * max(iterations - 2, 0):
        step = 0.5 if reach > 2.0 else 0.25
        offsets = np.arange(-reach, reach + 1e-9, step)
        centre = current.grid_to_world(centre_g)
        # Jacobian of each sample's normal displacement w.r.t. (dx, dz, turn about the
        # centre, expressed as the displacement of a point ``lever`` mm from it).
        _, _, _, d, peak, at_line, ok, jac = _edge_match_kernel(
            tensor, *arrays, _RIM_BIAS_PX, _RIM_DROP_PX, current.rotation,
            current.translation, camera.R, camera.t, camera.K, camera.dist,
            camera.has_distortion, offsets, int(np.argmin(np.abs(offsets))), step, centre,
            eps / lever, eps, True)
        delta, total = _alignment_step(d, peak, at_line, ok, jac, group, counts, weight,
                                       samples.weight is not None, max(reach, 1.0))
        if total < 10:
            break
        current = _pose_from_centre(np.array([centre[0] + delta[0], centre[2] + delta[1]]),
                                    current.yaw_deg + float(np.degrees(delta[2] / lever)),
                                    extent, geometry)
        if (np.hypot(delta[0], delta[1]) < 0.02 * mm_per_px
                and abs(delta[2]) < 0.02 * mm_per_px):
            break
    return current


@numba.njit(cache=True, nogil=True)
def _alignment_step(d, peak, at_line, ok, jac, group, counts, weight, weighted, c_tukey):
    """One step of :func:`_refine_edges` from its edge matches: the weighted least-squares
    update ``(dx, dz, lever turn)`` and the total weight.

    Each sample weighs how present its line or rim looks (the mean of its
    samples' edge strengths, as :func:`_match_edges` judges it; ``weight``
    instead when ``weighted``), times Tukey's weight of its offset (edges of
    something else), when its edge is strong enough and it is in view.
    """
    m = d.shape[0]
    sums = np.zeros(counts.shape[0])
    if not weighted:
        for i in range(m):
            sums[group[i]] += max(at_line[i], peak[i])
    a = np.zeros((3, 3))
    b = np.zeros(3)
    total = 0.0
    for i in range(m):
        di = _finite_or(d[i], 0.0)
        if weighted:
            presence = weight[i]
        else:
            mean = sums[group[i]] / max(counts[group[i]], 1.0)
            presence = min(max((mean - 0.15) / 0.3, 0.0), 1.0)
        r = di / c_tukey
        tukey = (1 - r * r) ** 2 if abs(di) < c_tukey else 0.0
        w = presence * tukey * (1.0 if peak[i] > 0.15 else 0.0) * (1.0 if ok[i] else 0.0)
        total += w
        for p in range(3):
            b[p] += jac[i, p] * w * di
            for q in range(3):
                a[p, q] += jac[i, p] * w * jac[i, q]
    if total < 10:
        return np.zeros(3), total
    for p in range(3):
        a[p, p] += 1e-6 * total
    return _solve3(a, b), total


@numba.njit(cache=True, inline="always")
def _solve3(a, b):
    """``a⁻¹ b`` for a 3×3 ``a``: Gaussian elimination with partial pivoting, as LAPACK's
    ``gesv`` (numba's ``np.linalg.solve`` adds seconds to the first compile)."""
    m = np.empty((3, 4))
    for i in range(3):
        for j in range(3):
            m[i, j] = a[i, j]
        m[i, 3] = b[i]
    for col in range(3):
        piv = col
        for r in range(col + 1, 3):
            if abs(m[r, col]) > abs(m[piv, col]):
                piv = r
        if piv != col:
            for j in range(4):
                m[col, j], m[piv, j] = m[piv, j], m[col, j]
        for r in range(col + 1, 3):
            f = m[r, col] / m[col, col]
            for j in range(col, 4):
                m[r, j] -= f * m[col, j]
    x = np.empty(3)
    for i in range(2, -1, -1):
        acc = m[i, 3]
        for j in range(i + 1, 3):
            acc -= m[i, j] * x[j]
        x[i] = acc / m[i, i]
    return x


def refine_pose(image: np.ndarray | EdgeMaps, camera: Camera, extent: Extent, pose: GridPose, *,
                geometry: LogGeometry = LogGeometry(),
                settings: PoseSettings = PoseSettings()) -> GridPose:
    """Polish a pose that is already within a few pixels of the truth.

    Maximises the oriented edge strength along the upper silhouettes that
    look present (see the module notes), over ``(x, z, yaw)``. Useful when
    a pose comes from elsewhere (a known placement seen through a slightly
    miscalibrated camera) before running the detectors.

    Parameters
    ----------
    image : (H, W, 3) uint8 or EdgeMaps
    camera : Camera
    extent : Extent
    pose : GridPose
    geometry : LogGeometry
    settings : PoseSettings

    Returns
    -------
    GridPose
        The same symbolic orientation as ``pose`` (no half-turn canonicalisation).
    """
    maps, camera, mm_per_px = _polish_inputs(image, camera, extent, pose, geometry, settings)
    return _refine_edges(maps, camera, extent, geometry, pose,
                         spacing=settings.sample_spacing_px, mm_per_px=mm_per_px)


def align_pose(image: np.ndarray | EdgeMaps, camera: Camera, extent: Extent, pose: GridPose, *,
               geometry: LogGeometry = LogGeometry(), settings: PoseSettings = PoseSettings(),
               iterations: int = 8) -> tuple[GridPose, float]:
    """Align ``pose`` on the image's edges and score it, as :func:`estimate_pose` does its
    candidates.

    For asking of a pose the search did not offer (the true one, in a benchmark)
    whether the edges prefer it: the score is comparable with the scores in
    ``PoseFit.candidates``.

    Parameters
    ----------
    image : (H, W, 3) uint8 or EdgeMaps
        An image, or the edge maps :func:`estimate_pose` was given
        (:func:`~unseeable.vision.scale.view_edge_maps` with ``pose=True``).
    camera : Camera
    extent : Extent
    pose : GridPose
    geometry : LogGeometry
    settings : PoseSettings
    iterations : int
        Alignment steps (the search gives its finalists 8).

    Returns
    -------
    pose : GridPose
        ``pose`` aligned.
    score : float
        Its alignment score: the samples of each of the grid's upper silhouettes and
        end rims lying on strong edges, summed over lines as ``n f²``.

    Examples
    --------
    >>> from unseeable.domain import Extent, GridPose
    >>> from unseeable.render.workspace import PendulumArm
    >>> camera = PendulumArm().camera(120.0)
    >>> blank = np.full((camera.height, camera.width, 3), 128, np.uint8)
    >>> aligned, score = align_pose(blank, camera, Extent(3, 2, 3), GridPose(0.0, 0.0, 10.0))
    >>> score
    0.0
    """
    iterations = check_whole_number(iterations, field="iterations", minimum=0)
    maps, camera, mm_per_px = _polish_inputs(image, camera, extent, pose, geometry, settings)
    score, aligned, _ = _aligned(maps, camera, extent, geometry, pose, settings=settings,
                                 mm_per_px=mm_per_px, iterations=iterations)
    return aligned, score


def _aligned(maps: EdgeMaps, camera: Camera, extent: Extent, geometry: LogGeometry,
             pose: GridPose, *, settings: PoseSettings, mm_per_px: float, iterations: int,
             samples: _FeatureSamples | None = None) -> tuple[float, GridPose, _EdgeMatches]:
    """``pose`` aligned ``iterations`` steps on the edges (none: as it is), its alignment
    score and edge matches: one candidate of :func:`estimate_pose`, and :func:`align_pose`.

    ``samples`` (``pose``'s grid features) serve both steps: a screen scores the aligned
    pose with the samples of the pose it started from.
    """
    aligned = (_refine_edges(maps, camera, extent, geometry, pose,
                             spacing=settings.sample_spacing_px, mm_per_px=mm_per_px,
                             iterations=iterations, samples=samples) if iterations else pose)
    matches = _match_edges(maps, camera, extent, geometry, aligned,
                           spacing=settings.sample_spacing_px, reach=1.5,
                           edge_bias_px=_EDGE_BIAS_PX, use_ends=True, samples=samples)
    return _alignment_score(matches), aligned, matches


def _polish_inputs(image: np.ndarray | EdgeMaps, camera: Camera, extent: Extent,
                   pose: GridPose, geometry: LogGeometry, settings: PoseSettings
                   ) -> tuple[EdgeMaps, float]:
    """The image's edge maps (checked, unless given), the camera that goes with them (see
    :func:`~unseeable.vision.scale.pose_view`) and millimetres per pixel at the pose."""
    if isinstance(image, EdgeMaps):
        maps, camera = image, camera_for(image.shape, camera)
    else:
        img, camera = _checked_view(image, camera, extent)
        maps = edge_maps(img, sigma=settings.sigma)
    centre = pose.grid_to_world(_centre_grid(extent, geometry))
    return maps, camera, float(camera.depth(centre[None])[0]) / float(camera.K[0, 0])


def refine_pose_on_structure(image: np.ndarray | EdgeMaps, camera: Camera,
                             structure: Structure, pose: GridPose, *,
                             geometry: LogGeometry = LogGeometry(),
                             settings: PoseSettings = PoseSettings(),
                             rim_weight: float = POLISH_RIM_WEIGHT,
                             reach_px: float = POLISH_REACH_PX) -> GridPose:
    """Polish a pose against the edges an estimated structure shows the camera.

    :func:`refine_pose` aligns every line the grid could hold, each weighted
    by how present its edges look; once a structure is estimated at the pose,
    only its logs' visible upper silhouettes and the rims of its log ends
    facing the camera are aligned, with known presence. On the validation
    renders this took the median pose error of the chosen poses from 0.70 to
    0.57 mm and the share within 1 mm from 71 % to 84 % (docs/results.md).

    Parameters
    ----------
    image : (H, W, 3) uint8 or EdgeMaps
    camera : Camera
    structure : Structure
        Estimated at ``pose`` (its extent numbers the grid of ``pose``).
    pose : GridPose
    geometry : LogGeometry
    settings : PoseSettings
    rim_weight : float
        The log-end rims' total weight relative to the silhouette lines'
        (> 0). Lines can settle on a top edge's highlight or half a layer
        off in depth; rims cannot. At 4 (:data:`POLISH_RIM_WEIGHT`) against
        1, the pose within 2 mm/1° went from 220 to 223 of 240 validation
        views, and from 148 to 153 of 180 views by other cameras and
        another renderer.
    reach_px : float
        How far (image pixels) the first steps look for each line's edge
        along its normal (>= :data:`POLISH_REACH_PX`). A wider reach is done
        in stages of 3 px down to 3 px (``9`` looks 9, then 6, then 3 px
        out), so the pose can leave a near-alias a few millimetres off; it
        can also be drawn to another log's edges, which the default's 3 px
        cannot (docs/results.md, "an estimated pose polished on its own
        estimate").

    Returns
    -------
    GridPose
        The same symbolic orientation as ``pose``; ``pose`` itself when the
        structure shows too few edges to align.

    Examples
    --------
    >>> from unseeable.domain import Extent, Log, Structure, GridPose
    >>> cam = Camera.look_at(eye=[0, 400, -500], target=[0, 0, 0], width=160, height=120,
    ...                      fov_deg=40)
    >>> s = Structure(Extent(2, 1, 1), [Log(layer=0, at=(0, 0), notches=2)])
    >>> pose = GridPose(-32, 0, 0)
    >>> refine_pose_on_structure(np.zeros((120, 160, 3), np.uint8), cam, s, pose) == pose
    True
    """
    if (isinstance(rim_weight, bool) or not isinstance(rim_weight, int | float)
            or not np.isfinite(rim_weight) or rim_weight <= 0):
        raise InputError("must be a positive number", field="rim_weight", value=rim_weight)
    if (isinstance(reach_px, bool) or not isinstance(reach_px, int | float)
            or not np.isfinite(reach_px) or reach_px < POLISH_REACH_PX):
        raise InputError(f"must be a number of pixels >= {POLISH_REACH_PX}", field="reach_px",
                         value=reach_px)
    extent = structure.extent
    maps, camera, mm_per_px = _polish_inputs(image, camera, extent, pose, geometry, settings)
    # Wide stages first (each two steps at its reach and two at half of it), then the
    # default polish; the samples are rebuilt at each stage's start (which silhouettes
    # face the camera depends on the pose).
    stages = np.arange(float(reach_px), POLISH_REACH_PX, -POLISH_REACH_PX)
    current = pose
    for reach in [*stages[stages > POLISH_REACH_PX], POLISH_REACH_PX]:
        samples = _structure_samples(structure, current, camera, geometry,
                                     spacing=settings.sample_spacing_px,
                                     edge_bias_px=_EDGE_BIAS_PX, rim_weight=float(rim_weight))
        if samples.n_groups == 0:
            return current
        wide = reach > POLISH_REACH_PX
        current = _refine_edges(maps, camera, extent, geometry, current,
                                spacing=settings.sample_spacing_px, mm_per_px=mm_per_px,
                                samples=samples, reach_px=float(reach),
                                iterations=4 if wide else 8)
    return current


def rim_support(image: np.ndarray | EdgeMaps, camera: Camera, structure: Structure,
                pose: GridPose, *, geometry: LogGeometry = LogGeometry(),
                settings: PoseSettings = PoseSettings(), tolerance_px: float = 0.75,
                strong: float = 0.3) -> float:
    """Share of the rims of a structure's visible log ends that lie on strong image edges.

    The end discs facing the camera, as :func:`~unseeable.vision.refine_pose_on_structure`
    aligns them: each rim sample counts when the strongest edge along its normal
    lies within ``tolerance_px`` and is stronger than ``strong``. 0 when the
    structure shows no log end.

    Parameters
    ----------
    image : (H, W, 3) uint8 or EdgeMaps
    camera : Camera
    structure : Structure
    pose : GridPose
    geometry : LogGeometry
    settings : PoseSettings
    tolerance_px, strong : float

    Returns
    -------
    float
        In [0, 1].

    Examples
    --------
    >>> from unseeable.domain import Extent, Log, Structure, GridPose
    >>> cam = Camera.look_at(eye=[0, 400, -500], target=[0, 0, 0], width=160, height=120,
    ...                      fov_deg=40)
    >>> s = Structure(Extent(2, 1, 1), [Log(layer=0, at=(0, 0), notches=2)])
    >>> rim_support(np.zeros((120, 160, 3), np.uint8), cam, s, GridPose(-32, 0, 0))
    0.0
    """
    maps, camera, _ = _polish_inputs(image, camera, structure.extent, pose, geometry,
                                     settings)
    samples = _structure_samples(structure, pose, camera, geometry,
                                 spacing=settings.sample_spacing_px, edge_bias_px=_EDGE_BIAS_PX)
    if samples.rim is None or not samples.rim.any():
        return 0.0
    m = _match_edges(maps, camera, structure.extent, geometry, pose,
                     spacing=settings.sample_spacing_px, reach=3.0,
                     edge_bias_px=_EDGE_BIAS_PX, use_ends=True, samples=samples)
    close = m.on_edges(tolerance_px=tolerance_px, strong=strong)
    return float(close[samples.rim].mean())


def _prism_corners(extent: Extent, geometry: LogGeometry) -> np.ndarray:
    """Grid-frame corners ``(8, 3)`` of the box every log of the extent lies in."""
    g = geometry
    I, J, K = extent.shape
    xs = (-g.l3, (I - 1) * g.l1 + g.l3)
    zs = (-g.l3, (K - 1) * g.l1 + g.l3)
    ys = (0.0, float(g.layer_height(J - 1)) + g.radius)
    return np.array([[x, y, z] for x in xs for y in ys for z in zs])


def _box_mask(extent: Extent, pose: GridPose, camera: Camera, shape: tuple[int, int],
              geometry: LogGeometry) -> np.ndarray | None:
    """``(H, W) uint8``: the image of the box every log of ``extent`` at ``pose`` lies in
    (None when part of the box is behind the camera)."""
    uv = camera.project(pose.grid_to_world(_prism_corners(extent, geometry)))
    if not np.all(np.isfinite(uv)):
        return None
    mask = np.zeros(shape, np.uint8)
    fill_convex_hull(mask, uv)
    return mask


def _wood_outside(wood: np.ndarray, camera: Camera, extent: Extent, pose: GridPose,
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
    mask = _box_mask(extent, pose, camera, wood.shape, geometry)
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


def _default_quality_model() -> PoseQualityModel:
    try:
        from unseeable.vision.calibration import default_calibration

        model = default_calibration().pose_quality
    except Exception:  # no shipped calibration: the built-in defaults
        model = None
    return model if model is not None else PoseQualityModel()


def pose_equivalent(a: GridPose, b: GridPose, extent: Extent, *,
                    geometry: LogGeometry = LogGeometry(),
                    quarter_turns: bool = False) -> tuple[float, float]:
    """Distance (mm, degrees) between ``a`` and the nearest pose numbering ``b``'s grid.

    ``b`` and its half turn describe the same grid lines; with ``quarter_turns``
    so do its quarter turns when the footprint is square (I = K).
    """
    turns = symbolic_orientations(b, extent, geometry)
    if not quarter_turns:
        turns = [t for t in turns if t[0] in (0, 2)]
    return min((a.distance(p) for _, p, _ in turns), key=lambda d: d[0] + d[1])
