"""Pose on tables whose seams or grout lines are long straight edges across the view."""

import numpy as np
import pytest

from unseeable.domain import GridPose
from unseeable.errors import InputError
from unseeable.vision import estimate_pose, pose_equivalent
from unseeable.vision.pose import PoseSettings
from unseeable.vision.pose.placement import placement_wood
from unseeable.vision.pose.yaw import collinear_length, concentration, crowd_map


def draw_tiles(camera, *, yaw_deg: float, tile_mm: float = 120.0, grout_mm: float = 3.0,
               tile=(205, 196, 180), grout=(70, 66, 60), seed: int = 0) -> np.ndarray:
    """An (H, W, 3) float32 picture of a table of square tiles whose grout lines run along
    the grid axes at ``yaw_deg`` (both directions, the whole view)."""
    from unseeable.vision.scale import table_point

    rng = np.random.default_rng(seed)
    h, w = camera.height, camera.width
    v, u = np.mgrid[0:h, 0:w]
    pts = table_point(camera, np.stack([u.ravel(), v.ravel()], axis=1).astype(float), 0.0)
    rotation = GridPose(0.0, 0.0, yaw_deg).rotation
    a = np.nan_to_num(pts @ rotation[:, 0] / tile_mm, nan=0.0)
    b = np.nan_to_num(pts @ rotation[:, 2] / tile_mm, nan=0.0)
    shade = rng.uniform(0.9, 1.08, 4096)[(np.floor(a).astype(int) * 61
                                          + np.floor(b).astype(int) * 7) % 4096]
    img = np.asarray(tile, np.float32)[None, :] * shade[:, None]
    at_grout = ((np.abs(a - np.round(a)) * tile_mm < grout_mm / 2)
                | (np.abs(b - np.round(b)) * tile_mm < grout_mm / 2))
    img[at_grout] = np.asarray(grout, np.float32)
    return img.reshape(h, w, 3)


def _seams_and_cluster(rng):
    """Long lines along 0° and 90° all over a 640x480 view, and a compact cluster of short
    segments along 30° and 120°: ``(segments, psi, weights, cluster mask)``."""
    seams = []
    for y in np.arange(20, 480, 40):
        seams += [[[x, y], [x + 150, y]] for x in range(0, 640, 160)]
    for x in np.arange(20, 640, 40):
        seams += [[[x, y], [x, y + 110]] for y in range(0, 480, 120)]
    centre = np.array([400.0, 260.0])
    cluster = [[centre + o, centre + o + [25, 0]] for o in rng.uniform(-40, 40, (16, 2))]
    seg = np.array(seams + cluster, float)
    psi = np.concatenate([np.where(np.arange(len(seams)) < 48, 0.0, 90.0),
                          np.where(np.arange(16) % 2 == 0, 30.0, 120.0)])
    weights = np.linalg.norm(seg[:, 1] - seg[:, 0], axis=1)
    return seg, psi, weights, np.arange(len(seg)) >= len(seams)


def test_directions_spread_over_the_view_lose_their_votes_and_a_compact_cluster_keeps_them():
    seg, psi, weights, cluster = _seams_and_cluster(np.random.default_rng(0))
    crowd = concentration(seg, psi, weights, radius_px=60.0, image_area=640 * 480)
    assert np.all(crowd[cluster] > 0.8)
    assert np.all(crowd[~cluster] < 0.1)
    # Where they crowd: near the cluster, not over the seams far from it.
    near = crowd_map(seg, crowd, (480, 640), radius_px=60.0)
    assert near[260, 410] > 0.5
    assert near[60, 60] < 0.01
    assert concentration(np.zeros((0, 2, 2)), np.zeros(0), np.zeros(0), radius_px=60.0,
                         image_area=1.0).shape == (0,)


def test_a_seam_broken_into_pieces_is_as_long_as_all_of_them():
    # Three pieces of one line (a seam interrupted by crossings or by what stands on it),
    # and a short edge beside it, parallel but 4 px off.
    seg = np.array([[[0, 100], [50, 101]], [[100, 102], [150, 103]], [[300, 106], [350, 107]],
                    [[100, 98], [130, 98.6]]], float)
    total = collinear_length(seg, np.array([10.0, 20.0, 30.0, 5.0]))
    assert total[:3] == pytest.approx([60.0, 60.0, 60.0])
    assert total[3] == pytest.approx(5.0)


def test_thin_dark_lines_read_as_wood_do_not_count_for_the_placement():
    wood = np.zeros((100, 100), np.float32)
    wood[:, 50:52] = 1.0  # a grout line, two pixels wide
    wood[20:40, 10:40] = 1.0  # a log, twenty pixels thick
    out = placement_wood(wood, log_px=20.0)
    assert out[:, 50:52].max() == 0.0
    assert out[25:35, 15:35].min() == pytest.approx(1.0)
    assert placement_wood(wood, 20.0, width_share=0.0, background=False) is None


def test_pose_on_a_tiled_table_whose_grout_runs_across_the_whole_view(scatter_view):
    # Grout lines along two perpendicular directions over the whole table outvote the
    # assembly's short log edges, and fit a grid's lines as well as the logs do; counted
    # by how they crowd, they lose the vote, and the search matches no feature with them.
    from drawing import draw_structure

    s, pose, cam, _ = scatter_view
    table = draw_tiles(cam, yaw_deg=pose.yaw_deg + 38.0, tile_mm=60.0)
    image = draw_structure(s, pose, cam, wood=(150, 100, 60), background=table)
    fit = estimate_pose(image, cam, s.extent)
    dt, dy = pose_equivalent(fit.pose, pose, s.extent)
    assert dt < 3.0 and dy < 1.0
    assert abs((fit.yaw_mod90_deg - pose.yaw_deg + 45.0) % 90.0 - 45.0) < 1.0
    # Votes by length alone, every edge matched, and the wood learnt where the first
    # vote's edges crowd: the grout's grid wins.
    plain = estimate_pose(image, cam, s.extent, strict=False,
                          settings=PoseSettings(spread_excess=0.0, wood_yaw_tries=1,
                                                rare_colour_wood=False))
    assert pose_equivalent(plain.pose, pose, s.extent)[0] > 50.0
    # The wood learnt where the image's rarest colours crowd (the logs' on the tiles')
    # finds the assembly without the crowding of the edges.
    by_colour = estimate_pose(image, cam, s.extent, strict=False,
                              settings=PoseSettings(spread_excess=0.0, wood_yaw_tries=1))
    dt, dy = pose_equivalent(by_colour.pose, pose, s.extent)
    assert dt < 3.0 and dy < 1.0
    # The wood alone finds the assembly again: of the colour models learnt where each
    # vote's edges crowd, the grout's marks the tiles and the assembly's far less.
    by_wood = estimate_pose(image, cam, s.extent, strict=False,
                            settings=PoseSettings(spread_excess=0.0, rare_colour_wood=False))
    dt, dy = pose_equivalent(by_wood.pose, pose, s.extent)
    assert dt < 3.0 and dy < 1.0


def test_the_rarest_colours_crowd_where_a_small_assembly_stands_on_a_tiled_table(
        scatter_view):
    import cv2
    from drawing import draw_structure

    from unseeable.vision.pose.placement import rare_colour_region

    s, pose, cam, _ = scatter_view
    table = draw_tiles(cam, yaw_deg=pose.yaw_deg + 38.0, tile_mm=60.0)
    image = draw_structure(s, pose, cam, wood=(150, 100, 60), background=table)
    clean = draw_structure(s, pose, cam, wood=(150, 100, 60), background=table, noise=0.0)
    logs = np.any(np.abs(clean.astype(float) - table) > 2, axis=2)
    region = rare_colour_region(cv2.cvtColor(image, cv2.COLOR_RGB2Lab))
    assert region[logs].mean() > 0.9  # the assembly's pixels
    assert region[~logs].mean() < 0.1  # hardly any of the table's
    # An image of one colour has no rare colours; a Lab image it must be.
    assert rare_colour_region(np.full((40, 50, 3), 128, np.uint8)) is None
    with pytest.raises(InputError, match="lab"):
        rare_colour_region(np.zeros((40, 50), np.uint8))
    with pytest.raises(InputError, match="lab"):
        rare_colour_region([[1, 2, 3]])  # not an image at all
