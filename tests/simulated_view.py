"""A simulated camera view for tests that need no renderer.

The detector is right (with prior ``strength``) on features that are truly
visible and reports noise on truly occluded ones — as a real detector looking
at the occluder would.
"""

from __future__ import annotations

import numpy as np

from unseeable.camera import Camera
from unseeable.domain import GridPose, LogGeometry, Structure, feature_values
from unseeable.visibility import feature_visibility
from unseeable.visibility.loop import ViewEvidence


def station_camera(structure: Structure, angle_deg: float, *, elevation_deg: float = 30.0,
                   distance: float = 900.0) -> tuple[Camera, GridPose]:
    g = LogGeometry()
    e = structure.extent
    pose = GridPose(-(e.I - 1) * g.l1 / 2, -(e.K - 1) * g.l1 / 2, 0.0)
    a, el = np.deg2rad(angle_deg), np.deg2rad(elevation_deg)
    eye = distance * np.array([np.cos(a) * np.cos(el), np.sin(el), np.sin(a) * np.cos(el)])
    cam = Camera.look_at(eye=eye, target=[0, 40, 0], width=640, height=480, fov_deg=40)
    return cam, pose


def simulated_observation(structure: Structure, camera: Camera, pose: GridPose, *,
                          strength: float = 0.9, seed: int = 0) -> tuple[ViewEvidence, np.ndarray]:
    rng = np.random.default_rng(seed)
    truth_vis = feature_visibility(structure, camera.centre, pose)
    value = feature_values(structure.extent, structure.occupancy)
    p = np.where(value, strength, 1 - strength)
    noise = rng.uniform(0.15, 0.85, len(p))
    priors = np.where(truth_vis, p, noise)
    return ViewEvidence(priors, camera.centre, pose, judged=np.ones(len(p), bool)), truth_vis


def biased_observation(structure: Structure, camera: Camera, pose: GridPose, bias: float, *,
                       seed: int) -> ViewEvidence:
    """A view whose detector is right on the visible features with a strength drawn per
    feature, and whose log-odds are all off by ``bias`` (a look unlike the calibration's:
    presence called too rarely, bias < 0, or too often)."""
    rng = np.random.default_rng(seed)
    visible = feature_visibility(structure, camera.centre, pose)
    value = feature_values(structure.extent, structure.occupancy)
    strength = rng.uniform(0.6, 0.95, len(value))
    z = np.log(strength / (1 - strength)) * np.where(value, 1.0, -1.0) + bias
    p = np.clip(1.0 / (1.0 + np.exp(-z)), 0.02, 0.98)
    priors = np.where(visible, p, rng.uniform(0.15, 0.85, len(p)))
    return ViewEvidence(priors, camera.centre, pose, judged=np.ones(len(p), bool))
