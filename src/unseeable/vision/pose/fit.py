"""The pose search's result: :class:`PoseFit`."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from unseeable.domain import GridPose

__all__ = ["PoseFit", "AMBIGUOUS_CHOICE_MARGIN"]

#: Below this lead of the chosen candidate's value over its best rival's, the choice is
#: called ambiguous (:attr:`PoseFit.ambiguous`) and an estimate made at that pose is not
#: confident (:attr:`unseeable.pipeline.Estimate.confident`). Read off, not fitted: on the
#: 160 corpus views (pose estimated) 3 of the 5 wrong choices lie below 0.1 and 3 of the
#: 155 right ones; on the 240 validation renders 6 of 19 wrong and 14 of 221 right; on
#: other cameras and another renderer (held out) 3 of 7 and 3 of 9 wrong, 5 of 53
#: and 6 of 51 right (docs/results.md).
AMBIGUOUS_CHOICE_MARGIN = 0.1


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
        statistics below (:class:`~unseeable.vision.calibration.PoseQualityModel`),
        times ``wood_factor``.
    margin : float
        Relative alignment-score margin over the best pose that is not the same
        (another quarter turn, or more than half a log diameter away).
    aligned : float
        Share of the pose's feature samples lying within 0.75 px of a strong edge.
    present : float
        Share of feature samples on lines and rims that look present.
    score : float
        Alignment score (see :func:`~unseeable.vision.pose.alignment.alignment_score`).
    yaw_mod90_deg : float
        The yaw modulo 90° from the vanishing directions alone.
    alternatives : tuple of (GridPose, float)
        The best pose of the other quarter-turn hypothesis and its score.
        When the footprint is square (I = K) a quarter turn fits the same
        lines after a translation; the estimator should try this pose too.
    candidates : tuple of (GridPose, float)
        ``pose`` and its aliases (:func:`~unseeable.vision.pose_aliases`, each aligned on the
        image) whose alignment score is close to the best, with their scores:
        edges alone cannot tell these apart reliably;
        :func:`unseeable.vision.select_pose` lets the grammar decide.
    choice_margin : float or None
        Set by :func:`~unseeable.vision.select_pose`: how far the chosen
        candidate's value is ahead of its best rival's (the units of the
        choice's value; a rival is a candidate more than 2 mm or 1° from the
        chosen pose). None when there was no rival (a single candidate, or
        the pitch check moved the choice by its own clear margin). Below
        :data:`AMBIGUOUS_CHOICE_MARGIN` the
        choice is close to a coin toss (:attr:`ambiguous`).
    choice_rival : GridPose or None
        That best rival (unpolished), when there was one: where the grid
        lies if the choice was wrong — what another view could rule out.
    wood_factor : float
        In [0, 1]: what the wood-coloured pixels outside the extent's box at
        ``pose`` leave of the quality (1: no more than
        :attr:`~unseeable.vision.pose.PoseSettings.wood_outside_ok` of the
        assembly's wood; 0: twice that). Low, the image contradicts the extent
        (or shows more than the assembly), whatever the edges say.
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
    wood_factor: float = 1.0

    @property
    def ambiguous(self) -> bool:
        """Whether the structure choice among the candidates was a near coin toss."""
        return self.choice_margin is not None and self.choice_margin < AMBIGUOUS_CHOICE_MARGIN

    @property
    def stats(self) -> np.ndarray:
        """The statistics of :data:`~unseeable.vision.calibration.POSE_QUALITY_STATS`,
        ``(4,)``."""
        return np.array([self.margin, self.aligned, self.present, np.log1p(max(self.score, 0))])

    def to_json(self) -> dict:
        data = {**self.pose.to_json(), "quality": self.quality}
        if self.choice_margin is not None:
            data.update(choice_margin=self.choice_margin, ambiguous=self.ambiguous)
        if self.choice_rival is not None:
            data["rival"] = self.choice_rival.to_json()
        return data
