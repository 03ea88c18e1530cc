"""``unseeable experiment``: the paper's experiments from the command line."""

import json

import pytest

from unseeable.cli import main


def run(capsys, *args):
    code = main(list(map(str, args)))
    out, err = capsys.readouterr()
    return code, out, err


def test_both_experiments_print_what_their_tables_hold(capsys, tiny_corpus, tmp_path):
    out_dir = tmp_path / "results"
    code, out, err = run(capsys, "experiment", "visibility", "--corpus", tiny_corpus,
                         "--known-pose", "--workers", 1, "--out", out_dir)
    assert code == 0, err
    table = json.loads((out_dir / "visibility.json").read_text())
    assert f"images: {table['evaluated']} of {table['images']} evaluated" in out
    assert (f"mean errors: manual {table['mean_errors_manual']:.2f}, "
            f"automatic {table['mean_errors_automatic']:.2f}") in out
    assert (out_dir / "visibility.png").exists()
    # The confidence experiment reads the same per-image records from the cache.
    code, out, err = run(capsys, "experiment", "confidence", "--corpus", tiny_corpus,
                         "--known-pose", "--workers", 1, "--out", out_dir)
    assert code == 0, err
    conf = json.loads((out_dir / "confidence.json").read_text())
    assert (f"false positives (confident, wrong): {conf['false_positives']}; "
            f"false negatives (not confident, right): {conf['false_negatives']}") in out
    assert (out_dir / "confidence.png").exists()


@pytest.mark.parametrize("experiment", ["visibility", "confidence"])
@pytest.mark.parametrize("option, value, needle", [
    ("--workers", 0, "workers: must be a whole number >= 1 (got 0)"),
    ("--corpus", "missing-corpus", "corpus.json: no such file"),
    ("--ties", "fullest", "ties: must be one of ['any', 'emptiest', 'fewest'] (got 'fullest')"),
    ("--calibration", "no-such-calibration.json", "no-such-calibration.json: no such file"),
])
def test_bad_input_is_one_line_and_writes_nothing(capsys, tiny_corpus, tmp_path, experiment,
                                                  option, value, needle):
    args = {"--corpus": tiny_corpus, "--workers": 1, "--out": tmp_path / "results"}
    args[option] = tmp_path / value if option == "--corpus" else value
    code, out, err = run(capsys, "experiment", experiment,
                         *[x for pair in args.items() for x in pair])
    assert code == 1 and out == ""
    assert err.startswith("error: ") and err.strip().splitlines() == [err.strip()]
    assert needle in err
    assert not (tmp_path / "results").exists()


def test_the_commands_default_to_the_pipelines_tie_policy():
    from unseeable.cli.options import PRIOR, TIES
    from unseeable.grammar.priors import TIE_POLICY
    from unseeable.pipeline import EstimateSettings

    settings = EstimateSettings.from_options(prior=PRIOR.default, ties=TIES.default)
    assert settings.prior.ties == TIE_POLICY and settings == EstimateSettings()


def test_the_active_experiment_prints_what_its_table_holds(capsys, tower_corpus, tmp_path):
    out_dir = tmp_path / "results"
    code, out, err = run(capsys, "experiment", "active", "--corpus", tower_corpus,
                         "--known-pose", "--workers", 1, "--starts", 1, "--max-actions", 1,
                         "--no-robot", "--out", out_dir)
    assert code == 0, err
    table = json.loads((out_dir / "active.json").read_text())
    assert f"starting images: {table['images']} of {table['structures']} structures" in out
    assert f"baseline {table['mean_errors']['baseline']:.2f}" in out
    for process, actions in table["actions_per_image"].items():
        assert f"{process} {actions:.2f}" in out
        assert actions <= 1  # --max-actions
    assert "robot:" not in out  # --no-robot
    assert (out_dir / "active.png").exists()


def test_the_active_experiment_refuses_a_negative_number_of_actions(capsys, tiny_corpus,
                                                                    tmp_path):
    code, out, err = run(capsys, "experiment", "active", "--corpus", tiny_corpus,
                         "--max-actions", -1, "--out", tmp_path / "results")
    assert code == 1 and out == ""
    assert err.strip() == "error: --max-actions: must be >= 0 (got -1)"
    assert not (tmp_path / "results").exists()
