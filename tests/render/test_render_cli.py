"""The ``unseeable render`` and ``unseeable cad`` commands."""

from __future__ import annotations

import json

import numpy as np
import pytest
import trimesh

import unseeable.cli as cli
import unseeable.cli.render  # noqa: F401  (registers the commands)
from unseeable.domain import save_structure
from unseeable.render.view import load_truth, load_view


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


@pytest.fixture
def cabin_file(tmp_path, cabin_structure):
    path = tmp_path / "cabin.json"
    save_structure(cabin_structure, path)
    return path


def test_render_writes_views_and_truth(run, tmp_path, cabin_file, cabin_structure, capsys):
    out = tmp_path / "out"
    code = run(["render", str(cabin_file), "--angles", "90,210", "--size", "64x48", "--spp", "2",
                "--seed", "5", "--removed-from-layer", "4", "--pose", "10,-20,15", "--out",
                str(out)])
    assert code == 0, capsys.readouterr().err
    names = sorted(p.name for p in out.iterdir())
    assert names == ["view1.ids.npz", "view1.json", "view1.png", "view1.truth.json",
                     "view2.ids.npz", "view2.json", "view2.png", "view2.truth.json"]
    view = load_view(out / "view2.json")
    assert view.image.shape == (48, 64, 3) and view.removed_from_layer == 4
    assert (view.pose.x, view.pose.z, view.pose.yaw_deg) == (10.0, -20.0, 15.0)
    truth = load_truth(out / "view2.truth.json")
    assert truth.structure == cabin_structure and truth.ids.shape == (48, 64)
    data = json.loads((out / "view1.truth.json").read_text())
    assert data["format"] == "unseeable/truth@1" and data["structure"]["extent"] == [3, 6, 3]
    assert "view1" in capsys.readouterr().out


def test_render_default_pose_centres_the_assembly(run, tmp_path, cabin_file):
    out = tmp_path / "o"
    assert run(["render", str(cabin_file), "--angles", "90", "--size", "32x24", "--spp", "1",
                "--out", str(out)]) == 0
    pose = load_view(out / "view1.json").pose
    assert (pose.x, pose.z, pose.yaw_deg) == (-64.0, -64.0, 0.0)


@pytest.mark.parametrize("args, message", [
    (["--angles", "a,b"], "--angles"),
    (["--size", "64by48"], "--size"),
    (["--pose", "1,2"], "--pose"),
    (["--removed-from-layer", "-1"], "removed_from_layer"),
])
def test_render_bad_options_fail_with_one_line(run, tmp_path, cabin_file, capsys, args, message):
    code = run(["render", str(cabin_file), "--out", str(tmp_path / "o"), *args])
    err = capsys.readouterr().err
    assert code == 1 and message in err and len(err.strip().splitlines()) == 1
    assert err.startswith("error: ")  # nothing before it (no progress bar's blank line)
    assert not (tmp_path / "o").exists()


def test_render_missing_structure_file(run, tmp_path, capsys):
    assert run(["render", str(tmp_path / "none.json"), "--out", str(tmp_path / "o")]) == 1
    assert "no such file" in capsys.readouterr().err


def test_cad_one_log_and_a_structure(run, tmp_path, cabin_file):
    assert run(["cad", "--notches", "3", "--out", str(tmp_path / "log3.stl")]) == 0
    log = trimesh.load(tmp_path / "log3.stl", force="mesh")
    assert log.is_watertight and log.extents[0] == pytest.approx(172.0)
    assert run(["cad", str(cabin_file), "--out", str(tmp_path / "house.ply")]) == 0
    house = trimesh.load(tmp_path / "house.ply", force="mesh", process=False)
    assert house.is_watertight
    np.testing.assert_allclose(house.bounds[:, [0, 2]].mean(axis=0), 0.0, atol=1e-6)


def test_cad_bad_suffix_is_an_input_error(run, tmp_path, capsys):
    assert run(["cad", "--notches", "2", "--out", str(tmp_path / "log.dxf")]) == 1
    assert "unknown mesh format" in capsys.readouterr().err
    assert not list(tmp_path.iterdir())
