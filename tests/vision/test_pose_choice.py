"""The grid's near-symmetric pose aliases, and the structure-based choice between them."""

import dataclasses

import numpy as np
import pytest

from unseeable.domain import GridPose, LogGeometry
from unseeable.errors import InputError
from unseeable.vision import (
    detect_features,
    detection_gain,
    pose_equivalent,
    refine_pose_on_structure,
    select_pose,
    structure_gain,
)
from unseeable.vision.pose import pose_aliases
from unseeable.vision.pose_choice import fills_extent, pitch_shift


@pytest.mark.parametrize("yaw", [0.0, 23.0, 45.0, -70.0])
def test_an_alias_moves_the_other_axis_lines_onto_lines_half_layers_away(arm_camera, yaw):
    from conftest import centred_pose, house

    g = LogGeometry()
    s = house()
    pose = centred_pose(s.extent, yaw)
    cam = arm_camera
    aliases = pose_aliases(pose, cam, s.extent, layers=(1, 2))
    assert len(aliases) == 8
    centre = pose.grid_to_world(np.array([64.0, 0.0, 64.0]))
    view = centre - cam.centre
    view_h = np.array([view[0], 0.0, view[2]]) / np.hypot(view[0], view[2])
    for a_index, axis in enumerate((0, 2)):
        along = pose.rotation[:, axis]
        if abs(along @ view_h) < 0.7:
            continue  # the step is clamped there: only roughly an alias
        other = pose.rotation[:, 2 - axis]  # lines of the other axis run along this
        for n_index, n in enumerate((1, 2)):
            errors = []
            for sign_index in (0, 1):
                alias = aliases[a_index * 4 + n_index * 2 + sign_index]
                move = np.array([alias.x - pose.x, 0.0, alias.z - pose.z])
                # The alias's image of a point against the image of a line n half-layers
                # up or down through the original point (the same horizontal line).
                p = centre + np.array([0.0, 30.0, 0.0])
                q = cam.project(p + move)
                best = np.inf
                for dy in (n * g.radius, -n * g.radius):
                    line = cam.project(np.stack([p + [0, dy, 0] - 200 * other,
                                                 p + [0, dy, 0] + 200 * other]))
                    d = line[1] - line[0]
                    normal = np.array([-d[1], d[0]]) / np.linalg.norm(d)
                    best = min(best, abs((q - line[0]) @ normal))
                errors.append(best)
            assert max(errors) < 1.0, (yaw, axis, n, errors)


def test_the_structure_choice_rejects_an_alias_that_edges_prefer(rendered_house):
    s, pose, cam, image = rendered_house
    alias = pose_aliases(pose, cam, s.extent, layers=(2,))
    from unseeable.vision import estimate_pose

    fit = estimate_pose(image, cam, s.extent, strict=False)
    wrong = min(alias, key=lambda a: pose_equivalent(a, fit.pose, s.extent)[0])
    # Both offered, the alias first and with the higher edge score.
    offered = dataclasses.replace(fit, pose=wrong, candidates=((wrong, 100.0), (pose, 95.0)))
    chosen = select_pose(image, cam, s.extent, offered, polish=False)
    assert pose_equivalent(chosen.pose, pose, s.extent)[0] < 0.5
    assert structure_gain(image, cam, s.extent, pose) > structure_gain(image, cam, s.extent,
                                                                      wrong)


def test_detections_already_made_are_valued_as_the_choice_values_a_pose(rendered_house):
    # What estimate_view compares when its polish moves a pose: the same value as
    # structure_gain at each pose (a small extent: the solve is not cut short).
    s, pose, cam, image = rendered_house
    wrong = pose_aliases(pose, cam, s.extent, layers=(2,))[0]
    gains = []
    for at in (pose, wrong):
        det = detect_features(image, cam, at, s.extent, refine=False)
        gains.append(detection_gain(det))
        assert gains[-1] == pytest.approx(structure_gain(image, cam, s.extent, at), abs=1e-9)
    assert gains[0] > gains[1]


def test_the_choice_reports_how_clearly_it_won(rendered_house):
    from unseeable.vision import estimate_pose
    from unseeable.vision.pose_choice import AMBIGUOUS_CHOICE_MARGIN

    s, pose, cam, image = rendered_house
    fit = estimate_pose(image, cam, s.extent, strict=False)
    wrong = pose_aliases(pose, cam, s.extent, layers=(2,))[0]
    clear = select_pose(image, cam, s.extent, dataclasses.replace(
        fit, candidates=((wrong, 100.0), (pose, 95.0))), polish=False, pitch_check=False)
    assert clear.choice_margin > AMBIGUOUS_CHOICE_MARGIN and not clear.ambiguous
    assert clear.choice_rival == wrong  # the other candidate, should the choice be wrong
    assert clear.to_json()["choice_margin"] == clear.choice_margin
    assert clear.to_json()["rival"] == wrong.to_json()
    # One candidate, or the same pose twice: no rival, nothing to be ambiguous about.
    for offered in (((pose, 95.0),), ((pose, 95.0), (pose, 95.0))):
        lone = select_pose(image, cam, s.extent, dataclasses.replace(fit, candidates=offered),
                           polish=False)
        assert lone.choice_margin is None and lone.choice_rival is None
        assert not lone.ambiguous and "choice_margin" not in lone.to_json()


def test_the_margin_is_over_the_best_rival_not_over_a_near_copy_of_the_choice():
    from unseeable.domain import Extent
    from unseeable.vision.pose_choice import lead_over_rival

    extent, g = Extent(3, 2, 3), LogGeometry()
    chosen = GridPose(0.0, 0.0, 10.0)
    copy = GridPose(1.0, 0.5, 10.3)  # the same pose aligned a millimetre away
    pitch = GridPose(32.0, 0.0, 10.0)  # a grid pitch along x: a rival
    turned = GridPose(0.0, 0.0, 13.0)  # three degrees: a rival
    judged = [(copy, 5.99), (chosen, 6.0), (pitch, 5.95), (turned, 5.5)]
    margin, rival = lead_over_rival(judged, chosen, extent, g)
    assert margin == pytest.approx(0.05) and rival == pitch
    assert lead_over_rival(judged[:2], chosen, extent, g) == (None, None)
    # A rival whose structure could not be solved (value -inf) is no rival.
    assert lead_over_rival([(chosen, 6.0), (pitch, -np.inf)], chosen, extent, g) == (None, None)
    # The half turn numbers the same grid from the other corner: the same pose.
    half = chosen.turned(2, extent, g)[0]
    assert lead_over_rival([(chosen, 6.0), (half, 5.99)], chosen, extent, g) == (None, None)


def test_a_single_candidate_is_returned_unchanged_unless_polished(rendered_house):
    s, pose, cam, image = rendered_house
    from unseeable.vision import estimate_pose

    fit = estimate_pose(image, cam, s.extent, strict=False)
    lone = dataclasses.replace(fit, candidates=((fit.pose, fit.score),))
    assert select_pose(image, cam, s.extent, lone, polish=False, pitch_check=False) is lone
    polished = select_pose(image, cam, s.extent, lone)
    assert polished.pose != fit.pose
    mm, deg = pose_equivalent(polished.pose, pose, s.extent)
    assert mm < 2.0 and deg < 1.0


def test_the_choice_hands_back_its_detections_at_every_candidate(rendered_house):
    s, pose, cam, image = rendered_house
    from unseeable.vision import detect_features, estimate_pose

    fit = estimate_pose(image, cam, s.extent, strict=False)
    alias = pose_aliases(fit.pose, cam, s.extent, layers=(2,))[0]
    offered = dataclasses.replace(fit, candidates=((fit.pose, fit.score), (alias, fit.score)))
    detections = {}
    chosen = select_pose(image, cam, s.extent, offered, polish=False, pitch_check=False,
                         detections=detections)
    assert set(detections) == {fit.pose, alias} and chosen.pose in detections
    # What the pipeline would otherwise detect again at the chosen pose (unpolished).
    again = detect_features(image, cam, chosen.pose, s.extent, refine=False)
    assert np.array_equal(detections[chosen.pose].p, again.p)
    assert np.array_equal(detections[chosen.pose].judged, again.judged)


@pytest.mark.parametrize("rim_weight", [1.0, 4.0])
@pytest.mark.parametrize("axis", [0, 2])
def test_a_pose_slid_along_a_grid_axis_is_polished_back_by_the_structures_edges(
        rendered_house, axis, rim_weight):
    # Sliding along one axis moves that axis's lines only along themselves: the
    # structure's log ends and the ends of its covered stretches bring it back.
    s, pose, cam, image = rendered_house
    move = 4.0 * pose.rotation[:, axis]
    slid = GridPose(pose.x + move[0], pose.z + move[2], pose.yaw_deg)
    polished = refine_pose_on_structure(image, cam, s, slid, rim_weight=rim_weight)
    assert pose_equivalent(polished, pose, s.extent)[0] < 1.5
    assert polished.yaw_deg == pytest.approx(pose.yaw_deg, abs=0.5)


@pytest.mark.parametrize("turn_deg", [0.0, 90.0])
def test_a_wide_polish_brings_back_a_pose_a_centimetre_off(rendered_house, turn_deg):
    # 10 mm is beyond the default reach's 3 px (about 5 mm here): the wide polish's first
    # stages look 9 and 6 px out and bring the pose back (a depth alias is as far off).
    s, pose, cam, image = rendered_house
    look = np.array([cam.R[2, 0], cam.R[2, 2]])
    c, sn = np.cos(np.radians(turn_deg)), np.sin(np.radians(turn_deg))
    move = 10.0 * np.array([c * look[0] - sn * look[1], sn * look[0] + c * look[1]])
    move /= np.linalg.norm(look)
    start = GridPose(pose.x + move[0], pose.z + move[1], pose.yaw_deg)
    polished = refine_pose_on_structure(image, cam, s, start, reach_px=9.0)
    assert pose_equivalent(polished, pose, s.extent)[0] < 1.5
    assert polished.yaw_deg == pytest.approx(pose.yaw_deg, abs=0.5)


def test_the_choice_polishes_a_candidate_a_centimetre_off_back_when_its_structure_is_better(
        rendered_house):
    # The only candidate 10 mm off in depth: the choice's polish on the implied structure,
    # reaching 9 px, finds the truth, where the detections imply a better structure.
    from unseeable.vision import estimate_pose

    s, pose, cam, image = rendered_house
    fit = estimate_pose(image, cam, s.extent, strict=False)
    look = np.array([cam.R[2, 0], cam.R[2, 2]])
    move = 10.0 * look / np.linalg.norm(look)
    off = GridPose(pose.x + move[0], pose.z + move[1], pose.yaw_deg)
    offered = dataclasses.replace(fit, pose=off, candidates=((off, fit.score),))
    chosen = select_pose(image, cam, s.extent, offered, pitch_check=False)
    assert pose_equivalent(chosen.pose, pose, s.extent)[0] < 1.5
    kept = select_pose(image, cam, s.extent, offered, polish=False, pitch_check=False)
    assert kept.pose == off


def test_structure_polish_weighs_the_rims_as_asked_against_the_lines(rendered_house):
    from unseeable.vision.pose import POLISH_RIM_WEIGHT
    from unseeable.vision.pose.samples import structure_samples

    s, pose, cam, _ = rendered_house
    for rim_weight in (1.0, POLISH_RIM_WEIGHT):
        samples = structure_samples(s, pose, cam, LogGeometry(), spacing=3.0,
                                    edge_bias_px=0.0, rim_weight=rim_weight)
        assert samples.rim.any() and (~samples.rim).any()
        rims = samples.weight[samples.rim].sum()
        lines = samples.weight[~samples.rim].sum()
        assert rims == pytest.approx(rim_weight * lines)


@pytest.mark.parametrize("option, value", [
    *[("rim_weight", v) for v in (0.0, -1.0, float("nan"), "4", True)],
    # The reach: a number of pixels, at least the default's 3.
    *[("reach_px", v) for v in (2.0, 0.0, float("inf"), "9", True)],
])
def test_structure_polish_refuses_options_out_of_range(option, value):
    from unseeable.camera import Camera
    from unseeable.domain import Extent, Structure

    cam = Camera.look_at(eye=[0, 400, -500], target=[0, 0, 0], width=160, height=120,
                         fov_deg=40)
    with pytest.raises(InputError, match=option):
        refine_pose_on_structure(np.zeros((120, 160, 3), np.uint8), cam,
                                 Structure(Extent(2, 1, 2), []), GridPose(0.0, 0.0, 0.0),
                                 **{option: value})


def test_structure_polish_keeps_a_pose_when_nothing_shows():
    from unseeable.camera import Camera
    from unseeable.domain import Extent, Structure

    cam = Camera.look_at(eye=[0, 400, -500], target=[0, 0, 0], width=160, height=120,
                         fov_deg=40)
    empty = Structure(Extent(2, 1, 2), [])
    pose = GridPose(-32.0, -32.0, 10.0)
    assert refine_pose_on_structure(np.zeros((120, 160, 3), np.uint8), cam, empty,
                                    pose) == pose


@pytest.mark.parametrize("finals_keep", [0.0, 0.8, 0.6])
def test_estimated_candidates_start_with_the_edge_best_pose(rendered_house, finals_keep):
    s, pose, cam, image = rendered_house
    from unseeable.vision import PoseSettings, estimate_pose

    settings = PoseSettings(finals_keep=finals_keep)
    fit = estimate_pose(image, cam, s.extent, strict=False, settings=settings)
    assert fit.candidates[0][0] == fit.pose
    floor = min(settings.alias_keep, finals_keep or 1.0)
    assert all(sc >= floor * fit.score - 1e-9 for _, sc in fit.candidates)
    assert all(isinstance(p, GridPose) and -90 <= p.yaw_deg < 90 for p, _ in fit.candidates)
    # No pose is offered twice (each costs the choice a detection and a solve).
    for n, (p, _) in enumerate(fit.candidates):
        assert all(p.distance(q)[0] > 0.5 or p.distance(q)[1] > 0.2
                   for q, _ in fit.candidates[n + 1:])


@pytest.mark.parametrize("axis, sign", [(0, 1.0), (2, -1.0)])
def test_a_choice_one_pitch_off_is_moved_back_onto_the_assembly(rendered_house, axis, sign):
    # A whole pitch along a grid axis puts every line where a line was: only the
    # detections on a common, larger grid show that logs lie outside the extent.
    s, pose, cam, image = rendered_house
    move = sign * LogGeometry().l1 * pose.rotation[:, axis]
    off = GridPose(pose.x + move[0], pose.z + move[2], pose.yaw_deg)
    shifted, structure, gain = pitch_shift(image, cam, s.extent, off)
    assert pose_equivalent(shifted, pose, s.extent)[0] < 1.0
    assert gain > 3.0 and structure is not None
    kept, _, no_gain = pitch_shift(image, cam, s.extent, pose)
    assert kept == pose and no_gain == 0.0


@pytest.mark.parametrize("axis, sign", [(0, 1.0), (2, -1.0)])
def test_one_pitch_off_the_structure_leaves_a_side_of_the_extent_empty(rendered_house, axis,
                                                                        sign):
    # select_pose runs the pitch check only then: at the truth the house fills its extent.
    from unseeable.solve import StructureSolver
    from unseeable.vision import detect_features

    s, pose, cam, image = rendered_house
    assert fills_extent(s)
    move = sign * LogGeometry().l1 * pose.rotation[:, axis]
    off = GridPose(pose.x + move[0], pose.z + move[2], pose.yaw_deg)
    solver = StructureSolver(s.extent)
    found = {}
    for name, at in (("truth", pose), ("off", off)):
        det = detect_features(image, cam, at, s.extent, refine=False)
        found[name] = solver.solve(det.evidence).structure
    assert fills_extent(found["truth"])
    assert not fills_extent(found["off"])
    with pytest.raises(InputError, match="min_positions"):
        fills_extent(s, min_positions=-1)


def test_visible_log_ends_sit_on_edges_at_the_true_pose_and_not_at_its_aliases(rendered_house):
    from unseeable.vision import rim_support

    s, pose, cam, image = rendered_house
    at_truth = rim_support(image, cam, s, pose)
    moved = [rim_support(image, cam, s, a) for a in pose_aliases(pose, cam, s.extent)]
    assert 0.0 <= min(moved) and at_truth <= 1.0
    assert at_truth > max(moved), (at_truth, moved)


def test_a_square_footprint_offers_both_quarter_turns(rendered_house):
    # The other quarter turn fits the same lines after a depth shift; the edge fit must
    # hand it on for the structure to decide, whichever turn its first look preferred.
    from unseeable.vision import estimate_pose

    s, pose, cam, image = rendered_house
    assert s.extent.I == s.extent.K
    fit = estimate_pose(image, cam, s.extent, strict=False)
    families = {int(((p.yaw_deg + 45.0) % 180.0) // 90.0) for p, _ in fit.candidates}
    assert families == {0, 1}


def test_a_structures_silhouette_is_where_its_logs_are_drawn(arm_camera):
    # Drawn by the flat-shaded renderer on a table of another colour, without noise or
    # blur or shadow-darkened table: the log pixels are those unlike the table.
    from conftest import centred_pose, house
    from unseeable.domain import Structure
    from unseeable.render.raster import RasterLook, rasterise_view
    from unseeable.vision.pose_choice import structure_silhouette

    s = house()
    pose = centred_pose(s.extent, 17.0)
    look = RasterLook(table=(0.2, 0.45, 0.25), noise=0.0, blur_px=0.0, ambient=1.0)
    image = rasterise_view(s, pose, arm_camera, look=look).astype(float)
    table = np.asarray(look.table) * 255.0
    wood = np.abs(image - table).max(axis=2) > 40
    sil = structure_silhouette(s, pose, arm_camera, image.shape[:2])
    iou = (wood & sil).sum() / (wood | sil).sum()
    assert iou > 0.9, iou
    assert not structure_silhouette(Structure(s.extent, []), pose, arm_camera,
                                    image.shape[:2]).any()
    # Its size is the camera's unless asked; a size that is not (H, W) is refused.
    assert structure_silhouette(s, pose, arm_camera).shape == image.shape[:2]
    for bad in [(480,), (0, 640), (480.0, 640), 480]:
        with pytest.raises(InputError, match="shape"):
            structure_silhouette(s, pose, arm_camera, bad)


def test_the_silhouette_overlap_prefers_the_true_pose_to_its_aliases(arm_camera):
    # The overlap of the structure's silhouette with the wood at each pose: the aliases
    # fit the same lines, but their logs cover some table and leave some wood uncovered.
    # Shadows read as wood as well (here on a grey table; more so on a wooden one), so
    # the differences are a few hundredths: a tie-breaker for the choice, no more.
    from conftest import centred_pose, house
    from unseeable.render.renderer import render_view
    from unseeable.render.settings import RenderSettings, SceneParams
    from unseeable.vision.implied_structure import silhouette_overlap, wood_near

    g = LogGeometry()
    s = house()
    pose = centred_pose(s.extent, -31.0)
    image, _, _ = render_view(s, pose, arm_camera, settings=RenderSettings(spp=4), seed=3,
                              look=SceneParams(table_kind="grey"))
    aliases = pose_aliases(pose, arm_camera, s.extent, layers=(1, 2))
    turned, _ = pose.turned(1, s.extent, g)
    wood, region = wood_near(image, arm_camera, s.extent, [pose, *aliases, turned], g)
    at_truth = silhouette_overlap(wood, region, s, pose, arm_camera, g)
    others = [silhouette_overlap(wood, region, s, p, arm_camera, g) for p in [*aliases, turned]]
    assert at_truth > 0.7, at_truth
    assert at_truth > max(others), (at_truth, others)
    # A pose a log's length away shares little wood with the logs.
    far = GridPose(pose.x + 3 * g.l1, pose.z, pose.yaw_deg)
    assert silhouette_overlap(wood, region, s, far, arm_camera, g) < 0.5 * at_truth


def test_structure_rims_look_for_their_edges_inside_and_below_the_projected_rim():
    # An end disc painted where the rim model says its edge shows (a little inside and
    # lower than the projected rim) is found the same distance off its edge at the top
    # and at the bottom; painted at the projected rim itself, its top is found further
    # out than its bottom.
    import cv2

    from unseeable.camera import Camera
    from unseeable.domain import Extent, Log, Structure
    from unseeable.vision.edges import edge_maps
    from unseeable.vision.pose.alignment import match_edges
    from unseeable.vision.pose.samples import structure_samples
    from unseeable.vision.pose.settings import EDGE_BIAS_PX, RIM_BIAS_PX, RIM_DROP_PX

    g = LogGeometry()
    cam = Camera.look_at(eye=[-150, 60, 0], target=[0, 30, 0], width=320, height=240,
                         fov_deg=40)
    s = Structure(Extent(2, 1, 1), [Log(layer=0, at=(0, 0), notches=2)])
    pose = GridPose(0.0, 0.0, 0.0)
    samples = structure_samples(s, pose, cam, g, spacing=3.0, edge_bias_px=EDGE_BIAS_PX)
    # The facing end disc, finely: its plane is the grid's y-z plane (the log runs along i).
    disc = samples.reference[samples.rim][0]
    t = np.linspace(0.0, 2 * np.pi, 720, endpoint=False)
    circle = disc + g.radius * np.stack([0 * t, np.cos(t), np.sin(t)], axis=1)
    projected = cam.project(pose.grid_to_world(circle))
    centre = cam.project(pose.grid_to_world(disc[None]))[0]
    radial = (projected - centre) / np.linalg.norm(projected - centre, axis=1, keepdims=True)
    drops = []
    for uv in (projected + RIM_BIAS_PX * radial + [0.0, RIM_DROP_PX], projected):
        # Anti-aliased by area: painted 8× finer (pixel centres at whole coordinates at
        # both scales, as the camera has them), then averaged down.
        fine = np.full((240 * 8, 320 * 8), 200, np.uint8)
        cv2.fillPoly(fine, [np.round(((uv + 0.5) * 8 - 0.5) * 16).astype(np.int32)], 60,
                     shift=4)
        image = np.repeat(
            cv2.resize(fine, (320, 240), interpolation=cv2.INTER_AREA)[..., None], 3, axis=2)
        m = match_edges(edge_maps(image, sigma=1.0), cam, s.extent, g, pose, spacing=3.0,
                        reach=2.0, edge_bias_px=EDGE_BIAS_PX, use_ends=True,
                        samples=samples)
        rim = samples.rim & m.ok
        top = rim & (m.normals[:, 1] < -0.7)
        bottom = rim & (m.normals[:, 1] > 0.7)
        assert top.sum() >= 2 and bottom.sum() >= 2
        # Blurring a curved edge moves it a little (the same all round): compare the two.
        drops.append(np.median(m.offset[top]) - np.median(m.offset[bottom]))
    at_model, at_projection = drops
    assert abs(at_model) < 0.1
    assert at_projection > at_model + 0.1


@pytest.mark.slow
def test_a_tall_wall_seen_along_its_depth_is_posed_through_a_distant_alias(tmp_path):
    # The corpus's screen wall (5 wide, 8 layers, 2 deep) from the arm at 210°: the edges
    # prefer a pose 43 mm off along the depth axis, and the right one is an alias 5
    # half-layers away from it. Offered to the structure choice, it is chosen.
    from unseeable.corpus.build import build_corpus
    from unseeable.render.settings import RenderSettings
    from unseeable.render.view import load_view
    from unseeable.vision import default_calibration, estimate_pose

    build_corpus(tmp_path, angles=[210], only=["screen-wall"],
                 settings=RenderSettings(spp=24), seed=0)
    view = load_view(tmp_path / "screen-wall" / "view210.json")
    fit = estimate_pose(view.image, view.camera, view.extent)
    chosen = select_pose(view.image, view.camera, view.extent, fit,
                         calibration=default_calibration())
    dt, dy = pose_equivalent(chosen.pose, view.pose, view.extent)
    assert dt < 2.0 and dy < 1.0
    # On two threads (the CLI's default) the search and the choice are the same.
    assert len(fit.candidates) > 2
    threaded = estimate_pose(view.image, view.camera, view.extent, threads=2)
    assert threaded == fit
    found = {}
    again = select_pose(view.image, view.camera, view.extent, threaded,
                        calibration=default_calibration(), threads=2, detections=found)
    assert again == chosen and set(found) == {p for p, _ in fit.candidates}


@pytest.mark.slow
def test_a_single_wall_seen_face_on_gets_its_yaw_from_the_search(tmp_path):
    # The corpus's 5-log wall from the arm at 180°: its long lines run nearly parallel to
    # the image plane and its ends are too short to vote, so the yaw votes missed it by
    # 3.8° and every candidate was wrong. Yaws every few degrees, for a one-log-deep
    # extent, let the edge alignment find it.
    from unseeable.corpus.build import build_corpus
    from unseeable.render.settings import RenderSettings
    from unseeable.render.view import load_view
    from unseeable.vision import default_calibration, estimate_pose

    build_corpus(tmp_path, angles=[180], only=["wall-5"], settings=RenderSettings(spp=24),
                 seed=0)
    view = load_view(tmp_path / "wall-5" / "view180.json")
    assert min(view.extent.I, view.extent.K) == 1
    fit = estimate_pose(view.image, view.camera, view.extent, strict=False)
    chosen = select_pose(view.image, view.camera, view.extent, fit,
                         calibration=default_calibration(), polish=False)
    dt, dy = pose_equivalent(chosen.pose, view.pose, view.extent)
    assert dt < 2.0 and dy < 1.0


@pytest.mark.slow
def test_two_walls_at_a_corner_are_posed_through_a_low_ranked_candidate(tmp_path):
    # The corpus's corner walls (an L of two walls in a 5x5x4 extent, most of it empty)
    # from the arm at 210°: the edges score grids shifted onto the table's plank seams
    # above the true one (every candidate at 0.8 of the best was 14-50 mm off, or a
    # quarter turn, which was chosen). The truth's neighbour one pitch along i scores 0.70
    # of the best: offered, the structure choice takes it and the pitch check moves it on.
    from unseeable.corpus.build import build_corpus
    from unseeable.render.settings import RenderSettings
    from unseeable.render.view import load_view
    from unseeable.vision import default_calibration, estimate_pose

    build_corpus(tmp_path, angles=[210], only=["corner-walls"],
                 settings=RenderSettings(spp=24), seed=0)
    view = load_view(tmp_path / "corner-walls" / "view210.json")
    fit = estimate_pose(view.image, view.camera, view.extent)
    assert all(pose_equivalent(p, view.pose, view.extent)[0] > 5.0 for p, _ in fit.candidates)
    chosen = select_pose(view.image, view.camera, view.extent, fit,
                         calibration=default_calibration(), polish=False)
    dt, dy = pose_equivalent(chosen.pose, view.pose, view.extent)
    assert dt < 2.0 and dy < 1.0
