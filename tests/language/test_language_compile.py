"""Compiling descriptions into solver constraints, reading the solver's choice back, and
"no structure satisfies" as an error."""

from __future__ import annotations

import numpy as np
import pytest

from unseeable.corpus import load_design
from unseeable.domain import Extent
from unseeable.grammar.expr import FALSE, And, Occ, evaluate
from unseeable.grammar.shapes import Placement, holds
from unseeable.language import (
    CompiledDescription,
    UnsatisfiableError,
    Viewpoint,
    check_satisfiable,
    choice_values,
    chosen_placements,
    compile_description,
    entity_placements,
    lateral_ranks,
    parse,
    relation_holds,
    satisfying_placements,
)
from unseeable.solve import SolveStatus, StructureSolver

SMALL = Extent(5, 6, 5)


def solve(extent, psi, *extra):
    return StructureSolver(extent, constraints=[*psi, *extra]).solve([])


@pytest.mark.parametrize("text, extent", [
    ("window left of and perpendicular to door", SMALL),
    # Seen from the -k side, openings in one plane are left or right of each other only
    # in a plane along i, where a window and a door need 7 positions.
    ("window right of and coplanar to door", Extent(7, 6, 3)),
    ("door left of window and perpendicular to wall", SMALL),
    ("wall right of door", SMALL),
])
def test_the_solver_places_the_entities_so_that_the_relations_hold(text, extent):
    d = parse(text)
    psi = compile_description(d, extent)
    result = solve(extent, psi)
    assert result.status == SolveStatus.OPTIMAL
    placed = chosen_placements(d, psi, result.choices)
    assert sorted(placed) == sorted(e.kind for e in d.entities)
    ranks = lateral_ranks(extent, None)
    for kind, p in placed.items():
        assert p.kind == kind and holds(p, result.structure)
    for r in d.relations:
        assert relation_holds(r.name, placed[r.subject.kind], placed[r.object.kind], ranks)


def test_without_a_viewpoint_left_is_larger_i_as_seen_from_the_minus_k_side():
    d = parse("window left of door")
    psi = compile_description(d, SMALL)
    placed = chosen_placements(d, psi, solve(SMALL, psi).choices)
    # Every grid point of the window has a larger i than every grid point of the door.
    assert min(p[0] for p in _points(placed["window"])) > max(p[0] for p in _points(placed["door"]))


def _points(p: Placement):
    return [p.point(t, j) for j in p.layers for t in p.positions]


def test_a_viewpoint_decides_left_and_right():
    # Cameras in front of (-z) and behind (+z) the grid see its i axis opposite ways.
    front = Viewpoint(np.array([128.0, 400.0, -1500.0]), _pose0())
    back = Viewpoint(np.array([128.0, 400.0, 1700.0]), _pose0())
    window, door = Placement("window", "i", 0, 3, 1, 3), Placement("door", "i", 0, 1, 0, 3)
    assert relation_holds("left_of", window, door, lateral_ranks(SMALL, front))
    assert relation_holds("right_of", window, door, lateral_ranks(SMALL, back))
    d = parse("window left of door")
    for viewpoint in (front, back):
        psi = compile_description(d, SMALL, viewpoint=viewpoint)
        placed = chosen_placements(d, psi, solve(SMALL, psi).choices)
        assert relation_holds("left_of", placed["window"], placed["door"],
                              lateral_ranks(SMALL, viewpoint))


def _pose0():
    from unseeable.domain import GridPose

    return GridPose(0.0, 0.0, 0.0)


def test_a_function_can_give_the_lateral_coordinate():
    d = parse("window left of door")
    psi = compile_description(d, SMALL, viewpoint=lambda pts: pts[:, 0])  # i to the right
    placed = chosen_placements(d, psi, solve(SMALL, psi).choices)
    assert max(p[0] for p in _points(placed["window"])) < min(p[0] for p in _points(placed["door"]))


def test_a_relation_of_an_entity_with_itself():
    assert FALSE in compile_description("door left of door", SMALL)
    assert solve(SMALL, compile_description("door left of door", SMALL)).status \
        == SolveStatus.INFEASIBLE
    assert solve(SMALL, compile_description("door coplanar to door", SMALL)).status \
        == SolveStatus.OPTIMAL


def test_compiled_constraints_are_a_tuple_of_expressions_with_their_selectors():
    psi = compile_description("window left of door", SMALL)
    assert isinstance(psi, tuple) and isinstance(psi, CompiledDescription)
    assert psi.size["selectors"] == (len(entity_placements("window", SMALL))
                                     + len(entity_placements("door", SMALL)))
    assert all(p.kind == "door" for _, p in psi.selectors["door"])
    import pickle

    again = pickle.loads(pickle.dumps(psi))
    assert tuple(again) == tuple(psi) and again.selectors == psi.selectors


def test_a_door_is_at_least_three_layers_high():
    from unseeable.grammar.shapes import placements
    from unseeable.language import DOOR_MIN_LAYERS

    doors = entity_placements("door", SMALL)
    assert doors and all(p.top - p.bottom + 1 >= DOOR_MIN_LAYERS == 3 for p in doors)
    low = [p for p in placements(SMALL, "door") if p not in doors]
    assert low and all(p.top == 1 and p.along == "i" for p in low)
    # A grid that holds only doors one log high holds no door to speak of.
    with pytest.raises(UnsatisfiableError, match="3×3×1 grid satisfies: door$"):
        check_satisfiable("door", Extent(3, 3, 1))


def test_only_placements_that_fit_the_extent_are_enumerated():
    for kind in ("door", "window", "wall"):
        for p in entity_placements(kind, SMALL):
            for q in _points(p):
                assert SMALL.contains(q)


def test_chosen_placements_without_the_constraints_solved_is_an_error():
    with pytest.raises(Exception, match="no placement of this entity"):
        chosen_placements("door", (), {})


# -- the compiled constraints agree with the direct semantics ----------------------------

_SENTENCES = ["door", "window", "wall", "window left of door", "window right of door",
              "window perpendicular to door", "window coplanar to door",
              "door left of and coplanar to wall", "door right of wall",
              "window left of wall and perpendicular to door", "wall perpendicular to window",
              "door perpendicular to door"]


@pytest.mark.parametrize("name", ["wall-door", "cabin-door-window", "tower-roofed"])
def test_a_structure_satisfies_the_constraints_exactly_when_the_description_holds(name):
    """The solver with the structure's occupancy forced finds the description's entities
    iff a direct search over the shapes that hold does (seen from the −k side and from a
    camera)."""
    entry = load_design(name)
    s = entry.structure
    forced = [Occ(q, {int(s.occupancy[q])}) for q in s.extent.iter_positions()]
    camera_side = Viewpoint(np.array([300.0, 600.0, -900.0]), entry.pose)
    agreements = set()
    for viewpoint in (None, camera_side):
        for text in _SENTENCES:
            psi = compile_description(text, s.extent, viewpoint=viewpoint)
            direct = satisfying_placements(text, s, viewpoint=viewpoint)
            result = solve(s.extent, psi, *forced)
            assert (result.status == SolveStatus.OPTIMAL) == (direct is not None), text
            if direct is not None:
                assert bool(evaluate(And(*psi), s.occupancy, choice_values(psi, direct)))
            agreements.add(direct is not None)
    assert agreements == {True, False}  # both outcomes were checked


# -- errors --------------------------------------------------------------------------------

def test_no_structure_satisfies_a_door_on_a_tiny_grid():
    with pytest.raises(UnsatisfiableError) as info:
        check_satisfiable("a door and a door", (2, 2, 2))
    assert str(info.value) == "no structure on a 2×2×2 grid satisfies: door"


def test_no_structure_satisfies_a_door_perpendicular_to_itself():
    with pytest.raises(UnsatisfiableError, match="5×6×5 grid satisfies: door perpendicular to "
                                                 "door$"):
        check_satisfiable("door perpendicular to door", SMALL)


def test_the_unsatisfiable_sentence_is_named():
    with pytest.raises(UnsatisfiableError) as info:
        check_satisfiable("a door and a window. window left of window. a wall", SMALL)
    assert str(info.value).endswith("satisfies: window left of window")


def test_a_contradiction_between_sentences_names_the_whole_description():
    with pytest.raises(UnsatisfiableError, match=r"satisfies: window left of door\. "
                                                 r"window right of door$"):
        check_satisfiable(["window left of door", "window right of door"], SMALL)


def test_a_satisfiable_description_passes():
    assert check_satisfiable("window left of and perpendicular to door", SMALL) is None


def test_hard_constraints_win_over_contradicting_evidence():
    """Evidence of a solid wall, and the description says there is a door: the estimate
    has one."""
    from unseeable.domain import Log, Structure, simulate_evidence
    from unseeable.pipeline import EstimateSettings, estimate_evidence

    extent = Extent(5, 5, 1)
    solid = Structure(extent, [Log(j, (0, 0), 3) for j in (0, 2, 4)]
                      + [Log(j, (3, 0), 2) for j in (0, 2, 4)]
                      + [Log(j, (i, 0), 1) for j in (1, 3) for i in range(5)])
    evidence = simulate_evidence(solid, accuracy=1.0, occluded_fraction=0.0, seed=0)
    settings = EstimateSettings().replace(enabled=False)
    d = parse("a door")
    psi = compile_description(d, extent)
    est = estimate_evidence(evidence, settings, constraints=psi)
    assert est.result.status == SolveStatus.OPTIMAL
    door = chosen_placements(d, psi, est.result.choices)["door"]
    assert holds(door, est.structure)
    assert estimate_evidence(evidence, settings).structure == solid
