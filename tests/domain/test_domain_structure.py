import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from strategies import structures
from unseeable.domain import (
    Extent,
    Log,
    Structure,
    feature_index,
    feature_values,
    grammar_violations,
    half_turn_structure,
    is_valid,
    load_structure,
    save_structure,
    structure_from_json,
    structure_to_json,
)
from unseeable.errors import InputError


@settings(max_examples=60, deadline=None)
@given(structures())
def test_round_trip_json_logs_occupancy(structure):
    assert is_valid(structure)
    again = structure_from_json(json.loads(json.dumps(structure_to_json(structure))))
    assert again == structure
    assert Structure.from_occupancy(structure.extent, structure.occupancy) == structure


@settings(max_examples=40, deadline=None)
@given(structures())
def test_half_turn_is_an_involution_and_keeps_validity(structure):
    turned = half_turn_structure(structure)
    assert is_valid(turned)
    assert half_turn_structure(turned) == structure
    assert len(turned) == len(structure)


def test_occupancy_codes_of_a_three_notch_log_on_odd_layer():
    e = Extent(1, 2, 3)
    s = Structure(e, [Log(0, (0, 0), 1), Log(0, (0, 2), 1), Log(1, (0, 0), 3)])
    assert s.occupancy[0, 1, :].tolist() == [4, 5, 6]
    assert is_valid(s)


def test_unsupported_logs_are_named():
    e = Extent(3, 2, 3)
    s = Structure(e, [Log(0, (0, 0), 3), Log(1, (0, 0), 3), Log(1, (2, 0), 2)])
    problems = grammar_violations(s)
    # The 3-notch log on layer 1 at i=0 rests on one notch only; the 2-notch at i=2 on one.
    assert len(problems) == 2
    assert "3-notch log on layer 1 at [0, 0]" in problems[0]
    assert not is_valid(s)


def test_three_notch_log_needs_two_of_three_supports():
    e = Extent(3, 2, 3)
    base = [Log(0, (0, 0), 3), Log(0, (0, 2), 3)]
    assert is_valid(Structure(e, [*base, Log(1, (0, 0), 3)]))  # supported at k=0 and k=2
    assert not is_valid(Structure(e, [Log(0, (0, 0), 3), Log(1, (0, 0), 3)]))


def test_overlap_and_off_grid_rejected():
    e = Extent(3, 1, 1)
    with pytest.raises(InputError, match="overlaps"):
        Structure(e, [Log(0, (0, 0), 2), Log(0, (1, 0), 2)])
    with pytest.raises(InputError, match="off the grid"):
        Structure(e, [Log(0, (2, 0), 2)])


def test_from_occupancy_rejects_broken_logs():
    e = Extent(3, 1, 1)
    with pytest.raises(InputError, match="incomplete"):
        Structure.from_occupancy(e, np.array([[[2]], [[0]], [[0]]], dtype=np.int8))
    with pytest.raises(InputError):
        Structure.from_occupancy(e, np.array([[[3]], [[0]], [[0]]], dtype=np.int8))


@settings(max_examples=60, deadline=None)
@given(structures(), st.lists(st.tuples(st.integers(0, 10_000), st.integers(0, 6)),
                              max_size=3))
def test_from_occupancy_reads_back_exactly_the_array_or_names_a_fault(structure, edits):
    # Any array of codes either is some structure's occupancy, read back whole, or is
    # refused with a message saying which log or notch is broken.
    z = np.array(structure.occupancy)
    for at, code in edits:
        z.flat[at % z.size] = code
    try:
        read = Structure.from_occupancy(structure.extent, z)
    except InputError as e:
        assert "incomplete" in str(e) or "notch without" in str(e)
    else:
        assert np.array_equal(read.occupancy, z)


def test_features_of_a_two_layer_wall():
    # Layer 0: a 2-notch log along i at k=0; layer 2 above it another one (touching).
    e = Extent(2, 3, 1)
    s = Structure(e, [Log(0, (0, 0), 2), Log(1, (0, 0), 1), Log(1, (1, 0), 1),
                      Log(2, (0, 0), 2)])
    g = feature_values(e, s.occupancy)
    idx = feature_index(e)
    on = {(int(idx.kind[n]), tuple(int(a) for a in idx.at[n])) for n in np.flatnonzero(g)}
    # w at layer 2, i=0: the top log spans; also the log two layers below spans.
    assert (4, (0, 2, 0)) in on
    # w at layer 4 (two above the top): the top edge of layer 2's log.
    assert (4, (0, 4, 0)) in on
    # no w at the far end of the grid
    assert (4, (1, 0, 0)) not in on
    # ends: end- at (0,0,0), end+ at (1,0,0)
    assert (0, (0, 0, 0)) in on and (1, (1, 0, 0)) in on and (1, (0, 0, 0)) not in on


def test_structure_file_errors_name_file_field_value(tmp_path):
    path = tmp_path / "s.json"
    path.write_text(json.dumps({"format": "unseeable/structure@1", "extent": [2, 2, 2],
                                "logs": [{"notches": 1, "layer": 1, "at": [0, 0]}]}))
    with pytest.raises(InputError) as err:
        load_structure(path)
    msg = str(err.value)
    assert str(path) in msg and "logs[0]" in msg and "grammar" in msg


def test_save_then_load(tmp_path):
    s = Structure(Extent(2, 1, 2), [Log(0, (0, 0), 2), Log(0, (0, 1), 1)])
    save_structure(s, tmp_path / "x.json")
    assert load_structure(tmp_path / "x.json") == s


@pytest.mark.parametrize("extent", [[0, 1, 1], [1, 1], [100, 100, 100], "a,b,c", [1.5, 2, 2]])
def test_bad_extents(extent):
    with pytest.raises(InputError, match="extent"):
        Extent.parse(extent)
