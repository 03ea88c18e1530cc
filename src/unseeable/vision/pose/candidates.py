"""Step 4 of the pose search: aligning the candidates; and the near-symmetric poses offered.

Around one wood cluster (:func:`fit_at_cluster`), the best translations of
every kept yaw and quarter-turn hypothesis are aligned by robust least
squares on the distances, along each sample's normal, to the strongest
nearby edge (:mod:`unseeable.vision.pose.alignment`: a few steps for every
candidate, all of them for the most promising); the aligned pose whose
features lie most coherently on edges wins, and its fit statistics give the
quality. Then the grid's near-symmetries of the winner, and the other
finalists that score nearly as well, are aligned and offered to the
structure choice (:func:`offered_aliases`).
"""

from __future__ import annotations

import logging
from typing import NamedTuple

import numpy as np

from unseeable.domain import GridPose
from unseeable.parallel import map_in_threads
from unseeable.vision.pose.aliases import canonical_pose, pose_aliases
from unseeable.vision.pose.alignment import EdgeMatches, align_and_score
from unseeable.vision.pose.lines import shifted_pose
from unseeable.vision.pose.quality import default_quality_model, wood_outside
from unseeable.vision.pose.samples import feature_samples
from unseeable.vision.pose.search import PoseSearch, dense_searches
from unseeable.vision.pose.settings import EDGE_BIAS_PX

__all__ = [
    "Finalist",
    "ClusterFit",
    "align_candidate",
    "ring_tops",
    "restarted",
    "fit_at_cluster",
    "offered_aliases",
]

logger = logging.getLogger(__name__)


class Finalist(NamedTuple):
    """A fully aligned candidate of :func:`fit_at_cluster`."""

    score: float
    #: The quarter-turn family of its yaw (0: grid i nearer world x, 1: nearer z).
    turn: int
    pose: GridPose
    matches: EdgeMatches
    #: Aligned only to be offered to the structure choice (the screening dropped it).
    forced: bool


class ClusterFit(NamedTuple):
    """The best fit around one wood cluster (:func:`fit_at_cluster`)."""

    quality: float
    #: The edge-best pose, its yaw in ``[-90, 90)``.
    pose: GridPose
    #: The same pose as aligned (its half turn, possibly).
    edge_best: GridPose
    best_score: float
    margin: float
    aligned_share: float
    present: float
    #: The best finalist of the other quarter-turn family, if any.
    other_turn: Finalist | None
    #: ``other_turn``'s pose, canonical, and its score.
    alternatives: list
    #: Every finalist, best first.
    finals: list
    #: The factor the wood outside the extent's box puts on the quality (1: no more than
    #: ``wood_outside_ok``; 0: twice it).
    wood_factor: float = 1.0


def align_candidate(search: PoseSearch, pose_c: GridPose, iterations: int, *,
                    screen: bool = False) -> tuple[float, GridPose, EdgeMatches]:
    """``pose_c`` aligned ``iterations`` steps, its alignment score and edge matches.

    A screen scores the refined pose with the samples of the pose it started from
    (the same features a few millimetres away): one sampling of the grid saved.
    """
    st = search.settings
    samples = (feature_samples(search.extent, pose_c, search.camera, search.geometry,
                               spacing=st.sample_spacing_px, edge_bias_px=EDGE_BIAS_PX,
                               use_ends=True) if screen else None)
    return align_and_score(search.maps, search.camera, search.extent, search.geometry, pose_c,
                           settings=st, mm_per_px=search.mm_per_px, iterations=iterations,
                           samples=samples)


def ring_tops(search: PoseSearch, centres: list[GridPose],
              steps_mm: tuple[float, ...]) -> list[GridPose]:
    """For each of ``centres``, the best of the screened alignments started at the 8
    translations each of ``steps_mm`` around it (rings of a square grid in its own
    grid frame)."""
    st = search.settings
    ring = [(dx, dz) for step in steps_mm
            for dx in (-step, 0.0, step) for dz in (-step, 0.0, step) if dx or dz]
    starts = [shifted_pose(c, dx, dz) for c in centres for dx, dz in ring]
    looked = map_in_threads(lambda p: align_candidate(search, p, st.screen_iterations,
                                                      screen=True),
                            starts, threads=search.threads)
    # Each centre's starts are one block of ``len(ring)``.
    return [max(looked[k * len(ring):(k + 1) * len(ring)], key=lambda r: r[0])[1]
            for k in range(len(centres))]


def restarted(search: PoseSearch, finals: list[Finalist]) -> list[Finalist]:
    """The best ``restart_keep`` finals, each replaced by the best of the alignments
    started ``restart_mm`` around it when one scores higher (then re-sorted)."""
    st = search.settings
    if not st.restart_mm:
        return finals
    seeds = [n for n, c in enumerate(finals) if not c[4]][: st.restart_keep]
    tops = list(zip(seeds, ring_tops(search, [finals[n][2] for n in seeds], st.restart_mm)))
    out = list(finals)
    for (n, _), (sc, refined, matches) in zip(
            tops, map_in_threads(lambda t: align_candidate(search, t[1], 8), tops,
                                 threads=search.threads)):
        if sc > out[n][0]:
            logger.debug("restart moved candidate %d by %.1f mm: score %.1f -> %.1f", n,
                         np.hypot(refined.x - out[n][2].x, refined.z - out[n][2].z),
                         out[n][0], sc)
            out[n] = Finalist(sc, out[n][1], refined, matches, out[n][4])
    out.sort(key=lambda c: -c[0])
    return out


def fit_at_cluster(search: PoseSearch, yaws: list[float], rank: int) -> ClusterFit | None:
    """The search's steps 2 to 4 around the ``rank``-th wood cluster (None: there is no
    such cluster, or no candidate there).

    For each yaw hypothesis of ``yaws`` and quarter turn: the translations whose upper
    silhouettes and end rims lie on the most edges (:func:`dense_searches`); the best
    candidates aligned, and the fit statistics and quality of the best.
    """
    st, extent, geometry = search.settings, search.extent, search.geometry
    region_scores = [0.0, 0.0]
    screened = []
    # ``o``: which of the two quarter-turn families the yaw belongs to (grid i nearer
    # world x, or nearer z), the same for every yaw peak.
    looks = [(y, turn, int(((y + 90.0 * turn + 45.0) % 180.0) // 90.0))
             for y in yaws for turn in (0, 1)]
    for (y, turn, o), found in zip(looks, dense_searches(search, [(y + 90.0 * turn, o, y)
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
    nearby = iter(dense_searches(search, [(y + d + 90.0 * turn, o, y)
                                          for _, y, turn, o, _ in kept_yaws for d in deltas],
                                 rank, region_scores))
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

    # Each candidate is aligned precisely with its image edges; the pose whose features
    # lie most coherently on edges wins.
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
    aligned = map_in_threads(lambda c: align_candidate(search, c[1], st.screen_iterations),
                             looked, threads=search.threads)
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
            chosen, map_in_threads(lambda c: align_candidate(search, c[2], 8), chosen,
                                   threads=search.threads)):
        finals.append(Finalist(sc, o, refined, matches, forced))
    if not finals:
        return None
    finals.sort(key=lambda c: -c[0])
    if st.restart_keep > 0:
        finals = restarted(search, finals)
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
    pose = canonical_pose(pose, extent, geometry)
    alternatives = []
    if h2 is not None:
        alternatives.append((canonical_pose(h2[2], extent, geometry), h2[0]))
    stats = np.array([margin, aligned_share, present, np.log1p(max(best_score, 0.0))])
    model = (search.quality_model if search.quality_model is not None
             else default_quality_model())
    quality = float(model.probability(stats))
    # Wood well outside the extent's box: the extent (or the pose) cannot be right.
    outside = wood_outside(search.wood, search.camera, extent, pose, geometry,
                           image=search.image)
    wood_factor = float(np.clip(1.0 - (outside - st.wood_outside_ok) / st.wood_outside_ok,
                                0, 1))
    quality *= wood_factor
    logger.debug("pose %s quality %.3f (margin %.3f, aligned %.3f, present %.3f, wood %.3f)",
                 pose, quality, margin, aligned_share, present, wood_factor)
    return ClusterFit(quality, pose, edge_best, best_score, margin, aligned_share, present, h2,
                      alternatives, finals, wood_factor)


def offered_aliases(search: PoseSearch, fit: ClusterFit) -> list[tuple[GridPose, float]]:
    """The poses offered to the structure choice beside ``fit``'s edge-best pose, with their
    alignment scores, best first (not canonical).

    The grid's near-symmetries: translations along a grid axis that move the image of
    the other axis's lines as rising a half-layer or two would
    (:func:`~unseeable.vision.pose.aliases.pose_aliases`). Edges score them almost
    alike; the close ones go to the caller, for the grammar to decide. With them, on a
    square footprint, the other quarter turn's best pose and its aliases, the other
    finalists that score nearly as well, and the grid a pitch off when the edges
    prefer it.
    """
    st, camera, extent, geometry = search.settings, search.camera, search.extent, search.geometry
    edge_best, best_score, h2 = fit.edge_best, fit.best_score, fit.other_turn
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

    if st.finals_keep > 0:
        # The other fully aligned candidates that score nearly as well: edges alone cannot
        # tell them from the best (they are often the grid's near-symmetries at another
        # start), the structure they imply may.
        for sc, _, pose_c, _, forced in fit.finals[1:]:
            if (not forced and sc >= st.finals_keep * best_score
                and _is_novel(pose_c, edge_best, aliases)):
                aliases.append((pose_c, float(sc)))
    # A few steps first: most aliases land on nothing and are dropped there.
    looked = map_in_threads(lambda p: align_candidate(search, p, st.screen_iterations,
                                                      screen=True),
                            tries, threads=search.threads)
    passed = [refined for sc, refined, _ in looked if sc >= st.alias_screen * best_score]
    if st.pitch_aliases:
        # The grid a whole pitch off along either axis or both: its lines fall on the true
        # grid's, and the translation search's peaks can sit a pitch from the truth. Only
        # the best of those, and only when the edges prefer it to the best pose: on a big
        # periodic grid a pitch shift fits nearly as well (0.80-0.84 of the best on the
        # big cabins), and each candidate costs the structure choice a solve.
        (start,) = ring_tops(search, [edge_best], (geometry.l1,))
        sc, refined, _ = align_candidate(search, start, 8)
        if sc >= st.pitch_keep * best_score and _is_novel(refined, edge_best, aliases):
            aliases.append((refined, sc))
    for sc, refined, _ in map_in_threads(lambda p: align_candidate(search, p, 8), passed,
                                         threads=search.threads):
        if sc >= st.alias_keep * best_score and _is_novel(refined, edge_best, aliases):
            aliases.append((refined, sc))
    aliases.sort(key=lambda c: -c[1])
    return aliases


def _is_novel(p: GridPose, edge_best: GridPose, aliases: list[tuple[GridPose, float]]) -> bool:
    """Whether ``p`` is more than 1 mm or 0.3° from the edge-best pose and every alias so far."""
    return all(np.hypot(p.x - q.x, p.z - q.z) > 1.0 or abs(p.yaw_deg - q.yaw_deg) > 0.3
               for q in [edge_best, *(a for a, _ in aliases)])
