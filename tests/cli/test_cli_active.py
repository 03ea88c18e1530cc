"""``unseeable active`` as a user meets it: files written, one-line errors, nothing
half-written."""

import json
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent.parent / "active"))
from scene import HIDDEN_CABIN, raster_view  # noqa: E402

from unseeable.cli import main  # noqa: E402
from unseeable.domain import Extent, Log, Structure, save_structure  # noqa: E402
from unseeable.render.view import View, save_view  # noqa: E402


def run(capsys, *args):
    code = main(list(map(str, args)))
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("views")
    made = {}
    for angle, layer in [(150.0, None), (90.0, None), (210.0, None), (150.0, 2)]:
        name = f"v{angle:g}" + ("" if layer is None else f"-L{layer}")
        made[name] = d / f"{name}.json"
        save_view(raster_view(angle, layer), made[name], image_path=d / f"{name}.png")
    save_structure(HIDDEN_CABIN, d / "truth.json")
    made["truth"] = d / "truth.json"
    return made


def test_active_on_photographs_writes_the_estimate_the_steps_and_the_strip(capsys, tmp_path,
                                                                            files):
    out = tmp_path / "out"
    code, stdout, err = run(capsys, "active", files["v150"], "--candidates", files["v90"],
                            "--candidates", files["v210"], "--candidates", files["v150-L2"],
                            "--out", out, "--truth", files["truth"], "--max-actions", 2)
    assert code == 0, err
    assert sorted(p.name for p in out.iterdir()) == ["active.json", "estimate.json",
                                                     "strip.png"]
    data = json.loads((out / "active.json").read_text())
    assert data["steps"][0]["plan"]["chosen_action"] is not None
    assert data["actions_taken"] == len(data["steps"]) - 1 >= 1
    assert "stopped" in stdout and "strip" in stdout


@pytest.mark.parametrize("args, needle", [
    (["--max-actions", "-1"], "--max-actions"),
    (["--workspace", "{truth}"], "--workspace"),
    ([], "--candidates"),
])
def test_bad_options_give_one_line_and_write_nothing(capsys, tmp_path, files, args, needle):
    args = [a.format(truth=files["truth"]) for a in args]
    cands = [] if needle == "--candidates" else ["--candidates", files["v90"]]
    code, out, err = run(capsys, "active", files["v150"], *cands, *args, "--out",
                         tmp_path / "o")
    assert code == 1
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and needle in lines[0]
    assert not (tmp_path / "o").exists()


def test_a_candidate_that_cannot_match_names_its_file(capsys, tmp_path, files):
    v = raster_view(90.0)
    save_view(View(v.image, v.camera, Extent(4, 4, 3), pose=v.pose), tmp_path / "odd.json",
              image_path=tmp_path / "odd.png")
    code, out, err = run(capsys, "active", files["v150"], "--candidates", tmp_path / "odd.json",
                         "--out", tmp_path / "o")
    assert code == 1 and "odd.json" in err and "extent" in err
    assert not (tmp_path / "o").exists()


def test_a_workspace_structure_that_breaks_the_grammar_is_refused(capsys, tmp_path):
    save_structure(Structure(Extent(2, 2, 2), [Log(1, (0, 0), 2)]), tmp_path / "bad.json")
    code, out, err = run(capsys, "active", "--workspace", tmp_path / "bad.json", "--out",
                         tmp_path / "o")
    assert code == 1 and "bad.json" in err
    assert not (tmp_path / "o").exists()
