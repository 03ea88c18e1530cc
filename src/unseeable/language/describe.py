"""The true sentences of a structure: :func:`describe`."""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np

from unseeable.domain.structure import Structure
from unseeable.grammar.shapes import Placement, find_shapes
from unseeable.language.relations import (
    entity_placements,
    lateral_ranks,
    lateral_span,
    relation_holds,
)
from unseeable.language.syntax import NOUNS, RELATION_WORDS, parse

__all__ = ["describe", "described_placements", "satisfying_placements", "SUBJECT_ORDER"]

#: Which noun is the subject when two are related: the smaller thing is placed relative to
#: the larger ("window left of door", "door coplanar to wall").
SUBJECT_ORDER = ("window", "door", "wall")


def _instances(structure: Structure) -> dict[str, list[Placement]]:
    """The placements of each kind that hold in ``structure`` and that its noun names
    (:func:`~unseeable.language.relations.entity_placements`)."""
    out = {}
    for kind in NOUNS:
        found = find_shapes(structure, kind, maximal_walls=False)
        # Only the placements the noun names (a door high enough, a minimal wall).
        named = set(entity_placements(kind, structure.extent))
        out[kind] = [p for p in found if p in named]
    return {kind: ps for kind, ps in out.items() if ps}


def _facts(a: Placement, b: Placement, spans: dict) -> list[str]:
    """The relations ``a`` stands in to ``b``: left/right first, then the planes'."""
    out = []
    (a_lo, a_hi), (b_lo, b_hi) = spans[a], spans[b]
    if a_hi < b_lo:
        out.append("left_of")
    elif b_hi < a_lo:
        out.append("right_of")
    if a.along != b.along:
        out.append("perpendicular_to")
    elif a.plane == b.plane:
        out.append("coplanar_to")
    return out


def _pairs(kinds: list[str]) -> list[tuple[str, str]]:
    ordered = [k for k in SUBJECT_ORDER if k in kinds]
    return [(s, o) for n, s in enumerate(ordered) for o in ordered[n + 1:]]


def described_placements(structure: Structure, *, viewpoint: Any = None
                         ) -> dict[str, Placement]:
    """The door, window and wall :func:`describe` speaks of.

    A description names one entity per noun, so of several doors (windows, walls)
    it can speak of one: the combination with the most relations between them is
    chosen (the first found on a tie). Walls are minimal walls (2 × 2), pieces of the
    structure's walls.

    Returns
    -------
    dict noun -> Placement
        Only the kinds the structure has.
    """
    found = _instances(structure)
    if not found:
        return {}
    ranks = lateral_ranks(structure.extent, viewpoint)
    spans = {p: lateral_span(p, ranks) for ps in found.values() for p in ps}
    kinds = [k for k in NOUNS if k in found]
    pairs = _pairs(kinds)
    best, best_count = None, -1
    for combo in itertools.product(*(found[k] for k in kinds)):
        chosen = dict(zip(kinds, combo))
        count = sum(len(_facts(chosen[s], chosen[o], spans)) for s, o in pairs)
        if count > best_count:
            best, best_count = chosen, count
    return best


def describe(structure: Structure, *, viewpoint: Any = None) -> list[str]:
    """The true sentences of a structure, shortest first.

    One sentence per door, window and wall the structure has ("a door"), and one
    per pair of them with the relations that hold between them ("window left of and
    perpendicular to door"), for the entities :func:`described_placements` chooses.
    Together they are a description the structure satisfies (under the language's
    rule that a noun names one thing throughout).

    Parameters
    ----------
    structure : Structure
    viewpoint : None, Viewpoint, (centre, GridPose) or callable, optional
        Where left and right are seen from (see
        :func:`~unseeable.language.compile_description`).

    Returns
    -------
    list of str
        Empty when the structure has no door, window or wall.

    Examples
    --------
    >>> from unseeable.domain import Extent, Log, Structure
    >>> logs = [Log(layer=j, at=(i, 0), notches=1) for j in range(4) for i in (0, 2)]
    >>> describe(Structure(Extent(3, 5, 1), [*logs, Log(layer=4, at=(0, 0), notches=3)]))
    ['a door']
    """
    chosen = described_placements(structure, viewpoint=viewpoint)
    if not chosen:
        return []
    ranks = lateral_ranks(structure.extent, viewpoint)
    spans = {p: lateral_span(p, ranks) for p in chosen.values()}
    sentences = [f"a {kind}" for kind in NOUNS if kind in chosen]
    for s, o in _pairs(list(chosen)):
        facts = _facts(chosen[s], chosen[o], spans)
        if facts:
            sentences.append(f"{s} {' and '.join(RELATION_WORDS[f] for f in facts)} {o}")
    return sorted(sentences, key=len)


def satisfying_placements(description: Any, structure: Structure, *, viewpoint: Any = None
                          ) -> dict[str, Placement] | None:
    """Where the entities of a description stand in ``structure`` so that it holds, checked
    directly (no solver): a placement per noun, or None when the structure does not
    satisfy the description.

    Parameters
    ----------
    description : Description or text
    structure : Structure
    viewpoint : optional
        Where left and right are seen from (:func:`~unseeable.language.compile_description`).

    Returns
    -------
    dict noun -> Placement, or None
        The first assignment found (walls minimal).

    Examples
    --------
    >>> from unseeable.domain import Extent, Log, Structure
    >>> logs = [Log(layer=j, at=(i, 0), notches=1) for j in range(4) for i in (0, 2)]
    >>> s = Structure(Extent(3, 5, 1), [*logs, Log(layer=4, at=(0, 0), notches=3)])
    >>> satisfying_placements("door", s)["door"].at
    1
    >>> satisfying_placements("door perpendicular to door", s) is None
    True
    """
    description = parse(description)
    entities = [e.kind for e in description.entities]
    found = _instances(structure)
    if any(kind not in found for kind in entities):
        return None
    relations = description.relations
    for r in relations:
        if r.subject == r.object and r.name != "coplanar_to":
            return None
    ranks = lateral_ranks(structure.extent, viewpoint) if any(
        r.name in ("left_of", "right_of") for r in relations) else np.zeros(
        structure.extent.shape, np.intp)
    chosen: dict[str, Placement] = {}

    def consistent(kind: str) -> bool:
        for r in relations:
            a, b = r.subject.kind, r.object.kind
            if a == b or kind not in (a, b) or a not in chosen or b not in chosen:
                continue
            if not relation_holds(r.name, chosen[a], chosen[b], ranks):
                return False
        return True

    def search(n: int) -> bool:
        if n == len(entities):
            return True
        kind = entities[n]
        for p in found[kind]:
            chosen[kind] = p
            if consistent(kind) and search(n + 1):
                return True
        del chosen[kind]
        return False

    return dict(chosen) if search(0) else None
