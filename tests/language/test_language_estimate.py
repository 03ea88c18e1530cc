"""Descriptions as evidence: synthetic estimates, photographs, and the commands."""

from __future__ import annotations

import json

import pytest

from unseeable.corpus import load_design
from unseeable.domain import save_structure, simulate_evidence
from unseeable.evaluate.metric import compare_structures
from unseeable.grammar.shapes import holds
from unseeable.language import (
    chosen_placements,
    compile_description,
    describe,
    estimate_with_description,
    parse,
)
from unseeable.pipeline import EstimateSettings, Observation, estimate_evidence


@pytest.mark.parametrize("name", ["wall-door", "wall-window", "tower-window"])
def test_the_true_description_never_makes_a_synthetic_estimate_worse(name):
    truth = load_design(name).structure
    psi = compile_description(describe(truth), truth.extent)
    settings = EstimateSettings().replace(enabled=False)
    alone, described = [], []
    for seed in range(4):
        evidence = simulate_evidence(truth, accuracy=0.8, occluded_fraction=0.5, seed=seed)
        alone.append(compare_structures(truth, estimate_evidence(evidence, settings).structure)
                     .errors)
        est = estimate_evidence(evidence, settings, constraints=psi)
        described.append(compare_structures(truth, est.structure).errors)
    assert all(d <= a for d, a in zip(described, alone)), (alone, described)
    assert sum(described) < sum(alone)


@pytest.fixture(scope="module")
def wall_door_view(tiny_corpus):
    from unseeable.corpus import load_corpus
    from unseeable.render.view import load_truth, load_view

    item = load_corpus(tiny_corpus)["wall-door"]
    v = item.views[0]
    return load_view(v.view), load_truth(v.truth)


@pytest.mark.parametrize("known_pose", [True, False])
def test_a_photograph_and_a_description_estimate_together(wall_door_view, known_pose):
    view, truth = wall_door_view
    settings = EstimateSettings().replace(enabled=False)
    d = parse("a door")
    obs = Observation.of(view, use_recorded_pose=known_pose)
    est = estimate_with_description([obs], d, settings)
    door = chosen_placements(d, (), est.result.choices)["door"]
    assert holds(door, est.structure)


def test_a_description_no_structure_satisfies_is_named(wall_door_view):
    from unseeable.language import UnsatisfiableError

    view, _ = wall_door_view
    with pytest.raises(UnsatisfiableError, match="4×6×1 grid satisfies: door left of door$"):
        estimate_with_description([Observation.of(view)], "a door. door left of door",
                                  EstimateSettings().replace(enabled=False))


def _run(capsys, *args):
    import unseeable.cli.language  # noqa: F401 - registers the commands
    from unseeable.cli import main

    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


def test_describe_prints_the_sentences(capsys, tmp_path):
    s = load_design("cabin-door-window").structure
    save_structure(s, tmp_path / "s.json")
    code, out, err = _run(capsys, "describe", tmp_path / "s.json")
    assert code == 0, err
    assert out.splitlines() == describe(s)


def test_describe_with_a_view_sees_left_and_right_from_its_camera(capsys, tiny_corpus,
                                                                  wall_door_view):
    from unseeable.language import Viewpoint

    view, truth = wall_door_view
    code, out, err = _run(capsys, "describe", tiny_corpus / "wall-door" / "structure.json",
                          "--view", view.image_path.with_suffix(".json"))
    assert code == 0, err
    assert out.splitlines() == describe(truth.structure,
                                        viewpoint=Viewpoint.from_view(view))


def test_describe_of_a_bad_file_is_one_line(capsys, tmp_path):
    (tmp_path / "s.json").write_text("{}")
    code, out, err = _run(capsys, "describe", tmp_path / "s.json")
    assert code == 1 and len(err.strip().splitlines()) == 1


def test_the_language_experiment_writes_its_tables(capsys, tiny_corpus, tmp_path):
    code, out, err = _run(capsys, "experiment", "language", "--corpus", tiny_corpus,
                          "--out", tmp_path, "--known-pose", "--workers", "1", "--no-figure")
    assert code == 0, err
    table = json.loads((tmp_path / "language.json").read_text())
    assert table["evaluated"] == 2 and table["known_pose"] is True
    assert table["mean_errors_with"] <= table["mean_errors_without"]
    assert (tmp_path / "language.png").stat().st_size > 0
    record = json.loads((tmp_path / "language" / "wall-door" / "view120.json").read_text())
    assert record["sentences"] and "door" in record["placed"]
