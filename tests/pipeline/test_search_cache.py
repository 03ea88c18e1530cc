"""The cache of pose searches the experiments share: an estimate is the same whether its
pose search was made, read back, or made again after a damaged entry."""

import dataclasses

import numpy as np
import pytest

from unseeable.pipeline import EstimateSettings, Observation, estimate
from unseeable.pipeline.search_cache import (
    active_search_cache,
    pose_searches_cached,
    search_key,
)
from unseeable.render.view import load_view


def _same(a, b) -> None:
    assert a.views[0].pose == b.views[0].pose
    assert a.views[0].pose_report == b.views[0].pose_report
    assert a.structure == b.structure
    assert a.result.log_probability == b.result.log_probability
    np.testing.assert_array_equal(a.views[0].priors, b.views[0].priors)
    np.testing.assert_array_equal(a.views[0].visible, b.views[0].visible)
    assert a.confident == b.confident
    assert a.confidence.tolerance == b.confidence.tolerance


@pytest.fixture(scope="module")
def view(tiny_corpus):
    return load_view(tiny_corpus / "wall-door" / "view120.json")


def test_an_estimate_is_the_same_with_its_search_made_read_or_redone(view, tmp_path):
    settings = EstimateSettings.from_options(time_limit=30.0)
    obs = Observation.of(view, use_recorded_pose=False)
    plain = estimate([obs], settings)
    folder = tmp_path / "searches"
    with pose_searches_cached(folder):
        assert active_search_cache() == folder
        made = estimate([obs], settings)
        entries = sorted(folder.glob("*.pickle"))
        assert entries, "the search was not written"
        read = estimate([obs], settings)
        assert sorted(folder.glob("*.pickle")) == entries
        for entry in entries:
            entry.write_bytes(b"not a pickle")
        redone = estimate([obs], settings)
    assert active_search_cache() is None
    for other in (made, read, redone):
        _same(plain, other)
    # The damaged entries were written again, whole.
    assert all(e.stat().st_size > 100 for e in entries)
    assert not list(folder.glob(".*.tmp"))


def test_the_key_follows_the_pixels_the_camera_and_the_settings(view):
    image = np.array(view.image)
    key = search_key(image, view.camera, view.extent, "settings")
    assert key == search_key(image.copy(), view.camera, view.extent, "settings")
    changed = image.copy()
    changed[0, 0, 0] ^= 1
    assert search_key(changed, view.camera, view.extent, "settings") != key
    assert search_key(image, view.camera, view.extent, "other settings") != key
    moved = dataclasses.replace(view.camera, t=view.camera.t + [0.0, 0.0, 1.0])
    assert search_key(image, moved, view.extent, "settings") != key


def test_cached_searches_nest_and_restore(tmp_path):
    with pose_searches_cached(tmp_path / "a"):
        with pose_searches_cached(None):
            assert active_search_cache() is None
        assert active_search_cache() == tmp_path / "a"
    assert active_search_cache() is None
