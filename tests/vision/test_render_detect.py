"""One real (small, quick) render: the shipped calibration tells present from absent."""

import numpy as np

from unseeable.visibility import feature_visibility
from unseeable.vision import detect_features, estimate_pose, pose_equivalent


def test_detectors_on_a_render(rendered_house):
    s, pose, cam, image = rendered_house
    visible = feature_visibility(s, cam.centre, pose)
    det = detect_features(image, cam, pose, s.extent, mask=visible)
    from unseeable.domain import feature_values

    truth = feature_values(s.extent, s.occupancy)
    j = det.judged
    assert j.sum() > 40
    assert det.p[j & truth].mean() > det.p[j & ~truth].mean() + 0.3
    assert np.mean((det.p[j] > 0.5) == truth[j]) > 0.75


def test_pose_of_a_render(rendered_house):
    s, pose, cam, image = rendered_house
    fit = estimate_pose(image, cam, s.extent, strict=False)
    # A square footprint: a quarter turn may fit the lines as well; the estimator tries it.
    candidates = [fit.pose] + [p for p, _ in fit.alternatives]
    best = min((pose_equivalent(p, pose, s.extent) for p in candidates), key=sum)
    assert best[0] < 2.5 and best[1] < 1.0
