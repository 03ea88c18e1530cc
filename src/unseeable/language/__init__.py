"""English descriptions as constraints on the estimate (paper §6; DESIGN.md §4 "Language").

A person who built the assembly says what they know — "window left of and
perpendicular to door" — and the estimator uses it as hard constraints Ψ beside
the grammar Φ in the same exact solve.

* :func:`parse` — text (sentences, or a list of them) to a :class:`Description`,
  a small logical formula (:mod:`~unseeable.language.syntax`, which states how
  nouns corefer: one thing per noun in a description);
* :func:`compile_description` — a description to solver-neutral constraints on a
  grid, left and right seen from a :class:`Viewpoint`
  (:mod:`~unseeable.language.viewpoint`; without one, from the grid's −k side);
  :func:`chosen_placements` reads back where the solver put each entity;
* :func:`describe` — the true sentences of a structure;
* :func:`check_satisfiable` — "no structure on a I×J×K grid satisfies: …";
* :func:`estimate_with_description` — photographs and a description together.

Examples
--------
>>> from unseeable.domain import Extent
>>> from unseeable.solve import StructureSolver
>>> d = parse("window left of and perpendicular to door")
>>> psi = compile_description(d, Extent(5, 6, 5))
>>> result = StructureSolver(Extent(5, 6, 5), constraints=psi).solve([])
>>> sorted(chosen_placements(d, psi, result.choices))
['door', 'window']
"""

from unseeable.language.check import check_satisfiable, is_satisfiable
from unseeable.language.compile import (
    NAMESPACE,
    CompiledDescription,
    choice_values,
    chosen_placements,
    compile_description,
    selector_name,
)
from unseeable.language.describe import (
    SUBJECT_ORDER,
    describe,
    described_placements,
    satisfying_placements,
)
from unseeable.language.estimation import (
    description_constraints,
    description_estimator,
    estimate_with_description,
)
from unseeable.language.relations import (
    DOOR_MIN_LAYERS,
    LATERAL_TOLERANCE,
    entity_placements,
    lateral_ranks,
    lateral_span,
    relation_holds,
)
from unseeable.language.syntax import (
    NOUNS,
    RELATION_WORDS,
    RELATIONS,
    VOCABULARY,
    Conjunction,
    Description,
    DescriptionError,
    Entity,
    Exists,
    Formula,
    Relation,
    UngrammaticalError,
    UnknownWordError,
    UnsatisfiableError,
    parse,
)
from unseeable.language.viewpoint import (
    DEFAULT_VIEWER,
    LateralFunction,
    Viewpoint,
    lateral_coordinates,
)

__all__ = [
    "parse", "Description", "Entity", "Exists", "Relation", "Conjunction", "Formula",
    "NOUNS", "RELATIONS", "RELATION_WORDS", "VOCABULARY", "DescriptionError",
    "UnknownWordError", "UngrammaticalError", "UnsatisfiableError", "compile_description",
    "CompiledDescription", "chosen_placements", "choice_values", "selector_name", "NAMESPACE",
    "describe", "described_placements", "satisfying_placements", "SUBJECT_ORDER",
    "check_satisfiable", "is_satisfiable", "Viewpoint", "LateralFunction",
    "lateral_coordinates", "DEFAULT_VIEWER",
    "entity_placements", "lateral_ranks", "lateral_span", "relation_holds", "LATERAL_TOLERANCE",
    "DOOR_MIN_LAYERS",
    "description_constraints", "estimate_with_description", "description_estimator",
]
