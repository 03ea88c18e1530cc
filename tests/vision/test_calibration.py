"""Calibration: statistics → probabilities, fitting, the shipped file."""

import json

import numpy as np
import pytest

from unseeable.errors import InputError, VisionError
from unseeable.vision import default_calibration, load_calibration, save_calibration
from unseeable.vision.calibration import (
    CONTEXT_INPUTS,
    GROUPS,
    Calibration,
    GroupEnsemble,
    PoseQualityModel,
    group_features,
    merge_calibrations,
    training_parts,
)
from unseeable.vision.calibration_fit import fit_calibration, fit_group, fit_pose_quality
from unseeable.vision.detectors import END_STATS, SEGMENT_STATS, score_features


def view_samples(scores, rng, n=400):
    """``{group: stats (n, S)}``: rows of the view's own judged statistics, resampled, so
    that a model fitted on them is used inside its training range on that view."""
    from unseeable.vision.detectors import feature_kind_groups

    out = {}
    for g, member in feature_kind_groups(scores.kind).items():
        stats = scores.end_stats if g == "end" else scores.segment_stats
        rows = stats[member & scores.judged]
        out[g] = rows[rng.integers(0, len(rows), n)]
    return out


def synthetic_samples(rng, n=400):
    out = {}
    for g in GROUPS:
        width = len(END_STATS) if g == "end" else len(SEGMENT_STATS)
        present = rng.random(n) < 0.4
        stats = rng.uniform(0.05, 0.3, (n, width))
        stats[present, 0] += 0.5  # strength tells
        out[g] = (stats, present)
    return out


def test_fit_group_learns_a_separable_rule():
    rng = np.random.default_rng(0)
    x = rng.normal(size=(300, 3))
    y = x[:, 0] + 0.5 * x[:, 1] > 0
    model = fit_group(x, y, hidden=4)
    assert np.mean((model.probability(x) > 0.5) == y) > 0.95


def test_fit_group_refuses_one_sided_data():
    with pytest.raises(VisionError):
        fit_group(np.zeros((50, 3)), np.ones(50, bool))


def test_probabilities_are_clipped_and_unjudged_stay_half(synthetic_view, tmp_path):
    rng = np.random.default_rng(1)
    cal = fit_calibration(synthetic_samples(rng), clip=(0.02, 0.98), hidden=4)
    s, pose, cam, image = synthetic_view
    mask = np.zeros(len(cal.probabilities(score_features(image, cam, pose, s.extent))), bool)
    mask[: len(mask) // 2] = True
    sc = score_features(image, cam, pose, s.extent, mask=mask)
    p = cal.probabilities(sc)
    assert np.all(p[~sc.judged] == 0.5)
    assert np.all((p[sc.judged] >= 0.02) & (p[sc.judged] <= 0.98))


def test_round_trip_and_size(tmp_path):
    rng = np.random.default_rng(2)
    cal = fit_calibration(synthetic_samples(rng), hidden=4, info={"scenes": 3})
    cal = Calibration(cal.models, cal.clip, cal.info, PoseQualityModel())
    save_calibration(cal, tmp_path / "c.json")
    back = load_calibration(tmp_path / "c.json")
    x = rng.uniform(0, 1, (10, len(SEGMENT_STATS)))
    f = group_features("long", x)
    assert back.models["long"].probability(f) == pytest.approx(
        cal.models["long"].probability(f), abs=1e-4)
    assert back.pose_quality is not None
    assert back.info["scenes"] == 3


@pytest.mark.slow
def test_an_ensemble_averages_networks_whose_first_is_the_single_fit(tmp_path):
    rng = np.random.default_rng(4)
    samples = synthetic_samples(rng)
    single = fit_calibration(samples, hidden=4, max_iter=50)
    runs = [fit_calibration(samples, hidden=4, max_iter=50, members=3, workers=w) for w in (1, 2)]
    for g in GROUPS:
        one, two = (c.models[g] for c in runs)
        assert isinstance(one, GroupEnsemble) and len(one.members) == 3
        # The same networks whether fitted in one process or two.
        assert all(np.array_equal(a.w1, b.w1) for a, b in zip(one.members, two.members))
        first = one.members[0]
        assert np.array_equal(first.w1, single.models[g].w1) and first.b2 == single.models[g].b2
        # Different initial weights give different networks, and the ensemble their mean.
        assert not np.array_equal(one.members[1].w1, first.w1)
        x = group_features(g, samples[g][0][:20])
        assert one.logit(x) == pytest.approx(np.mean([m.logit(x) for m in one.members], 0))
    assert runs[0].info == runs[1].info and runs[0].info["members"] == 3
    save_calibration(runs[0], tmp_path / "c.json")
    back = load_calibration(tmp_path / "c.json")
    x = group_features("short", samples["short"][0][:20])
    assert back.models["short"].probability(x) == pytest.approx(
        runs[0].models["short"].probability(x), abs=1e-4)
    with pytest.raises(InputError, match="members"):
        fit_calibration(samples, members=0)


def test_broken_calibration_files_are_input_errors(tmp_path):
    p = tmp_path / "c.json"
    p.write_text(json.dumps({"format": "unseeable/vision-calibration@1", "clip": [0.02, 0.98],
                             "groups": {"end": {"mean": [1, 2]}}}))
    with pytest.raises(InputError, match="groups"):
        load_calibration(p)
    p.write_text(json.dumps({"format": "unseeable/vision-calibration@1", "clip": [0.02, 0.98],
                             "groups": {g: [] for g in GROUPS}}))
    with pytest.raises(InputError, match=r"groups\.end.*at least one network"):
        load_calibration(p)
    p.write_text(json.dumps({"format": "something/else"}))
    with pytest.raises(InputError, match="format"):
        load_calibration(p)


def test_shipped_calibration_is_small_and_complete():
    from importlib import resources

    text = resources.files("unseeable").joinpath("data/calibration.json").read_text()
    # Six models of ten 32-unit networks each, their first layers as wide as the
    # detectors' statistics and profiles, and the pose model: ~5 MB.
    assert len(text) < 6_000_000
    cal = default_calibration()
    assert set(cal.models) == set(GROUPS) == set(cal.context_models)
    # What the docs describe: two fits of five networks each, one of them with the big
    # cabins of TRAIN_HALLS among its scenes, every model their ten networks averaged.
    for model in [*cal.models.values(), *cal.context_models.values()]:
        assert isinstance(model, GroupEnsemble) and len(model.members) == 10
    parts = training_parts(cal)
    assert [p.get("members") for p in parts] == [5, 5]
    assert [p.get("halls_scenes", 0) for p in parts] == [0, 200]
    # Never fitted on the validation scenes the benchmarks hold out.
    assert all(p.get("scene_family") == "train" for p in parts)
    assert cal.clip == (0.02, 0.98)


def test_pose_quality_fit_orders_good_fits_first():
    rng = np.random.default_rng(3)
    right = rng.random(200) < 0.6
    stats = rng.normal(size=(200, 4)) + right[:, None] * np.array([1.0, 1.0, 0.0, 0.5])
    model = fit_pose_quality(stats, right)
    p = model.probability(stats)
    assert p[right].mean() > p[~right].mean() + 0.2


def test_context_models_are_fitted_used_and_saved(synthetic_view, tmp_path):
    # With what lies behind each training feature, a second set of models takes it as
    # an input: here wood behind makes a feature present whatever its statistics say.
    rng = np.random.default_rng(3)
    s, pose, cam, image = synthetic_view
    sc = score_features(image, cam, pose, s.extent)
    n = len(sc.kind)
    samples = {}
    for g, stats in view_samples(sc, rng).items():
        behind = (rng.random(len(stats)) < 0.5).astype(float)
        samples[g] = (stats, behind > 0.5, behind)
    cal = fit_calibration(samples, hidden=4)
    assert cal.has_context and "context_end_train_accuracy" in cal.info
    wood = cal.probabilities(sc, behind=np.ones(n))
    table = cal.probabilities(sc, behind=np.zeros(n))
    assert np.all(wood[sc.judged] > 0.9) and np.all(table[sc.judged] < 0.1)
    save_calibration(cal, tmp_path / "c.json")
    back = load_calibration(tmp_path / "c.json")
    assert back.probabilities(sc, behind=np.ones(n)) == pytest.approx(wood, abs=1e-3)
    with pytest.raises(InputError, match="behind"):
        cal.probabilities(sc, behind=np.ones(n + 1))
    plain = fit_calibration(synthetic_samples(rng), hidden=4)
    assert not plain.has_context
    with pytest.raises(VisionError, match="context"):
        plain.probabilities(sc, behind=np.ones(n))


def test_context_priors_of_one_detection_are_its_probabilities_under_any_background(
        synthetic_view):
    # What the visibility fixpoint calls under each estimate: the statistics' share of the
    # first layer kept, the same probabilities; the same checks of ``behind``.
    rng = np.random.default_rng(8)
    s, pose, cam, image = synthetic_view
    sc = score_features(image, cam, pose, s.extent)
    n = len(sc.kind)
    samples = {g: (stats, rng.random(len(stats)) < 0.5, rng.random((len(stats), 2)))
               for g, stats in view_samples(sc, rng).items()}
    for cal in (default_calibration(), fit_calibration(samples, hidden=4)):
        priors = cal.context_priors(sc)
        for _ in range(3):
            behind = rng.random((n, 2))
            assert priors(behind) == pytest.approx(cal.probabilities(sc, behind=behind),
                                                   abs=1e-12)
        with pytest.raises(InputError, match="behind"):
            priors(np.ones((n + 1, 2)))
    with pytest.raises(VisionError, match="context"):
        fit_calibration(synthetic_samples(rng), hidden=4).context_priors(sc)


def test_a_context_model_of_the_wrong_width_is_refused(tmp_path):
    rng = np.random.default_rng(4)
    samples = {g: (x, y, rng.random(len(y))) for g, (x, y) in synthetic_samples(rng).items()}
    data = fit_calibration(samples, hidden=4).to_json()
    data["context_groups"]["end"]["mean"] = data["context_groups"]["end"]["mean"][:-1]
    (tmp_path / "c.json").write_text(json.dumps(data))
    with pytest.raises(InputError, match="context_groups.end"):
        load_calibration(tmp_path / "c.json")


def test_the_shipped_calibration_knows_what_lies_behind():
    from unseeable.visibility import BACKGROUND_INPUTS

    cal = default_calibration()
    # the context models take background_context's columns, in its order
    assert cal.has_context and cal.context_inputs == CONTEXT_INPUTS == BACKGROUND_INPUTS


def test_context_models_take_both_background_columns(synthetic_view, tmp_path):
    # The second column (a log's edge right behind the line) alone decides here.
    rng = np.random.default_rng(6)
    s, pose, cam, image = synthetic_view
    sc = score_features(image, cam, pose, s.extent)
    n = len(sc.kind)
    samples = {}
    for g, stats in view_samples(sc, rng).items():
        behind = np.column_stack([rng.random(len(stats)), rng.random(len(stats)) < 0.5])
        samples[g] = (stats, behind[:, 1] > 0.5, behind)
    cal = fit_calibration(samples, hidden=4)
    assert cal.context_inputs == CONTEXT_INPUTS
    edge = cal.probabilities(sc, behind=np.column_stack([np.full(n, 0.5), np.ones(n)]))
    none = cal.probabilities(sc, behind=np.column_stack([np.full(n, 0.5), np.zeros(n)]))
    assert np.all(edge[sc.judged] > 0.9) and np.all(none[sc.judged] < 0.1)
    assert np.all(edge[sc.judged] > none[sc.judged])
    save_calibration(cal, tmp_path / "c.json")
    back = load_calibration(tmp_path / "c.json")
    assert back.context_inputs == CONTEXT_INPUTS
    assert back.probabilities(sc, behind=np.column_stack([np.full(n, 0.5), np.ones(n)])) \
        == pytest.approx(edge, abs=1e-3)
    # the share of wood alone is not enough for these models
    with pytest.raises(InputError, match="behind_edges"):
        cal.probabilities(sc, behind=np.ones(n))


def test_a_calibration_with_the_wood_share_alone_still_loads_and_uses_it(synthetic_view,
                                                                         tmp_path):
    rng = np.random.default_rng(7)
    samples = {g: (x, y, rng.random(len(y))) for g, (x, y) in synthetic_samples(rng).items()}
    cal = fit_calibration(samples, hidden=4)
    assert cal.context_inputs == ("behind",)
    save_calibration(cal, tmp_path / "c.json")
    back = load_calibration(tmp_path / "c.json")
    assert back.context_inputs == ("behind",)
    s, pose, cam, image = synthetic_view
    sc = score_features(image, cam, pose, s.extent)
    n = len(sc.kind)
    wood = np.full(n, 0.7)
    # background_context's two columns: the first is used, the second ignored
    both = np.column_stack([wood, rng.random(n)])
    assert back.probabilities(sc, behind=both) == pytest.approx(
        back.probabilities(sc, behind=wood))
    data = cal.to_json()
    data["context"] = ["behind_edges"]
    (tmp_path / "d.json").write_text(json.dumps(data))
    with pytest.raises(InputError, match="context"):
        load_calibration(tmp_path / "d.json")


def test_the_second_stage_keeps_the_plain_models_and_refits_the_context_ones():
    rng = np.random.default_rng(8)
    samples = {g: (x, y, rng.random((len(y), 2))) for g, (x, y) in synthetic_samples(rng).items()}
    first = fit_calibration({g: (x, y, b[:, :1]) for g, (x, y, b) in samples.items()}, hidden=4)
    second = fit_calibration(samples, hidden=4, plain=first.models)
    assert second.models == first.models
    assert second.context_inputs == CONTEXT_INPUTS
    assert "end_train_accuracy" not in second.info and "context_end_train_accuracy" in second.info
    with pytest.raises(InputError, match="plain"):
        fit_calibration({g: (x, y) for g, (x, y, _) in samples.items()}, plain=first.models)


def test_merged_calibrations_average_every_network_of_every_part():
    rng = np.random.default_rng(5)
    samples = synthetic_samples(rng)
    a = fit_calibration(samples, hidden=4, max_iter=50, members=2, info={"scenes": 1})
    b = fit_calibration(synthetic_samples(rng), hidden=4, max_iter=50, info={"scenes": 2})
    b = Calibration(b.models, b.clip, b.info, PoseQualityModel())
    both = merge_calibrations([a, b])
    for g in GROUPS:
        x = group_features(g, samples[g][0][:20])
        nets = [*a.models[g].members, b.models[g]]
        assert len(both.models[g].members) == 3
        # Each network weighs the same: a's two count twice b's one.
        assert both.models[g].logit(x) == pytest.approx(np.mean([n.logit(x) for n in nets], 0))
    assert both.pose_quality is b.pose_quality  # the first part that has one
    assert [p["scenes"] for p in training_parts(both)] == [1, 2]
    # A merged calibration merges again part by part, and survives its file.
    again = merge_calibrations([both, a])
    assert [p["scenes"] for p in training_parts(again)] == [1, 2, 1]
    assert again.info["members"] == 5
    assert training_parts(a) == [a.info]


def test_calibrations_that_disagree_are_not_merged():
    rng = np.random.default_rng(6)
    a = fit_calibration(synthetic_samples(rng), hidden=4, max_iter=20)
    b = Calibration(a.models, (0.05, 0.95), a.info)
    with pytest.raises(InputError, match=r"b\.json: clip: .*got \[0\.05, 0\.95\]"):
        merge_calibrations([a, b], names=["a.json", "b.json"])
    with pytest.raises(InputError, match=r"calibrations\[1\]\.clip"):
        merge_calibrations([a, b])
    with_context = Calibration(a.models, a.clip, a.info, context_models=a.models)
    with pytest.raises(InputError, match="context"):
        merge_calibrations([with_context, a])
    with pytest.raises(InputError, match="two or more"):
        merge_calibrations([a])
