"""The active-vision experiment on a corpus (unseeable.evaluate.active)."""

import json

import pytest

from unseeable.errors import InputError
from unseeable.evaluate.active import (
    PROCESSES,
    active_experiment,
    active_jobs,
    evaluate_active,
    robot_jobs,
)
from unseeable.evaluate.experiments import EvaluationSettings


def _record(name, start, baseline, **processes):
    rec = {"name": name, "start": start, "failed": None,
           "baseline": {"errors": baseline[0], "confident": baseline[1], "structure": None}}
    for p in PROCESSES:
        errors, confident = processes[p]
        rec[p] = {"errors": errors, "confident": confident, "stopped": "confident"
                  if confident else "nothing to learn", "actions": 1, "seconds": 1.0,
                  "structure": None,
                  "steps": [{"solves": None}, {"solves": 2, "groups": 3, "delta_low": 0.1}]}
    return rec


def test_the_summary_counts_errors_confident_wrong_and_each_structures_worst(tmp_path):
    records = [
        _record("a", 90.0, (3, False), views=(0, True), disassembly=(1, True),
                combined=(0, True)),
        _record("a", 150.0, (1, False), views=(2, False), disassembly=(1, False),
                combined=(3, False)),
        _record("b", 90.0, (0, True), views=(0, True), disassembly=(0, True),
                combined=(0, True)),
    ]
    table = active_experiment(records, [], tmp_path)
    assert table["images"] == 3 and table["structures"] == 2
    assert table["mean_errors"]["baseline"] == pytest.approx(4 / 3)
    assert table["confident_wrong"] == {"baseline": 0, "views": 0, "disassembly": 1,
                                        "combined": 0}
    assert table["combined_errors_by_structure"] == {"a": 3, "b": 0}
    assert table["combined_structures_within_2"] == 1
    assert table["search_solves"]["views"] == 6
    assert json.loads((tmp_path / "active.json").read_text())["images"] == 3
    assert (tmp_path / "active.png").is_file()


def test_a_corpus_without_removal_subsets_has_no_starting_image(tiny_corpus, tmp_path):
    with pytest.raises(InputError, match="removal subset"):
        active_jobs(tiny_corpus, tmp_path)
    jobs = robot_jobs(tiny_corpus, tmp_path, start=120.0)
    assert [j.name for j in jobs] == ["wall-door"] and jobs[0].stations == (120.0, 150.0)
    # The robot starts from the corpus's own photograph of that station, when it has one.
    assert jobs[0].view == str(tiny_corpus / "wall-door" / "view120.json")
    assert robot_jobs(tiny_corpus, tmp_path, start=135.0)[0].view is None


@pytest.mark.slow
def test_the_robot_loop_starts_from_the_corpus_photograph_and_acts(tiny_corpus, tmp_path):
    from unseeable.evaluate.active import evaluate_robot_job
    from unseeable.evaluate.experiments import EvaluationSettings

    job = robot_jobs(tiny_corpus, tmp_path, start=120.0, max_actions=1)[0]
    record = evaluate_robot_job(job, EvaluationSettings(known_pose=True))
    assert record["failed"] is None
    assert len(record["steps"]) in (1, 2) and record["steps"][0]["action"] is None
    assert record["stopped"] in ("confident", "max actions", "nothing to learn")
    assert record["errors"] == record["steps"][-1]["errors"] >= 0


@pytest.mark.slow
def test_the_experiment_runs_every_process_from_every_start_and_draws_fig_results(
        tower_corpus, tmp_path):
    jobs = active_jobs(tower_corpus, tmp_path)
    assert [(j.name, len(j.candidates["views"]), len(j.candidates["disassembly"]),
             len(j.candidates["combined"])) for j in jobs] == [("tower-3", 1, 1, 3)] * 2
    settings = EvaluationSettings(known_pose=True)
    records, robots = evaluate_active(tower_corpus, tmp_path, settings=settings, workers=1,
                                      starts=1, max_actions=2, robot=False)
    assert robots == [] and len(records) == 1 and records[0]["failed"] is None
    rec = records[0]
    for p in PROCESSES:
        assert rec[p]["actions"] <= 2 and rec[p]["stopped"] in (
            "confident", "nothing to learn", "max actions", "no actions")
        assert rec[p]["confident"] is False or rec[p]["errors"] == 0
    table = active_experiment(records, robots, tmp_path)
    assert (tmp_path / "results.png").is_file() and table["results_figure"]["name"] == "tower-3"
    # Cached: the second run reads the record back.
    again, _ = evaluate_active(tower_corpus, tmp_path, settings=settings, workers=1, starts=1,
                               max_actions=2, robot=False)
    assert again == records
