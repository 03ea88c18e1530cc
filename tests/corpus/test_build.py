"""Rendering the corpus: layout, manifest, caching, resuming, reading back."""

import json
import shutil

import pytest

pytest.importorskip("mitsuba")

from unseeable.corpus import load_design  # noqa: E402
from unseeable.corpus.build import (  # noqa: E402
    CORPUS_FORMAT,
    build_corpus,
    load_corpus,
    plan_views,
)
from unseeable.errors import InputError  # noqa: E402
from unseeable.render.settings import RenderSettings  # noqa: E402

TINY = dict(angles=[90, 150], size=(80, 60), settings=RenderSettings(spp=2), seed=3,
            only=["tower-3-L3"])
FILES = ("view{a}.png", "view{a}.json", "view{a}.truth.json", "view{a}.ids.npz")


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    root = tmp_path_factory.mktemp("corpus")
    seen = []
    report = build_corpus(root, progress=lambda item, rendered: seen.append(rendered), **TINY)
    return root, report, seen


def _mtimes(root):
    return {p: p.stat().st_mtime_ns for p in root.rglob("*") if p.is_file()}


def test_build_writes_the_layout_and_manifest(built):
    root, report, seen = built
    assert len(report.rendered) == 2 and not report.skipped and seen == [True, True]
    folder = root / "tower-3-L3"
    for a in (90, 150):
        for pattern in FILES:
            assert (folder / pattern.format(a=a)).is_file()
    manifest = json.loads((root / "corpus.json").read_text())
    assert manifest["format"] == CORPUS_FORMAT
    assert manifest["render"]["angles"] == [90.0, 150.0]
    assert (manifest["render"]["width"], manifest["render"]["height"]) == (80, 60)
    [entry] = manifest["entries"]
    assert entry["name"] == "tower-3-L3"
    assert [v["angle"] for v in entry["views"]] == [90.0, 150.0]
    # only built structures are listed; relations to unbuilt ones are left out
    assert entry["subset_of"] == []


def test_load_corpus_reads_views_and_truth(built):
    root, _, _ = built
    corpus = load_corpus(root)
    assert corpus.names == ["tower-3-L3"] and corpus.angles == (90.0, 150.0)
    item = corpus["tower-3-L3"]
    design = load_design("tower-3-L3")
    assert item.structure == design.structure and item.pose == design.pose
    view = item.view(150).load_view()
    truth = item.view(150).load_truth()
    assert view.image.shape == (60, 80, 3)
    assert view.pose == design.pose and view.extent == design.structure.extent
    assert truth.structure == design.structure and truth.ids.shape == (60, 80)
    assert truth.ids.max() >= 0  # the structure is in the picture
    with pytest.raises(InputError, match="no view at this angle"):
        item.view(120)


def test_second_build_skips_everything_and_touches_nothing(built):
    root, _, _ = built
    before = _mtimes(root)
    seen = []
    report = build_corpus(root, progress=lambda item, rendered: seen.append(rendered), **TINY)
    assert not report.rendered and len(report.skipped) == 2 and seen == [False, False]
    after = _mtimes(root)
    changed = {p for p in after if after[p] != before.get(p)}
    assert changed <= {root / "corpus.json"}


def test_missing_or_stale_views_are_rebuilt_alone(built, tmp_path):
    root, _, _ = built
    copy = tmp_path / "c"
    shutil.copytree(root, copy)
    (copy / "tower-3-L3" / "view150.ids.npz").unlink()  # as if interrupted
    report = build_corpus(copy, **TINY)
    assert [d.angle for d in report.rendered] == [150.0]
    stamp = copy / "tower-3-L3" / "view90.stamp.json"
    data = json.loads(stamp.read_text())
    data["settings_hash"] = "0" * 64
    stamp.write_text(json.dumps(data))
    report = build_corpus(copy, **TINY)
    assert [d.angle for d in report.rendered] == [90.0]


def test_a_view_does_not_depend_on_the_other_views_built(built, tmp_path):
    root, _, _ = built
    alone = build_corpus(tmp_path / "alone", **{**TINY, "angles": [150]})
    assert len(alone.rendered) == 1
    a = (root / "tower-3-L3" / "view150.png").read_bytes()
    b = (tmp_path / "alone" / "tower-3-L3" / "view150.png").read_bytes()
    assert a == b


def test_other_settings_change_the_hash():
    base = {j.angle: j.settings_hash for j in plan_views("x", **TINY)}
    more_spp = {j.angle: j.settings_hash
                for j in plan_views("x", **{**TINY, "settings": RenderSettings(spp=3)})}
    other_seed = {j.angle: j.settings_hash for j in plan_views("x", **{**TINY, "seed": 4})}
    more_angles = {j.angle: j.settings_hash
                   for j in plan_views("x", **{**TINY, "angles": [90, 120, 150]})}
    assert all(base[a] != more_spp[a] and base[a] != other_seed[a] for a in base)
    assert all(base[a] == more_angles[a] for a in base)


def test_corpora_built_before_a_field_was_added_stay_complete():
    # Rendering a corpus takes minutes: a settings field added later, at its default, must
    # not make every view built before it look stale. (Hashes of the plans as they were
    # before SceneParams/SceneRandomisation.grain_contrast existed.)
    from unseeable.render.settings import SceneRandomisation

    plain = plan_views("x", **TINY)[0].settings_hash
    randomised = plan_views("x", **TINY, randomise=True)[0].settings_hash
    assert plain == "ce82656e44c01f24ef8bc1d3828ae2e0ec38e2101f6b0059c8d2ea0247ee3f92"
    assert randomised == "ac3182cfe732632d629b4a21605df3cbd097aa813de5b877e33936ab665ef9d6"
    # Set, the field counts.
    plain_logs = RenderSettings(spp=2, randomisation=SceneRandomisation(grain_contrast=(0, 0)))
    assert plan_views("x", **{**TINY, "settings": plain_logs})[0].settings_hash != randomised


def test_bad_options_raise_input_errors(tmp_path):
    with pytest.raises(InputError, match="only.*towr"):
        build_corpus(tmp_path, **{**TINY, "only": ["towr"]})
    with pytest.raises(InputError, match="same angle twice"):
        build_corpus(tmp_path, **{**TINY, "angles": [90, 90.0]})
    with pytest.raises(InputError, match="workers"):
        build_corpus(tmp_path, workers=0, **TINY)


def test_load_corpus_names_what_is_wrong(built, tmp_path):
    root, _, _ = built
    copy = tmp_path / "c"
    shutil.copytree(root, copy)
    path = copy / "corpus.json"
    good = json.loads(path.read_text())

    def broken(change):
        data = json.loads(json.dumps(good))
        change(data)
        path.write_text(json.dumps(data))
        return copy

    with pytest.raises(InputError, match=r"corpus\.json: format"):
        load_corpus(broken(lambda d: d.update(format="unseeable/corpus@9")))
    with pytest.raises(InputError, match=r"entries\[0\]\.views\[1\]\.image: names a missing"):
        load_corpus(broken(lambda d: d["entries"][0]["views"][1].update(image="nope.png")))
    with pytest.raises(InputError, match=r"entries\[0\]\.subset_of: names no structure"):
        load_corpus(broken(lambda d: d["entries"][0].update(subset_of=["tower-3"])))
    with pytest.raises(InputError, match=r"entries\[0\]\.views\[0\]\.angle"):
        load_corpus(broken(lambda d: d["entries"][0]["views"][0].update(angle=33)))
    with pytest.raises(InputError, match="not a corpus folder"):
        load_corpus(tmp_path)


def _run_cli(args):
    """Exit code of ``unseeable ARGS`` (typer may exit through SystemExit)."""
    import unseeable.cli.corpus  # noqa: F401  (registers the commands)
    from unseeable.cli import main

    try:
        return main(args)
    except SystemExit as done:
        return done.code or 0


@pytest.mark.slow
def test_cli_build_in_parallel_then_cached(tmp_path, capsys):
    args = ["corpus", "build", "--out", str(tmp_path), "--only", "wall-5",
            "--angles", "90,210", "--size", "80x60", "--spp", "1", "--workers", "2"]
    assert _run_cli(args) == 0
    assert "2 views rendered" in capsys.readouterr().out
    assert _run_cli(args) == 0
    assert "0 views rendered" in capsys.readouterr().out
    assert load_corpus(tmp_path).names == ["wall-5"]
    assert _run_cli(["corpus", "build", "--out", str(tmp_path), "--only", "nope"]) == 1
    assert "no such corpus design" in capsys.readouterr().err


def test_cli_bad_worker_count_is_one_line_and_writes_nothing(tmp_path, capsys):
    out = tmp_path / "corpus"
    assert _run_cli(["corpus", "build", "--out", str(out), "--only", "wall-5",
                     "--workers", "0"]) == 1
    err = capsys.readouterr().err
    assert err.startswith("error: ") and len(err.strip().splitlines()) == 1  # no bar before
    assert "workers" in err and not out.exists()
