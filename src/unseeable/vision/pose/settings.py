"""Constants and settings of the pose search and the pose polish (pixels unless stated)."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = [
    "PoseSettings",
    "EDGE_BIAS_PX",
    "RIM_BIAS_PX",
    "RIM_DROP_PX",
    "POLISH_RIM_WEIGHT",
    "POLISH_REACH_PX",
]

#: Where a log's upper silhouette shows in the image, relative to the projected line (px):
#: the strongest gradient of a top edge lies a little inside the log (the rim is rounded
#: and the optics blur it); measured on the training renders.
EDGE_BIAS_PX = -0.15
#: Where an end disc's rim shows, relative to the projected rim (px, along its outward
#: normal): ``RIM_BIAS_PX + RIM_DROP_PX * n_v`` with ``n_v`` the normal's downward image
#: component. The strongest gradient lies a little inside the end face and a little low
#: (the top of the face borders the log's own lit top surface, not a step to the
#: background); measured at the true poses of the training renders (the flat-shaded ones
#: agree within 0.05 px). Applied where a structure's rims are aligned (the polish and
#: the pose choice); the search keeps the raw rims (see docs/decisions.md).
RIM_BIAS_PX = -0.15
RIM_DROP_PX = 0.17
#: In the polish on a structure, the rims' total weight relative to the silhouette
#: lines' (see :func:`~unseeable.vision.refine_pose_on_structure`).
POLISH_RIM_WEIGHT = 4.0
#: How far (px) :func:`~unseeable.vision.refine_pose_on_structure` and the edge alignment
#: look for a line's edge at first (then half of it).
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
    spread_excess : float
        Each segment's vote is weighted by how much its direction crowds near it
        beyond this many times that direction's rate over the whole view
        (:func:`~unseeable.vision.pose.yaw.concentration`): an assembly's edges
        crowd within its own image size, a seamed or tiled table's lines (or a
        room's) run the same directions all over the view. 0: votes by length alone.
    spread_crowd, spread_mask_px, spread_length : float
        When the votes are so weighted, the segments whose crowding is below
        ``spread_crowd`` and which are longer in the world than ``spread_length``
        times the footprint's longer side (no log edge is: measured on the plane
        of the assembly's top, where a segment is shortest) are a texture's or a
        room's: the search's edge maps are set to 0 in a band ``spread_mask_px``
        wide along each (0: kept), so that no feature is matched with a seam.
    crowd_full : float
        Segments crowding this much (or more) keep their whole vote; below it,
        their vote falls in proportion.
    min_crowded_segments : int
        The weighting applies only when at least this many segments crowd (an
        assembly filling the view crowds nowhere beyond its own rate).
    yaw_peaks : int
        Yaw hypotheses tried (the best peaks of the votes, 4° apart at least).
    axis_peaks : int
        Further yaw hypotheses from the peaks of either axis direction's votes
        alone (:func:`axis_yaws`), for views with one axis along the horizon.
    yaw_keep : int
        Yaw and quarter-turn hypotheses searched further (the best after a first look).
    weak_yaw_peaks, weak_yaw_keep : int
        A fit whose quality is below ``min_quality`` is searched again with this many yaw
        peaks and kept hypotheses (where above ``yaw_peaks`` and ``yaw_keep``), and the
        better fit kept: a small assembly casts few votes, and its true yaw can lie
        beyond the first peaks.
    yaw_offsets_deg : tuple of float
        Turns tried around each kept yaw hypothesis.
    orientation_tol_deg : float
        An edge pixel belongs to an axis family when its orientation is this
        close to the direction of that family's vanishing point.
    thin_wood_share : float
        The footprint search leaves out wood narrower than this share of a log's
        diameter in the image (a seamed or tiled table's dark lines read as wood;
        :func:`~unseeable.vision.pose.placement.placement_wood`). 0: none.
    wood_background : bool
        The footprint search counts only the wood above the map's median (the
        level of the table itself).
    crowd_floor : float
        When the yaw votes were weighted by how their directions crowd (see
        ``spread_excess``), the footprint search counts the wood far from every
        crowded segment (more than the assembly's size) at this share (1: all of it).
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
        Fits whose quality (probability of being right) is below this are poor:
        an estimate on one is never confident. They raise :class:`VisionError`
        (``estimate_pose``'s ``strict=True``) only when the wood outside the
        extent's box alone takes them below it (:attr:`PoseFit.wood_factor`).
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
        quarter turn and 30 mm off (docs/results.md).
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
        table's planks'). Another replaces the first's when it marks less than
        half as much of the image as wood (a model learnt on the table marks
        the table).
    rare_colour_wood : bool
        A model learnt where the image's rarest colours crowd competes with those
        of the yaw hypotheses in the same way
        (:func:`~unseeable.vision.pose.placement.rare_colour_region`): a small
        assembly far off on a tiled or seamed table crowds fewer edges than the
        table's lines.
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
        pitch ring of ``restart_mm``) also moves right poses onto wrong ones,
        offering it does not (docs/results.md).
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
    spread_excess: float = 2.0
    min_crowded_segments: int = 4
    crowd_full: float = 0.5
    spread_crowd: float = 0.1
    spread_mask_px: float = 5.0
    spread_length: float = 1.25
    yaw_peaks: int = 4
    axis_peaks: int = 2
    yaw_keep: int = 3
    weak_yaw_peaks: int = 6
    weak_yaw_keep: int = 6
    yaw_offsets_deg: tuple[float, ...] = (-1.5, 0.0, 1.5)
    orientation_tol_deg: float = 12.0
    thin_wood_share: float = 0.5
    wood_background: bool = True
    crowd_floor: float = 0.25
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
    rare_colour_wood: bool = True
    thin_yaw_step_deg: float = 2.0
    restart_mm: tuple[float, ...] = (12.0,)
    restart_keep: int = 1
    pitch_aliases: bool = True
    pitch_keep: float = 1.0
