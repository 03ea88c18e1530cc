"""A description compiled into hard constraints Ψ on the structure (solver-neutral ``Expr``).

Compositional, one piece per entity and per relation:

* **Entity** (a noun): one :class:`~unseeable.grammar.expr.Choice` *selector* per
  placement the entity may take on the grid
  (:func:`~unseeable.language.relations.entity_placements`), ``Exactly(1,
  selectors)``, and ``Implies(selector, shape_expr(placement))``: the solver
  chooses where the door stands and the occupancy must then hold a door there.
* **perpendicular to**: ``AtMost(1, ·)`` over the two entities' selectors of walls
  along ``i``, and again along ``k`` (not both in planes of one direction).
* **coplanar to**: for each plane ``g`` the subject may take,
  ``Or(subject's selectors in g) → Or(object's selectors in g)``.
* **left of** / **right of**: the relation needs the subject's rightmost lateral
  rank below the object's leftmost one. Each entity gets an *order encoding* of
  its rightmost rank, Choices ``≤ r`` chained ``≤ r → ≤ r'`` for the ranks ``r <
  r'`` its placements take, so that each object selector needs one implication
  (``selector → subject's rightmost rank ≤ r``). The model grows linearly with the
  placements; forbidding incompatible pairs instead grows with their product: for
  "window left of door" on the lodge's 6×8×6 grid, 322 implications against 8,961
  forbidden pairs (``tests/language/benchmark_parse_compile.py``).
* A relation of an entity with itself ("door left of door"): FALSE, except
  *coplanar to* (TRUE).

Each entity's constraints are one ``And``, and so are each relation's: a solver checks
every top-level constraint of a structure it returns, and one expression per entity
shares the literals its placements have in common.

Choice names start with the namespace (``"language"``) and the noun, and a
selector's name spells its placement, so :func:`chosen_placements` reads the
solver's choice back from the names alone. Compile descriptions that are solved
together with one viewpoint (the order encoding's names hold lateral ranks).

Examples
--------
>>> from unseeable.domain import Extent
>>> from unseeable.language import parse
>>> from unseeable.solve import StructureSolver
>>> extent = Extent(5, 6, 5)
>>> psi = compile_description(parse("window left of and perpendicular to door"), extent)
>>> result = StructureSolver(extent, constraints=psi).solve([])
>>> placed = chosen_placements(parse("window left of and perpendicular to door"), psi,
...                            result.choices)
>>> sorted(placed), placed["window"].along != placed["door"].along
(['door', 'window'], True)
"""

from __future__ import annotations

import bisect
import re
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from unseeable.domain.grid import Extent
from unseeable.errors import InputError
from unseeable.grammar.expr import FALSE, And, AtMost, Choice, Exactly, Expr, Implies, Or
from unseeable.grammar.shapes import Placement, shape_expr
from unseeable.language.relations import entity_placements, lateral_ranks, lateral_span
from unseeable.language.syntax import Description, Relation, parse

__all__ = ["NAMESPACE", "CompiledDescription", "compile_description", "chosen_placements",
           "selector_name", "choice_values"]

#: Default first part of every Choice name a description adds.
NAMESPACE = "language"

_SELECTOR = re.compile(r"^(?P<ns>.+):(?P<kind>door|window|wall)@(?P<along>[ik])(?P<plane>\d+)"
                       r":(?P<at>\d+)\+(?P<width>\d+):(?P<bottom>\d+)-(?P<top>\d+)$")


def selector_name(placement: Placement, *, namespace: str = NAMESPACE) -> str:
    """The Choice name of "the entity of this kind stands at ``placement``".

    Examples
    --------
    >>> from unseeable.grammar.shapes import Placement
    >>> selector_name(Placement("door", "k", 3, 2, 0, 2))
    'language:door@k3:2+1:0-2'
    """
    p = placement
    return (f"{namespace}:{p.kind}@{p.along}{p.plane}:{p.at}+{p.width}:"
            f"{p.bottom}-{p.top}")


def _placement_of(name: str, namespace: str) -> Placement | None:
    m = _SELECTOR.match(name)
    if m is None or m["ns"] != namespace:
        return None
    return Placement(m["kind"], m["along"], int(m["plane"]), int(m["at"]), int(m["bottom"]),
                     int(m["top"]), int(m["width"]))


class CompiledDescription(tuple):
    """The constraints of a description: a ``tuple`` of ``Expr`` (pass it as a solver's or
    the estimator's ``constraints``) that also knows its selectors.

    Attributes
    ----------
    description : Description
    extent : Extent
    namespace : str
    selectors : dict kind -> tuple of (name, Placement)
        Each entity's selector Choices.
    orders : dict kind -> dict name -> int
        Each entity's order-encoding Choices: name -> lateral rank ``r`` ("the
        entity's rightmost grid point has rank ``<= r``").
    ranks : (I, J, K) int
        The grid's lateral ranks (:func:`~unseeable.language.relations.lateral_ranks`).
    viewpoint
        What it was compiled with.
    """

    description: Description
    extent: Extent
    viewpoint: Any
    namespace: str
    selectors: dict
    orders: dict
    ranks: np.ndarray

    def __new__(cls, exprs, **attributes):
        obj = super().__new__(cls, exprs)
        for key, value in attributes.items():
            setattr(obj, key, value)
        return obj

    def __reduce__(self):
        return (_rebuild, (tuple(self), dict(self.__dict__)))

    @property
    def size(self) -> dict[str, int]:
        """Model size: selectors, order-encoding Choices, and constraints (top-level
        expressions, the shapes' implications included)."""
        return {"selectors": sum(len(v) for v in self.selectors.values()),
                "order_choices": sum(len(v) for v in self.orders.values()),
                "constraints": len(self)}


def _rebuild(exprs, attributes):
    return CompiledDescription(exprs, **attributes)


class _Order:
    """One entity's order encoding of its rightmost lateral rank."""

    def __init__(self, kind: str, selectors: list[tuple[Choice, int]], namespace: str) -> None:
        self.kind = kind
        self.names: dict[str, int] = {}
        by_rank: dict[int, list[Choice]] = {}
        for choice, rank in selectors:
            by_rank.setdefault(rank, []).append(choice)
        self.ranks = sorted(by_rank)
        self.top = self.ranks[-1] if self.ranks else -1
        self.exprs: list[Expr] = []
        self._at_most: dict[int, Choice] = {}
        previous = None
        for r in self.ranks[:-1]:  # "<= top" always holds: no Choice for it
            name = f"{namespace}:{kind}:right-edge<={r}"
            y = Choice(name)
            self.names[name] = r
            self._at_most[r] = y
            # y ⇔ the chosen placement's rightmost rank <= r, as clauses.
            self.exprs += [Implies(s, y) for s in by_rank[r]]
            if previous is not None:
                self.exprs.append(Implies(previous, y))
            self.exprs.append(Implies(y, Or(*([previous] if previous is not None else []),
                                            *by_rank[r])))
            previous = y

    def below(self, rank: int) -> Expr | None:
        """"The rightmost rank is < ``rank``": an Expr, or None when always true."""
        if not self.ranks or self.top < rank:
            return None
        n = bisect.bisect_left(self.ranks, rank)  # the ranks below ``rank``: ranks[:n]
        return FALSE if n == 0 else self._at_most[self.ranks[n - 1]]


def compile_description(description: Description | str | Sequence[str], extent: Extent, *,
                        viewpoint: Any = None, namespace: str = NAMESPACE
                        ) -> CompiledDescription:
    """The hard constraints Ψ of a description on a grid.

    Parameters
    ----------
    description : Description, or text for :func:`~unseeable.language.parse`
    extent : Extent or (I, J, K)
        The grid of the structure to be estimated (the reference view's).
    viewpoint : None, Viewpoint, (camera centre, GridPose) or callable, optional
        Where *left* and *right* are seen from: the reference view's camera and the
        pose of ``extent``'s grid on the table
        (:meth:`Viewpoint.from_view <unseeable.language.Viewpoint.from_view>`), or
        a function from grid points to lateral coordinates; None: from the grid's
        −k side (:data:`~unseeable.language.viewpoint.DEFAULT_VIEWER`).
    namespace : str
        First part of every Choice name.

    Returns
    -------
    CompiledDescription
        A tuple of ``Expr``; every one must hold.

    Examples
    --------
    >>> psi = compile_description("door", (3, 5, 1))   # a door 4 layers high
    >>> psi.size["selectors"]
    1
    """
    description = parse(description)
    if not isinstance(extent, Extent):
        extent = Extent.parse(extent)
    if not isinstance(namespace, str) or not namespace or ":" in namespace:
        raise InputError("must be a non-empty name without ':'", field="namespace",
                         value=namespace)
    exprs: list[Expr] = []
    selectors: dict[str, tuple] = {}
    choices: dict[str, list[tuple[Choice, Placement]]] = {}
    for entity in description.entities:
        ps = entity_placements(entity.kind, extent)
        pairs = [(Choice(selector_name(p, namespace=namespace)), p) for p in ps]
        choices[entity.kind] = pairs
        selectors[entity.kind] = tuple((c.name, p) for c, p in pairs)
        exprs.append(And(Exactly(1, [c for c, _ in pairs]),
                         *(Implies(c, shape_expr(p)) for c, p in pairs)))
    relations = description.relations
    lateral = any(r.name in ("left_of", "right_of") and r.subject != r.object
                  for r in relations)
    ranks = lateral_ranks(extent, viewpoint) if lateral else np.zeros(extent.shape, np.intp)
    spans = {kind: [lateral_span(p, ranks) for _, p in pairs] if lateral else []
             for kind, pairs in choices.items()}
    orders: dict[str, _Order] = {}

    def order(kind: str) -> _Order:
        if kind not in orders:
            orders[kind] = _Order(kind, [(c, hi) for (c, _), (_, hi)
                                         in zip(choices[kind], spans[kind])], namespace)
            exprs.append(And(*orders[kind].exprs))
        return orders[kind]

    for relation in relations:
        parts = _relation(relation, choices, spans, order)
        if parts:
            exprs.append(parts[0] if len(parts) == 1 else And(*parts))
    return CompiledDescription(
        tuple(exprs), description=description, extent=extent, viewpoint=viewpoint,
        namespace=namespace,
        selectors=selectors, orders={k: dict(o.names) for k, o in orders.items()},
        ranks=ranks)


def _relation(relation: Relation, choices: dict, spans: dict, order) -> list[Expr]:
    a, b = relation.subject.kind, relation.object.kind
    if a == b:
        # One entity (module docstring of syntax): coplanar with itself, nothing else.
        return [] if relation.name == "coplanar_to" else [FALSE]
    if relation.name == "perpendicular_to":
        return [AtMost(1, [c for c, p in choices[a] if p.along == along]
                       + [c for c, p in choices[b] if p.along == along]) for along in "ik"]
    if relation.name == "coplanar_to":
        planes_b: dict[tuple, list[Choice]] = {}
        for c, p in choices[b]:
            planes_b.setdefault((p.along, p.plane), []).append(c)
        planes_a: dict[tuple, list[Choice]] = {}
        for c, p in choices[a]:
            planes_a.setdefault((p.along, p.plane), []).append(c)
        return [Implies(Or(*cs), Or(*planes_b.get(g, []))) for g, cs in planes_a.items()]
    if relation.name == "right_of":
        a, b = b, a
    # a left of b: a's rightmost rank below b's leftmost, for b's chosen placement.
    left = order(a)
    out: list[Expr] = []
    for (c, _), (lo, _) in zip(choices[b], spans[b]):
        below = left.below(lo)
        if below is not None:
            out.append(Implies(c, below))
    return out


def chosen_placements(description: Description | str | Sequence[str],
                      compiled: Sequence[Expr], choices: Mapping[str, Any]
                      ) -> dict[str, Placement]:
    """Where the solver put each entity of a description.

    Parameters
    ----------
    description : Description (or its text)
    compiled : CompiledDescription or sequence of Expr
        What :func:`compile_description` returned (its namespace is read from it;
        a plain sequence means the default namespace).
    choices : mapping name -> bool
        A solve's ``result.choices`` (an estimate's ``estimate.result.choices``).

    Returns
    -------
    dict noun -> Placement
        ``{"door": Placement(...), "window": ...}``; walls are minimal walls (2 × 2).

    Raises
    ------
    InputError
        An entity has no selected placement in ``choices`` (not solved with these
        constraints).
    """
    description = parse(description)
    namespace = getattr(compiled, "namespace", NAMESPACE)
    out: dict[str, Placement] = {}
    for name, value in choices.items():
        if not value:
            continue
        p = _placement_of(name, namespace)
        if p is not None:
            out.setdefault(p.kind, p)
    missing = [e.kind for e in description.entities if e.kind not in out]
    if missing:
        raise InputError("no placement of this entity among the choices; were they solved "
                         "with the description's constraints?", field="choices",
                         value=missing)
    return {e.kind: out[e.kind] for e in description.entities}


def choice_values(compiled: CompiledDescription, placed: Mapping[str, Placement]
                  ) -> dict[str, bool]:
    """The value of every Choice of ``compiled`` when each entity stands at ``placed``.

    With these values, :func:`~unseeable.grammar.expr.evaluate` of the constraints
    on an occupancy says whether the occupancy satisfies the description with the
    entities there.

    Parameters
    ----------
    compiled : CompiledDescription
    placed : mapping noun -> Placement
        One placement per entity (as :func:`chosen_placements` returns; walls minimal).

    Returns
    -------
    dict name -> bool
    """
    if not isinstance(compiled, CompiledDescription):
        raise InputError("must be what compile_description returned", field="compiled",
                         value=type(compiled).__name__)
    values: dict[str, bool] = {}
    for kind, pairs in compiled.selectors.items():
        if kind not in placed:
            raise InputError("no placement given for this entity", field="placed", value=kind)
        target = placed[kind]
        values.update({name: p == target for name, p in pairs})
        if kind in compiled.orders:
            hi = lateral_span(target, compiled.ranks)[1]
            values.update({name: hi <= r for name, r in compiled.orders[kind].items()})
    return values
