"""The choice of the next action: δ′ by the simultaneous search (unseeable.active.planner)."""

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scene import HIDDEN_CABIN, raster_view

from unseeable.active import Action, per_action_search, plan_action, revealed_features
from unseeable.active.planner import smallest_shift
from unseeable.confidence import estimation_tolerance
from unseeable.domain import Extent, feature_index
from unseeable.domain.evidence import simulate_evidence
from unseeable.errors import InputError
from unseeable.grammar import random_structure
from unseeable.pipeline import EstimateSettings, Observation, estimate, estimate_evidence
from unseeable.render.workspace import PendulumArm

ARM = PendulumArm()


@pytest.fixture(scope="module")
def start():
    """The hidden cabin estimated from station 150° (right, not confident)."""
    return estimate([Observation.of(raster_view(150.0))], EstimateSettings())


def _actions():
    return ([Action(f"station {a:g}", ARM.camera(a), station=a) for a in (90.0, 120.0, 180.0)]
            + [Action(f"150 L{n}", ARM.camera(150.0), removed_from_layer=n, station=150.0)
               for n in (1, 2, 3)])


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 10_000), rows=st.integers(1, 4))
def test_the_simultaneous_search_finds_the_smallest_exact_delta(seed, rows):
    """Against each row's own exact tolerance (the confidence's crossing search): the row
    chosen has the smallest δ′ to the resolution, and every bound holds it."""
    extent = Extent(3, 3, 2)
    rng = np.random.default_rng(seed)
    truth = random_structure(extent, density=0.6, seed=seed)
    ev = simulate_evidence(truth, accuracy=0.8, occluded_fraction=0.6, seed=seed)
    est = estimate_evidence(ev, EstimateSettings.from_options(enabled=False))
    features = (~ev.judged) & (rng.random((rows, len(ev.judged))) < 0.5)
    m = est.model
    found = smallest_shift(m.solver, m.terms, est.result, features, resolution=0.005)
    exact = np.array([estimation_tolerance(m.solver, m.terms, est.result, f)[0]
                      if f.any() else 0.5 for f in features])
    assert np.all(found.low <= exact + 1e-9) and np.all(exact <= found.high + 1e-9)
    if np.all(exact >= 0.5):
        assert found.chosen is None
    else:
        assert exact[found.chosen] <= exact.min() + 0.005


def test_rows_that_show_nothing_unseen_have_nothing_to_teach():
    truth = random_structure(Extent(2, 2, 2), density=0.6, seed=3)
    ev = simulate_evidence(truth, accuracy=0.9, occluded_fraction=0.5, seed=3)
    est = estimate_evidence(ev)
    none = np.zeros((2, len(ev.judged)), dtype=bool)
    found = smallest_shift(est.model.solver, est.model.terms, est.result, none)
    assert found.chosen is None and found.solves == 0
    assert found.low.tolist() == [0.5, 0.5]


def test_what_an_action_reveals_was_unseen_and_stays_below_a_disassembly(start):
    from unseeable.active import unseen_features

    acts = _actions()
    revealed = revealed_features(start, acts)
    unseen = unseen_features(start)
    assert not (revealed & ~unseen).any()
    layer = feature_index(HIDDEN_CABIN.extent).at[:, 1]
    for a, row in zip(acts, revealed):
        if a.removed_from_layer is not None:
            assert (layer[row] < a.removed_from_layer).all()
    assert revealed[0].any()  # station 90° sees the far side
    # The station already taken shows nothing new.
    again = revealed_features(start, [Action("150", ARM.camera(150.0), station=150.0)])
    assert again.sum() <= 2


def test_the_plan_agrees_with_per_action_binary_searches_in_fewer_solves(start):
    assert start.confident is False  # the log behind the front wall is a guess
    acts = _actions()
    plan = plan_action(start, acts)
    delta, solves = per_action_search(start, acts)
    assert plan.chosen is not None
    assert delta[plan.chosen] <= delta.min() + 0.005
    assert plan.solves < solves
    c = plan.candidates[plan.chosen]
    assert c.finite and c.low <= delta[plan.chosen] + 1e-9
    data = plan.to_json()
    assert data["chosen_action"] == acts[plan.chosen].name
    assert len(data["candidates"]) == len(acts)


def test_the_plan_needs_the_kept_model_and_candidates(start):
    with pytest.raises(InputError, match="candidate"):
        plan_action(start, [])
    with pytest.raises(InputError, match="resolution"):
        plan_action(start, _actions(), resolution=0.7)
