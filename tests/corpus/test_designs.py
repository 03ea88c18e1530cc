"""The shipped corpus designs: valid, distinct, related as documented, as generated."""

import itertools
import json
import shutil
from collections import Counter

import numpy as np
import pytest

from unseeable.corpus import (
    is_proper_subset,
    list_designs,
    load_design,
    physical_logs,
    truncation_layer,
)
from unseeable.corpus.designs import designs, stale_corpus_files, write_corpus_files
from unseeable.corpus.designs_index import DATA_DIR, read_index
from unseeable.domain import (
    Extent,
    GridPose,
    LogGeometry,
    half_turn_structure,
    is_valid,
    structure_to_json,
)
from unseeable.errors import InputError
from unseeable.grammar.shapes import find_shapes


@pytest.fixture(scope="module")
def entries():
    return list_designs()


def test_there_are_32_valid_designs_with_unique_names(entries):
    assert len(entries) == 32
    assert len({e.name for e in entries}) == 32
    for e in entries:
        assert is_valid(e.structure), e.name
        assert len(e.structure) > 0
        assert e.description and "\n" not in e.description


def test_designs_are_pairwise_distinct_even_half_turned(entries):
    seen = {}
    for e in entries:
        for s in (e.structure, half_turn_structure(e.structure)):
            key = (s.extent, s.logs)
            assert key not in seen or seen[key] == e.name, (e.name, seen.get(key))
            seen[key] = e.name


def test_sizes_are_realistic(entries):
    for e in entries:
        ext = e.structure.extent
        assert ext.I <= 6 and ext.J <= 8 and ext.K <= 6, e.name
        assert ext.J >= 3, e.name
        # the extent is tight: something on its top layer and at its far sides
        z = e.structure.occupancy
        assert z[:, -1, :].any() and z[-1].any() and z[:, :, -1].any(), e.name
    layers = Counter(e.structure.extent.J for e in entries)
    assert sum(n for j, n in layers.items() if 4 <= j <= 7) >= 20
    assert max(e.structure.extent.positions for e in entries) == 6 * 8 * 6
    notches = Counter(log.notches for e in entries for log in e.structure.logs)
    assert all(notches[m] >= 50 for m in (1, 2, 3)), notches
    mixed = sum(len({log.notches for log in e.structure.logs}) == 3 for e in entries)
    assert mixed >= 20


def test_poses_are_varied_and_near_the_table_centre(entries):
    geometry = LogGeometry()
    yaws = {e.pose.yaw_deg for e in entries}
    assert len(yaws) >= 10 and yaws != {0.0}
    for e in entries:
        ext = e.structure.extent
        centre = np.array([(ext.I - 1) * geometry.l1 / 2, 0, (ext.K - 1) * geometry.l1 / 2])
        world = e.pose.grid_to_world(centre)
        # a subset keeps its superset's placement, so its own centre may be off by a notch
        assert np.hypot(world[0], world[2]) < 30.0 + (geometry.l1 if e.subset_of else 0), e.name


def test_stored_subset_relations_are_the_computed_ones(entries):
    by_name = {e.name: e for e in entries}
    for a, b in itertools.permutations(entries, 2):
        related = is_proper_subset(a.structure, a.pose, b.structure, b.pose)
        assert related == (b.name in a.subset_of), (a.name, b.name)
        assert related == (a.name in b.contains), (a.name, b.name)
    # every relation is within one placement (the arm takes logs off, never moves them)
    for e in entries:
        for other in e.subset_of:
            assert by_name[other].pose == e.pose


def test_subset_pairs_include_truncations_and_inner_walls_removed(entries):
    by_name = {e.name: e for e in entries}
    truncations = [(a.name, b) for a in entries for b in a.subset_of
                   if truncation_layer(a.structure, by_name[b].structure) is not None]
    assert len(truncations) >= 4
    assert ("cabin-door-L3", "cabin-door") in truncations
    assert truncation_layer(by_name["lodge-L4"].structure, by_name["lodge"].structure) == 4
    # inner wall removed: same extent, and every removed log lies in the partition's plane
    for small, big, plane in (("cabin-partition-open", "cabin-partition", ("i", 2)),
                              ("hall-open", "hall", ("k", 2)),
                              ("lodge-open", "lodge", ("k", 3))):
        s, b = by_name[small].structure, by_name[big].structure
        assert big in by_name[small].subset_of
        assert s.extent == b.extent
        removed = set(b.logs) - set(s.logs)
        axis = 0 if plane[0] == "i" else 2
        assert removed and all(q[axis] == plane[1] for log in removed for q in log.positions())
    assert sum(len(e.subset_of) > 0 for e in entries) >= 12


def test_physical_comparison_ignores_how_the_grid_is_described():
    e = load_design("cabin-window")
    pose2, extent2 = e.pose.turned(2, e.structure.extent)
    turned = half_turn_structure(e.structure)
    assert extent2 == e.structure.extent
    assert physical_logs(turned, pose2) == physical_logs(e.structure, e.pose)
    small = load_design("cabin-window-L5")
    assert is_proper_subset(half_turn_structure(small.structure),
                            small.pose.turned(2, small.structure.extent)[0], e.structure, e.pose)
    # moved on the table: no longer a subset
    moved = GridPose(small.pose.x + 64.0, small.pose.z, small.pose.yaw_deg)
    assert not is_proper_subset(small.structure, moved, e.structure, e.pose)


def find_openings(structure):
    return find_shapes(structure, ("door", "window"))


def test_enough_designs_have_doors_or_windows(entries):
    with_openings = [e.name for e in entries if find_openings(e.structure)]
    assert len(with_openings) >= 6
    kinds = Counter(o.kind for e in entries for o in find_openings(e.structure))
    assert kinds["door"] >= 6 and kinds["window"] >= 5
    opening = {(o.kind, o.along, o.plane, o.at, o.bottom, o.top)
               for o in find_openings(load_design("cabin-door-window").structure)}
    assert opening == {("door", "i", 0, 2, 0, 3), ("window", "k", 0, 2, 2, 4)}


def test_shipped_files_equal_what_the_generator_writes(tmp_path):
    assert stale_corpus_files() == []
    # and the generator really rewrites them: a tampered copy is reported, then fixed
    copy = tmp_path / "corpus"
    shutil.copytree(DATA_DIR, copy)
    data = json.loads((copy / "wall-5.json").read_text())
    data["logs"].pop()
    (copy / "wall-5.json").write_text(json.dumps(data))
    (copy / "extra.json").write_text("{}")
    assert stale_corpus_files(copy) == ["wall-5.json", "extra.json"]
    write_corpus_files(copy)
    assert stale_corpus_files(copy) == []


def test_generated_designs_match_the_loaded_ones(entries):
    generated = designs()
    assert [d.name for d in generated] == [e.name for e in entries]
    for d, e in zip(generated, entries):
        assert d.structure == e.structure and d.pose == e.pose
        assert structure_to_json(d.structure) == json.loads(e.file.read_text())


def test_load_design_unknown_name_suggests_close_names():
    with pytest.raises(InputError, match="did you mean cabin-door"):
        load_design("cabin-dor")


def test_read_index_names_the_bad_field(tmp_path):
    shutil.copytree(DATA_DIR, tmp_path / "c")
    path = tmp_path / "c" / "index.json"
    data = json.loads(path.read_text())
    data["designs"][2]["contains"] = ["no-such-design"]
    path.write_text(json.dumps(data))
    with pytest.raises(InputError, match=r"designs\[2\]\.contains.*no-such-design"):
        read_index(tmp_path / "c")
    data["designs"][2]["contains"] = []
    data["designs"][3]["pose"] = {"x": 0.0, "z": "left", "yaw_deg": 0.0}
    path.write_text(json.dumps(data))
    with pytest.raises(InputError, match=r"pose\.z"):
        read_index(tmp_path / "c")


def test_extents_are_extent_objects(entries):
    assert all(isinstance(e.structure.extent, Extent) for e in entries)
