"""Which action to take next: the smallest δ′ (paper §5).

For an action, take the features no current view saw that its photograph would show
(:func:`~unseeable.active.revealed_features`) and shift their priors away from ½,
towards the opposite of their value under the estimate, by δ. δ′ is the largest shift
under which the joint estimate stays the same — how much imagined evidence in that
photograph it takes to change the estimator's mind. The action with the smallest δ′
is the one whose photograph could most easily overturn the estimate: take it.

Every test asks the kept model one question, "does any structure beat the estimate
under these priors?" (:func:`~unseeable.confidence.rival_under_shift`: the estimate as
cut-off and hint). δ′ is searched for every action at once (the paper's simultaneous
binary search): a branch point is tested on every action still in the running, and
the search ends as soon as one action is known to lie below all the others, rather
than when each δ′ is known to the resolution. A test that changes the estimate also
returns the structure that beat it, whose own crossing shift is an upper bound on δ′
in closed form (:func:`~unseeable.confidence.crossing_shift`), so the bounds close
faster than by halving.

Actions that would show the same unseen features have the same δ′ and are tested once.
An action that shows nothing unseen, or whose δ′ is ½ (no shift below ½ changes the
estimate), can teach nothing: δ′ is infinite.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from unseeable.active.actions import Action, revealed_features, unseen_features
from unseeable.errors import InputError

__all__ = ["ActionBounds", "ActionPlan", "ShiftSearch", "plan_action", "smallest_shift",
           "per_action_search", "RESOLUTION"]

logger = logging.getLogger(__name__)

#: Bounds on δ′ closer than this separate no action from another: a tie.
RESOLUTION = 0.005


@dataclass(frozen=True)
class ActionBounds:
    """What the search learnt of one action's δ′.

    Attributes
    ----------
    action : Action
    revealed : int
        Features no current view saw that its photograph would show.
    low, high : float
        ``low <= δ′ <= high``; ``high = 0.5`` with ``low = 0.5``: no shift changes the
        estimate (infinite δ′, nothing to learn); equal bounds: δ′ exactly.
    group : int
        Actions that show the same unseen features share a group (and δ′).
    """

    action: Action
    revealed: int
    low: float
    high: float
    group: int

    @property
    def finite(self) -> bool:
        """Some imagined evidence in this photograph would change the estimate."""
        return self.revealed > 0 and self.low < 0.5

    def to_json(self) -> dict:
        return {"action": self.action.name, "station": self.action.station,
                "removed_from_layer": self.action.removed_from_layer,
                "revealed_features": self.revealed, "delta_low": self.low,
                "delta_high": self.high, "finite": self.finite, "group": self.group}


@dataclass(frozen=True)
class ActionPlan:
    """The outcome of :func:`plan_action`.

    Attributes
    ----------
    candidates : tuple of ActionBounds
        One per action, in the order given.
    chosen : int or None
        Index of the action to take; None when no action has a finite δ′.
    tie : bool
        The chosen action's δ′ could not be told from another's within the
        resolution; it was chosen by the tie rule (most unseen features shown, then
        the fewest layers removed, then the order given).
    solves : int
        Re-solves the simultaneous search spent.
    groups : int
        Distinct sets of revealed features (the actions the search had to tell apart).
    seconds : float
    """

    candidates: tuple[ActionBounds, ...]
    chosen: int | None
    tie: bool
    solves: int
    groups: int
    seconds: float

    @property
    def action(self) -> Action | None:
        return None if self.chosen is None else self.candidates[self.chosen].action

    def to_json(self) -> dict:
        return {"chosen": self.chosen,
                "chosen_action": None if self.action is None else self.action.name,
                "tie": self.tie, "solves": self.solves, "groups": self.groups,
                "seconds": self.seconds,
                "candidates": [c.to_json() for c in self.candidates]}


class _Group:
    """Actions that would reveal one set of features, and the bounds on their δ′."""

    def __init__(self, features: np.ndarray, members: list[int]) -> None:
        self.features = features
        self.members = members
        self.low = 0.0
        self.high = 0.5
        self.first = members[0] if members else -1
        self.dominated_by: _Group | None = None


def _check(estimate, actions, resolution: float):
    model = estimate.model
    if model is None or model.solver is None or estimate.structure is None:
        raise InputError("needs an estimate made from photographs, with its kept model",
                         field="estimate", value="none kept")
    if not 0 < resolution < 0.5:
        raise InputError("must be in (0, 0.5)", field="resolution", value=resolution)
    actions = list(actions)
    if not actions:
        raise InputError("needs at least one candidate action", field="actions", value=0)
    return model, actions


def _distinct(revealed: np.ndarray, order) -> tuple[list[list[int]], np.ndarray]:
    """Actions that reveal the same features (they share a δ′), taken in ``order``: the
    members of each distinct set (those revealing nothing left out), and each action's
    set (-1: none)."""
    rows: dict[bytes, list[int]] = {}
    for n in order:
        if revealed[n].any():
            rows.setdefault(np.packbits(revealed[n]).tobytes(), []).append(n)
    members = list(rows.values())
    group_of = np.full(len(revealed), -1, dtype=int)
    for k, m in enumerate(members):
        group_of[m] = k
    return members, group_of


def plan_action(estimate, actions: Sequence[Action], *, resolution: float = RESOLUTION,
                time_limit: float | None = None) -> ActionPlan:
    """Choose the action with the smallest δ′, by the simultaneous search.

    The search keeps, for every group of actions that reveal the same features, bounds
    ``low <= δ′ <= high``. Each structure a test finds beating the estimate bounds every
    group's δ′ from above at once, by its crossing shift on that group's features. The
    group with the least upper bound is the front-runner: it is tested at that bound
    (unchanged there: its δ′ is the bound), and then each other group that might still
    lie below it is tested at the front-runner's δ′ — unchanged, it is out; changed, the
    structure that beat the estimate gives it a lower bound and it leads. A group whose
    revealed features lie within another's is never below it (every rival gains on at
    least as many features there), so it is left out from the start.

    Parameters
    ----------
    estimate : Estimate
        The current joint estimate (from :func:`~unseeable.pipeline.estimate` or
        :func:`~unseeable.pipeline.extend_estimate`): its kept model answers the tests.
    actions : sequence of Action
        The candidates, in the table frame of the estimate's views.
    resolution : float
        δ′ closer than this count as tied.
    time_limit : float, optional
        Seconds per re-solve (default: the estimate's settings'). An undecided test
        counts as a change (as in the confidence test).

    Returns
    -------
    ActionPlan

    Examples
    --------
    See :func:`~unseeable.active.run_active`, which plans every step with it.
    """
    t0 = time.perf_counter()
    model, actions = _check(estimate, actions, resolution)
    limit = estimate.settings.solver.time_limit if time_limit is None else time_limit
    unseen = unseen_features(estimate)
    revealed = revealed_features(estimate, actions, unseen=unseen)
    counts = revealed.sum(axis=1)

    def preference(n: int) -> tuple:
        # The tie rule: most unseen features shown, then the fewest layers removed (a
        # disassembly cannot be undone), then the order given.
        layer = actions[n].removed_from_layer
        return (-int(counts[n]), 0 if layer is None else 1, -(layer or 0), n)

    # Actions revealing the same features share a δ′: one row each, in order of preference.
    members, group_of = _distinct(revealed, sorted(range(len(actions)), key=preference))
    features = (np.array([revealed[m[0]] for m in members]) if members
                else np.zeros((0, revealed.shape[1]), dtype=bool))
    search = smallest_shift(model.solver, model.terms, estimate.result, features,
                            resolution=resolution, time_limit=limit)
    bounds = []
    for n, a in enumerate(actions):
        k = group_of[n]
        low, high = (0.5, 0.5) if k < 0 else (search.low[k], search.high[k])
        bounds.append(ActionBounds(a, int(counts[n]), float(low), float(high), int(k)))
    chosen = None if search.chosen is None else members[search.chosen][0]
    tie = search.tie or (chosen is not None and len(members[search.chosen]) > 1)
    plan = ActionPlan(tuple(bounds), chosen, tie, search.solves, len(members),
                      time.perf_counter() - t0)
    logger.info("planned over %d actions (%d distinct, %d not within another): %s in %d "
                "re-solves, %.2f s", len(actions), len(members),
                len(members) - int(search.dominated.sum()),
                "nothing to learn" if chosen is None else actions[chosen].name,
                search.solves, plan.seconds)
    return plan


@dataclass(frozen=True)
class ShiftSearch:
    """The outcome of :func:`smallest_shift`.

    Attributes
    ----------
    low, high : (G,) float
        Bounds on each row's δ′ (0.5, 0.5: infinite).
    chosen : int or None
        The row with the smallest δ′ (the first such in the order given); None when
        every δ′ is infinite.
    tie : bool
        Another row's δ′ is known to lie within the resolution of the chosen one's.
    solves : int
    dominated : (G,) bool
        Rows whose features lie within another row's (never searched on their own).
    """

    low: np.ndarray
    high: np.ndarray
    chosen: int | None
    tie: bool
    solves: int
    dominated: np.ndarray


def smallest_shift(solver, terms, result, features: np.ndarray, *,
                   resolution: float = RESOLUTION, time_limit: float = 60.0) -> ShiftSearch:
    """Which set of features, shifted away from the estimate, changes it at the least
    shift: the simultaneous search of :func:`plan_action`, on the solver's terms.

    Parameters
    ----------
    solver : StructureSolver
        The kept model of the estimate.
    terms : sequence of terms
        The objective the estimate maximised.
    result : SolveResult
        The estimate.
    features : (G, N) bool
        One row per candidate: the features its imagined evidence shifts. Rows earlier
        win ties; a row whose features lie within another's is never chosen (its δ′ is
        never smaller).
    resolution : float
    time_limit : float
        Seconds per re-solve.

    Returns
    -------
    ShiftSearch

    Examples
    --------
    >>> from unseeable.domain import Extent, Log, Structure, simulate_evidence
    >>> from unseeable.pipeline import estimate_evidence
    >>> truth = Structure(Extent(2, 2, 2), [Log(0, (0, 0), 2), Log(0, (0, 1), 2)])
    >>> ev = simulate_evidence(truth, accuracy=0.9, occluded_fraction=0.5, seed=1)
    >>> est = estimate_evidence(ev)
    >>> rows = np.array([~ev.judged, np.zeros_like(ev.judged)])
    >>> found = smallest_shift(est.model.solver, est.model.terms, est.result, rows)
    >>> found.chosen, float(found.low[1])
    (0, 0.5)
    """
    from unseeable.confidence import MAX_DELTA, rival_under_shift

    features = np.asarray(features, dtype=bool)
    if features.ndim != 2:
        raise InputError("must be a (G, N) boolean array", field="features",
                         value=features.shape)
    if not 0 < resolution < 0.5:
        raise InputError("must be in (0, 0.5)", field="resolution", value=resolution)
    groups = [_Group(row, [k]) for k, row in enumerate(features)]
    for g in groups:
        if not g.features.any():
            g.low = g.high = 0.5  # shows nothing unseen: nothing to learn
    # A row whose features lie within another's: every rival gains on at least as many
    # features in the other, so its δ′ is never smaller (and the other comes first in a
    # tie when it holds more). Checked from the largest down.
    by_size = sorted(groups, key=lambda g: -int(g.features.sum()))
    for g in by_size:
        g.dominated_by = next((h for h in by_size if h is not g and h.dominated_by is None
                               and h.features.sum() > g.features.sum()
                               and np.all(h.features >= g.features)), None)
    live = [g for g in groups if g.dominated_by is None and g.low < 0.5]
    rivals = _Rivals(terms, result)
    solves = 0

    def test(g: _Group, delta: float) -> None:
        nonlocal solves
        solves += 1
        changed, rival = rival_under_shift(solver, terms, result, g.features, delta,
                                           time_limit=time_limit)
        if not changed:
            g.low = max(g.low, delta)
        elif rival is None:  # undecided: counted as a change, with no rival to share
            g.high = min(g.high, max(delta, g.low))
        else:
            rivals.add(rival, groups)
            g.high = min(g.high, max(delta, g.low))

    tiny = resolution / 5
    lead = None
    for _ in range(20 * len(live) + 20):  # each test narrows some row's bounds
        live = [g for g in live if g.low < 0.5]
        if not live:
            lead = None
            break
        lead = min(live, key=lambda g: (g.high, g.members[0]))
        if lead.high - lead.low > resolution:
            if lead.high >= 0.5:
                # Nothing bounds it yet: exact tie-mates are the common case (one shift
                # just above 0 finds one), else the largest shift.
                test(lead, tiny if lead.low < tiny else MAX_DELTA)
                if lead.low >= MAX_DELTA:
                    lead.low = lead.high = 0.5  # no shift changes the estimate: infinite
            else:
                test(lead, lead.high)
            continue
        # The lead's δ′ is known to the resolution: might another row lie below it?
        other = next((g for g in live if g is not lead and g.low < lead.low - 1e-12), None)
        if other is None:
            break
        test(other, max(lead.low, tiny))
    for g in groups:  # a row within another's is never below it
        top = g
        while top.dominated_by is not None:
            top = top.dominated_by
        g.low = max(g.low, top.low)
        g.high = max(g.high, g.low)
    chosen, tie = None, False
    if lead is not None and lead.low < 0.5:
        chosen = lead.members[0]
        tie = any(g is not lead and g.low < 0.5 and g.high <= lead.high + resolution
                  for g in groups)
    return ShiftSearch(np.array([g.low for g in groups]), np.array([g.high for g in groups]),
                       chosen, tie, solves,
                       np.array([g.dominated_by is not None for g in groups], dtype=bool))


class _Rivals:
    """Structures found beating the estimate under some shift: each bounds every group's
    δ′ from above by its crossing shift on that group's features, in closed form."""

    def __init__(self, terms, estimate) -> None:
        from unseeable.domain.features import feature_values
        from unseeable.grammar import log_probability

        self._terms = terms
        self._values = feature_values(estimate.structure.extent, estimate.structure.occupancy)
        self._ours = log_probability(terms, estimate.structure, estimate.choices)

    def add(self, rival, groups: Sequence[_Group]) -> None:
        from unseeable.domain.features import feature_values
        from unseeable.grammar import log_probability

        differ = feature_values(rival.structure.extent, rival.structure.occupancy) != self._values
        a0 = log_probability(self._terms, rival.structure, rival.choices) - self._ours
        for g in groups:
            d = int(np.count_nonzero(g.features & differ))
            if d == 0:
                continue
            # Ahead by a0 + d·log((½+δ)/(½−δ)): level at δ = ½·tanh(−a0 / 2d).
            crossing = 0.0 if a0 >= 0 else float(0.5 * np.tanh(-a0 / (2 * d)))
            g.high = min(g.high, max(crossing, g.low))


def per_action_search(estimate, actions: Sequence[Action], *,
                      resolution: float = RESOLUTION,
                      time_limit: float | None = None) -> tuple[np.ndarray, int]:
    """δ′ of every action by its own binary search to ``resolution`` (the paper's
    baseline for the simultaneous search): what :func:`plan_action` avoids.

    Returns
    -------
    delta : (A,) float
        The upper end of each action's final interval (0.5: infinite).
    solves : int
    """
    from unseeable.confidence import MAX_DELTA, estimate_changes

    model, actions = _check(estimate, actions, resolution)
    limit = estimate.settings.solver.time_limit if time_limit is None else time_limit
    revealed = revealed_features(estimate, actions)
    members, group_of = _distinct(revealed, range(len(actions)))
    solves = 0
    found = []
    for m in members:
        def changes(delta: float, features: np.ndarray = revealed[m[0]]) -> bool:
            nonlocal solves
            solves += 1
            return estimate_changes(model.solver, model.terms, estimate.result, features,
                                    delta, time_limit=limit)

        if not changes(MAX_DELTA):
            found.append(0.5)
            continue
        low, high = 0.0, MAX_DELTA
        while high - low > resolution:
            mid = (low + high) / 2
            if changes(mid):
                high = mid
            else:
                low = mid
        found.append(high)
    delta = np.array([found[k] if k >= 0 else 0.5 for k in group_of])
    return delta, solves
