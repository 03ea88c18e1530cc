"""Evidence for the estimator from one photograph; the overlays."""

import numpy as np

from unseeable.domain import Evidence, feature_index, load_evidence, save_evidence
from unseeable.visibility import feature_visibility
from unseeable.vision import detect_features, draw_evidence, draw_pose, feature_evidence
from unseeable.vision.overlay import probability_colours


def test_detect_features_gives_evidence_for_the_requested_features(synthetic_view, tmp_path):
    s, pose, cam, image = synthetic_view
    visible = feature_visibility(s, cam.centre, pose)
    det = detect_features(image, cam, pose, s.extent, mask=visible)
    assert isinstance(det.evidence, Evidence)
    assert np.array_equal(det.evidence.p, det.p)
    assert not det.judged[~visible].any()
    assert np.all(det.p[~det.judged] == 0.5)
    assert np.all((det.p[det.judged] >= 0.02) & (det.p[det.judged] <= 0.98))
    # Only judged features go to the file.
    save_evidence(det.evidence, tmp_path / "e.json")
    back = load_evidence(tmp_path / "e.json")
    assert np.allclose(back.p, det.p)
    # The pose was polished on the image, not moved away.
    assert abs(det.pose.x - pose.x) < 3 and abs(det.pose.z - pose.z) < 3


def test_feature_evidence_matches_detect_features(synthetic_view):
    s, pose, cam, image = synthetic_view
    mask = np.zeros(len(feature_index(s.extent)), bool)
    mask[:40] = True
    a = feature_evidence(image, cam, pose, s.extent, mask=mask, refine=False)
    b = detect_features(image, cam, pose, s.extent, mask=mask, refine=False).evidence
    assert np.array_equal(a.p, b.p)


def test_overlays_draw_on_a_copy(synthetic_view):
    s, pose, cam, image = synthetic_view
    det = detect_features(image, cam, pose, s.extent, refine=False)
    before = image.copy()
    over = draw_evidence(image, det.scores.projection, det.p, det.judged)
    assert over.shape == image.shape and over.dtype == np.uint8
    assert np.array_equal(image, before)
    assert (over != (image * 0.6).astype(np.uint8)).any()
    grid = draw_pose(image, cam, s.extent, pose)
    assert grid.shape == image.shape


def test_probability_colours_run_red_to_green():
    c = probability_colours(np.array([0.0, 0.5, 1.0]))
    assert c[0].tolist() == [255, 0, 0]
    assert c[2].tolist() == [0, 255, 0]
    assert c[1, 0] == 255 and c[1, 1] == 255


def test_initial_mask_leaves_out_removed_layers(synthetic_view):
    from unseeable.vision.evidence import initial_mask

    s, pose, cam, image = synthetic_view
    idx = feature_index(s.extent)
    full = initial_mask(s.extent, cam, pose)
    cut = initial_mask(s.extent, cam, pose, removed_from_layer=2)
    assert full.sum() > cut.sum() > 0
    ends = idx.kind <= 1
    assert idx.at[cut & ends, 1].max() <= 1  # no ends of removed logs
    assert idx.at[cut & ~ends, 1].max() == 3  # but the top edges of layers 0 and 1
    assert not initial_mask(s.extent, cam, pose, removed_from_layer=0).any()
