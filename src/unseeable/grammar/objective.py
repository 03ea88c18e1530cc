"""The objective of structure estimation: a sum of evidence terms and factors.

The log-probability of an occupancy Z (DESIGN.md §2) is

    Σ_terms Σ_f log p_f(g_f(Z'))  +  Σ_factors (if_true if expr(Z) else if_false)

where Z' is Z with the term's removed layers emptied. Several views of one
assembly are several terms; a partial disassembly is a term with
``removed_from_layer``. A :class:`Factor` ties any expression to a soft
score, which is how a feature tied to Z by an implication instead of an
equivalence enters (its factor is then the sum of the allowed values'
probabilities, see :meth:`Factor.feature`).

:func:`compile_objective` turns terms into ``constant + Σ_e c_e [e]`` over
distinct expressions ``e`` — the form every backend maximises.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from unseeable.domain.evidence import Evidence
from unseeable.domain.grid import Extent
from unseeable.domain.structure import Structure
from unseeable.errors import InputError
from unseeable.grammar.expr import (
    LAST_NOTCH_CODES,
    And,
    Const,
    Expr,
    Occ,
    as_expr,
    empty,
    evaluate,
    occupied,
    simplify,
)
from unseeable.grammar.rules import feature_table, line_positions

__all__ = ["EvidenceTerm", "Factor", "Term", "Objective", "compile_objective", "as_terms",
           "log_probability", "terms_extent", "joint_prior", "seen_joints", "check_prior_cost",
           "stacked_joint_prior", "unsupported_notch_prior", "is_joint_factor"]


@dataclass(frozen=True, eq=False)
class EvidenceTerm:
    """Evidence observed on the assembly, possibly after a partial disassembly.

    Parameters
    ----------
    evidence : Evidence
    removed_from_layer : int or None
        ``L``: the evidence was observed with every log on layers ``>= L``
        removed, so its features are evaluated against Z with those layers
        emptied. None: the whole assembly.
    """

    evidence: Evidence
    removed_from_layer: int | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.evidence, Evidence):
            raise InputError("must be an Evidence", field="evidence", value=self.evidence)
        L = self.removed_from_layer
        if L is not None:
            if isinstance(L, bool) or not isinstance(L, (int, np.integer)) or L < 0:
                raise InputError("must be a layer number >= 0 or None",
                                 field="removed_from_layer", value=L)
            # Removing from above the top removes nothing.
            object.__setattr__(self, "removed_from_layer",
                               None if L >= self.evidence.extent.J else int(L))

    @property
    def extent(self) -> Extent:
        return self.evidence.extent


@dataclass(frozen=True, eq=False)
class Factor:
    """A soft factor: ``if_true`` is added when ``expr`` holds, else ``if_false``.

    Parameters
    ----------
    expr : Expr
        Any expression of occupancy and choices.
    if_true, if_false : float
        Log-probability contributions (finite).

    Examples
    --------
    >>> from unseeable.grammar.expr import occupied
    >>> f = Factor.feature(occupied((0, 0, 0)), 0.9, tie="expr_implies_feature")
    >>> round(f.if_true, 4), f.if_false   # present required: log 0.9; else free: log 1
    (-0.1054, 0.0)
    """

    expr: Expr
    if_true: float
    if_false: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "expr", as_expr(self.expr))
        for name in ("if_true", "if_false"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float, np.floating, np.integer)) \
                    or not math.isfinite(v):
                raise InputError("must be a finite number", field=name, value=v)
            object.__setattr__(self, name, float(v))

    @classmethod
    def feature(cls, expr: Expr, p: float, *, tie: str = "equivalence") -> Factor:
        """The factor of a feature with prior ``p`` tied to ``expr``.

        ``tie="equivalence"``: feature ⇔ expr (``log p`` / ``log(1-p)``).
        ``tie="expr_implies_feature"``: expr → feature; when expr fails the
        feature is free, its factor ``p + (1-p) = 1``.
        ``tie="feature_implies_expr"``: feature → expr; when expr holds the
        feature is free (factor 1), else it is absent (``1-p``).
        """
        if not 0.0 < float(p) < 1.0:
            raise InputError("must be a probability in (0, 1)", field="p", value=p)
        lp, lq = math.log(p), math.log1p(-p)
        if tie == "equivalence":
            return cls(expr, lp, lq)
        if tie == "expr_implies_feature":
            return cls(expr, lp, 0.0)
        if tie == "feature_implies_expr":
            return cls(expr, 0.0, lq)
        raise InputError("must be 'equivalence', 'expr_implies_feature' or "
                         "'feature_implies_expr'", field="tie", value=tie)


Term = EvidenceTerm | Factor


def joint_prior(extent: Extent, cost: float, *, seen: np.ndarray | None = None
                ) -> tuple[Factor, ...]:
    """A prior over structures under which each joint costs ``cost`` nats.

    A joint is two logs meeting end to end on one line (a log's last notch
    with another log at the next position). Of the ways to divide a run of
    occupied notches into logs, the prior prefers those with fewer joints, by
    ``exp(-cost)`` a joint; how many notches are occupied, and where, it leaves
    to the evidence. It is the soft form of the "fewest" tie policy
    (:mod:`unseeable.solve.ties`): that one settles only exact ties, so a joint
    on a wall is placed by any detection however weak (docs/decisions.md).
    Uniform (no factors) at ``cost = 0``, the paper's prior.

    Parameters
    ----------
    extent : Extent
    cost : float
        Nats per joint, ``>= 0``.
    seen : (I, J, K) bool array, optional
        Charge only the joints after these positions (a joint after q is one
        between q and the next position on its line), e.g. those a camera
        sees (:func:`seen_joints`); default every one.

    Returns
    -------
    tuple of Factor
        One per charged pair of neighbouring positions on a line.

    Examples
    --------
    >>> from unseeable.domain import Extent, Log, Structure
    >>> prior = joint_prior(Extent(3, 1, 1), 1.0)
    >>> len(prior)
    2
    >>> split = Structure(Extent(3, 1, 1), [Log(0, (0, 0), 1), Log(0, (1, 0), 2)])
    >>> log_probability(prior, split), log_probability(prior, Structure(Extent(3, 1, 1),
    ...                                                [Log(0, (0, 0), 3)]))
    (-1.0, 0.0)
    """
    cost = check_prior_cost(cost, field="joint_cost")
    if cost == 0:
        return ()
    if seen is not None:
        seen = np.asarray(seen, dtype=bool)
        if seen.shape != extent.shape:
            raise InputError(f"must have the extent's shape {extent.shape}", field="seen",
                             value=seen.shape)
    return tuple(Factor(_joint_after(q, nq), -cost, 0.0)
                 for line in line_positions(extent) for q, nq in zip(line, line[1:])
                 if seen is None or seen[q])


def _joint_after(q, nq) -> Expr:
    """Two logs meet end to end between q and the next position nq on its line: a log's
    last notch at q, and a log at nq."""
    return And(Occ(q, LAST_NOTCH_CODES), occupied(nq))


def is_joint_factor(factor: Any) -> bool:
    """Whether ``factor`` is one of :func:`joint_prior`'s: a cost on two logs meeting end
    to end after one position (not a stacked joint's, nor any other factor).

    Examples
    --------
    >>> from unseeable.domain import Extent
    >>> [is_joint_factor(f) for f in joint_prior(Extent(2, 1, 1), 1.0)]
    [True]
    >>> [is_joint_factor(f) for f in stacked_joint_prior(Extent(2, 3, 1), 1.0)]
    [False]
    """
    if not isinstance(factor, Factor) or not (factor.if_true < 0 and factor.if_false == 0):
        return False
    e = factor.expr
    if not (isinstance(e, And) and e.args and isinstance(e.args[0], Occ)):
        return False
    q = e.args[0].q
    return e == _joint_after(q, Extent.next(q))


def stacked_joint_prior(extent: Extent, cost: float) -> tuple[Factor, ...]:
    """A prior under which a joint straight above another costs ``cost`` nats.

    Builders stagger joints: a joint on a course (two logs end to end after
    position q) is bridged by a whole log on the next course of the same wall
    (two layers up), not met by another joint after the same q. The corpus's
    designed assemblies stagger 159 joints and stack 12 (docs/decisions.md,
    "Where no camera sees"). Where a course is hidden its joints are guesses; this
    prior makes the guess the one a builder would make. Uniform at ``cost = 0``.

    Parameters
    ----------
    extent : Extent
    cost : float
        Nats per pair of stacked joints, ``>= 0``.

    Returns
    -------
    tuple of Factor
        One per pair of neighbouring positions on a line with a line of the same
        wall two layers up.

    Examples
    --------
    >>> from unseeable.domain import Extent, Log, Structure
    >>> extent = Extent(2, 3, 1)
    >>> prior = stacked_joint_prior(extent, 1.0)
    >>> len(prior)
    1
    >>> stacked = Structure(extent, [Log(0, (0, 0), 1), Log(0, (1, 0), 1), Log(1, (0, 0), 1),
    ...                              Log(2, (0, 0), 1), Log(2, (1, 0), 1)])
    >>> log_probability(prior, stacked)
    -1.0
    """
    cost = check_prior_cost(cost, field="stacked_joint_cost")
    if cost == 0:
        return ()
    factors = []
    for line in line_positions(extent):
        if line[0][1] + 2 >= extent.J:
            continue
        for (i, j, k), (ni, _, nk) in zip(line, line[1:]):
            factors.append(Factor(And(_joint_after((i, j, k), (ni, j, nk)),
                                      _joint_after((i, j + 2, k), (ni, j + 2, nk))),
                                  -cost, 0.0))
    return tuple(factors)


def unsupported_notch_prior(extent: Extent, cost: float) -> tuple[Factor, ...]:
    """A prior under which a notch with nothing below it costs ``cost`` nats.

    The grammar lets a log above layer 0 rest on some of its notches only (a
    3-notch log on two, over a door); builders rest logs on all of them where
    they can. Of the notches above layer 0, the corpus's designed assemblies
    leave 2.1 % with nothing below, the random structures of the held-out
    families 1–12 % (docs/decisions.md, "Where no camera sees"). Where the
    course below is hidden, this prior fills it under the logs it can see
    rather than leaving it empty, as the "fewest" tie policy would. Uniform
    at ``cost = 0``.

    Parameters
    ----------
    extent : Extent
    cost : float
        Nats per notch with nothing below it, ``>= 0``.

    Returns
    -------
    tuple of Factor
        One per position above layer 0.

    Examples
    --------
    >>> from unseeable.domain import Extent, Log, Structure
    >>> extent = Extent(1, 2, 3)
    >>> prior = unsupported_notch_prior(extent, 1.0)
    >>> len(prior)
    3
    >>> posts = [Log(0, (0, 0), 1), Log(0, (0, 2), 1)]
    >>> bridge = Structure(extent, [*posts, Log(1, (0, 0), 3)])  # over a gap at k = 1
    >>> log_probability(prior, bridge)
    -1.0
    >>> log_probability(prior, Structure(extent, [*posts, Log(0, (0, 1), 1),
    ...                                           Log(1, (0, 0), 3)]))
    0.0
    """
    cost = check_prior_cost(cost, field="unsupported_notch_cost")
    if cost == 0:
        return ()
    I, J, K = extent.shape
    return tuple(Factor(And(occupied((i, j, k)), empty((i, j - 1, k))), -cost, 0.0)
                 for j in range(1, J) for i in range(I) for k in range(K))


def seen_joints(extent: Extent, visible) -> np.ndarray:
    """Positions whose joint with the next position on their line some camera sees.

    A joint after q on layer j shows where it breaks the log's edges: its
    bottom edge, the long segment ``w`` at q on layer j, and its top edge,
    ``w`` at q on layer j + 2 (DESIGN.md §2). Where neither is visible no
    detection reads the joint, and a prior on it could only trade it for a
    gap (a hidden course kept with a notch empty rather than whole with a
    joint); there the tie policy settles it, as under the paper's prior.

    Parameters
    ----------
    extent : Extent
    visible : (N,) bool array or sequence of them
        Visible features (:func:`~unseeable.domain.features.feature_index`
        order), one array per view.

    Returns
    -------
    (I, J, K) bool array

    Examples
    --------
    >>> from unseeable.domain.features import FeatureKind, feature_index
    >>> extent = Extent(3, 1, 1)
    >>> idx = feature_index(extent)
    >>> visible = (idx.kind == FeatureKind.W) & (idx.at[:, 0] == 0) & (idx.at[:, 1] == 2)
    >>> seen_joints(extent, visible)[:, 0, 0]  # the top edge between notches 0 and 1
    array([ True, False, False])
    """
    from unseeable.domain.features import FeatureKind, feature_index

    idx = feature_index(extent)
    views = [visible] if np.ndim(visible) == 1 else list(visible)
    seen_any = np.zeros(len(idx), dtype=bool)
    for v in views:
        v = np.asarray(v, dtype=bool)
        if v.shape != (len(idx),):
            raise InputError(f"must have one entry per feature ({len(idx)})",
                             field="visible", value=v.shape)
        seen_any |= v
    I, J, K = extent.shape
    w_seen = np.zeros((I, J + 2, K), dtype=bool)
    at = idx.at[seen_any & (idx.kind == FeatureKind.W)]
    w_seen[at[:, 0], at[:, 1], at[:, 2]] = True
    return w_seen[:, :J] | w_seen[:, 2:]


#: The largest cost a structure prior may charge (nats): a habit that costs more is a hard
#: rule, and costs far beyond it overflow the solvers' scaled integer objectives.
MAX_PRIOR_COST = 50.0


def check_prior_cost(cost: Any, *, field: str) -> float:
    """``cost`` as a float when it is a finite number ``>= 0`` (nats under one of the
    structure priors: :func:`joint_prior`, :func:`stacked_joint_prior`,
    :func:`unsupported_notch_prior`), else an :class:`InputError` naming ``field``.

    >>> check_prior_cost(1, field="joint_cost")
    1.0
    """
    if isinstance(cost, bool) or not isinstance(cost, (int, float, np.floating, np.integer)) \
            or not math.isfinite(cost) or not 0 <= cost <= MAX_PRIOR_COST:
        raise InputError(f"must be a number from 0 to {MAX_PRIOR_COST:g} (nats)", field=field,
                         value=cost)
    return float(cost)


def as_terms(terms: Any, *, removed_from_layer: int | None = None) -> list[Term]:
    """Normalise what callers pass as evidence into a list of terms.

    Accepts an :class:`Evidence`, an :class:`EvidenceTerm`, a :class:`Factor`,
    a pair ``(Evidence, removed_from_layer)``, or a sequence of these.
    ``removed_from_layer`` applies to a bare :class:`Evidence` only.
    """
    def one(t: Any) -> Term | None:
        if isinstance(t, (EvidenceTerm, Factor)):
            return t
        if isinstance(t, Evidence):
            return EvidenceTerm(t, removed_from_layer)
        if isinstance(t, tuple) and len(t) == 2 and isinstance(t[0], Evidence):
            return EvidenceTerm(t[0], t[1])
        return None

    single = one(terms)
    if single is not None:
        return [single]
    if removed_from_layer is not None:
        raise InputError("give removed_from_layer per term when passing several terms "
                         "(EvidenceTerm(evidence, removed_from_layer=L))",
                         field="removed_from_layer", value=removed_from_layer)
    if isinstance(terms, (str, bytes)) or not isinstance(terms, Iterable):
        raise InputError("expected Evidence, EvidenceTerm, Factor or a sequence of them",
                         field="evidence", value=terms)
    out = []
    for n, t in enumerate(terms):
        item = one(t)
        if item is None:
            raise InputError("expected Evidence, EvidenceTerm, (Evidence, layer) or Factor",
                             field=f"evidence[{n}]", value=t)
        out.append(item)
    return out


def terms_extent(terms: Iterable[Term], extent: Extent | None = None) -> Extent:
    """The common extent of the evidence terms (or ``extent``); mismatches raise."""
    for n, t in enumerate(terms):
        if isinstance(t, EvidenceTerm):
            if extent is None:
                extent = t.extent
            elif t.extent != extent:
                raise InputError(f"evidence is for extent {t.extent}, the model for {extent}",
                                 field=f"evidence[{n}]", value=t.extent.as_list())
    if extent is None:
        raise InputError("no evidence: cannot tell the extent", field="evidence", value=[])
    return extent


@dataclass(frozen=True, eq=False)
class Objective:
    """``constant + Σ_e coefs[e]·[exprs[e]]``, to be maximised.

    Attributes
    ----------
    extent : Extent
    exprs : tuple of Expr, length M
        Distinct, simplified, non-constant expressions.
    coefs : (M,) float64
        Non-zero weights.
    constant : float
    """

    extent: Extent
    exprs: tuple[Expr, ...]
    coefs: np.ndarray
    constant: float

    def __len__(self) -> int:
        return len(self.exprs)

    def value(self, occupancy: np.ndarray, choices: Mapping[str, bool] | None = None) -> float:
        """The objective at an occupancy (slow path: evaluates every expression)."""
        z = np.asarray(occupancy)
        names = {} if choices is None else choices
        truth = np.array([bool(evaluate(e, z, names)) for e in self.exprs], dtype=bool)
        return float(self.constant + np.sum(self.coefs[truth]))


def compile_objective(extent: Extent, terms: Any) -> Objective:
    """Collect the terms into ``constant + Σ_e c_e [e]`` over distinct expressions.

    ``terms`` is anything :func:`as_terms` accepts.

    Features with p = ½ have equal weights either way and drop out (they
    only move the constant); ``u`` and ``v`` features at one position share
    one expression; the same feature seen in several views adds up.
    """
    constant = 0.0
    per_level: dict[int | None, tuple[np.ndarray, float]] = {}
    weights: dict[Expr, float] = {}
    for n, t in enumerate(as_terms(terms)):
        if isinstance(t, EvidenceTerm):
            if t.extent != extent:
                raise InputError(f"evidence is for extent {t.extent}, the model for {extent}",
                                 field=f"evidence[{n}]", value=t.extent.as_list())
            lp, lq = t.evidence.weights()
            diff, const = per_level.get(t.removed_from_layer, (0.0, 0.0))
            per_level[t.removed_from_layer] = (diff + (lp - lq), const + float(lq.sum()))
        elif isinstance(t, Factor):
            e = simplify(t.expr, extent)
            if isinstance(e, Const):
                constant += t.if_true if e.value else t.if_false
            else:
                constant += t.if_false
                weights[e] = weights.get(e, 0.0) + (t.if_true - t.if_false)
        else:
            raise InputError("expected EvidenceTerm or Factor", field=f"terms[{n}]", value=t)
    for level, (diff, const) in per_level.items():
        table = feature_table(extent, level)
        diff = np.asarray(diff, dtype=float)
        constant += const + float(diff[table.constant_value].sum())
        live = table.expr_of_feature >= 0
        summed = np.bincount(table.expr_of_feature[live], weights=diff[live],
                             minlength=len(table.exprs))
        for e_id in np.flatnonzero(summed):
            e = table.exprs[e_id]
            weights[e] = weights.get(e, 0.0) + float(summed[e_id])
    exprs = tuple(e for e, w in weights.items() if w != 0.0)
    coefs = np.array([weights[e] for e in exprs], dtype=float)
    return Objective(extent, exprs, coefs, float(constant))


def log_probability(terms: Any, structure: Structure | np.ndarray,
                    choices: Mapping[str, bool] | None = None) -> float:
    """Log-probability of a structure under the terms, in float64, from the terms themselves.

    Each evidence term contributes ``evidence.log_probability(Z')`` (all
    features, p = ½ ones included, as :meth:`Evidence.log_probability` does).
    """
    z = structure.occupancy if isinstance(structure, Structure) else np.asarray(structure)
    total = 0.0
    for t in as_terms(terms):
        if isinstance(t, EvidenceTerm):
            zt = z
            if t.removed_from_layer is not None:
                zt = z.copy()
                zt[:, t.removed_from_layer:, :] = 0
            total += t.evidence.log_probability(zt)
        else:
            holds = bool(evaluate(t.expr, z, {} if choices is None else choices))
            total += t.if_true if holds else t.if_false
    return float(total)
