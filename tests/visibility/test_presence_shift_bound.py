"""The presence shift is bounded and cannot empty an estimate of what the detectors see."""

from __future__ import annotations

import numpy as np
import pytest

from simulated_view import biased_observation, station_camera
from unseeable.corpus import load_design
from unseeable.domain import Extent, FeatureKind, Log, Structure, feature_index, feature_values
from unseeable.evaluate import count_errors
from unseeable.pipeline.evidence_checks import presence_doubt
from unseeable.solve import StructureSolver
from unseeable.visibility import feature_visibility, initial_visibility, loop
from unseeable.visibility.loop import (
    PRESENCE_SHIFT_BOUND,
    ViewEvidence,
    estimate_with_visibility,
)


def test_the_applied_shift_stays_within_the_bound_and_the_view_is_in_doubt():
    # Detectors so shy that no structure agrees with them: the fit asks for more than a
    # look explains; the shift applied stops at the bound, and the view says so.
    truth = load_design("cabin-door").structure
    cam, pose = station_camera(truth, 150)
    obs = biased_observation(truth, cam, pose, -2.0, seed=4)
    fp = estimate_with_visibility(obs, truth.extent, solver=StructureSolver(truth.extent),
                                  initial_visibility=initial_visibility(truth.extent, cam, pose),
                                  presence_shift=True)
    (fitted,), (applied,) = fp.presence_fitted, fp.presence_shift
    assert abs(fitted) > PRESENCE_SHIFT_BOUND
    assert applied == pytest.approx(np.sign(fitted) * PRESENCE_SHIFT_BOUND)
    assert fp.presence_refused == (False,)
    assert presence_doubt(fp)


def test_a_view_without_bias_is_shifted_as_fitted_and_not_in_doubt():
    truth = load_design("tower-3").structure
    cam, pose = station_camera(truth, 120)
    obs = biased_observation(truth, cam, pose, 0.0, seed=4)
    fp = estimate_with_visibility(obs, truth.extent, solver=StructureSolver(truth.extent),
                                  initial_visibility=initial_visibility(truth.extent, cam, pose),
                                  presence_shift=True)
    assert abs(fp.presence_fitted[0]) < PRESENCE_SHIFT_BOUND
    assert fp.presence_shift in ((0.0,), fp.presence_fitted)  # 0 when not worth a fixpoint
    assert fp.presence_refused == (False,)
    assert not presence_doubt(fp)


def _clear_ends_observation(segment_log_odds: float):
    """Four logs whose ends the detectors see clearly (log-odds 1.6, beyond the bound)
    and whose segments they see with ``segment_log_odds``; every other feature clearly
    absent."""
    truth = Structure(Extent(5, 2, 5), [Log(0, (0, 0), 3), Log(0, (0, 2), 3),
                                        Log(1, (0, 0), 3), Log(1, (2, 0), 3)])
    cam, pose = station_camera(truth, 150)
    idx = feature_index(truth.extent)
    value = feature_values(truth.extent, truth.occupancy).astype(bool)
    visible = feature_visibility(truth, cam.centre, pose)
    ends = np.isin(idx.kind, [FeatureKind.END_MINUS, FeatureKind.END_PLUS])
    z = np.where(value, np.where(ends, 1.6, segment_log_odds), -3.9)
    p = np.where(visible, 1.0 / (1.0 + np.exp(-z)), 0.5)
    obs = ViewEvidence(p, cam.centre, pose, judged=visible.copy(), clip=(0.02, 0.98))
    return truth, obs, initial_visibility(truth.extent, cam, pose)


@pytest.mark.parametrize("segment_log_odds, refused", [(0.3, True), (2.5, False)])
def test_a_shift_that_would_empty_what_the_detectors_see_clearly_is_refused(
        monkeypatch, segment_log_odds, refused):
    # Whatever made the detections ask for it, a shift towards absent at the bound turns
    # the weakly seen segments against their logs: the estimate under it would drop the
    # logs whose ends are seen clearly. The estimate before the shift is kept, and the
    # view is in doubt. Where the segments are seen clearly too, the shift stands.
    truth, obs, start = _clear_ends_observation(segment_log_odds)
    solve = dict(solver=StructureSolver(truth.extent), initial_visibility=start)
    plain = estimate_with_visibility(obs, truth.extent, presence_shift=False, **solve)
    assert count_errors(truth, plain.structure) == 0
    monkeypatch.setattr(loop, "fit_presence_shift", lambda p, present: -PRESENCE_SHIFT_BOUND)
    fp = estimate_with_visibility(obs, truth.extent, presence_shift=True, **solve)
    assert fp.presence_fitted == (-PRESENCE_SHIFT_BOUND,)
    assert fp.presence_refused == (refused,)
    assert presence_doubt(fp)  # (the fitted shift is at the doubt's bar either way)
    if refused:
        assert fp.presence_shift == (0.0,)
        assert fp.structure == plain.structure
    else:
        assert fp.presence_shift == (-PRESENCE_SHIFT_BOUND,)
        assert count_errors(truth, fp.structure) == 0


def test_doubt_reads_an_older_fixpoint_without_the_fitted_shift():
    # A fixpoint made without the presence shift, or recorded before the fit was kept.
    class Old:
        presence_shift = (-1.6, 0.2)
        presence_fitted = ()
        presence_refused = ()

    assert presence_doubt(Old(), 0) and not presence_doubt(Old(), 1)

    class Without:
        presence_shift = presence_fitted = presence_refused = ()

    assert not presence_doubt(Without())
