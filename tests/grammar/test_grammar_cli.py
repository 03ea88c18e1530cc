"""``unseeable grammar count``."""

from __future__ import annotations

import pytest

import unseeable.cli as cli
import unseeable.cli.grammar  # noqa: F401  (registers the sub-command)
from unseeable.domain import Extent
from unseeable.grammar import count_valid


@pytest.fixture
def run(monkeypatch):
    # Only this stage's commands: other command modules may not exist yet.
    monkeypatch.setattr(cli, "_register", lambda: None)

    def main(argv: list[str]) -> int:
        # typer may end a successful command with SystemExit(0) despite standalone_mode=False.
        try:
            return cli.main(argv)
        except SystemExit as end:
            return int(end.code or 0)

    return main


def test_count_prints_the_exact_count_last(run, capsys):
    assert run(["grammar", "count", "--extent", "3,2,3"]) == 0
    out = capsys.readouterr().out.strip().splitlines()
    assert out[-1] == str(count_valid(Extent(3, 2, 3)))


def test_count_rejects_a_bad_extent(run, capsys):
    assert run(["grammar", "count", "--extent", "3,2"]) == 1
    assert "--extent" in capsys.readouterr().err
