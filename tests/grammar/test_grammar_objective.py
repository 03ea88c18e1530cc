"""The compiled objective equals the evidence log-probability it was built from."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from grammar.brute import random_priors
from strategies import structures
from unseeable.domain import Evidence, Extent
from unseeable.errors import InputError
from unseeable.grammar import (
    Choice,
    EvidenceTerm,
    Factor,
    as_terms,
    compile_objective,
    joint_prior,
    log_probability,
    occupied,
)


@settings(max_examples=40, deadline=None)
@given(structures(max_positions=60), st.integers(0, 2**31 - 1), st.integers(0, 6))
def test_objective_value_is_the_log_probability(structure, seed, removed):
    extent = structure.extent
    rng = np.random.default_rng(seed)
    first = Evidence(extent, random_priors(extent, rng))
    second = Evidence(extent, random_priors(extent, rng))
    terms = [EvidenceTerm(first), EvidenceTerm(second, removed),
             Factor(occupied((0, 0, 0)), -0.3, -1.2)]
    objective = compile_objective(extent, terms)
    z = structure.occupancy
    after = structure.removed_from_layer(min(removed, extent.J)).occupancy
    expected = first.log_probability(z) + second.log_probability(after) + (
        -0.3 if z[0, 0, 0] else -1.2)
    assert objective.value(z) == pytest.approx(expected, abs=1e-9)
    assert log_probability(terms, structure) == pytest.approx(expected, abs=1e-9)


def test_uniform_evidence_drops_out():
    extent = Extent(3, 2, 3)
    objective = compile_objective(extent, Evidence.uniform(extent))
    assert len(objective) == 0
    assert objective.constant == pytest.approx(len(Evidence.uniform(extent).p) * math.log(0.5))


def test_u_and_v_share_one_expression():
    extent = Extent(1, 1, 1)
    p = np.full(2 * 1 + 3 * 3, 0.5)
    p[2] = 0.9  # u at layer 0
    p[5] = 0.8  # v at layer 0
    objective = compile_objective(extent, Evidence(extent, p))
    assert len(objective) == 1
    assert objective.coefs[0] == pytest.approx(math.log(0.9 / 0.1) + math.log(0.8 / 0.2))


def test_factor_ties():
    e = occupied((0, 0, 0))
    eq = Factor.feature(e, 0.8)
    assert (eq.if_true, eq.if_false) == pytest.approx((math.log(0.8), math.log(0.2)))
    implied = Factor.feature(e, 0.8, tie="expr_implies_feature")
    assert (implied.if_true, implied.if_false) == pytest.approx((math.log(0.8), 0.0))
    reverse = Factor.feature(e, 0.8, tie="feature_implies_expr")
    assert (reverse.if_true, reverse.if_false) == pytest.approx((0.0, math.log(0.2)))
    with pytest.raises(InputError, match="tie"):
        Factor.feature(e, 0.8, tie="sometimes")
    with pytest.raises(InputError):
        Factor(e, math.inf)


def test_terms_are_normalised_and_checked():
    extent = Extent(2, 2, 2)
    ev = Evidence.uniform(extent)
    assert as_terms(ev, removed_from_layer=1)[0].removed_from_layer == 1
    assert as_terms((ev, 5))[0].removed_from_layer is None  # above the top removes nothing
    assert len(as_terms([ev, (ev, 1), Factor(Choice("x"), 1.0)])) == 3
    with pytest.raises(InputError, match="removed_from_layer"):
        as_terms([ev], removed_from_layer=1)
    with pytest.raises(InputError, match="removed_from_layer"):
        EvidenceTerm(ev, -1)
    with pytest.raises(InputError, match="extent"):
        compile_objective(Extent(2, 2, 3), ev)
    with pytest.raises(InputError):
        as_terms(["not evidence"])


def _joints(structure) -> int:
    """Two logs end to end on a line, counted from the occupancy directly."""
    from unseeable.domain.grid import EMPTY, LAST_NOTCH
    from unseeable.grammar import line_positions

    z = np.asarray(structure.occupancy)
    return sum(1 for line in line_positions(structure.extent) for q, nq in zip(line, line[1:])
               if LAST_NOTCH[z[q]] and z[nq] != EMPTY)


@settings(max_examples=40, deadline=None)
@given(structures(max_positions=48), st.sampled_from([0.0, 0.5, 2.0]))
def test_the_joint_prior_costs_each_joint_and_nothing_else(structure, cost):
    prior = joint_prior(structure.extent, cost)
    assert math.isclose(log_probability(prior, structure), -cost * _joints(structure),
                        abs_tol=1e-9)


def test_the_joint_prior_charges_only_the_joints_a_camera_sees():
    from unseeable.domain import Log, Structure
    from unseeable.domain.features import FeatureKind, feature_index
    from unseeable.grammar import seen_joints

    extent = Extent(4, 1, 1)
    split = Structure(extent, [Log(0, (0, 0), 1), Log(0, (1, 0), 1), Log(0, (2, 0), 2)])
    idx = feature_index(extent)
    w = idx.kind == FeatureKind.W
    # The bottom edge between notches 0 and 1 seen in one view, the top edge (layer 2)
    # between 1 and 2 in another: both joints are seen, that after notch 2 (inside the
    # 2-notch log) is not, and nothing else is.
    views = [w & (idx.at[:, 0] == 0) & (idx.at[:, 1] == 0),
             w & (idx.at[:, 0] == 1) & (idx.at[:, 1] == 2)]
    seen = seen_joints(extent, views)
    assert seen.shape == (4, 1, 1) and seen[:, 0, 0].tolist() == [True, True, False, False]
    assert log_probability(joint_prior(extent, 1.0, seen=seen), split) == -2.0
    assert log_probability(joint_prior(extent, 1.0, seen=seen_joints(extent, views[0])),
                           split) == -1.0
    # Ends and short segments do not show a joint.
    assert not seen_joints(extent, ~w).any()
    with pytest.raises(InputError, match="seen"):
        joint_prior(extent, 1.0, seen=np.ones((3, 1, 1), dtype=bool))
    with pytest.raises(InputError, match="visible"):
        seen_joints(extent, np.ones(5, dtype=bool))


def test_the_stacked_joint_prior_charges_a_joint_straight_above_another():
    from unseeable.domain import Log, Structure
    from unseeable.grammar import stacked_joint_prior

    extent = Extent(4, 3, 1)
    crossing = [Log(1, (i, 0), 1) for i in range(4)]
    below = [Log(0, (0, 0), 2), Log(0, (2, 0), 2)]  # a joint after notch 1
    stacked = Structure(extent, below + crossing + [Log(2, (0, 0), 2), Log(2, (2, 0), 2)])
    staggered = Structure(extent, below + crossing + [Log(2, (0, 0), 1), Log(2, (1, 0), 3)])
    prior = stacked_joint_prior(extent, 1.5)
    assert log_probability(prior, stacked) == -1.5
    assert log_probability(prior, staggered) == 0.0
    # A course with nothing two layers up has no pairs; a cost of 0 is no prior.
    assert stacked_joint_prior(Extent(4, 2, 1), 1.0) == ()
    assert stacked_joint_prior(extent, 0) == ()
    for bad in (-1.0, float("nan"), True):
        with pytest.raises(InputError, match="stacked_joint_cost"):
            stacked_joint_prior(extent, bad)


def test_the_unsupported_notch_prior_charges_each_notch_with_nothing_below():
    from unseeable.domain import Log, Structure
    from unseeable.grammar import unsupported_notch_prior

    extent = Extent(1, 4, 3)
    prior = unsupported_notch_prior(extent, 0.5)
    assert len(prior) == 3 * 3  # every position above layer 0
    # Two bridges, one over the other: each rests on two of its three notches.
    posts = [Log(0, (0, 0), 1), Log(0, (0, 2), 1), Log(2, (0, 0), 1), Log(2, (0, 2), 1)]
    bridges = Structure(extent, [*posts, Log(1, (0, 0), 3), Log(3, (0, 0), 3)])
    assert log_probability(prior, bridges) == -1.0
    assert unsupported_notch_prior(extent, 0) == ()
    assert unsupported_notch_prior(Extent(3, 1, 3), 1.0) == ()  # one layer: none above 0
    for bad in (-1.0, float("inf"), "1"):
        with pytest.raises(InputError, match="unsupported_notch_cost"):
            unsupported_notch_prior(extent, bad)


def test_the_joint_prior_checks_its_cost():
    assert joint_prior(Extent(3, 1, 1), 0) == ()
    for bad in (-0.5, float("nan"), float("inf"), True, "1"):
        with pytest.raises(InputError, match="joint_cost"):
            joint_prior(Extent(3, 1, 1), bad)
