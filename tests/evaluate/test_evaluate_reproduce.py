"""The paper reproduced in one run (unseeable.evaluate.reproduce) and its report
(unseeable.report.paper)."""

import json
import re
from dataclasses import replace

import pytest

import unseeable.executor
from unseeable.errors import InputError
from unseeable.evaluate import reproduce as module
from unseeable.evaluate.reproduce import QUICK, STAGES, reproduce
from unseeable.report.paper import PAPER_CLAIMS, PAPER_NUMBERS, within

#: Smaller than --quick, for a test: the same designs (every stage has work) at two
#: stations, 4 samples per pixel, the recorded poses, one action, no robot.
TINY = replace(QUICK, name="tiny", angles=(120.0, 150.0), spp=4, known_pose=True,
               max_actions=1, robot=False)

SECTIONS = ["## Headline", "## Run", "### Stage times", "## Visibility: manual vs automatic",
            "## Confidence (δ* = 0.2)", "## Several views and partial disassembly",
            "## Active vision", "## Language", "## Showcase: one estimate in 3-D", "## Files"]


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("reproduce") / "report"
    reports = []
    rep = reproduce(out, settings=TINY, workers=1,
                    progress=lambda stage, done, total: reports.append((stage, done, total)))
    return rep, reports


@pytest.mark.slow
def test_a_run_writes_the_report_with_every_section(run):
    rep, _ = run
    md = rep.files["markdown"].read_text()
    positions = [md.find(s) for s in SECTIONS]
    assert -1 not in positions and positions == sorted(positions)
    assert [s.name for s in rep.stages] == list(STAGES)
    for stage in rep.stages:  # each stage's wall time, as the report rounds it
        assert re.search(rf"\| {re.escape(stage.title)} \| [\d.]+ s \|", md), stage.name
    assert "unseeable 0.1" in md and "CPUs" in md and "load average" in md
    assert "320×240, 4 samples per pixel" in md and "cabin-door, cabin-door-L3" in md


@pytest.mark.slow
def test_the_reports_numbers_are_the_experiment_functions_tables(run):
    rep, _ = run
    md = rep.files["markdown"].read_text()
    figures = rep.out / "figures"
    data = json.loads(rep.files["json"].read_text())
    for stage in data["stages"]:  # the tables the experiment functions wrote and returned
        for name, table in stage["tables"].items():
            if (figures / f"{name}.json").is_file():
                assert json.loads((figures / f"{name}.json").read_text()) == table
    vis = rep.stage("visibility").tables["visibility"]
    assert (f"| mean errors | – | {vis['mean_errors_automatic']:.2f} | "
            f"{vis['mean_errors_manual']:.2f} |") in md
    assert f"| within 12 errors | 100 % | {100 * within(vis['automatic']):.0f} % |" in md
    conf = rep.stage("confidence").tables["confidence"]
    assert f"| false positives (confident, wrong) | 3 | {conf['false_positives']} |" in md
    assert f"| false negatives (not confident, right) | 7 | {conf['false_negatives']} " in md
    views = rep.stage("views").tables["views"]
    assert "| mean errors | " + " | ".join(f"{m:.2f}" for m in views["mean_errors"].values()) \
        in md
    active = rep.stage("active").tables["active"]
    for process in ("baseline", "views", "disassembly", "combined"):
        assert f"| {process} | {active['mean_errors'][process]:.2f} |" in md
    lang = rep.stage("language").tables["language"]
    assert (f"| mean errors | {lang['mean_errors_without']:.2f} | "
            f"{lang['mean_errors_with']:.2f} |") in md
    # The published numbers stand beside ours, quoted.
    for key in ("visibility", "confidence", "active_images"):
        assert PAPER_CLAIMS[key].quote in md


@pytest.mark.slow
def test_the_html_report_is_self_contained(run):
    rep, _ = run
    page = rep.files["html"].read_text()
    assert "http://" not in page and "https://" not in page and "<script src" not in page
    figures = [f for s in rep.stages for f in s.figures if f.endswith(".png")]
    assert figures and page.count('src="data:image/png;base64,') == len(figures)
    assert "<iframe" in page and "srcdoc=" in page  # the showcase's 3-D page, inline
    for heading in SECTIONS:
        assert f">{heading.lstrip('#').strip()}</h" in page


@pytest.mark.slow
def test_every_stage_reports_its_progress_to_the_end(run):
    rep, reports = run
    finished = {stage: (done, total) for stage, done, total in reports}
    assert list(finished) == list(STAGES)
    assert all(done == total for done, total in finished.values())


@pytest.mark.slow
def test_a_rerun_reads_the_corpus_and_the_records_back(run, tmp_path):
    rep, _ = run
    again = reproduce(tmp_path / "again", settings=TINY, corpus=rep.corpus, workers=1)
    assert again.stage("corpus").tables["corpus"]["rendered"] == 0
    for name in ("visibility", "confidence", "views", "active", "language"):
        assert again.stage(name).tables == rep.stage(name).tables, name


@pytest.mark.slow
def test_a_stage_that_fails_leaves_no_report_but_keeps_the_caches(run, tmp_path, monkeypatch):
    rep, _ = run
    import unseeable.evaluate.views

    def broken(*args, **kwargs):
        raise InputError("broken on purpose", field="views")

    monkeypatch.setattr(unseeable.evaluate.views, "evaluate_views", broken)
    out = tmp_path / "report"
    with pytest.raises(InputError, match="broken on purpose"):
        reproduce(out, settings=TINY, corpus=rep.corpus, workers=1)
    assert not out.exists()
    assert (rep.corpus / "corpus.json").is_file()


def test_an_output_folder_that_is_a_file_is_refused_before_any_work(tmp_path):
    out = tmp_path / "report"
    out.write_text("a file")
    with pytest.raises(InputError, match="--out: is a file"):
        reproduce(out, settings=TINY, workers=1)
    assert out.read_text() == "a file"


def test_a_corpus_of_an_older_version_is_refused_before_any_work(tmp_path):
    corpus = tmp_path / "corpus"
    corpus.mkdir()
    (corpus / "corpus.json").write_text(json.dumps({"format": "unseeable/corpus@0"}))
    out = tmp_path / "report"
    with pytest.raises(InputError, match=r"--corpus: holds a corpus of another version "
                                          r"\(format 'unseeable/corpus@0'"):
        reproduce(out, settings=TINY, corpus=corpus, workers=1)
    assert not out.exists() and sorted(p.name for p in corpus.iterdir()) == ["corpus.json"]


def test_a_corpus_of_other_render_settings_is_not_rendered_over(tmp_path):
    corpus = tmp_path / "corpus"
    corpus.mkdir()
    render = {"angles": [90.0, 120.0, 150.0, 180.0, 210.0], "width": 640, "height": 480,
              "spp": 24, "seed": 0, "randomise": False}
    (corpus / "corpus.json").write_text(json.dumps({"format": "unseeable/corpus@1",
                                                    "render": render, "entries": []}))
    with pytest.raises(InputError, match=r"--corpus: was rendered with other settings "
                                          r"\(640x480, 24 spp"):
        reproduce(tmp_path / "report", settings=TINY, corpus=corpus, workers=1)
    assert not (tmp_path / "report").exists()


def test_an_unreachable_scheduler_is_refused_before_any_work(tmp_path, monkeypatch):
    import socket

    monkeypatch.setattr(unseeable.executor, "CONNECT_TIMEOUT", 1.0)
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    out = tmp_path / "report"
    with pytest.raises(InputError, match="--scheduler: no Dask scheduler answered"):
        reproduce(out, settings=TINY, scheduler=f"tcp://127.0.0.1:{port}")
    assert not out.exists()


def test_quick_gives_every_stage_work():
    from unseeable.corpus import list_designs
    from unseeable.grammar.shapes import find_shapes

    designs = {e.name: e for e in list_designs()}
    assert set(QUICK.designs) <= set(designs)
    # A structure and its removal subset (active vision, disassembly pairs) ...
    assert any(other in QUICK.designs for name in QUICK.designs
               for other in designs[name].contains)
    # ... and a door or a window (the language stage).
    assert any(find_shapes(designs[name].structure, ("door", "window"))
               for name in QUICK.designs)
    assert QUICK.starts == 1 and QUICK.max_actions == 2 and len(QUICK.angles) == 3
    assert QUICK.robot_start in QUICK.angles


def test_the_full_run_uses_the_experiment_commands_defaults():
    import inspect

    from unseeable.cli.active import experiment_active
    from unseeable.cli.corpus import build_command
    from unseeable.cli.experiment import views
    from unseeable.evaluate.experiments import EvaluationSettings
    from unseeable.pipeline import EstimateSettings

    def default(command, name):
        return inspect.signature(command).parameters[name].default.default

    full = module.FULL
    assert full.designs is None and default(build_command, "only") is None
    assert ",".join(f"{a:g}" for a in full.angles) == default(build_command, "angles")
    assert f"{full.size[0]}x{full.size[1]}" == default(build_command, "size")
    assert full.spp == default(build_command, "spp") and full.seed == default(build_command,
                                                                               "seed")
    # Several views from one seeded start per structure (each start holds 1 to 5 views),
    # active vision from every start, as the commands do with --starts 1 and by default.
    assert full.view_starts == 1 and default(views, "starts") is None
    assert full.starts is None and default(experiment_active, "starts") is None
    assert full.max_actions == default(experiment_active, "max_actions")
    assert full.robot is default(experiment_active, "robot")
    assert full.robot_start == default(experiment_active, "robot_start")
    # The same records as `unseeable experiment visibility --corpus C` (shared cache).
    command = EvaluationSettings(
        estimate=EstimateSettings.from_options(time_limit=30.0, prior="builder",
                                               backend="cpsat", calibration=None, ties=None,
                                               joint_cost=None, stacked_joint_cost=None,
                                               unsupported_notch_cost=None),
        known_pose=False)
    assert full.evaluation().digest() == command.digest()


def test_the_code_version_falls_back_to_the_package_version(monkeypatch):
    import subprocess

    import unseeable

    def no_git(*args, **kwargs):
        raise FileNotFoundError("git")

    monkeypatch.setattr(subprocess, "run", no_git)
    version = module.code_version()
    assert version == {"package": unseeable.__version__, "describe": None, "commit": None}
    host = module.machine()
    assert host["cpus"] >= 1 and host["platform"] and host["python"]


def test_the_papers_numbers_are_those_of_its_sentences():
    text = " ".join(c.quote for c in PAPER_CLAIMS.values())
    for key in ("images", "visibility_images", "false_positives", "false_negatives",
                "active_images"):
        assert re.search(rf"\b{PAPER_NUMBERS[key]}\b", text), key
    assert "3/105" in text and "7/105" in text and "100%" in text
