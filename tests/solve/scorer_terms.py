"""Objective terms of every kind the tie search's scorer handles, for its tests."""

from __future__ import annotations

import numpy as np

from unseeable.domain import Structure, simulate_evidence
from unseeable.grammar import EvidenceTerm, Factor
from unseeable.grammar.expr import Choice, Implies, Not, empty, occupied
from unseeable.grammar.priors import StructurePrior


def every_kind_of_term(structure: Structure, seed: int, removed: bool) -> tuple[list, dict]:
    """Evidence of ``structure`` (seen whole and, when ``removed``, with layers taken off),
    the shipped prior's factors, and factors a scorer evaluates whole, finds constant or
    simplifies; with the choices their ``Choice`` takes."""
    extent = structure.extent
    rng = np.random.default_rng(seed)
    evidence = simulate_evidence(structure, accuracy=0.8, occluded_fraction=0.3, seed=seed)
    layer = int(rng.integers(0, extent.J + 1)) if removed else None
    q = (0, extent.J - 1, 0)
    terms = [EvidenceTerm(evidence), EvidenceTerm(evidence, layer),
             *StructurePrior().factors(extent),
             Factor(occupied(q) | Choice("c"), -0.3),            # evaluated one by one
             Factor(Implies(occupied(q), empty((0, 0, 0))), 0.7, -0.2),
             Factor(Not(occupied((extent.I, 0, 0))), 0.25),      # off the grid: constant
             Factor(occupied(q) & occupied(q), float(rng.normal()))]
    return terms, {"c": bool(rng.integers(2))}
