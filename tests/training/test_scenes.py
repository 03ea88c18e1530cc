"""Training and validation scene families (rendering itself is tested by the render stage)."""

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from unseeable.domain import Extent, is_valid
from unseeable.errors import InputError
from unseeable.training.scenes import (
    TRAIN,
    TRAIN_HALLS,
    TRAIN_LOOKS,
    TRAIN_TALL,
    TRAIN_WALLS,
    VALIDATION,
    SceneSpec,
    jpeg_roundtrip,
    random_structure,
    random_walls,
    scene_spec,
)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 10_000), density=st.floats(0.2, 0.9))
def test_random_structures_are_valid_and_tight(seed, density):
    s = random_structure(Extent(4, 4, 4), density=density, seed=seed)
    assert is_valid(s)
    occ = s.occupancy != 0
    i, j, k = np.nonzero(occ)
    # The paper's extent convention: the logs fill the grid from 0 to I-1, J-1, K-1.
    assert i.min() == 0 and k.min() == 0 and j.min() == 0
    assert (i.max(), j.max(), k.max()) == (s.extent.I - 1, s.extent.J - 1, s.extent.K - 1)
    assert random_structure(Extent(4, 4, 4), density=density, seed=seed) == s


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 10_000), shape=st.sampled_from([(3, 3, 3), (5, 7, 5), (4, 8, 6)]))
def test_walled_structures_are_valid_tight_walls(seed, shape):
    s = random_walls(Extent(*shape), seed=seed)
    assert is_valid(s) and len(s.logs) >= 1
    occ = s.occupancy != 0
    i, j, k = np.nonzero(occ)
    assert i.min() == 0 and k.min() == 0 and j.min() == 0
    # Walls: inside the outer lines at most one partition line stands.
    inner = np.argwhere(occ[1:-1, :, 1:-1].any(axis=1))
    if len(inner):
        assert len(set(inner[:, 0])) == 1 or len(set(inner[:, 1])) == 1
    assert random_walls(Extent(*shape), seed=seed) == s


def _inner_walls(s) -> int:
    """The fewest grid lines (i or k fixed) that hold every occupied inner column."""
    cells = {tuple(c) for c in np.argwhere((s.occupancy != 0).any(axis=1))}
    inner = {(i, k) for i, k in cells if 0 < i < s.extent.I - 1 and 0 < k < s.extent.K - 1}
    lines = [(0, a) for a in range(1, s.extent.I - 1)] + [(1, a) for a in range(1, s.extent.K - 1)]
    for n in range(len(lines) + 1):
        for chosen in itertools.combinations(lines, n):
            if all(any(c[axis] == a for axis, a in chosen) for c in inner):
                return n
    raise AssertionError("unreachable: all inner lines hold every inner column")


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 10_000))
def test_walls_with_several_rooms(seed):
    s = random_walls(Extent(6, 8, 6), seed=seed, partition=1.0, partitions=3, openings=6)
    assert is_valid(s)
    # Inner walls stand on whole grid lines, at most as many as asked for.
    assert _inner_walls(s) <= 3


def test_walls_with_one_partition_are_those_drawn_before_partitions_was_added():
    # The families made before keep their structures (and their cached renders): this
    # cabin, with its inner wall on k = 1, is what random_walls drew at 41db0b6.
    s = random_walls(Extent(3, 3, 4), seed=125)
    assert s.extent.shape == (3, 2, 4)
    assert sorted((log.layer, tuple(log.at), log.notches) for log in s.logs) == [
        (0, (0, 0), 2), (0, (0, 1), 2), (0, (0, 2), 3), (0, (0, 3), 3), (1, (0, 0), 2),
        (1, (0, 2), 2), (1, (1, 0), 3), (1, (1, 3), 1), (1, (2, 2), 2)]


def test_hall_family_has_several_rooms():
    assert scene_spec("train-halls") is TRAIN_HALLS
    assert TRAIN_HALLS.partitions > 1 and TRAIN_HALLS.walls == 1.0
    assert TRAIN_HALLS.key() not in {TRAIN.key(), VALIDATION.key(), TRAIN_WALLS.key(),
                                     TRAIN_TALL.key(), TRAIN_LOOKS.key()}
    walls = [_inner_walls(random_walls(Extent(6, 8, 6), seed=n, partition=1.0, partitions=3))
             for n in range(10)]
    # Most such cabins have two or three inner walls (two draws may share a line).
    assert sum(n >= 2 for n in walls) >= 6, walls
    with pytest.raises(InputError, match="partitions"):
        SceneSpec("x", partitions=-1)


def test_families_never_share_scenes():
    assert len({TRAIN.key(), VALIDATION.key(), TRAIN_WALLS.key(), TRAIN_TALL.key()}) == 4
    assert scene_spec("train") is TRAIN and scene_spec("validation") is VALIDATION
    assert scene_spec("train-walls") is TRAIN_WALLS and TRAIN_WALLS.walls == 1.0
    assert scene_spec("train-tall") is TRAIN_TALL
    # The tall family reaches the heights the others never do.
    assert max(e[1] for e in TRAIN_TALL.extents) > max(e[1] for e in TRAIN_WALLS.extents)
    # Families made before walled scenes existed keep their cache keys (their renders).
    assert TRAIN.key() == "0c78f967ff" and VALIDATION.key() == "19a5ed6e14"
    # ... and so do those made before the light's and the grain's ranges could be set.
    assert TRAIN_WALLS.key() == "5946c78d28" and TRAIN_TALL.key() == "a93ff58b9a"
    assert scene_spec("train-looks") is TRAIN_LOOKS
    assert TRAIN_LOOKS.key() not in {TRAIN.key(), VALIDATION.key(), TRAIN_WALLS.key(),
                                     TRAIN_TALL.key()}
    # The looks family has the hard shadows and plain logs the others lack.
    assert TRAIN_LOOKS.key_size_mm[1] <= TRAIN.key_size_mm[0]
    assert TRAIN_LOOKS.grain_contrast[0] == 0.0 and TRAIN.grain_contrast == (1.0, 1.0)
    with pytest.raises(InputError):
        scene_spec("test")
    # The validation family looks different: wider colour, light and compression ranges.
    assert VALIDATION.wood_redness[1] > TRAIN.wood_redness[1]
    assert VALIDATION.jpeg_quality[0] < TRAIN.jpeg_quality[0]


def test_jpeg_roundtrip_keeps_the_picture():
    rng = np.random.default_rng(0)
    img = np.clip(rng.normal(128, 20, (32, 48, 3)), 0, 255).astype(np.uint8)
    out = jpeg_roundtrip(img, 90)
    assert out.shape == img.shape and out.dtype == np.uint8
    assert np.abs(out.astype(int) - img.astype(int)).mean() < 15


def test_a_scene_is_the_same_rendered_now_or_read_from_the_cache(tmp_path):
    # The run that renders a scene and every later run (reading the cache) must see the
    # same pixels, or benchmark figures change between the first run and the next.
    from dataclasses import replace

    from unseeable.training.scenes import make_scene

    spec = replace(VALIDATION, name="raster-test", renderer="raster", width=160, height=120)
    fresh = make_scene(spec, 2, cache=tmp_path)
    cached = make_scene(spec, 2, cache=tmp_path)
    uncached = make_scene(spec, 2, cache=False)
    assert np.array_equal(fresh.image, cached.image)
    assert np.array_equal(fresh.image, uncached.image)
    assert fresh.structure == cached.structure and fresh.pose == cached.pose
    with pytest.raises(InputError, match="renderer"):
        replace(VALIDATION, renderer="blender")
