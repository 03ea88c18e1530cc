"""describe(): the true sentences of a structure, and the round trip through the compiler."""

from __future__ import annotations

import numpy as np
import pytest

from unseeable.camera import Camera
from unseeable.corpus import design_names, load_design
from unseeable.domain import Extent, Log, Structure
from unseeable.grammar.expr import And, Occ, evaluate
from unseeable.language import (
    Viewpoint,
    choice_values,
    compile_description,
    describe,
    described_placements,
    parse,
    satisfying_placements,
)
from unseeable.solve import SolveStatus, StructureSolver


def _camera_for(entry, angle_deg: float) -> Camera:
    """A camera 1.2 m from the assembly's middle, 0.8 m up, at ``angle_deg`` round it."""
    s = entry.structure
    middle = entry.pose.grid_to_world(np.array([(s.extent.I - 1) * 32.0, 0.0,
                                                (s.extent.K - 1) * 32.0]))
    a = np.deg2rad(angle_deg)
    eye = middle + np.array([1200 * np.cos(a), 800.0, -1200 * np.sin(a)])
    return Camera.look_at(eye=eye, target=middle, width=640, height=480, fov_deg=45)


@pytest.mark.parametrize("name", design_names())
def test_every_corpus_design_satisfies_its_own_description(name):
    entry = load_design(name)
    s = entry.structure
    for viewpoint in (None, Viewpoint.from_camera(_camera_for(entry, 90.0), entry.pose)):
        sentences = describe(s, viewpoint=viewpoint)
        assert sentences == sorted(sentences, key=len)
        assert sentences, "every corpus design has a wall at least"
        psi = compile_description(sentences, s.extent, viewpoint=viewpoint)
        placed = described_placements(s, viewpoint=viewpoint)
        assert bool(evaluate(And(*psi), s.occupancy, choice_values(psi, placed)))
        assert satisfying_placements(sentences, s, viewpoint=viewpoint) is not None


@pytest.mark.parametrize("name", ["wall-window", "cabin-door-window", "lodge"])
def test_the_solver_finds_the_truth_among_the_structures_its_description_allows(name):
    entry = load_design(name)
    s = entry.structure
    viewpoint = Viewpoint.from_camera(_camera_for(entry, 120.0), entry.pose)
    psi = compile_description(describe(s, viewpoint=viewpoint), s.extent, viewpoint=viewpoint)
    forced = [Occ(q, {int(s.occupancy[q])}) for q in s.extent.iter_positions()]
    result = StructureSolver(s.extent, constraints=[*psi, *forced]).solve([])
    assert result.status == SolveStatus.OPTIMAL and result.structure == s


def test_describe_names_the_relations_that_hold():
    entry = load_design("cabin-door-window")  # a door along i, a window along k
    sentences = describe(entry.structure)
    assert {"a door", "a window", "a wall"} <= set(sentences)
    (window_door,) = [t for t in sentences if t.startswith("window") and t.endswith("door")]
    assert "perpendicular to" in window_door
    assert ("left of" in window_door) != ("right of" in window_door)


def test_left_and_right_are_as_the_camera_sees_them():
    """The sentence's left/right agrees with the entities' image x coordinates."""
    entry = load_design("cabin-door-window")
    s = entry.structure
    seen = set()
    for angle in (60.0, 90.0, 150.0, 200.0):
        camera = _camera_for(entry, angle)
        viewpoint = Viewpoint.from_camera(camera, entry.pose)
        placed = described_placements(s, viewpoint=viewpoint)
        xs = {}
        for kind in ("door", "window"):
            p = placed[kind]
            column = np.array([p.point(t, j) for j in p.layers for t in p.positions], float)
            xs[kind] = camera.project(viewpoint.world_points(column))[:, 0]
        (sentence,) = [t for t in describe(s, viewpoint=viewpoint)
                       if t.startswith("window") and t.endswith("door")]
        if "left of" in sentence:
            seen.add("left")
            assert xs["window"].max() < xs["door"].min(), angle
        elif "right of" in sentence:
            seen.add("right")
            assert xs["window"].min() > xs["door"].max(), angle
    assert seen == {"left", "right"}


def test_a_structure_without_shapes_has_no_sentences():
    assert describe(Structure(Extent(3, 1, 3), [Log(0, (0, 0), 3)])) == []


def test_a_gap_one_log_high_is_no_door():
    from unseeable.grammar.shapes import find_shapes

    logs = [Log(layer=j, at=(i, 0), notches=1) for j in (0, 1) for i in (0, 2)]
    s = Structure(Extent(3, 3, 1), [*logs, Log(layer=2, at=(0, 0), notches=3)])
    assert find_shapes(s, "door")  # the shape holds ...
    assert describe(s) == []  # ... but the word does not name it


def test_describe_speaks_of_one_window_when_there_are_two():
    """A noun names one thing in a description, so of two windows one is described."""
    s = load_design("lodge").structure  # one door, two windows
    sentences = describe(s)
    assert sum(t == "a window" for t in sentences) == 1
    assert satisfying_placements(parse(sentences), s) is not None
