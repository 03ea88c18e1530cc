"""``--scheduler`` of the commands that run corpus-wide jobs: a value that will not do is
one line naming the option, exit code 1, and nothing written."""

from __future__ import annotations

import socket

import pytest

import unseeable.executor
from unseeable.cli import main


def unused_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def run(capsys, *args):
    code = main(list(map(str, args)))
    out, err = capsys.readouterr()
    return code, out, err


def commands(corpus, out):
    return {
        "corpus build": ["corpus", "build", "--out", out, "--only", "wall-5",
                         "--angles", "90", "--size", "80x60", "--spp", "1"],
        "visibility": ["experiment", "visibility", "--corpus", corpus, "--known-pose",
                       "--out", out],
        "views": ["experiment", "views", "--corpus", corpus, "--known-pose", "--out", out],
        "calibrate": ["calibrate", "--scenes", 1, "--walls", 0, "--tall", 0, "--looks", 0,
                      "--out", out / "calibration.json", "--cache", out / "cache"],
    }


@pytest.mark.parametrize("command", ["corpus build", "visibility", "views", "calibrate"])
@pytest.mark.parametrize("scheduler, needle", [
    ("unreachable", "--scheduler: no Dask scheduler answered there within 1 s (got "),
    ("dask", "--scheduler: must be processes:N, local:N or tcp://HOST:PORT (got 'dask')"),
    ("local:0", "--scheduler: N, the workers, must be in 1..256 (got 'local:0')"),
])
def test_a_scheduler_that_will_not_do_is_one_line_and_writes_nothing(
        capsys, monkeypatch, tiny_corpus, tmp_path, command, scheduler, needle):
    monkeypatch.setattr(unseeable.executor, "CONNECT_TIMEOUT", 1.0)
    if scheduler == "unreachable":
        scheduler = f"tcp://127.0.0.1:{unused_port()}"
    out = tmp_path / "out"
    code, stdout, err = run(capsys, *commands(tiny_corpus, out)[command],
                            "--scheduler", scheduler)
    assert code == 1 and stdout == ""
    assert err.startswith("error: ") and err.strip().splitlines() == [err.strip()]
    assert needle in err and scheduler in err
    assert not out.exists()
