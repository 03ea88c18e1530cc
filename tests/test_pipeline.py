"""What an estimate reports about itself (unseeable.pipeline)."""

import dataclasses

from unseeable.domain import Extent, Log, Structure, simulate_evidence
from unseeable.pipeline import estimate_evidence, estimate_to_json


def _sure_estimate():
    truth = Structure(Extent(2, 1, 2), [Log(0, (0, 0), 2), Log(0, (0, 1), 2)])
    est = estimate_evidence(simulate_evidence(truth, accuracy=1.0, occluded_fraction=0.0,
                                              seed=0))
    assert est.confidence.confident
    return est


def test_an_estimate_at_an_ambiguously_chosen_pose_is_not_confident():
    est = _sure_estimate()
    assert est.confident and estimate_to_json(est)["confident"] is True
    doubtful = dataclasses.replace(est, extra={"pose_ambiguous": True,
                                               "pose_choice_margin": 0.02})
    assert doubtful.confident is False
    data = estimate_to_json(doubtful)
    # The δ* test itself passed: the file says so beside the overall judgement.
    assert data["confident"] is False and data["confident_at_pose"] is True
    assert data["pose_ambiguous"] is True and data["pose_choice_margin"] == 0.02
    clear = dataclasses.replace(est, extra={"pose_ambiguous": False})
    assert clear.confident is True


def test_without_a_confidence_test_nothing_is_claimed():
    est = dataclasses.replace(_sure_estimate(), confidence=None,
                              extra={"pose_ambiguous": False})
    assert est.confident is None
    assert "confident" not in estimate_to_json(est)
