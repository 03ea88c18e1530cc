"""What an estimate reports about itself (unseeable.pipeline)."""

import dataclasses

import numpy as np
import pytest

import unseeable.pipeline.evidence_checks as checks
import unseeable.vision.pose_choice as pose_choice
from unseeable.domain import Extent, GridPose, Log, Structure, simulate_evidence
from unseeable.grammar.priors import StructurePrior
from unseeable.pipeline import (
    PRESENCE_SHIFT_DOUBT,
    EstimateSettings,
    PoseReport,
    boundary_ends,
    estimate_evidence,
    estimate_to_json,
    estimate_view,
)
from unseeable.render.raster import RasterLook, rasterise_view
from unseeable.render.view import View
from unseeable.render.workspace import PendulumArm


def _sure_estimate():
    truth = Structure(Extent(2, 1, 2), [Log(0, (0, 0), 2), Log(0, (0, 1), 2)])
    est = estimate_evidence(simulate_evidence(truth, accuracy=1.0, occluded_fraction=0.0,
                                              seed=0))
    assert est.confidence.confident
    return est


def _with_view(est, **fields):
    """``est`` with its one view record's fields changed."""
    return dataclasses.replace(est, views=(dataclasses.replace(est.views[0], **fields),))


def test_an_estimate_at_an_ambiguously_chosen_pose_is_not_confident():
    est = _sure_estimate()
    assert est.confident and estimate_to_json(est)["confident"] is True
    doubtful = _with_view(est, pose_report=PoseReport("estimated", quality=0.9,
                                                      choice_margin=0.02, ambiguous=True))
    assert doubtful.confident is False
    data = estimate_to_json(doubtful)
    # The δ* test itself passed: the file says so beside the overall judgement.
    assert data["confident"] is False and data["confidence"]["confident"] is True
    fit = data["views"][0]["pose_fit"]
    assert fit["ambiguous"] is True and fit["choice_margin"] == 0.02
    clear = _with_view(est, pose_report=PoseReport("estimated", ambiguous=False))
    assert clear.confident is True


def test_without_a_confidence_test_nothing_is_claimed():
    est = dataclasses.replace(_sure_estimate(), confidence=None)
    assert est.confident is None
    data = estimate_to_json(est)
    assert data["confident"] is None and data["confidence"] is None


def test_an_estimate_whose_extent_is_in_doubt_is_not_confident():
    est = _sure_estimate()
    doubtful = _with_view(est, extent_doubt=True, edge_ends_judged=4, edge_ends_absent=2)
    assert doubtful.confident is False
    data = estimate_to_json(doubtful)
    assert data["confident"] is False and data["confidence"]["confident"] is True
    view = data["views"][0]
    assert view["extent_doubt"] is True and view["edge_ends_absent"] == 2


def test_an_estimate_whose_detections_had_to_be_shifted_far_towards_absent_is_not_confident():
    est = _sure_estimate()
    doubtful = _with_view(est, evidence_doubt=True, presence_shift=-1.5)
    assert doubtful.confident is False
    data = estimate_to_json(doubtful)
    assert data["confident"] is False and data["confidence"]["confident"] is True
    assert data["views"][0]["evidence_doubt"] is True
    assert data["views"][0]["presence_shift"] == -1.5
    assert _with_view(est, evidence_doubt=False).confident is True


def test_an_estimate_on_a_poorly_fitting_pose_is_not_confident():
    # A weak fit (or, with --force-pose, one the image contradicts) still gives an
    # estimate, never a confident one; a pose given with the view, or one that fits well,
    # leaves it be.
    from unseeable.pipeline import PoseReport
    from unseeable.vision import PoseSettings

    est = _sure_estimate()
    bar = PoseSettings().min_quality
    poor = _with_view(est, pose_report=PoseReport("estimated", quality=bar - 0.01))
    assert poor.views[0].pose_poor and poor.confident is False
    for fine in (PoseReport("estimated", quality=bar), PoseReport("given")):
        assert _with_view(est, pose_report=fine).confident is True


def test_an_estimate_from_photographs_that_builds_nothing_is_not_confident():
    # Photographs show an assembly: an empty grid means the grid is off it (a small
    # assembly seen at a pose a few centimetres off looks absent everywhere). Bare
    # evidence of an empty grid may be answered with a confident empty grid.
    empty = Structure(Extent(2, 1, 2), [])
    est = estimate_evidence(simulate_evidence(empty, accuracy=1.0, occluded_fraction=0.0,
                                              seed=0))
    assert not est.structure.logs and est.confidence.confident
    assert est.confident is True and not est.builds_nothing
    photographed = _with_view(est, pose=GridPose(), pose_report=PoseReport("given"))
    assert photographed.builds_nothing and photographed.confident is False
    assert estimate_to_json(photographed)["confident"] is False
    assert _with_view(_sure_estimate(), pose=GridPose()).confident is True


NO_CONFIDENCE = EstimateSettings.from_options(enabled=False)


@pytest.fixture(scope="module")
def cabin_view():
    """(structure, pose, camera, image): a cabin 3 positions square, drawn by the raster
    renderer (quick), seen from the arm at 180°."""
    s = Structure(Extent(3, 4, 3), [
        Log(0, (0, 0), 3), Log(0, (0, 2), 3), Log(1, (0, 0), 3), Log(1, (2, 0), 3),
        Log(2, (0, 0), 3), Log(2, (0, 2), 3), Log(3, (0, 0), 3), Log(3, (2, 0), 3)])
    camera = PendulumArm().camera(180.0)
    rotation = GridPose(0.0, 0.0, 17.0).rotation
    origin = -(rotation @ np.array([64.0, 0.0, 64.0]))
    pose = GridPose(float(origin[0]), float(origin[2]), 17.0)
    return s, pose, camera, rasterise_view(s, pose, camera, look=RasterLook(), seed=2)


def test_log_ends_seen_missing_at_the_extents_boundary_put_a_short_extent_in_doubt(
        cabin_view):
    """Given an extent of 2 for the cabin 3 square, its logs go on where the estimate must
    end them, and the end detectors see no ends there."""
    s, pose, camera, image = cabin_view
    right = estimate_view(View(image, camera, s.extent, pose=pose), NO_CONFIDENCE).views[0]
    assert right.extent_doubt is False and right.edge_ends_judged >= 4
    assert right.edge_ends_absent == 0
    assert right.evidence_doubt is False
    short = estimate_view(View(image, camera, Extent(2, 4, 2), pose=pose), NO_CONFIDENCE)
    assert short.views[0].extent_doubt is True
    assert (short.views[0].edge_ends_judged, short.views[0].edge_ends_absent) == \
        boundary_ends(short.structure, short.priors)


def test_detections_the_grammar_cannot_build_on_a_grid_off_the_assembly_put_it_in_doubt(
        cabin_view):
    """Given the cabin's pose half a pitch off along z (not polished), the detectors see
    the walls' edges where no structure on that grid has them all: the estimate keeps far
    fewer logs than they show, and the shift that makes them agree is strongly negative.
    The boundary's log ends do not give this away; the detections as a whole do."""
    s, pose, camera, image = cabin_view
    off = GridPose(pose.x, pose.z + 32.0, pose.yaw_deg)
    est = estimate_view(View(image, camera, s.extent, pose=off),
                        NO_CONFIDENCE.replace(refine=False))
    assert len(est.structure.logs) < len(s.logs) // 2
    view = est.views[0]
    assert view.presence_shift <= PRESENCE_SHIFT_DOUBT
    assert view.evidence_doubt is True and view.extent_doubt is False


@pytest.mark.slow
def test_an_estimated_pose_in_doubt_is_searched_again_and_kept_unless_the_new_one_is_clear(
        cabin_view, monkeypatch):
    """With the doubt rule made to hold for every estimate, the pose is searched again with
    the aliases' bar lowered, and the first estimate stays (the second is in doubt too)."""
    s, _, camera, image = cabin_view
    view = View(image, camera, s.extent)
    # The polish that follows is another test's subject (below): off here, so that the
    # pose in question is the search's alone.
    monkeypatch.setattr(pose_choice, "POLISH_MOVE", (np.inf, np.inf))
    # The estimate without the rule, to compare with (on this square footprint the search's
    # pose is a quarter turn, which the rule itself rightly doubts).
    monkeypatch.setattr(checks, "EDGE_ENDS_ABSENT_MIN", 10**9)
    first = estimate_view(view, NO_CONFIDENCE)
    assert first.views[0].extent_doubt is False
    assert first.views[0].pose_report.searched_again is False
    monkeypatch.setattr(checks, "EDGE_ENDS_ABSENT_MIN", 0)
    monkeypatch.setattr(checks, "EDGE_ENDS_ABSENT_SHARE", 0.0)
    doubted = estimate_view(view, NO_CONFIDENCE)
    assert doubted.views[0].pose_report.searched_again is True
    assert doubted.views[0].extent_doubt
    assert doubted.views[0].pose_report.changed_by_second_search is False
    assert doubted.pose == first.pose and "pose_again_s" in doubted.timings
    assert doubted.structure.occupancy.tolist() == first.structure.occupancy.tolist()


@pytest.mark.slow
def test_an_estimated_pose_a_few_millimetres_off_is_polished_on_its_estimate_and_used(
        cabin_view, monkeypatch):
    """The search's choice made the truth, then 6 mm off it: the estimate's own edges bring
    the second back, where the detections imply a better structure (as the pose choice
    values it), and the structure is estimated again there, as at the truth."""
    import unseeable.vision as vision
    from unseeable.vision import pose_equivalent

    s, pose, camera, image = cabin_view
    view = View(image, camera, s.extent)
    choose = vision.select_pose

    def choosing(made: GridPose):
        return lambda *args, **kwargs: dataclasses.replace(choose(*args, **kwargs), pose=made)

    monkeypatch.setattr(vision, "select_pose", choosing(pose))
    at_truth = estimate_view(view, NO_CONFIDENCE)
    assert at_truth.views[0].pose_report.moved_by_polish is False
    assert pose_equivalent(at_truth.pose, pose, s.extent)[0] < 1.5
    monkeypatch.setattr(vision, "select_pose",
                        choosing(GridPose(pose.x + 6.0, pose.z - 1.5, pose.yaw_deg)))
    est = estimate_view(view, NO_CONFIDENCE)
    report = est.views[0].pose_report
    assert report.moved_by_polish is True and "pose_polish_s" in est.timings
    before, after = report.polish_gain
    assert after > before + pose_choice.POLISH_MIN_GAIN
    assert pose_equivalent(est.pose, pose, s.extent)[0] < 1.5
    assert est.structure == at_truth.structure
    # Not taken unless the structure there is better by the margin.
    monkeypatch.setattr(pose_choice, "POLISH_MIN_GAIN", after - before)
    kept = estimate_view(view, NO_CONFIDENCE)
    report = kept.views[0].pose_report
    assert report.moved_by_polish is False and report.polish_gain is not None
    assert pose_equivalent(kept.pose, pose, s.extent)[0] > 5.0


def test_a_disassembly_views_pose_is_polished_on_the_logs_it_shows(cabin_view, monkeypatch):
    """After the arm took layers 2 and up away, the search's choice made 6 mm off: the
    polish on the logs the image still shows brings it back (aligning the whole cabin's
    edges, those of the removed logs included, leaves it 6 mm off)."""
    import unseeable.vision as vision
    from unseeable.vision import pose_equivalent

    s, pose, camera, _ = cabin_view
    image = rasterise_view(s.removed_from_layer(2), pose, camera, look=RasterLook(), seed=2)
    choose = vision.select_pose
    off = GridPose(pose.x + 6.0, pose.z - 1.5, pose.yaw_deg)
    monkeypatch.setattr(vision, "select_pose",
                        lambda *args, **kwargs: dataclasses.replace(choose(*args, **kwargs),
                                                                    pose=off))
    est = estimate_view(View(image, camera, s.extent, removed_from_layer=2), NO_CONFIDENCE)
    assert est.views[0].pose_report.moved_by_polish is True
    assert pose_equivalent(est.pose, pose, s.extent)[0] < 1.5


def test_the_shift_fitted_to_the_estimate_is_recorded_and_can_be_turned_off(cabin_view):
    """The detections' log-odds are shifted by what makes them agree with the plain
    estimate (on the features it sees), and the view estimated again under them."""
    from unseeable.domain import feature_values
    from unseeable.visibility.loop import PRESENCE_SHIFT_MIN, fit_presence_shift

    s, pose, camera, image = cabin_view
    view = View(image, camera, s.extent, pose=pose)
    plain = estimate_view(view, NO_CONFIDENCE.replace(presence_shift=False))
    shifted = estimate_view(view, NO_CONFIDENCE)
    assert plain.views[0].presence_shift == 0.0
    seen = plain.visible & (plain.priors != 0.5)
    present = feature_values(s.extent, plain.structure.occupancy).astype(bool)
    fitted = fit_presence_shift(plain.priors[seen], present[seen])
    assert abs(fitted) >= PRESENCE_SHIFT_MIN  # (this look calls presence too rarely)
    assert shifted.views[0].presence_shift == pytest.approx(fitted, abs=1e-9)


def test_a_weak_reading_of_a_joint_does_not_split_a_log_under_the_joint_prior():
    # A 3-notch log seen whole, but its segment between the first two notches read
    # weakly absent (0.4) and the log ends a joint there would show hidden: the paper's
    # uniform prior splits the log (1 + 2) on that reading; the joint prior's nat per
    # joint outweighs it, and a confident reading (0.05) still splits it.
    from unseeable.domain import Evidence
    from unseeable.domain.features import FeatureKind, feature_index

    extent = Extent(3, 1, 1)
    truth = Structure(extent, [Log(0, (0, 0), 3)])
    p = simulate_evidence(truth, accuracy=0.95, occluded_fraction=0.0, seed=0).p.copy()
    idx = feature_index(extent)
    at = idx.at[:, 0]
    p[(idx.kind == FeatureKind.END_PLUS) & (at == 0)] = 0.5
    p[(idx.kind == FeatureKind.END_MINUS) & (at == 1)] = 0.5
    w = (idx.kind == FeatureKind.W) & (at == 0)
    for reading, cost, notches in ((0.4, 0.0, [1, 2]), (0.4, 1.0, [3]), (0.05, 1.0, [1, 2])):
        p[w] = reading
        est = estimate_evidence(Evidence(extent, p), NO_CONFIDENCE.replace(joint_cost=cost))
        assert sorted(log.notches for log in est.structure.logs) == notches, (reading, cost)


def _wall_with_a_hidden_joint():
    # Two courses of a wall with crossing logs between them, the bottom one with a joint
    # after notch 2; the top one's joint after notch 1 (a builder's) or after notch 2
    # (stacked, the tie policy's pick under the paper's prior).
    extent = Extent(5, 3, 1)
    wall = [Log(0, (0, 0), 3), Log(0, (3, 0), 2), *[Log(1, (i, 0), 1) for i in range(5)]]
    return (Structure(extent, [*wall, Log(2, (0, 0), 2), Log(2, (2, 0), 3)]),
            Structure(extent, [*wall, Log(2, (0, 0), 3), Log(2, (3, 0), 2)]))


def _log_on_a_hidden_post():
    # A 3-notch log on three posts (a builder's) or on the outer two over a gap (the
    # grammar allows it, and the tie policy's fewest logs pick it).
    extent = Extent(1, 2, 3)
    posts = [Log(0, (0, 0), 1), Log(0, (0, 2), 1)]
    return (Structure(extent, [*posts, Log(0, (0, 1), 1), Log(1, (0, 0), 3)]),
            Structure(extent, [*posts, Log(1, (0, 0), 3)]))


@pytest.mark.parametrize(("pair", "cost"), [(_wall_with_a_hidden_joint, "stacked_joint_cost"),
                                            (_log_on_a_hidden_post, "unsupported_notch_cost")])
def test_where_no_reading_decides_the_structure_prior_builds_as_builders_do(pair, cost):
    # Every reading that would tell the two apart is ½: the default structure prior picks
    # the builder's; with this cost 0 the two tie (the joint cost is held at 0 so that
    # only this cost can separate them: it is charged on seen joints only, and the ½
    # readings leave the two structures' top joints differently seen). The estimate
    # records the cost, and a bad one is an error naming it.
    from unseeable.domain import Evidence
    from unseeable.domain.features import feature_values
    from unseeable.errors import InputError
    from unseeable.grammar.objective import EvidenceTerm, log_probability

    builders, other = pair()
    extent = builders.extent
    p = simulate_evidence(builders, accuracy=0.95, occluded_fraction=0.0, seed=0).p.copy()
    p[feature_values(extent, builders.occupancy) != feature_values(extent, other.occupancy)] = 0.5
    evidence = Evidence(extent, p)
    settings = NO_CONFIDENCE.replace(joint_cost=0.0)
    est = estimate_evidence(evidence, settings)
    assert est.structure == builders
    assert estimate_to_json(est)["settings"]["prior"][cost] == getattr(StructurePrior(),
                                                                        cost) > 0
    flat = settings.replace(**{cost: 0})
    terms = [EvidenceTerm(evidence), *flat.prior.factors(extent)]
    assert log_probability(terms, builders) == pytest.approx(log_probability(terms, other))
    assert estimate_evidence(evidence, flat).result.log_probability >= (
        log_probability(terms, other) - 1e-6)
    with pytest.raises(InputError, match=cost):
        NO_CONFIDENCE.replace(**{cost: -1.0})


@pytest.mark.slow
def test_a_pose_in_doubt_is_replaced_by_the_second_searchs_when_that_ones_estimate_is_clear(
        cabin_view, monkeypatch):
    """The first search's choice made a whole pitch off the truth, where the estimate's
    log ends on the extent's boundary are seen missing: the search with the aliases' bar
    lowered (here: the truth) is adopted, and its estimate is the one reported."""
    import unseeable.vision as vision
    from unseeable.vision import pose_equivalent

    s, pose, camera, image = cabin_view
    view = View(image, camera, s.extent)
    choose = vision.select_pose
    along_i = pose.rotation @ np.array([64.0, 0.0, 0.0])
    off = GridPose(pose.x + along_i[0], pose.z + along_i[2], pose.yaw_deg)
    calls = []

    def first_off_then_true(*args, **kwargs):
        calls.append(1)
        return dataclasses.replace(choose(*args, **kwargs), pose=off if len(calls) == 1
                                   else pose)

    monkeypatch.setattr(vision, "select_pose", first_off_then_true)
    monkeypatch.setattr(pose_choice, "POLISH_MOVE", (np.inf, np.inf))  # the polish: off
    est = estimate_view(view, NO_CONFIDENCE)
    report = est.views[0].pose_report
    assert len(calls) == 2 and report.searched_again and report.changed_by_second_search
    assert pose_equivalent(est.pose, pose, s.extent)[0] < 1.5
    assert est.views[0].extent_doubt is False
    assert est.structure == estimate_view(View(image, camera, s.extent, pose=pose),
                                          NO_CONFIDENCE.replace(refine=False)).structure
