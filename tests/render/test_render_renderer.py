"""The Mitsuba renderer: ground truth consistent with the cameras, deterministic images."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from unseeable.camera import Camera
from unseeable.domain import (
    Extent,
    FeatureKind,
    GridPose,
    Log,
    LogGeometry,
    Structure,
    feature_axes,
    feature_index,
    feature_values,
)
from unseeable.errors import InputError
from unseeable.render.renderer import render, render_ground_truth, render_view
from unseeable.render.settings import RenderSettings, SceneParams, SceneRandomisation
from unseeable.render.workspace import PendulumArm, default_pose

G = LogGeometry()
FAST = RenderSettings(spp=4)


@pytest.fixture(scope="module")
def cabin_view(cabin_structure):
    pose = default_pose(cabin_structure.extent)
    camera = PendulumArm(radius_mm=500, width=160, height=120).camera(150.0)
    return cabin_structure, pose, camera, render(cabin_structure, pose, camera, settings=FAST,
                                                 seed=3)


def test_outputs_have_the_documented_shapes_and_types(cabin_view):
    structure, pose, camera, r = cabin_view
    assert r.image.shape == (120, 160, 3) and r.image.dtype == np.uint8
    assert r.ids.shape == (120, 160) and r.ids.dtype == np.int32
    assert r.depth.shape == (120, 160) and r.depth.dtype == np.float32
    assert set(np.unique(r.ids)) <= set(range(-1, len(structure.logs)))
    # Every log of the cabin shows somewhere; the table fills the rest.
    assert len(np.unique(r.ids[r.ids >= 0])) >= len(structure.logs) // 2
    assert (r.ids == -1).mean() > 0.5
    # The image is not blank: wood is darker and redder than nothing.
    assert r.image.std() > 5


def test_depth_is_camera_z_of_the_table_plane(cabin_view):
    _, _, camera, r = cabin_view
    table = r.ids == -1
    v, u = np.nonzero(table)
    rays = camera.pixel_rays(np.stack([u, v], axis=1).astype(float))
    # Intersect each pixel ray with the table (y = 0) and compare camera z.
    c = camera.centre
    t = -c[1] / rays[:, 1]
    hit = c + t[:, None] * rays
    np.testing.assert_allclose(r.depth[v, u], camera.depth(hit), rtol=1e-4)


def test_log_end_centre_projects_onto_its_log():
    # One 2-notch log along x, camera in front of its end- disc and a little above.
    s = Structure(Extent(2, 1, 1), [Log(0, (0, 0), 2)])
    pose = GridPose(10.0, -20.0, 30.0)
    centre = pose.grid_to_world(np.array([-G.l3, G.layer_height(0), 0.0]))
    outward = pose.directions_to_world(np.array([-1.0, 0.0, 0.0]))
    eye = centre + 300 * outward + np.array([0.0, 120.0, 0.0])
    cam = Camera.look_at(eye=eye, target=centre, width=96, height=72, fov_deg=40)
    ids, depth = render_ground_truth(s, pose, cam)
    u, v = np.rint(cam.project(centre[None])[0]).astype(int)
    assert ids[v, u] == 0
    assert depth[v, u] == pytest.approx(cam.depth(centre[None])[0], abs=1.0)
    # A principal point off the centre moves the picture with it.
    K = cam.K.copy()
    K[0, 2] += 11.0
    K[1, 2] -= 7.0
    shifted = Camera(cam.width, cam.height, K, cam.R, cam.t)
    ids2, _ = render_ground_truth(s, pose, shifted)
    np.testing.assert_array_equal(ids2[10:60, 20:80], ids[17:67, 9:69])


def test_visible_log_ends_land_on_their_logs(cabin_view):
    structure, pose, camera, r = cabin_view
    idx = feature_index(structure.extent)
    present = feature_values(structure.extent, structure.occupancy)
    axes = pose.grid_to_world(feature_axes(structure.extent, G))
    ends = np.nonzero(present & (idx.kind <= FeatureKind.END_PLUS))[0]
    normal = axes[ends, 1] - axes[ends, 0]
    facing = np.sum(normal * (camera.centre - axes[ends, 0]), axis=1) > 0
    # Unoccluded: the depth map at the projected centre matches the centre's depth.
    uv = np.rint(camera.project(axes[ends, 0])).astype(int)
    owner = {}
    for n, log in enumerate(structure.logs):
        for q in log.positions():
            owner[q] = n
    checked = 0
    for f, (u, v), face in zip(ends, uv, facing):
        if not face:
            continue
        d = camera.depth(axes[f, 0][None])[0]
        if abs(r.depth[v, u] - d) < 2.0:
            assert r.ids[v, u] == owner[tuple(idx.at[f])]
            checked += 1
    assert checked >= 4


def test_the_same_seed_gives_the_same_image():
    # Large enough that the renderer splits the image between threads.
    s = Structure(Extent(2, 2, 1), [Log(0, (0, 0), 2), Log(1, (0, 0), 1), Log(1, (1, 0), 1)])
    cam = PendulumArm(radius_mm=300, width=320, height=240).camera(120.0)
    pose = default_pose(s.extent)
    a = render_view(s, pose, cam, settings=FAST, seed=7)
    b = render_view(s, pose, cam, settings=FAST, seed=7)
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x, y)
    c = render_view(s, pose, cam, settings=FAST, seed=8)
    assert not np.array_equal(a[0], c[0])
    np.testing.assert_array_equal(a[1], c[1])  # the ground truth does not depend on the seed


def test_randomised_scenes_vary_with_the_seed_and_repeat_with_it():
    s = Structure(Extent(1, 1, 1), [Log(0, (0, 0), 1)])
    cam = PendulumArm(radius_mm=300, width=48, height=36).camera(90.0)
    settings = RenderSettings(spp=2, randomisation=SceneRandomisation())
    r1 = render(s, GridPose(), cam, settings=settings, seed=1)
    r2 = render(s, GridPose(), cam, settings=settings, seed=2)
    r1b = render(s, GridPose(), cam, settings=settings, seed=1)
    assert r1.look != r2.look and r1.look == r1b.look
    np.testing.assert_array_equal(r1.image, r1b.image)
    assert np.abs(r1.image.astype(int) - r2.image.astype(int)).mean() > 2


def test_grain_contrast_is_drawn_only_from_a_real_range():
    # The standard looks (a single grain contrast) draw exactly what they drew before the
    # field existed: every other field is the same whatever that single value is.
    plain = SceneParams.sample(SceneRandomisation(grain_contrast=(0.3, 0.3)),
                               np.random.default_rng(5))
    standard = SceneParams.sample(SceneRandomisation(), np.random.default_rng(5))
    assert plain.grain_contrast == 0.3 and standard.grain_contrast == 1.0
    assert replace(plain, grain_contrast=1.0) == standard
    assert "grain_contrast" not in standard.to_json() and plain.to_json()["grain_contrast"] == 0.3
    drawn = [SceneParams.sample(SceneRandomisation(grain_contrast=(0.0, 0.6)),
                                np.random.default_rng(n)).grain_contrast for n in range(20)]
    assert 0.0 <= min(drawn) < max(drawn) <= 0.6
    with pytest.raises(InputError):
        SceneRandomisation(grain_contrast=(-0.5, 1.0))


def test_plain_logs_have_no_grain():
    # Grain contrast 0 paints the logs in their textures' mean colour; 1 leaves them as drawn.
    from unseeable.render.renderer import _with_contrast
    from unseeable.render.textures import side_grain

    grain = side_grain(seed=3)
    plain = _with_contrast(grain, 0.0)
    np.testing.assert_allclose(plain, np.broadcast_to(grain.reshape(-1, 3).mean(0), grain.shape),
                               atol=1e-6)
    np.testing.assert_allclose(_with_contrast(grain, 1.0), grain, atol=1e-6)
    half = _with_contrast(grain, 0.5)
    spread = [np.std(t - t.mean(axis=(0, 1))) for t in (half, grain)]
    assert spread[0] == pytest.approx(0.5 * spread[1], rel=0.02)
    # And the renderer uses it.
    s = Structure(Extent(1, 1, 1), [Log(0, (0, 0), 1)])
    cam = Camera.look_at(eye=[0, 200, 0.1], target=[0, 0, 0], width=64, height=48,
                         fov_deg=20)
    images = [render_view(s, GridPose(), cam, settings=RenderSettings(spp=2),
                          look=SceneParams(grain_contrast=c))[0] for c in (1.0, 0.0)]
    assert not np.array_equal(images[0], images[1])


def test_distorted_camera_ground_truth_follows_the_distortion():
    s = Structure(Extent(2, 1, 1), [Log(0, (0, 0), 2)])
    plain = Camera.look_at(eye=[30, 250, -250], target=[30, 0, 0], width=80, height=60,
                           fov_deg=60)
    bent = Camera(80, 60, plain.K, plain.R, plain.t, [-0.25, 0.05, 0.0, 0.0, 0.0])
    ids, _ = render_ground_truth(s, GridPose(), bent)
    # The log's axis points project (with distortion) onto the log.
    pts = np.stack([np.linspace(-10, 70, 9), np.full(9, G.layer_height(0)), np.zeros(9)], 1)
    pts[:, 1] += G.radius * 0.9  # on its top
    uv = np.rint(bent.project(pts)).astype(int)
    assert np.mean(ids[uv[:, 1], uv[:, 0]] == 0) >= 8 / 9
    image, _, _ = render_view(s, GridPose(), bent, settings=RenderSettings(spp=1))
    assert image.shape == (60, 80, 3)


def test_bad_inputs_are_input_errors():
    s = Structure(Extent(1, 1, 1), [Log(0, (0, 0), 1)])
    cam = PendulumArm(width=8, height=6).camera(90.0)
    with pytest.raises(InputError):
        render_view(s, (0, 0, 0), cam)
    with pytest.raises(InputError):
        render_view(s, GridPose(), cam, seed=-1)
    with pytest.raises(InputError):
        RenderSettings(spp=0)
    with pytest.raises(InputError):
        RenderSettings(variant="cuda_ad_rgb")


def test_scalar_variant_gives_the_same_ground_truth(cabin_view):
    structure, pose, camera, r = cabin_view
    scalar = render(structure, pose, camera, settings=RenderSettings(spp=2,
                                                                     variant="scalar_rgb"))
    assert scalar.variant == "scalar_rgb"
    np.testing.assert_array_equal(scalar.ids, r.ids)
    finite = np.isfinite(r.depth)
    np.testing.assert_allclose(scalar.depth[finite], r.depth[finite], atol=0.05)
    # Same scene, same exposure: the photographs match up to sampling noise.
    assert abs(float(scalar.image.mean()) - float(r.image.mean())) < 3.0
