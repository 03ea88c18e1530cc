"""Each structure prior charges exactly its cost times a count read from the logs.

The counts (brute.py) follow the definitions in DESIGN.md §2 and the priors' docstrings,
not the package's prior code: a joint after q is a log's last notch at q with a log at the
next position on the line; stacked joints are joints after (i, j, k) and after (i, j + 2, k);
an unsupported notch is an occupied position above layer 0 with nothing below it.
"""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from grammar.brute import (
    features_from_logs,
    habit_cost,
    joints_after,
    stacked_joints,
    unsupported_notches,
)
from strategies import extents
from unseeable.domain import Extent, FeatureKind, feature_index, feature_values
from unseeable.grammar import (
    joint_prior,
    log_probability,
    random_structure,
    stacked_joint_prior,
    unsupported_notch_prior,
)
from unseeable.grammar.priors import StructurePrior

COSTS = st.sampled_from([0.0, 0.25, 1.0, 2.5, 50.0])


@st.composite
def structures_and_seen(draw, max_positions: int = 60):
    """A random valid structure (random_structure, dense enough to have joints and
    bridges) and a random mask of positions whose joints are seen."""
    extent = draw(extents(max_positions=max_positions, max_dim=6))
    seed = draw(st.integers(0, 2**31 - 1))
    density = draw(st.sampled_from([0.4, 0.7, 0.9, 1.0]))
    rng = np.random.default_rng(seed)
    structure = random_structure(extent, density=density, seed=rng)
    seen = rng.random(extent.shape) < draw(st.sampled_from([0.0, 0.5, 1.0]))
    return structure, seen


@settings(max_examples=60, deadline=None)
@given(structures_and_seen(), COSTS)
def test_the_joint_prior_costs_each_seen_joint(case, cost):
    structure, seen = case
    extent = structure.extent
    every = int(joints_after(structure).sum())
    charged = int((joints_after(structure) & seen).sum())
    assert math.isclose(log_probability(joint_prior(extent, cost, seen=seen), structure),
                        -cost * charged, abs_tol=1e-9)
    assert math.isclose(log_probability(joint_prior(extent, cost), structure), -cost * every,
                        abs_tol=1e-9)


@settings(max_examples=60, deadline=None)
@given(structures_and_seen(), COSTS)
def test_the_stacked_joint_prior_costs_each_joint_above_a_joint(case, cost):
    structure, _ = case
    assert math.isclose(log_probability(stacked_joint_prior(structure.extent, cost), structure),
                        -cost * stacked_joints(structure), abs_tol=1e-9)


@settings(max_examples=60, deadline=None)
@given(structures_and_seen(), COSTS)
def test_the_unsupported_notch_prior_costs_each_notch_with_nothing_below(case, cost):
    structure, _ = case
    assert math.isclose(
        log_probability(unsupported_notch_prior(structure.extent, cost), structure),
        -cost * unsupported_notches(structure), abs_tol=1e-9)


@settings(max_examples=60, deadline=None)
@given(structures_and_seen(), COSTS, COSTS, COSTS)
def test_a_structure_prior_costs_its_three_habits(case, joint, stacked, unsupported):
    structure, seen = case
    prior = StructurePrior(joint_cost=joint, stacked_joint_cost=stacked,
                           unsupported_notch_cost=unsupported)
    expected = -habit_cost(structure, joint=joint, stacked=stacked, unsupported=unsupported,
                           seen=seen)
    assert math.isclose(log_probability(prior.factors(structure.extent, seen=seen), structure),
                        expected, abs_tol=1e-9)


@settings(max_examples=60, deadline=None)
@given(structures_and_seen())
def test_the_shipped_prior_costs_one_nat_a_habit(case):
    structure, seen = case
    for prior in (StructurePrior(), StructurePrior.named("builder")):
        assert math.isclose(log_probability(prior.factors(structure.extent, seen=seen),
                                            structure),
                            -habit_cost(structure, joint=1, stacked=1, unsupported=1, seen=seen),
                            abs_tol=1e-9)
    assert log_probability(StructurePrior.named("uniform").factors(structure.extent, seen=seen),
                           structure) == 0.0


def _seen_from_visible_edges(extent: Extent, visible: np.ndarray) -> np.ndarray:
    """Joints after q some view shows: the long segment w at q (the joint's bottom edge)
    or at q two layers up (its top edge) is visible — in the documented feature order."""
    I, J, K = extent.shape
    w = np.asarray(visible, bool)[-I * (J + 2) * K:].reshape(I, J + 2, K)
    return w[:, :J] | w[:, 2:]


@settings(max_examples=40, deadline=None)
@given(structures_and_seen(), st.integers(0, 2**31 - 1), st.integers(1, 3))
def test_the_prior_given_visibility_charges_the_joints_whose_edges_are_visible(case, seed,
                                                                                 views):
    structure, _ = case
    extent = structure.extent
    idx = feature_index(extent)
    w_features = extent.I * (extent.J + 2) * extent.K
    assert (idx.kind[-w_features:] == FeatureKind.W).all()  # the documented order
    rng = np.random.default_rng(seed)
    visibility = [rng.random(len(idx)) < 0.3 for _ in range(views)]
    seen = _seen_from_visible_edges(extent, np.logical_or.reduce(visibility))
    factors = StructurePrior().given_visibility(extent)(visibility)
    assert math.isclose(log_probability(factors, structure),
                        -habit_cost(structure, joint=1, stacked=1, unsupported=1, seen=seen),
                        abs_tol=1e-9)



@settings(max_examples=40, deadline=None)
@given(structures_and_seen())
def test_the_features_read_from_the_logs_are_the_domain_features(case):
    # The brute-force references score evidence with features read from the logs; they
    # must be the package's g_f(Z), or both could be wrong together unnoticed.
    structure, _ = case
    assert np.array_equal(features_from_logs(structure),
                          feature_values(structure.extent, structure.occupancy))
