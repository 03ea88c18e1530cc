"""Feature truth: the visibility model agrees with what the renderer shows."""

from __future__ import annotations

import numpy as np
import pytest

from strategies import build_random_structure
from unseeable.domain import (
    Extent,
    FeatureKind,
    GridPose,
    Log,
    Structure,
    feature_index,
    feature_values,
)
from unseeable.render.renderer import render_ground_truth
from unseeable.render.truth import feature_owners, feature_truth, rendered_visibility
from unseeable.render.workspace import PendulumArm, default_pose


def test_feature_owners_name_the_log_at_q_and_two_layers_below():
    s = Structure(Extent(2, 3, 1), [Log(0, (0, 0), 2), Log(2, (1, 0), 1)])
    idx = feature_index(s.extent)
    owners = feature_owners(s)
    assert owners[idx.lookup(FeatureKind.END_MINUS, (0, 0, 0)), 0] == 0
    assert owners[idx.lookup(FeatureKind.END_PLUS, (1, 2, 0)), 0] == 1
    # The u segment of layer 2 at (1, 2, 0): bottom of log 1, top of log 0 two layers below.
    assert owners[idx.lookup(FeatureKind.U, (1, 2, 0))].tolist() == [1, 0]
    assert owners[idx.lookup(FeatureKind.W, (0, 2, 0))].tolist() == [-1, 0]
    assert owners[idx.lookup(FeatureKind.V, (1, 4, 0))].tolist() == [-1, 1]
    assert owners[idx.lookup(FeatureKind.V, (0, 4, 0))].tolist() == [-1, -1]


def test_rendered_visibility_of_a_lone_log():
    s = Structure(Extent(2, 1, 1), [Log(0, (0, 0), 2)])
    cam = PendulumArm(radius_mm=400, width=160, height=120, look_at=(32.0, 10.0, 0.0)
                      ).camera(150.0)
    ids, _ = render_ground_truth(s, GridPose(), cam)
    vis, seen = rendered_visibility(s, GridPose(), cam, ids)
    idx = feature_index(s.extent)
    # Seen from the -x side: end- faces the camera, end+ faces away; the near edges show.
    assert vis[idx.lookup(FeatureKind.END_MINUS, (0, 0, 0))]
    assert not vis[idx.lookup(FeatureKind.END_PLUS, (1, 0, 0))]
    assert vis[idx.lookup(FeatureKind.W, (0, 0, 0))]
    assert not vis[~feature_values(s.extent, s.occupancy)].any()


def test_visibility_model_agrees_with_the_rendered_id_map():
    pytest.importorskip("unseeable.visibility")
    agree = []
    for seed in (0, 1):
        s = build_random_structure(Extent(4, 4, 4), seed, 0.7)
        pose = default_pose(s.extent)
        arm = PendulumArm(radius_mm=600, width=320, height=240)
        present = feature_values(s.extent, s.occupancy)
        for angle in (90.0, 150.0, 210.0):
            cam = arm.camera(angle)
            ids, _ = render_ground_truth(s, pose, cam)
            _, model, source = feature_truth(s, pose, cam, ids)
            assert source == "model"
            rendered, _ = rendered_visibility(s, pose, cam, ids)
            agree.append((model == rendered)[present])
    share = np.concatenate(agree).mean()
    assert share >= 0.95, share
