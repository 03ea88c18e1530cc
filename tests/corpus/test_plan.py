"""The design helpers: walls, doors, windows, blocks, truncations, openings."""

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from unseeable.corpus.plan import Plan, block, cabin, door, truncate, wall, window
from unseeable.domain import Extent, Log, Structure, is_valid
from unseeable.errors import InputError
from unseeable.grammar.shapes import find_shapes


def find_openings(structure):
    return find_shapes(structure, ("door", "window"))


def test_a_wall_fills_its_plane_and_is_valid():
    plan = Plan((5, 4, 2))
    wall(plan, "w", along="i", at=1, span=range(5), layers=range(4))
    s = plan.build()
    assert is_valid(s)
    assert (s.occupancy[:, :, 1] > 0).all() and not s.occupancy[:, :, 0].any()


@settings(max_examples=40, deadline=None)
@given(st.integers(3, 6), st.integers(3, 6), st.integers(2, 8), st.data())
def test_cabins_with_a_door_are_valid_and_have_the_door(I, K, J, data):
    plan = Plan((I, J, K))
    cabin(plan, layers=range(J))
    mantels = [m for m in range(2, J, 2)]
    if mantels:
        at = data.draw(st.integers(1, I - 2))
        mantel = data.draw(st.sampled_from(mantels))
        door(plan, "front", at=at, mantel=mantel)
    s = plan.build()
    assert is_valid(s)
    found = [(o.kind, o.along, o.plane, o.at, o.bottom, o.top) for o in find_openings(s)]
    if mantels:
        assert ("door", "i", 0, at, 0, mantel - 1) in found


def test_window_in_a_side_wall_runs_on_odd_layers():
    plan = Plan((4, 7, 5))
    cabin(plan, layers=range(7))
    window(plan, "right", at=2, sill=1, lintel=5)
    s = plan.build()
    z = s.occupancy
    assert (z[3, 2:5, 2] == 0).all() and z[3, 1, 2] == 5 and z[3, 5, 2] == 5
    assert [o.kind for o in find_openings(s)] == ["window"]


def test_removable_region_leaves_a_valid_rest():
    plan = Plan((5, 6, 5))
    cabin(plan, layers=range(6))
    wall(plan, "partition", along="k", at=2, span=range(5), layers=range(6), removable=True)
    full, rest = plan.build(), plan.build(without=("partition",))
    assert is_valid(full) and is_valid(rest)
    assert set(rest.logs) < set(full.logs)


def test_plan_errors_name_the_problem():
    plan = Plan((5, 6, 4))
    cabin(plan, layers=range(6))
    with pytest.raises(InputError, match="mantel"):
        door(plan, "front", at=2, mantel=3)  # odd layer: not the front wall's
    with pytest.raises(InputError, match="post position"):
        door(plan, "front", at=0, mantel=4)
    with pytest.raises(InputError, match="lintel"):
        window(plan, "front", at=2, sill=2, lintel=4)
    with pytest.raises(InputError, match="no such region"):
        door(plan, "porch", at=2, mantel=4)
    with pytest.raises(InputError, match="not declared removable"):
        plan.build(without=("front",))
    with pytest.raises(InputError, match="exists already"):
        wall(plan, "front", along="i", at=0, span=range(5), layers=range(6))


def test_unsupported_plan_is_rejected():
    plan = Plan((3, 3, 3))
    block(plan, "floating", i=range(3), k=range(1, 2), layers=range(2, 3))
    with pytest.raises(InputError, match="supported"):
        plan.build()


def test_truncate_keeps_the_lower_layers_on_a_lower_grid():
    plan = Plan((3, 5, 3))
    cabin(plan, layers=range(5))
    s = plan.build()
    t = truncate(s, 2)
    assert t.extent == Extent(3, 2, 3)
    assert set(t.logs) == {log for log in s.logs if log.layer < 2}
    with pytest.raises(InputError):
        truncate(s, 5)


def _wall_line(codes_by_layer):
    """A one-plane wall structure from per-layer lists of logs (start, notches)."""
    logs = [Log(layer=j, at=(a, 0) if j % 2 == 0 else (a, 0), notches=m)
            for j, row in enumerate(codes_by_layer) for a, m in row]
    width = 1 + max(a + (m if j % 2 == 0 else 1) - 1
                    for j, row in enumerate(codes_by_layer) for a, m in row)
    return Structure(Extent(width, len(codes_by_layer), 1), logs)


def test_find_openings_requires_one_mantel_log_and_log_ends_as_posts():
    # door at i=1: posts are 1-notch logs at 0 and 2, mantel 3-notch 0..2
    good = _wall_line([[(0, 1), (2, 1)], [(0, 1), (2, 1)], [(0, 3)]])
    assert [(o.kind, o.at) for o in find_openings(good)] == [("door", 1)]
    # the mantel made of two logs is no mantel
    two = _wall_line([[(0, 1), (2, 1)], [(0, 1), (2, 1)], [(0, 2), (2, 1)]])
    assert find_openings(two) == []
    # a post that continues away from the opening is fine, one that continues
    # through it cannot exist; a post that is not a log end on the opening's side:
    wide = _wall_line([[(0, 2), (3, 1)], [(0, 1), (1, 1), (3, 1)], [(1, 3)]])
    assert [(o.kind, o.at) for o in find_openings(wide)] == [("door", 2)]
    blocked = _wall_line([[(0, 2), (3, 1)], [(0, 1), (1, 1), (3, 1)], [(0, 3)]])
    assert find_openings(blocked) == []  # mantel 0..2 over an occupied position 1


def test_a_door_the_shapes_would_not_find_is_refused():
    # a door in a wall along k (logs on odd layers) under a mantel on layer 1 has no post
    # layer: no door by unseeable.grammar.shapes, so the plan refuses to cut it
    plan = Plan((4, 4, 5))
    cabin(plan, layers=range(4))
    with pytest.raises(InputError, match="post layer"):
        door(plan, "left", at=2, mantel=1)
    door(plan, "left", at=2, mantel=3)
    assert [(o.kind, o.along, o.at, o.top) for o in find_openings(plan.build())] == [
        ("door", "k", 2, 2)]
