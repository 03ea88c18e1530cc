"""The assembly's pose on the table from one image (issue item 4; DESIGN.md §4 "Pose").

Given the camera (intrinsics and extrinsics relative to the table) and the
extent, the pose has three unknowns, ``GridPose(x, z, yaw)``:

1. **Yaw modulo 90°.** Every log edge is a horizontal line along one of the
   grid's two axes. Each image line segment (OpenCV's LSD) is the image of a
   horizontal line only for one horizontal direction ψ (its vanishing point
   must lie on the segment's line), so each segment votes for ψ. The
   assembly's two axes are 90° apart: a yaw scores the product of the votes
   for it and for it + 90°, which ignores clutter with one direction only
   (a wooden table's grain). A seamed or tiled table's lines run their
   directions all over the view, the assembly's edges crowd within its own
   image size: votes count by how much their direction crowds near them
   beyond its rate over the whole view (:func:`concentration`), and the
   spread segments on lines longer than any log edge leave the edge maps the
   search matches with. Votes are weighted by how much wood lies
   beside each segment; the best few peaks are kept as hypotheses, with
   the peaks of either direction alone (:func:`axis_yaws`): an axis seen
   across the line of sight has its edges along the horizon, where they
   fit any direction and so carry no weight.
2. **Where the wood is.** A colour model learnt on the image itself
   (:func:`unseeable.vision.edges.woodness_map`: wood against background)
   is warped onto the table plane at the assembly's mid-height; a box
   filter of the extent's footprint places each yaw and quarter-turn
   hypothesis where it covers the most wood (within a couple of
   centimetres): wood thinner than half a log (dark seams read as wood),
   the table's own level of it, and wood far from every crowd of edges
   count less (:func:`~unseeable.vision.pose.placement.placement_wood`).
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
alignment score) by a logistic model fitted on training renders, times a
factor for wood-coloured pixels outside the extent's box. A fit the image
contradicts (that wood alone takes it below ``PoseSettings.min_quality``)
raises :class:`~unseeable.errors.VisionError`; a fit that is only weak is
returned, and an estimate on it is never confident.

The modules, in the order of the search: :mod:`~unseeable.vision.pose.yaw`
(step 1), :mod:`~unseeable.vision.pose.placement` (step 2),
:mod:`~unseeable.vision.pose.search` (step 3),
:mod:`~unseeable.vision.pose.candidates` (step 4 and the aliases),
:mod:`~unseeable.vision.pose.estimate` (:func:`estimate_pose`, all of them);
beneath them :mod:`~unseeable.vision.pose.lines` (where a pose puts the
grid's features), :mod:`~unseeable.vision.pose.samples`,
:mod:`~unseeable.vision.pose.alignment` (edge matching and alignment),
:mod:`~unseeable.vision.pose.aliases`, :mod:`~unseeable.vision.pose.quality`,
:mod:`~unseeable.vision.pose.settings` and :mod:`~unseeable.vision.pose.fit`
(:class:`PoseFit`); :mod:`~unseeable.vision.pose.refinement` polishes and
scores a given pose.
"""

from unseeable.vision.calibration import POSE_QUALITY_STATS, PoseQualityModel
from unseeable.vision.pose.aliases import pose_aliases, pose_equivalent
from unseeable.vision.pose.estimate import estimate_pose
from unseeable.vision.pose.fit import PoseFit
from unseeable.vision.pose.lines import grid_lines, pose_lines
from unseeable.vision.pose.refinement import (
    align_pose,
    refine_pose,
    refine_pose_on_structure,
    rim_support,
)
from unseeable.vision.pose.settings import POLISH_REACH_PX, POLISH_RIM_WEIGHT, PoseSettings
from unseeable.vision.pose.yaw import (
    axis_yaws,
    concentration,
    dominant_yaw,
    line_segments,
    segment_directions,
)

__all__ = [
    "PoseSettings",
    "PoseFit",
    "estimate_pose",
    "line_segments",
    "segment_directions",
    "dominant_yaw",
    "axis_yaws",
    "concentration",
    "pose_lines",
    "grid_lines",
    "pose_equivalent",
    "pose_aliases",
    "refine_pose",
    "refine_pose_on_structure",
    "align_pose",
    "rim_support",
    "PoseQualityModel",
    "POSE_QUALITY_STATS",
    "POLISH_REACH_PX",
    "POLISH_RIM_WEIGHT",
]
