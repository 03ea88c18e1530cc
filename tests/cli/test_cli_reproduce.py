"""``unseeable reproduce``: one command, a report; bad input is one line and writes nothing."""

import json
import re
import socket
from dataclasses import replace

import pytest

import unseeable.executor
from unseeable.cli import main
from unseeable.evaluate import reproduce as module


def run(capsys, *args):
    code = main(list(map(str, args)))
    out, err = capsys.readouterr()
    return code, out, err


@pytest.mark.slow
def test_quick_prints_each_stages_time_and_writes_the_report(capsys, monkeypatch, tmp_path):
    # --quick made smaller still for a test: one design (no removal subset, no door: the
    # active-vision and language stages say why they did not run), two stations, the
    # recorded poses.
    tiny = replace(module.QUICK, designs=("cabin-door-L3",), angles=(120.0, 150.0), spp=4,
                   known_pose=True)
    monkeypatch.setattr(module, "QUICK", tiny)
    out = tmp_path / "report"
    docs = tmp_path / "docs"
    docs.mkdir()
    code, stdout, err = run(capsys, "reproduce", "--out", out, "--quick", "--workers", 1,
                            "--publish", docs / "results.md")
    assert code == 0, err
    lines = stdout.splitlines()
    assert lines[-2] == f"wrote {out / 'report.md'} and {out / 'report.html'}"
    assert lines[-1] == f"wrote {docs / 'results.md'}"
    data = json.loads((out / "report.json").read_text())
    for stage, line in zip(data["stages"], lines):
        assert line.startswith(f"{stage['title']}: {stage['seconds']:.1f} s")
    assert re.search(r"^active vision and the robot: [\d.]+ s \(not run: no structure with a "
                     r"removal subset", stdout, re.MULTILINE)
    assert (out / "corpus-quick" / "corpus.json").is_file()  # the corpus cache
    md = (out / "report.md").read_text()
    assert "## Visibility: manual vs automatic" in md and "## Showcase" in md
    assert data["settings"]["designs"] == ["cabin-door-L3"]
    # The published copy: the same report, its figures as JPEGs beside it, said generated.
    published = (docs / "results.md").read_text()
    assert published.splitlines()[0] == md.splitlines()[0]
    assert "not edited by hand" in published.splitlines()[2]
    figures = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", published)
    assert figures and len(figures) == len(re.findall(r"!\[[^\]]*\]\(([^)]+)\)", md))
    for figure in figures:
        assert figure.startswith("images/results/") and (docs / figure).stat().st_size > 0
    assert "](figures/" not in published and "](showcase/" not in published
    # The report written again from the run's report.json, running nothing: the same.
    (out / "report.md").unlink()
    code, stdout, err = run(capsys, "reproduce", "--out", out, "--report-only",
                            "--publish", docs / "again.md")
    assert code == 0, err
    assert (out / "report.md").read_text() == md
    assert (docs / "again.md").read_text() == published.replace("results.md", "again.md")


def unused_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.mark.parametrize("case, needle", [
    ("out is a file", "--out: is a file; give a folder"),
    ("older corpus", "--corpus: holds a corpus of another version (format "
                     "'unseeable/corpus@0'; this version reads 'unseeable/corpus@1')"),
    ("other corpus", "--corpus: was rendered with other settings (640x480, 24 spp, seed 0, "
                     "stations 90,120,150,180,210) than this run's (320x240, 8 spp, seed 0, "
                     "stations 120,150,180)"),
    ("unreachable scheduler", "--scheduler: no Dask scheduler answered there within 1 s"),
    ("no workers", "--workers: must be a whole number >= 1 (got 0)"),
    ("publish nowhere", "--publish: must be a file in an existing folder"),
    ("no run to report", "report.json: no such file"),
    ("broken report", "report.json: is not a finished run's report (no 'stages')"),
])
def test_bad_input_is_one_line_exit_1_and_no_report(capsys, monkeypatch, tmp_path, case,
                                                    needle):
    monkeypatch.setattr(unseeable.executor, "CONNECT_TIMEOUT", 1.0)
    out = tmp_path / "report"
    corpus = tmp_path / "corpus"
    args = ["reproduce", "--out", out, "--quick", "--workers", 1]
    if case == "out is a file":
        out.write_text("a file")
    elif case in ("older corpus", "other corpus"):
        corpus.mkdir()
        manifest = {"format": "unseeable/corpus@0"} if case == "older corpus" else {
            "format": "unseeable/corpus@1", "entries": [],
            "render": {"angles": [90, 120, 150, 180, 210], "width": 640, "height": 480,
                       "spp": 24, "seed": 0}}
        (corpus / "corpus.json").write_text(json.dumps(manifest))
        args += ["--corpus", corpus]
    elif case == "unreachable scheduler":
        args += ["--scheduler", f"tcp://127.0.0.1:{unused_port()}"]
    elif case == "publish nowhere":
        args += ["--publish", tmp_path / "missing" / "results.md"]
    elif case == "no run to report":
        args += ["--report-only"]
    elif case == "broken report":
        out.mkdir()
        (out / "report.json").write_text('{"format": "unseeable/reproduction@1"}')
        args += ["--report-only"]
    else:
        args[-1] = 0
    code, stdout, err = run(capsys, *args)
    assert code == 1 and stdout == ""
    assert err.startswith("error: ") and err.strip().splitlines() == [err.strip()]
    assert needle in err
    if case == "out is a file":
        assert out.read_text() == "a file"
    elif case == "broken report":
        assert [p.name for p in out.iterdir()] == ["report.json"]
    else:
        assert not out.exists()
    if corpus.exists():
        assert [p.name for p in corpus.iterdir()] == ["corpus.json"]
