"""Detectors focused on the expected place and shape of each feature."""

import numpy as np
import pytest

from unseeable.domain import Extent, FeatureKind, LogGeometry, feature_index, feature_values
from unseeable.errors import InputError
from unseeable.visibility import feature_visibility
from unseeable.vision import END_STATS, SEGMENT_STATS, edge_maps, score_features
from unseeable.vision.detectors import score_ends, score_segments


def auc(score, truth):
    score, truth = np.asarray(score, float), np.asarray(truth, bool)
    pos, neg = score[truth], score[~truth]
    return float(np.mean(pos[:, None] > neg[None, :]) + 0.5 * np.mean(pos[:, None] == neg[None, :]))


def test_ellipse_filter_finds_a_drawn_ellipse_and_its_offset():
    import cv2

    img = np.full((80, 80, 3), 200, np.uint8)
    cv2.ellipse(img, (41, 39), (12, 6), 30, 0, 360, (60, 40, 30), -1, cv2.LINE_AA)
    maps = edge_maps(img)
    expected = np.array([[40.0, 40.0, 12.0, 6.0, np.deg2rad(30)],  # off by a pixel
                         [20.0, 60.0, 12.0, 6.0, np.deg2rad(30)]])  # nothing there
    stats, best = score_ends(maps, expected, np.array([[1.0, 0.0], [1.0, 0.0]]))
    strength = END_STATS.index("strength")
    assert stats[0, strength] > 3 * stats[1, strength]
    # The search over small perturbations moved the ellipse onto the drawn one.
    assert best[0, :2] == pytest.approx([41.0, 39.0], abs=1.01)


def test_a_rim_made_up_by_a_log_body_is_told_from_a_drawn_end_disc():
    import cv2

    # Left: a drawn end disc. Right: a horizontal bar (a log body seen from the side)
    # whose straight silhouettes pass through the same-sized ellipse's top and bottom.
    img = np.full((80, 160, 3), 200, np.uint8)
    cv2.ellipse(img, (40, 40), (6, 12), 0, 0, 360, (60, 40, 30), -1, cv2.LINE_AA)
    img[28:53, 90:160] = (60, 40, 30)
    maps = edge_maps(img)
    expected = np.array([[40.0, 40.0, 6.0, 12.0, 0.0], [120.0, 40.0, 6.0, 12.0, 0.0]])
    stats, _ = score_ends(maps, expected, np.array([[1.0, 0.0], [1.0, 0.0]]))
    col = {name: END_STATS.index(name) for name in
           ("rim_alignment", "quadrant_min", "quadrant_spread", "radial_peak")}
    assert stats[0, col["quadrant_min"]] > 3 * stats[1, col["quadrant_min"]]
    assert stats[0, col["quadrant_spread"]] < stats[1, col["quadrant_spread"]]
    assert stats[0, col["radial_peak"]] > 1.5 * stats[1, col["radial_peak"]]
    assert stats[0, col["rim_alignment"]] > stats[1, col["rim_alignment"]]
    del cv2


def test_segment_detector_prefers_the_drawn_line_and_measures_its_run():
    import cv2

    img = np.full((60, 120, 3), 200, np.uint8)
    img[30:, 10:60] = 60  # a dark region whose top edge runs from x=10 to x=60
    maps = edge_maps(img)
    segs = np.array([[[12.0, 29.5], [58.0, 29.5]],   # on the edge
                     [[12.0, 45.0], [58.0, 45.0]],   # inside the dark region
                     [[12.0, 29.5], [108.0, 29.5]]])  # edge for half its length
    s = score_segments(maps, segs)
    strength, run = SEGMENT_STATS.index("strength"), SEGMENT_STATS.index("run")
    assert s[0, strength] > 5 * s[1, strength]
    assert s[0, run] > 0.9
    assert 0.35 < s[2, run] < 0.65
    del cv2


def test_present_features_score_higher_than_absent_ones(synthetic_view):
    s, pose, cam, image = synthetic_view
    visible = feature_visibility(s, cam.centre, pose)
    sc = score_features(image, cam, pose, s.extent, mask=visible)
    truth = feature_values(s.extent, s.occupancy)
    kind = feature_index(s.extent).kind
    ends = sc.judged & (kind <= FeatureKind.END_PLUS)
    segs = sc.judged & (kind >= FeatureKind.U)
    assert ends.sum() > 10 and segs.sum() > 50
    # The chosen line is the stronger of the log's own lower and the upper one of j-2.
    col = {name: SEGMENT_STATS.index(name) for name in
           ("strength", "lower_strength", "upper_strength", "interior_here", "interior_below")}
    st = sc.segment_stats[segs]
    assert st[:, col["strength"]] == pytest.approx(
        np.maximum(st[:, col["lower_strength"]], st[:, col["upper_strength"]]))
    assert np.isfinite(st[:, [col["interior_here"], col["interior_below"]]]).all()
    assert auc(sc.end_stats[ends, END_STATS.index("strength")], truth[ends]) > 0.8
    assert auc(sc.segment_stats[segs, SEGMENT_STATS.index("band_max")], truth[segs]) > 0.85


def test_only_requested_features_are_judged(synthetic_view):
    s, pose, cam, image = synthetic_view
    n = len(feature_index(s.extent))
    mask = np.zeros(n, bool)
    mask[::7] = True
    sc = score_features(image, cam, pose, s.extent, mask=mask)
    assert not sc.judged[~mask].any()
    assert sc.judged.sum() > 0
    judged_ends = sc.judged & sc.projection.is_end
    assert np.isfinite(sc.end_stats[judged_ends]).all()
    assert np.isnan(sc.end_stats[~judged_ends]).all()
    assert np.isnan(sc.segment_stats[~(sc.judged & ~sc.projection.is_end)]).all()


def test_two_threads_give_the_same_scores(synthetic_view):
    # The ends and the segments side by side: the same statistics, bit for bit.
    s, pose, cam, image = synthetic_view
    one = score_features(image, cam, pose, s.extent)
    two = score_features(image, cam, pose, s.extent, threads=2)
    assert np.array_equal(one.judged, two.judged)
    for a, b in ((one.end_stats, two.end_stats), (one.segment_stats, two.segment_stats),
                 (one.ellipses, two.ellipses)):
        assert np.array_equal(a, b, equal_nan=True)
    # (both halves scored something)
    assert np.isfinite(two.end_stats[two.judged & two.projection.is_end]).all()
    assert np.isfinite(two.segment_stats[two.judged & ~two.projection.is_end]).all()


def test_bad_mask_and_image_size_are_input_errors(synthetic_view):
    s, pose, cam, image = synthetic_view
    with pytest.raises(InputError, match="mask"):
        score_features(image, cam, pose, s.extent, mask=np.ones(5, bool))
    with pytest.raises(InputError, match="image"):
        score_features(image[:100], cam, pose, s.extent)


def test_features_outside_the_image_are_not_judged(synthetic_view):
    s, pose, cam, image = synthetic_view
    from unseeable.domain import GridPose

    far = GridPose(pose.x + 3000.0, pose.z, pose.yaw_deg)
    sc = score_features(image, cam, far, Extent(*s.extent.shape))
    assert not sc.judged.any()


def _profile_block(stats, names, prefix):
    """Columns of ``stats`` whose names start with ``prefix``, in the names' order."""
    return stats[:, [i for i, n in enumerate(names) if n.startswith(prefix)]]


def _judged_present(view):
    """The view's scores of its visible features, their index, and which are present."""
    s, pose, cam, image = view
    visible = feature_visibility(s, cam.centre, pose)
    sc = score_features(image, cam, pose, s.extent, mask=visible)
    idx = feature_index(s.extent)
    return sc, idx, sc.judged & (feature_values(s.extent, s.occupancy) > 0)


def test_segment_profiles_find_the_logs_silhouettes_where_the_pose_puts_them(synthetic_view):
    from unseeable.vision.detectors import SEGMENT_PROFILE_ACROSS

    sc, idx, present = _judged_present(synthetic_view)
    # Segments whose own log is there (the lower silhouette is the log's, not j-2's top).
    own = present & (idx.kind == FeatureKind.W) & (idx.at[:, 1] < synthetic_view[0].extent.J)
    assert own.sum() > 10
    edge = _profile_block(sc.segment_stats[own], SEGMENT_STATS, "profile_edge_")
    across = np.asarray(SEGMENT_PROFILE_ACROSS)
    assert edge.shape[1] == len(across)
    mean = edge.mean(axis=0)
    at = {t: int(np.argmin(np.abs(across - t))) for t in (0.0, 0.5, 1.0, 2.25)}
    # Edges on both silhouettes, weaker ones (the grain) on the log's body between them,
    # none on the background above it.
    assert mean[at[0.0]] > 1.25 * mean[at[0.5]]
    assert mean[at[1.0]] > 1.25 * mean[at[0.5]]
    assert min(mean[at[0.0]], mean[at[1.0]]) > 3 * mean[at[2.25]]
    width = sc.segment_stats[own, SEGMENT_STATS.index("profile_width")]
    assert np.all(width > 2)


def test_end_profiles_find_the_logs_silhouettes_inside_the_end_and_not_past_it(synthetic_view):
    from unseeable.vision.detectors import END_PROFILE_ACROSS, END_PROFILE_ALONG

    sc, idx, present = _judged_present(synthetic_view)
    ends = present & (idx.kind <= FeatureKind.END_PLUS)
    assert ends.sum() >= 3
    shape = (len(ends.nonzero()[0]), len(END_PROFILE_ACROSS), len(END_PROFILE_ALONG))
    across = _profile_block(sc.end_stats[ends], END_STATS, "profile_edge_across_").reshape(shape)
    a = np.asarray(END_PROFILE_ALONG)
    c = np.asarray(END_PROFILE_ACROSS)
    inside, past = (int(np.argmin(np.abs(a - t))) for t in (-2.0, 1.5))
    lower, upper = (int(np.argmin(np.abs(c - t))) for t in (0.0, 1.0))
    # The log's silhouettes show inside the end and stop at it.
    for line in (lower, upper):
        assert across[:, line, inside].mean() > 1.5 * across[:, line, past].mean()


@pytest.mark.parametrize("case", ["cabin", "scatter", "close-up with a distorting lens"])
def test_the_detectors_read_nothing_outside_their_sampling_window(case, synthetic_view,
                                                                  scatter_view, monkeypatch):
    # The maps are made only in the window around the assembly (zero elsewhere): every
    # statistic must be what the whole image's maps give.
    import unseeable.vision.detectors as detectors
    from unseeable.camera import Camera

    s, pose, cam, image = scatter_view if case == "scatter" else synthetic_view
    if case.startswith("close-up"):
        # Nearer and distorted: the assembly fills most of the frame, part of it beyond.
        cam = Camera(cam.width, cam.height, cam.K * np.array([[1.6], [1.6], [1.0]]),
                     cam.R, cam.t, np.array([-0.25, 0.08, 0.0, 0.0, 0.0]))
    window = detectors._sampling_window(s.extent, pose, cam, LogGeometry(), image.shape[:2])
    assert window != (slice(0, image.shape[0]), slice(0, image.shape[1]))
    windowed = score_features(image, cam, pose, s.extent)
    monkeypatch.setattr(detectors, "_sampling_window",
                        lambda *args, **kwargs: (slice(0, image.shape[0]),
                                                 slice(0, image.shape[1])))
    whole = score_features(image, cam, pose, s.extent)
    np.testing.assert_array_equal(windowed.judged, whole.judged)
    for a, b in ((windowed.end_stats, whole.end_stats),
                 (windowed.segment_stats, whole.segment_stats),
                 (windowed.ellipses, whole.ellipses)):
        np.testing.assert_allclose(a, b, rtol=1e-5, atol=1e-6, equal_nan=True)


def test_ends_seen_edge_on_are_judged_and_told_apart(arm_camera):
    # Seen straight along k, the ends facing along i are thin slivers (a quarter of the
    # corpus's visible ends are under 1.5 px across): they used to be left unjudged, yet
    # the log's band stopping there, or running on, shows whether a log ends.
    from drawing import draw_structure

    from conftest import centred_pose, scatter
    from unseeable.vision.calibration import default_calibration

    s = scatter()
    forward = arm_camera.R[2]
    pose = centred_pose(s.extent, float(np.degrees(np.arctan2(forward[0], forward[2]))))
    assert abs(pose.rotation[:, 0] @ forward) < 1e-9  # the grid's i across the view
    image = draw_structure(s, pose, arm_camera, seed=1)
    visible = feature_visibility(s, arm_camera.centre, pose)
    sc = score_features(image, arm_camera, pose, s.extent, mask=visible)
    ell = sc.projection.ellipses
    thin = visible & sc.projection.is_end & (np.minimum(ell[:, 2], ell[:, 3]) < 1.5)
    assert thin.sum() >= 15 and sc.judged[thin].all()
    assert np.isfinite(sc.end_stats[thin]).all()
    p = default_calibration().probabilities(sc)[thin]
    present = feature_values(s.extent, s.occupancy)[thin] > 0
    assert 0 < present.sum() < len(present)
    assert auc(p, present) > 0.9 and np.mean((p > 0.5) == present) > 0.8
