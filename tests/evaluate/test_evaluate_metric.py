import numpy as np
import pytest
from hypothesis import given, settings

from strategies import structures
from unseeable.domain import Extent, GridPose, Log, Structure, half_turn_structure
from unseeable.errors import InputError
from unseeable.evaluate import ERROR_KINDS, compare_structures, count_errors, error_histogram

E = Extent(4, 3, 4)
BASE = [Log(0, (0, 0), 3), Log(0, (0, 3), 3), Log(1, (0, 0), 2), Log(1, (0, 2), 2),
        Log(1, (2, 0), 3)]


def s(logs):
    return Structure(E, logs)


def test_identical_is_zero():
    assert count_errors(s(BASE), s(BASE)) == 0


def test_one_log_missing_is_one():
    assert count_errors(s(BASE), s(BASE[:-1])) == 1


def test_one_extra_log_is_one():
    assert count_errors(s(BASE[:-1]), s(BASE)) == 1


def test_three_notch_split_into_one_and_two_is_one():
    est = [Log(0, (0, 0), 1), Log(0, (1, 0), 2), *BASE[1:]]
    assert count_errors(s(BASE), s(est)) == 1


def test_adjacent_pair_resplit_is_two():
    truth = [Log(0, (0, 1), 2), Log(0, (2, 1), 1)]
    est = [Log(0, (0, 1), 1), Log(0, (1, 1), 2)]
    assert count_errors(s(truth), s(est)) == 2


def test_groups_say_what_went_wrong():
    # The first wall's 3-notch log split 1 + 2 (joints), the second's dropped (missing),
    # a log added on an empty line (extra), and one line both shortened and moved (mixed).
    truth = [Log(0, (0, 0), 3), Log(0, (0, 3), 3), Log(1, (0, 0), 2)]
    est = [Log(0, (0, 0), 1), Log(0, (1, 0), 2), Log(0, (0, 2), 2), Log(1, (0, 1), 2)]
    c = compare_structures(s(truth), s(est))
    kinds = {g.line: (g.kind, g.start, g.stop, g.truth_logs, g.estimate_logs, g.errors)
             for g in c.groups}
    assert kinds == {(0, 0, 0): ("split", 0, 2, 1, 2, 1), (0, 0, 3): ("missing", 0, 2, 1, 0, 1),
                     (0, 0, 2): ("extra", 0, 1, 0, 1, 1), (1, 2, 0): ("mixed", 0, 2, 1, 1, 1)}
    assert c.errors_by_kind() == {"split": 1, "extra": 1, "missing": 1, "mixed": 1}
    assert c.errors == 4


@settings(max_examples=40, deadline=None)
@given(structures(max_positions=48), structures(max_positions=48))
def test_groups_add_up_to_the_errors(truth, estimate):
    if truth.extent != estimate.extent:
        estimate = Structure(truth.extent, [])
    c = compare_structures(truth, estimate)
    by_kind = c.errors_by_kind()
    assert list(by_kind) == list(ERROR_KINDS)
    assert sum(by_kind.values()) == c.errors == sum(g.errors for g in c.groups)
    assert sum(g.truth_logs for g in c.groups) == int((~c.truth_correct).sum())
    assert sum(g.estimate_logs for g in c.groups) == int((~c.estimate_correct).sum())
    assert [g.line for g in c.groups] == sorted(g.line for g in c.groups)


def test_correct_masks():
    c = compare_structures(s(BASE), s(BASE[:-1]))
    assert c.truth_correct.tolist() == [True, True, True, True, False]
    assert c.estimate_correct.all()


@settings(max_examples=30, deadline=None)
@given(structures(max_positions=48))
def test_physical_comparison_across_a_half_turn(structure):
    pose = GridPose(12.0, -30.0, 20.0)
    turned_pose, _ = pose.turned(2, structure.extent)
    turned = half_turn_structure(structure)
    assert count_errors(structure, turned, truth_pose=pose, estimate_pose=turned_pose) == 0
    if len(structure):
        fewer = turned.with_logs(turned.logs[1:])
        assert count_errors(structure, fewer, truth_pose=pose, estimate_pose=turned_pose) == 1


def test_a_grid_that_does_not_line_up_raises_or_counts_every_log():
    truth, estimate = s(BASE), s(BASE[:-1])
    pose = GridPose(0.0, 0.0, 20.0)
    off = GridPose(20.0, 0.0, 20.0)  # 20 mm: between two notches
    with pytest.raises(InputError, match="does not line up"):
        compare_structures(truth, estimate, truth_pose=pose, estimate_pose=off)
    c = compare_structures(truth, estimate, truth_pose=pose, estimate_pose=off,
                           on_misaligned="count")
    assert c.errors == len(truth.logs) + len(estimate.logs)
    assert c.errors_by_kind() == {"split": 0, "extra": len(estimate.logs),
                                  "missing": len(truth.logs), "mixed": 0}
    assert not c.truth_correct.any() and not c.estimate_correct.any()
    # Lined up, "count" changes nothing.
    assert compare_structures(truth, estimate, truth_pose=pose, estimate_pose=pose,
                              on_misaligned="count").errors == 1
    with pytest.raises(InputError, match="on_misaligned"):
        compare_structures(truth, estimate, on_misaligned="ignore")


@settings(max_examples=30, deadline=None)
@given(structures(max_positions=48))
def test_snapping_compares_the_structure_whatever_its_pose(structure):
    # A camera whose calibration is off puts every pose found for it millimetres off: the
    # same logs posed 20 mm and 1.5° off, or described from the other side (a half turn)
    # and off too, are no error once snapped; a log fewer is still one.
    from unseeable.evaluate import snapped_pose

    pose = GridPose(12.0, -30.0, 20.0)
    off = GridPose(32.0, -22.0, 21.5)
    snapped = snapped_pose(off, pose)
    assert np.allclose([snapped.x, snapped.z, snapped.yaw_deg], [12.0, -30.0, 20.0])
    assert compare_structures(structure, structure, truth_pose=pose, estimate_pose=off,
                              on_misaligned="snap").errors == 0
    turned_pose, _ = pose.turned(2, structure.extent)
    askew = GridPose(turned_pose.x - 15.0, turned_pose.z + 9.0, turned_pose.yaw_deg - 1.2)
    assert compare_structures(structure, half_turn_structure(structure), truth_pose=pose,
                              estimate_pose=askew, on_misaligned="snap").errors == 0
    if len(structure):
        fewer = structure.with_logs(structure.logs[1:])
        assert compare_structures(structure, fewer, truth_pose=pose, estimate_pose=off,
                                  on_misaligned="snap").errors == 1


def test_histogram():
    h = error_histogram([0, 2, 2, 5])
    assert h.tolist() == [0.25, 0.25, 0.75, 0.75, 0.75, 1.0]
    assert np.all(np.diff(error_histogram([3, 1, 4, 1, 5], max_errors=8)) >= 0)
    with pytest.raises(ValueError):
        error_histogram([])


@settings(max_examples=15, deadline=None)
@given(structures(max_positions=48))
def test_matched_features_are_the_same_features_across_a_half_turn(structure):
    """The same structure numbered from the other side: matched features agree on
    presence and on visibility from any camera (what the corpus experiment's visibility
    agreement relies on under an estimated pose)."""
    from unseeable.domain import feature_values
    from unseeable.evaluate import match_features
    from unseeable.visibility import feature_visibility

    pose = GridPose(30.0, -20.0, 25.0)
    camera = np.array([200.0, 600.0, -700.0])
    turned_pose, _ = pose.turned(2, structure.extent)
    turned = half_turn_structure(structure)
    m = match_features(turned.extent, turned_pose, structure.extent, pose)
    ok = m >= 0
    assert ok.mean() > 0.7 and len(set(m[ok])) == ok.sum()  # one to one
    present = feature_values(structure.extent, structure.occupancy)
    assert (feature_values(turned.extent, turned.occupancy)[ok] == present[m[ok]]).all()
    seen = feature_visibility(structure, camera, pose)
    assert (feature_visibility(turned, camera, turned_pose)[ok] == seen[m[ok]]).all()
