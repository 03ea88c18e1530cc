"""The experiment drivers end to end on a tiny rendered corpus."""

import json

import pytest

from unseeable.evaluate.experiments import (
    EvaluationSettings,
    confidence_experiment,
    evaluate_corpus,
    visibility_experiment,
)
from unseeable.pipeline import EstimateSettings

EXPERIMENTS = EvaluationSettings().estimate  # the experiments' estimator


def _with(**options) -> EvaluationSettings:
    """Evaluation settings, pose known, with some fields of the estimator's changed."""
    return EvaluationSettings(estimate=EXPERIMENTS.replace(**options), known_pose=True)


def test_experiments_write_tables_and_plots(tiny_corpus, tmp_path):
    settings = EvaluationSettings(known_pose=True)
    seen = []
    records = evaluate_corpus(tiny_corpus, tmp_path, settings=settings, workers=1,
                              progress=lambda done, total: seen.append((done, total)))
    assert len(records) == 2 and seen[-1] == (2, 2)
    for r in records:
        assert r["failed"] is None
        assert r["errors_auto"] >= 0 and r["errors_manual"] >= 0
        # The kinds of errors add up to the paper's count.
        assert sum(r["errors_auto_by_kind"].values()) == r["errors_auto"]
        assert sum(r["errors_manual_by_kind"].values()) == r["errors_manual"]
        assert r["iterations"] >= 1
        assert 0 <= r["tolerance"] <= 0.5
    table = visibility_experiment(records, tmp_path)
    assert table["t"][0] == 0 and table["automatic"][-1] == 1.0
    assert sum(table["errors_by_kind"]["automatic"].values()) == sum(
        r["errors_auto"] for r in records)
    assert (tmp_path / "visibility.png").stat().st_size > 1000
    conf = confidence_experiment(records, tmp_path)
    assert conf["false_positives"] + conf["true_positives"] == conf["confident"]
    assert json.loads((tmp_path / "confidence.json").read_text())["images"] == 2
    assert all(r["delta_star"] == settings.estimate.confidence.delta_star for r in records)
    # A second run reads every image from the cache.
    again = evaluate_corpus(tiny_corpus, tmp_path, settings=settings, workers=1)
    assert [r["errors_auto"] for r in again] == [r["errors_auto"] for r in records]


def test_records_of_another_estimator_revision_are_not_reused(monkeypatch):
    import unseeable.evaluate.experiments as ex

    settings = EvaluationSettings(known_pose=True)
    before = settings.digest()
    assert before == EvaluationSettings(known_pose=True).digest()
    assert before != _with(background=False).digest()
    assert before != _with(ties="emptiest").digest()
    assert before != _with(lines_once=False).digest()
    assert before != EvaluationSettings().digest()  # the pose estimated
    monkeypatch.setattr(ex, "ESTIMATOR_REVISION", ex.ESTIMATOR_REVISION + " and more")
    assert settings.digest() != before


def test_a_calibration_file_keys_the_records_by_its_contents(tmp_path):
    import shutil

    from unseeable.errors import InputError
    from unseeable.vision import default_calibration, save_calibration
    from unseeable.vision.calibration import Calibration

    cal = default_calibration()
    save_calibration(Calibration(cal.models, (0.3, 0.7), cal.info, cal.pose_quality,
                                 cal.context_models), tmp_path / "timid.json")
    (tmp_path / "elsewhere").mkdir()
    shutil.copy(tmp_path / "timid.json", tmp_path / "elsewhere" / "copy.json")
    timid = _with(calibration=str(tmp_path / "timid.json"))
    assert timid.estimate.detection.calibration == str((tmp_path / "timid.json").absolute())
    # Where the file lies does not matter, what it holds does.
    assert timid.digest() == _with(calibration=str(tmp_path / "elsewhere" / "copy.json")).digest()
    assert timid.digest() != EvaluationSettings(known_pose=True).digest()
    with pytest.raises(InputError, match="none.json"):
        _with(calibration=str(tmp_path / "none.json"))


def test_only_cycles_are_counted_as_cycles(tmp_path):
    # A fixpoint stopped by the cap on estimates or the time budget did not settle, but it
    # did not cycle either.
    def record(converged, cycle_length):
        return {"name": "x", "angle": 90.0, "failed": None, "errors_manual": 1,
                "errors_auto": 2, "iterations": 3, "converged": converged,
                "errors_manual_by_kind": {"split": 1, "extra": 0, "missing": 0, "mixed": 0},
                "errors_auto_by_kind": {"split": 1, "extra": 1, "missing": 0, "mixed": 0},
                "cycle_length": cycle_length, "visibility_agreement": 0.99, "seconds": 0.1}

    records = [record(True, 0), record(False, 2), record(False, 0)]
    assert visibility_experiment(records, tmp_path)["cycles"] == 1


def test_false_negatives_at_tolerance_zero_are_counted_as_exact_ties(tmp_path):
    # Right but not confident: at tolerance 0 another structure is as probable (a tie);
    # above it, but under δ*, the evidence merely left too little margin.
    def record(errors, confident, tolerance):
        return {"name": "x", "angle": 90.0, "failed": None, "errors_auto": errors,
                "confident": confident, "tolerance": tolerance, "delta_star": 0.2}

    records = [record(0, False, 0.0), record(0, False, 0.0), record(0, False, 0.13),
               record(3, False, 0.0), record(0, True, 0.31), record(2, True, 0.25),
               record(0, False, None)]
    table = confidence_experiment(records, tmp_path)
    assert (table["false_negatives"], table["false_negatives_exact_ties"]) == (4, 2)
    assert table["false_positives"] == 1
    assert json.loads((tmp_path / "confidence.json").read_text())[
        "false_negatives_exact_ties"] == 2


def test_the_settings_default_to_the_shipped_estimator_with_a_30_s_solve_limit():
    from unseeable.errors import InputError

    assert EvaluationSettings().estimate == EstimateSettings().replace(time_limit=30.0)
    # another prior is another estimator: its records are kept apart
    for cost in ("joint_cost", "stacked_joint_cost", "unsupported_notch_cost"):
        assert _with(**{cost: 0}).digest() != _with().digest()
        with pytest.raises(InputError, match=cost):
            _with(**{cost: -1.0})
    with pytest.raises(InputError, match="ties"):
        _with(ties="fullest")
    with pytest.raises(InputError, match="estimate"):
        EvaluationSettings(estimate="builder")
