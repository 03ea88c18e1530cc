"""Ray-cast feature visibility: what a user of feature_visibility relies on."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from unseeable.camera import Camera
from unseeable.domain import (
    Extent,
    FeatureKind,
    GridPose,
    Log,
    LogGeometry,
    Structure,
    feature_index,
)
from unseeable.errors import InputError
from unseeable.grammar import full_structure
from unseeable.training.scenes import random_structure
from unseeable.visibility import (
    background_context,
    background_fraction,
    blocked_rays,
    blocked_rays_reference,
    feature_own_logs,
    feature_sample_points,
    feature_visibility,
    first_log_beyond,
    log_cylinders,
    occlusion_fraction,
    rays_beyond,
)

G = LogGeometry()




def features_at(extent: Extent, kinds, i=None, j=None, k=None) -> np.ndarray:
    idx = feature_index(extent)
    mask = np.isin(idx.kind, [int(x) for x in kinds])
    for axis, value in enumerate((i, j, k)):
        if value is not None:
            mask &= np.isin(idx.at[:, axis], np.atleast_1d(value))
    return mask


SEGMENTS = (FeatureKind.U, FeatureKind.V, FeatureKind.W)


# -- geometry ------------------------------------------------------------------

def test_log_cylinders_span_full_log_length_centred_on_notches():
    s = Structure(Extent(3, 2, 3), [Log(layer=0, at=(0, 1), notches=3),
                                    Log(layer=1, at=(2, 0), notches=2)])
    cyl = log_cylinders(s)
    assert cyl.shape == (2, 2, 3)
    # layer 0, along i, k = 1: from -l3 to 2*l1 + l3
    np.testing.assert_allclose(cyl[0], [[-G.l3, G.l2 / 2, G.l1], [2 * G.l1 + G.l3, G.l2 / 2, G.l1]])
    # layer 1, along k, i = 2
    y1 = G.l2 / 2 + G.l2 / 2
    np.testing.assert_allclose(cyl[1], [[2 * G.l1, y1, -G.l3], [2 * G.l1, y1, G.l1 + G.l3]])
    lengths = np.linalg.norm(cyl[:, 1] - cyl[:, 0], axis=1)
    np.testing.assert_allclose(lengths, [G.log_length(3), G.log_length(2)])


def test_segment_samples_lie_on_lower_silhouette_outside_notch_slot():
    extent = Extent(3, 2, 2)
    camera = np.array([100.0, 400.0, -700.0])
    pts, ok = feature_sample_points(extent, camera, n_segment=10)
    idx = feature_index(extent)
    for kind, lo, hi in ((FeatureKind.U, -G.l3, -G.l2 / 2), (FeatureKind.V, G.l2 / 2, G.l3),
                         (FeatureKind.W, G.l3, G.l1 - G.l3)):
        sel = np.flatnonzero(idx.kind == kind)
        at = idx.at[sel]
        along_i = at[:, 1] % 2 == 0
        q = np.stack([at[:, 0] * G.l1, G.layer_height(at[:, 1]), at[:, 2] * G.l1], axis=1)
        p = pts[sel][:, :10]
        offset = np.where(along_i[:, None], p[..., 0] - q[:, None, 0], p[..., 2] - q[:, None, 2])
        assert np.all(offset > lo) and np.all(offset < hi)
        # distance from the axis is the radius, and the points are below the axis
        across = np.where(along_i[:, None], p[..., 2] - q[:, None, 2], p[..., 0] - q[:, None, 0])
        radial = np.hypot(across, p[..., 1] - q[:, None, 1])
        np.testing.assert_allclose(radial, G.radius, atol=1e-9)
        assert np.all(p[..., 1] < q[:, None, 1])
        assert ok[sel][:, :10].all() and not ok[sel][:, 10:].any()


def test_end_samples_on_disc_within_radius():
    extent = Extent(2, 2, 2)
    pts, ok = feature_sample_points(extent, np.array([0.0, 300.0, -500.0]), n_end=16)
    idx = feature_index(extent)
    ends = idx.kind <= FeatureKind.END_PLUS
    at = idx.at[ends]
    sign = np.where(idx.kind[ends] == FeatureKind.END_MINUS, -1.0, 1.0)
    along_i = at[:, 1] % 2 == 0
    centre = np.stack([at[:, 0] * G.l1 + along_i * sign * G.l3, G.layer_height(at[:, 1]),
                       at[:, 2] * G.l1 + ~along_i * sign * G.l3], axis=1)
    d = pts[ends] - centre[:, None, :]
    axial = np.where(along_i[:, None], d[..., 0], d[..., 2])
    np.testing.assert_allclose(axial, 0.0, atol=1e-9)
    assert np.all(np.linalg.norm(d, axis=-1) <= 0.8 * G.radius + 1e-9)
    assert ok[ends].all()


def test_own_logs_of_segments_are_the_log_and_the_one_two_layers_below():
    e = Extent(2, 3, 1)
    s = Structure(e, [Log(layer=0, at=(0, 0), notches=2), Log(layer=2, at=(0, 0), notches=1)])
    own = feature_own_logs(s)
    idx = feature_index(e)
    # s.logs sorted: layer 0 log is id 0, layer 2 log is id 1
    assert sorted(own[idx.lookup(FeatureKind.U, (0, 2, 0))]) == [0, 1]
    assert sorted(own[idx.lookup(FeatureKind.W, (0, 2, 0))]) == [-1, 0]  # 1-notch ends at q+l3
    assert sorted(own[idx.lookup(FeatureKind.W, (0, 0, 0))]) == [-1, 0]
    assert sorted(own[idx.lookup(FeatureKind.V, (1, 4, 0))]) == [-1, -1]
    assert own[idx.lookup(FeatureKind.END_PLUS, (1, 0, 0)), 0] == 0


# -- visibility semantics -------------------------------------------------------

def test_lone_log_fully_visible_from_above():
    e = Extent(3, 1, 2)
    s = Structure(e, [Log(layer=0, at=(0, 0), notches=3)])
    camera = np.array([64.0, 900.0, -350.0])
    frac = occlusion_fraction(s, camera, GridPose())
    # its bottom edges (layer 0) and top edges (layer 2), all along the row k = 0
    mine = features_at(e, SEGMENTS, j=[0, 2], k=0) & ~features_at(e, [FeatureKind.W], i=2)
    assert mine.sum() == 16
    assert np.all(frac[mine] == 0.0)
    assert feature_visibility(s, camera, GridPose())[mine].all()


def test_log_behind_a_wall_is_occluded_and_visible_without_it():
    e = Extent(3, 7, 3)
    target = Log(layer=0, at=(0, 2), notches=3)
    wall = [Log(layer=j, at=(0, 0), notches=3) for j in (0, 2, 4, 6)]
    camera = np.array([64.0, 60.0, -900.0])  # low, in front of the wall (k < 0)
    mine = features_at(e, SEGMENTS, j=[0, 2], k=2) & ~features_at(e, [FeatureKind.W], i=2)
    alone = feature_visibility(Structure(e, [target]), camera, GridPose())
    hidden = feature_visibility(Structure(e, [target, *wall]), camera, GridPose())
    assert alone[mine].all()
    assert not hidden[mine].any()
    # leaving the wall out through the blockers mask gives back the lone view
    s = Structure(e, [target, *wall])
    mask = np.array([log == target for log in s.logs])
    np.testing.assert_array_equal(feature_visibility(s, camera, GridPose(), blockers=mask),
                                  alone)


def test_wood_behind_an_empty_place_is_the_far_wall_and_never_the_features_own_log():
    e = Extent(3, 7, 3)
    camera = np.array([64.0, 60.0, -900.0])  # low, in front (k < 0)
    near = Log(layer=0, at=(0, 0), notches=3)
    far_wall = [Log(layer=j, at=(0, 2), notches=3) for j in (0, 2, 4, 6)]
    empty_middle = features_at(e, [FeatureKind.U], i=[0, 1], j=[2, 4], k=1)
    with_wall = background_fraction(Structure(e, [near, *far_wall]), camera, GridPose())
    without = background_fraction(Structure(e, [near]), camera, GridPose())
    assert np.all(with_wall[empty_middle] > 0.5)  # the wall has gaps at odd layers
    assert np.all(without[empty_middle] == 0.0)
    # the near log's own segments: nothing but the table behind them without the wall
    own = features_at(e, [FeatureKind.U], i=[0, 1], j=0, k=0)
    assert np.all(without[own] == 0.0)
    assert np.all((with_wall >= 0) & (with_wall <= 1))


def test_a_far_logs_edge_along_a_features_line_is_found_and_wood_throughout_is_not():
    # A lone log at k = 1 seen from high up in front: the top silhouette of that log
    # runs just below the line of the u segment at (0, 2, 0) (no wood behind the line
    # itself), while behind the u segment at (0, 1, 1) there is wood above and below.
    s = Structure(Extent(1, 1, 2), [Log(layer=0, at=(0, 1), notches=1)])
    camera = np.array([0.0, 300.0, -900.0])
    (edge_line,) = np.flatnonzero(features_at(s.extent, [FeatureKind.U], i=0, j=2, k=0))
    (over_wood,) = np.flatnonzero(features_at(s.extent, [FeatureKind.U], i=0, j=1, k=1))
    c = background_context(s, camera, GridPose())
    assert c[edge_line, 0] == 0.0 and c[edge_line, 1] > 0.5
    assert c[over_wood, 0] == 1.0 and c[over_wood, 1] < 0.2
    empty = background_context(Structure(s.extent, []), camera, GridPose())
    assert np.all(empty == 0.0)
    with pytest.raises(InputError, match="edge_offset_mm"):
        background_context(s, camera, GridPose(), edge_offset_mm=0.0)


def _random_scene(seed: int, extent: Extent, density: float):
    """A random structure, a camera in front of it and a pose on the table."""
    rng = np.random.default_rng(seed)
    s = random_structure(extent, density=density, seed=seed)
    camera = np.array([rng.uniform(-400, 400), rng.uniform(80, 600), -800.0])
    return s, camera, GridPose(rng.uniform(-20, 20), rng.uniform(-20, 20), rng.uniform(0, 90))


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 10_000))
def test_background_context_is_the_wood_share_and_an_edge_share(seed):
    s, camera, pose = _random_scene(seed, Extent(3, 4, 3), 0.6)
    c = background_context(s, camera, pose)
    assert c.shape == (len(feature_index(s.extent)), 2)
    np.testing.assert_array_equal(c[:, 0], background_fraction(s, camera, pose))
    assert np.all((c >= 0) & (c <= 1))


def test_the_first_log_beyond_is_met_exactly_where_rays_beyond_meet_one():
    rng = np.random.default_rng(11)
    camera = np.array([0.0, 300.0, -700.0])
    cylinders = rng.uniform(-150, 150, (12, 2, 3))
    points = rng.uniform(-200, 200, (40, 6, 3))
    valid = rng.random((40, 6)) < 0.9
    first = first_log_beyond(points, valid, camera, cylinders, 15.0)
    np.testing.assert_array_equal(first >= 0, rays_beyond(points, valid, camera, cylinders,
                                                          15.0))


@settings(max_examples=20, deadline=None)
@given(kept=st.lists(st.booleans(), min_size=4, max_size=4))
def test_the_first_log_beyond_is_the_nearest_one(kept):
    # Walls across the line of sight at increasing distance behind the point; some left out.
    camera = np.array([0.0, 0.0, 500.0])
    walls = np.array([[[-80.0, 0, -z], [80.0, 0, -z]] for z in (50.0, 120.0, 200.0, 320.0)])
    keep = np.flatnonzero(kept)
    first = first_log_beyond(np.zeros((1, 1, 3)), np.ones((1, 1), bool), camera, walls[keep],
                             10.0)[0, 0]
    assert first == (0 if len(keep) else -1)  # index into the kept walls: the nearest


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 10_000))
def test_pruning_the_rays_cast_past_their_points_changes_no_answer(seed):
    # Logs of a random structure (touching, stacked, crossing: many near ties) and rays
    # lifted off their points, as background_context casts them, against every pair tested.
    from unseeable.visibility.rays import _beyond_args, _beyond_kernel, _first_beyond_kernel

    rng = np.random.default_rng(seed)
    s = random_structure(Extent(4, 4, 4), density=0.7, seed=seed)
    cylinders = log_cylinders(s)
    camera = np.array([rng.uniform(-500, 500), rng.uniform(50, 600), rng.uniform(-900, -300)])
    points, valid = feature_sample_points(s.extent, camera)
    points = points + rng.uniform(-3.0, 3.0, points.shape)
    own = feature_own_logs(s)
    for kernel in (_beyond_kernel, _first_beyond_kernel):
        pruned = kernel(*_beyond_args(points, valid, camera, cylinders, G.radius, own, 2000.0))
        every = kernel(*_beyond_args(points, valid, camera, cylinders, G.radius, own, 2000.0,
                                     prune=False))
        np.testing.assert_array_equal(pruned, every)


def test_rays_beyond_a_point_are_blocked_rays_to_a_camera_behind_it():
    # The same segment, walked the other way: a camera placed on the far side of the
    # point, on the line from the real camera, sees exactly what lies behind the point.
    rng = np.random.default_rng(5)
    camera = np.array([0.0, 300.0, -700.0])
    cylinders = rng.uniform(-150, 150, (12, 2, 3))
    points = rng.uniform(-150, 150, (200, 1, 3))
    valid = np.ones((200, 1), bool)
    beyond = rays_beyond(points, valid, camera, cylinders, 12.0, reach=1000.0)
    mirrored = []
    for p in points[:, 0]:
        away = (p - camera) / np.linalg.norm(p - camera)
        far = p + (1000.0 + 0.1) * away
        mirrored.append(blocked_rays(p[None, None], np.ones((1, 1), bool), far, cylinders,
                                     12.0)[0, 0])
    assert 20 < beyond.sum() < 180  # both outcomes occur
    np.testing.assert_array_equal(beyond[:, 0], mirrored)
    with pytest.raises(InputError):
        rays_beyond(points, valid, camera, cylinders, 12.0, reach=-1.0)


def test_end_facing_away_is_occluded():
    e = Extent(2, 1, 1)
    s = Structure(e, [Log(layer=0, at=(0, 0), notches=2)])
    idx = feature_index(e)
    camera = np.array([-800.0, 150.0, 20.0])  # beyond the low-i end
    vis = feature_visibility(s, camera, GridPose())
    frac = occlusion_fraction(s, camera, GridPose())
    assert vis[idx.lookup(FeatureKind.END_MINUS, (0, 0, 0))]
    assert not vis[idx.lookup(FeatureKind.END_PLUS, (1, 0, 0))]
    assert frac[idx.lookup(FeatureKind.END_PLUS, (1, 0, 0))] == 1.0
    # an empty structure hides nothing, but a turned-away end stays occluded
    empty = feature_visibility(Structure(e, []), camera, GridPose())
    assert empty[idx.kind == FeatureKind.END_MINUS].all()
    assert not empty[idx.kind == FeatureKind.END_PLUS].any()
    assert empty[idx.kind >= FeatureKind.U].all()


def test_threshold_decides_partly_blocked_features():
    e = Extent(4, 6, 4)
    s = full_structure(e)
    camera = np.array([-300.0, 500.0, -500.0])
    frac = occlusion_fraction(s, camera, GridPose())
    partial = (frac > 0) & (frac < 1)
    assert partial.any()
    t = float(np.median(frac[partial]))
    vis = feature_visibility(s, camera, GridPose(), threshold=t)
    np.testing.assert_array_equal(vis, frac < t)
    with pytest.raises(InputError):
        feature_visibility(s, camera, GridPose(), threshold=0.0)


def test_full_structure_hides_its_back_bottom_and_shows_its_front():
    e = Extent(4, 4, 4)
    s = full_structure(e)
    camera = np.array([-400.0, 450.0, -500.0])  # in front of the (i=0, k=0) corner
    vis = feature_visibility(s, camera, GridPose())
    # Logs are thin and 64 mm apart, so much of the inside shows through the gaps;
    # the bottom layer at the back corner does not.
    back_bottom = features_at(e, SEGMENTS, i=[2, 3], j=0, k=[2, 3])
    assert back_bottom.sum() == 12
    assert not vis[back_bottom].any()
    # u segments (camera side of the slot) on the outer rows of the two front faces
    front_u = (features_at(e, [FeatureKind.U], i=0, j=[1, 3, 5])
               | features_at(e, [FeatureKind.U], k=0, j=[0, 2, 4]))
    assert vis[front_u].all()


@settings(max_examples=20, deadline=None)
@given(x=st.floats(-500, 500), z=st.floats(-500, 500), yaw=st.floats(-180, 180),
       seed=st.integers(0, 2**31 - 1))
def test_visibility_is_invariant_to_pose(x, z, yaw, seed):
    rng = np.random.default_rng(seed)
    e = Extent(3, 3, 3)
    s = full_structure(e).with_logs(
        [log for log in full_structure(e).logs if rng.random() < 0.6])
    cam_grid = rng.uniform([-600, 100, -600], [800, 700, 800])
    pose = GridPose(x, z, yaw)
    cam_world = pose.grid_to_world(cam_grid)
    expected = occlusion_fraction(s, cam_grid, GridPose())
    got = occlusion_fraction(s, cam_world, pose)
    np.testing.assert_array_equal(got > 0.5, expected > 0.5)
    np.testing.assert_allclose(got, expected, atol=1e-12)
    camera = Camera.look_at(eye=cam_world, target=pose.grid_to_world([64.0, 0.0, 64.0]),
                            width=64, height=48, fov_deg=60)
    np.testing.assert_array_equal(feature_visibility(s, camera, pose),
                                  feature_visibility(s, cam_world, pose))


# -- numba kernel vs plain numpy -------------------------------------------------

@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n_cyl=st.integers(0, 12), n_feat=st.integers(1, 20),
       camera_scale=st.sampled_from([0.2, 1.0]))
def test_numba_kernel_agrees_with_numpy_reference(seed, n_cyl, n_feat, camera_scale):
    # camera_scale 0.2 puts the camera among the cylinders (inside some bounding spheres)
    rng = np.random.default_rng(seed)
    cylinders = rng.uniform(-100, 100, size=(n_cyl, 2, 3))
    if n_cyl:
        # some cylinders along the grid axes, as logs are
        axis_aligned = rng.random(n_cyl) < 0.5
        cylinders[axis_aligned, 1] = cylinders[axis_aligned, 0]
        cylinders[axis_aligned, 1, rng.integers(0, 3)] += rng.uniform(-150, 150)
    radius = rng.uniform(1, 30, size=n_cyl)
    points = rng.uniform(-120, 120, size=(n_feat, 5, 3))
    valid = rng.random((n_feat, 5)) < 0.8
    camera = rng.uniform(-400, 400, size=3) * camera_scale
    exclude = rng.integers(-1, max(n_cyl, 1), size=(n_feat, 2))
    fast = blocked_rays(points, valid, camera, cylinders, radius, exclude=exclude)
    slow = blocked_rays_reference(points, valid, camera, cylinders, radius, exclude=exclude,
                                  chunk=7)
    np.testing.assert_array_equal(fast, slow)


def test_numba_kernel_agrees_with_numpy_reference_on_a_structure():
    e = Extent(4, 5, 3)
    s = full_structure(e)
    camera = np.array([-250.0, 380.0, -420.0])
    pts, ok = feature_sample_points(e, camera)
    cyl = log_cylinders(s)
    own = feature_own_logs(s)
    fast = blocked_rays(pts, ok, camera, cyl, G.radius, exclude=own)
    slow = blocked_rays_reference(pts, ok, camera, cyl, G.radius, exclude=own)
    assert 0.2 < fast[ok].mean() < 0.95  # a real mix of blocked and free rays
    np.testing.assert_array_equal(fast, slow)


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 10_000))
def test_rays_cast_on_two_threads_give_the_same_answers(seed):
    s, camera, pose = _random_scene(seed, Extent(4, 5, 3), 0.7)
    np.testing.assert_array_equal(background_context(s, camera, pose, threads=2),
                                  background_context(s, camera, pose))
    np.testing.assert_array_equal(feature_visibility(s, camera, pose, threads=2),
                                  feature_visibility(s, camera, pose))
    with pytest.raises(InputError, match="threads"):
        feature_visibility(s, camera, pose, threads=0)


def test_grazing_rays_along_a_touching_log_are_not_blocked():
    # A ray running along the top line of a log (tangent) is not blocked.
    cyl = np.array([[[0.0, 0.0, 0.0], [100.0, 0.0, 0.0]]])
    pts = np.array([[[-10.0, 9.5, 0.0]]])
    camera = np.array([500.0, 9.5, 0.0])
    ok = np.ones((1, 1), bool)
    assert not blocked_rays(pts, ok, camera, cyl, 9.5)[0, 0]
    assert blocked_rays(pts - [0, 1.0, 0], ok, camera - [0, 1.0, 0], cyl, 9.5)[0, 0]
