"""One estimate from several photographs (unseeable.pipeline.joint)."""

import numpy as np
import pytest

from unseeable.domain import Extent, GridPose, Log, Structure
from unseeable.errors import InputError
from unseeable.pipeline import EstimateSettings, Observation, estimate
from unseeable.render.raster import RasterLook, rasterise_view
from unseeable.render.view import View
from unseeable.render.workspace import PendulumArm

NO_CONFIDENCE = EstimateSettings.from_options(enabled=False)


@pytest.fixture(scope="module")
def cabin():
    """A cabin 3 positions square with a wall inside along i and one wall a log lower than
    the others, so that no turn maps it onto itself: (structure, pose)."""
    s = Structure(Extent(3, 4, 3), [
        Log(0, (0, 0), 3), Log(0, (0, 2), 3), Log(1, (0, 0), 3), Log(1, (2, 0), 3),
        Log(2, (0, 0), 3), Log(2, (0, 1), 3), Log(2, (0, 2), 3), Log(3, (0, 0), 3)])
    rotation = GridPose(0.0, 0.0, 17.0).rotation
    origin = -(rotation @ np.array([64.0, 0.0, 64.0]))
    return s, GridPose(float(origin[0]), float(origin[2]), 17.0)


def _view(structure, pose, angle, *, extent=None, removed_from_layer=None, recorded=None):
    camera = PendulumArm().camera(angle)
    shown = structure if removed_from_layer is None else \
        structure.removed_from_layer(removed_from_layer)
    image = rasterise_view(shown, pose, camera, look=RasterLook(), seed=int(angle))
    return View(image, camera, extent or structure.extent,
                pose=pose if recorded is None else recorded,
                removed_from_layer=removed_from_layer)


def test_two_stations_in_one_table_frame_make_one_estimate_with_a_record_per_view(cabin):
    s, pose = cabin
    views = [_view(s, pose, 150.0), _view(s, pose, 90.0)]
    est = estimate([Observation.of(v, source=f"v{n}") for n, v in enumerate(views)],
                   NO_CONFIDENCE)
    assert est.structure == s
    assert [v.source for v in est.views] == ["v0", "v1"]
    assert [v.pose_report.source for v in est.views] == ["given", "shared"]
    # Each view reads its own features (the second sees the far side the first does not).
    seen = [v.visible & (v.priors != 0.5) for v in est.views]
    assert (seen[1] & ~seen[0]).any() and (seen[0] & ~seen[1]).any()
    assert not any(v.disagrees for v in est.views)
    assert est.logs_seen().all()


def test_a_disassembly_view_shows_what_the_full_view_hides_and_agrees_with_it(cabin):
    s, pose = cabin
    full = _view(s, pose, 150.0)
    removed = _view(s, pose, 150.0, removed_from_layer=2)
    est = estimate([Observation.of(full), Observation.of(removed)], NO_CONFIDENCE)
    assert est.structure == s
    assert est.views[1].removed_from_layer == 2
    # The second view's evidence is read against the structure without the removed logs:
    # whatever stands on layers 2 and up, it scores the same.
    from unseeable.grammar import EvidenceTerm, log_probability

    term = next(t for t in est.model.terms
                if isinstance(t, EvidenceTerm) and t.removed_from_layer == 2)
    lower = s.removed_from_layer(2)
    assert log_probability([term], s) == pytest.approx(log_probability([term], lower))
    assert log_probability([term], s) > log_probability(
        [term], Structure(s.extent, [log for log in s.logs if log.layer != 1]))


def test_independent_views_are_registered_by_their_symbolic_orientation(cabin):
    """The second view's recorded pose numbers the grid from the other corner (a half
    turn): registration finds the half turn, and the estimate is the truth."""
    s, pose = cabin
    turned, _ = pose.turned(2, s.extent)
    views = [_view(s, pose, 150.0), _view(s, pose, 210.0, recorded=turned)]
    settings = NO_CONFIDENCE.replace(independent=True)
    est = estimate([Observation.of(v) for v in views], settings)
    assert est.structure == s
    assert est.views[1].orientation == 2
    assert est.views[1].registration_margin > 0 and not est.views[1].registration_doubt


def test_views_that_cannot_be_one_assembly_are_refused_naming_the_file(cabin):
    s, pose = cabin
    other = _view(s, pose, 150.0, extent=Extent(3, 5, 3))
    with pytest.raises(InputError, match="b.json: extent"):
        estimate([Observation.of(_view(s, pose, 150.0), source="a.json"),
                  Observation.of(other, source="b.json")], NO_CONFIDENCE)
    beyond = _view(s, pose, 90.0, removed_from_layer=9)
    with pytest.raises(InputError, match="c.json: removed_from_layer"):
        estimate([Observation.of(_view(s, pose, 150.0)),
                  Observation.of(beyond, source="c.json")], NO_CONFIDENCE)


def test_an_estimate_goes_on_with_another_view_without_detecting_the_first_again(cabin):
    from unseeable.pipeline import extend_estimate

    s, pose = cabin
    first, second = _view(s, pose, 150.0), _view(s, pose, 90.0)
    one = estimate([Observation.of(first)], NO_CONFIDENCE)
    two = extend_estimate(one, [Observation.of(second)])
    assert two.views[0].detection is one.views[0].detection  # not detected again
    assert len(two.views) == 2 and two.model.observations[1].view is second
    scratch = estimate([Observation.of(first), Observation.of(second)], NO_CONFIDENCE)
    assert two.structure == scratch.structure == s
    # The second view starts its polish from the first's polished pose, not the recorded
    # one: the same structure, nearly the same probability.
    assert two.result.log_probability == pytest.approx(scratch.result.log_probability,
                                                       abs=0.1)
    with pytest.raises(InputError, match="previous"):
        extend_estimate(estimate_evidence_of(s), [Observation.of(second)])


def estimate_evidence_of(structure):
    from unseeable.domain import simulate_evidence
    from unseeable.pipeline import estimate_evidence

    return estimate_evidence(simulate_evidence(structure, accuracy=1.0, occluded_fraction=0.0,
                                               seed=0), NO_CONFIDENCE)
