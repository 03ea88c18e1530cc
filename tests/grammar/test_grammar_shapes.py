"""Walls, doors and windows as grid shapes: found, checked and stated as expressions alike."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from unseeable.corpus import list_designs
from unseeable.corpus.designs_index import DATA_DIR
from unseeable.domain import Evidence, Extent, Log, Structure
from unseeable.errors import InputError
from unseeable.fileio import read_json
from unseeable.grammar import Choice, Exactly, evaluate, random_structure
from unseeable.grammar.shapes import (
    SHAPE_KINDS,
    Placement,
    check_placement,
    conditions,
    find_shapes,
    holds,
    placements,
    shape_expr,
    span_logs,
)
from unseeable.solve import StructureSolver


def _openings(structure):
    return [p.to_json() for p in find_shapes(structure, ("door", "window"))]


def test_corpus_doors_and_windows_are_the_recorded_ones():
    # index.json records what the corpus's designer found before the shapes existed;
    # its structures are the shipped ones.
    recorded = {d["name"]: d["openings"] for d in read_json(DATA_DIR / "index.json")["designs"]}
    entries = list_designs()
    assert len(entries) == len(recorded) == 32
    for e in entries:
        assert _openings(e.structure) == recorded[e.name], e.name


@pytest.mark.parametrize(("name", "doors", "windows"), [
    ("cabin-4x4", 0, 0), ("cabin-door", 1, 0), ("cabin-door-L3", 0, 0),
    ("cabin-window", 1, 1), ("cabin-window-L5", 1, 0), ("cabin-door-window", 1, 1),
    ("lodge", 1, 2), ("wall-window", 0, 1), ("wall-door", 1, 0), ("tower-window", 0, 1),
])
def test_corpus_designs_have_the_doors_and_windows_their_names_promise(name, doors, windows):
    (entry,) = [e for e in list_designs() if e.name == name]
    kinds = [p.kind for p in find_shapes(entry.structure, ("door", "window"))]
    assert (kinds.count("door"), kinds.count("window")) == (doors, windows)


def _door_line(layer0, layer1, layer2):
    """A one-plane wall, 3 positions long, from per-layer lists of logs (start, notches)."""
    logs = [Log(layer=j, at=(a, 0), notches=m)
            for j, row in enumerate((layer0, layer1, layer2)) for a, m in row]
    return Structure(Extent(3, 3, 1), logs)


DOOR = Placement("door", "i", 0, 1, 0, 1)


def test_a_door_between_posts_under_a_mantel_is_found_and_broken_ones_are_not():
    good = _door_line([(0, 1), (2, 1)], [(0, 1), (2, 1)], [(0, 3)])
    assert find_shapes(good, "door") == [DOOR] and holds(DOOR, good)
    assert find_shapes(good, "window") == []
    no_mantel = _door_line([(0, 1), (2, 1)], [(0, 1), (2, 1)], [])
    assert find_shapes(no_mantel, "door") == [] and not holds(DOOR, no_mantel)
    two_logs = _door_line([(0, 1), (2, 1)], [(0, 1), (2, 1)], [(0, 2), (2, 1)])
    assert find_shapes(two_logs, "door") == []
    # the left post a 2-notch log that continues into the opening
    into = _door_line([(0, 2), (2, 1)], [(0, 1), (2, 1)], [(0, 3)])
    assert find_shapes(into, "door") == [] and not holds(DOOR, into)
    # a missing post (an occupancy, not a valid structure)
    no_post = good.occupancy.copy()
    no_post[0, 0, 0] = 0
    assert not holds(DOOR, no_post) and holds(DOOR, good.occupancy)


def test_a_window_stands_on_a_threshold_log_and_needs_a_post_layer():
    # threshold on layer 0, posts on layer 2, mantel on layer 4
    logs = [Log(layer=0, at=(0, 0), notches=3), Log(layer=4, at=(0, 0), notches=3)]
    logs += [Log(layer=j, at=(i, 0), notches=1) for j in (1, 2, 3) for i in (0, 2)]
    s = Structure(Extent(3, 5, 1), logs)
    window = Placement("window", "i", 0, 1, 1, 3)
    assert find_shapes(s, ("door", "window")) == [window]
    assert [part for part, _ in span_logs(window)] == ["threshold", "mantel"]
    with pytest.raises(InputError, match="post layer"):
        check_placement(Placement("window", "i", 0, 1, 1, 1))  # threshold 0, mantel 2
    with pytest.raises(InputError, match="fit the grid"):
        check_placement(window, Extent(3, 4, 1))


def test_every_placement_fits_its_extent_and_is_one_shape():
    extent = Extent(4, 6, 3)
    for kind in SHAPE_KINDS:
        ps = placements(extent, kind)
        assert ps and len(set(ps)) == len(ps)
        assert all(p.kind == kind and check_placement(p, extent) is p for p in ps)
    # a door per position inside each plane's line and per mantel with a post below it:
    # along i 3 planes x 2 positions x mantels {2, 4}; along k 4 planes x 1 x mantels {3, 5}
    assert len(placements(extent, "door")) == 3 * 2 * 2 + 4 * 1 * 2


def test_walls_found_are_the_largest_full_rectangles():
    s = Structure(Extent(3, 2, 2), [Log(layer=0, at=(0, 0), notches=3),
                                    Log(layer=0, at=(0, 1), notches=1),
                                    Log(layer=1, at=(0, 0), notches=2),
                                    Log(layer=1, at=(1, 0), notches=1),
                                    Log(layer=1, at=(2, 0), notches=1)])
    walls = find_shapes(s, "wall")
    assert walls == [Placement("wall", "i", 0, 0, 0, 1, width=3),
                     Placement("wall", "k", 0, 0, 0, 1, width=2)]
    every = find_shapes(s, "wall", maximal_walls=False)
    assert len(every) == 4 and all(holds(p, s) for p in every)


def _check_expr_matches_holds(occupancies: np.ndarray, extent: Extent) -> int:
    """evaluate(shape_expr(p)) == holds(p) on a batch, for every placement; how many held."""
    held = 0
    for kind in SHAPE_KINDS:
        for p in placements(extent, kind):
            expected = holds(p, occupancies)
            assert np.array_equal(evaluate(shape_expr(p), occupancies), expected), p
            held += int(expected.sum())
    return held


@settings(max_examples=25, deadline=None)
@given(st.integers(1, 4), st.integers(1, 5), st.integers(1, 4),
       st.floats(0.5, 1.0), st.integers(0, 2**31 - 1))
def test_expression_and_numpy_check_agree_on_random_structures(I, J, K, density, seed):
    extent = Extent(I, J, K)
    batch = np.stack([random_structure(extent, density=density, seed=seed + n).occupancy
                      for n in range(6)])
    _check_expr_matches_holds(batch, extent)


def test_expression_and_numpy_check_agree_near_corpus_doors_and_windows():
    # designs with openings, and copies with a few grid points changed: positives and
    # near misses of every literal kind
    rng = np.random.default_rng(0)
    held = 0
    for name in ("wall-door", "wall-window", "tower-window", "cabin-door-window"):
        (entry,) = [e for e in list_designs() if e.name == name]
        z = entry.structure.occupancy
        batch = np.repeat(z[None], 12, axis=0)
        for b in range(1, len(batch)):
            at = rng.integers(0, z.size, size=b % 3 + 1)
            batch[b].reshape(-1)[at] = rng.integers(0, 7, size=len(at))
        held += _check_expr_matches_holds(batch, entry.structure.extent)
    assert held > 3  # the unchanged designs' openings and walls at least


def test_holds_reads_outside_the_grid_as_empty():
    p = Placement("door", "i", 0, 1, 0, 1)
    assert not holds(p, np.zeros((3, 2, 1), dtype=np.int8))  # mantel off the grid
    assert bool(evaluate(shape_expr(p), np.zeros((3, 2, 1), dtype=np.int8))) is False


def test_conditions_name_the_door_parts():
    parts = [c.part for c in conditions(DOOR)]
    assert parts == ["opening", "opening", "mantel", "mantel", "mantel", "post", "post",
                     "side", "side", "side", "side"]


def test_an_opening_closed_off_in_front_or_behind_is_no_door():
    # the door of _door_line in the middle plane of three: clear on both sides, a door
    line = _door_line([(0, 1), (2, 1)], [(0, 1), (2, 1)], [(0, 3)])
    z = np.zeros((3, 3, 3), dtype=np.int8)
    z[:, :, 1] = line.occupancy[:, :, 0]
    middle = Placement("door", "i", 1, 1, 0, 1)
    assert holds(middle, z)
    for k in (0, 2):  # a log's grid point just in front of / behind the opening
        blocked = z.copy()
        blocked[1, 1, k] = 1
        assert not holds(middle, blocked), k
    # the tower's hollow core: 1-notch stubs in the middle lines, walled all round
    (tower,) = [e for e in list_designs() if e.name == "tower-roofed"]
    assert find_shapes(tower.structure, ("door", "window")) == []


def test_a_solver_places_some_door_when_asked_to():
    extent = Extent(3, 3, 2)
    doors = placements(extent, "door")
    selectors = [Choice(f"door {n}") for n in range(len(doors))]
    constraints = [Exactly(1, selectors),
                   *[s.implies(shape_expr(p)) for s, p in zip(selectors, doors)]]
    # evidence against every log: without the constraint the empty structure wins
    evidence = Evidence(extent, np.full(len(Evidence.uniform(extent).p), 0.3))
    result = StructureSolver(extent, constraints=constraints).solve(evidence, time_limit=20)
    chosen = [p for s, p in zip(selectors, doors) if result.choices[s.name]]
    assert len(chosen) == 1 and chosen[0] in find_shapes(result.structure, "door")


def test_bad_kinds_and_placements_are_input_errors():
    with pytest.raises(InputError, match="kind"):
        placements((3, 3, 3), "porch")
    with pytest.raises(InputError, match="kind"):
        find_shapes(Structure(Extent(1, 1, 1), []), "porch")
    with pytest.raises(InputError, match="along"):
        Placement("door", "j", 0, 1, 0, 1)
    with pytest.raises(InputError, match="one position wide"):
        conditions(Placement("door", "i", 0, 1, 0, 1, width=2))
