"""Training the vision front end on rendered scenes.

* :mod:`unseeable.training.scenes` — random rendered scenes with their ground
  truth, in families that never overlap (training and validation), cached on
  disk (:func:`make_scene`, :func:`default_cache_dir`).
* :mod:`unseeable.training.fit` — fitting the detector calibration and the pose
  quality model on them (:func:`calibrate`, ``unseeable calibrate``).

This package renders (:mod:`unseeable.render`) and runs the pipeline
(:mod:`unseeable.pipeline`); the runtime vision (:mod:`unseeable.vision`) does
neither and never imports it.
"""

from unseeable.training.fit import calibrate, pose_sample, scene_samples, training_samples
from unseeable.training.scenes import (
    TRAIN,
    TRAIN_HALLS,
    TRAIN_LOOKS,
    TRAIN_TALL,
    TRAIN_WALLS,
    VALIDATION,
    Scene,
    SceneSpec,
    default_cache_dir,
    jpeg_roundtrip,
    load_scenes,
    make_scene,
    random_structure,
    random_walls,
    scene_spec,
)

__all__ = [
    "calibrate",
    "scene_samples",
    "training_samples",
    "pose_sample",
    "SceneSpec",
    "Scene",
    "TRAIN",
    "TRAIN_WALLS",
    "TRAIN_TALL",
    "TRAIN_LOOKS",
    "TRAIN_HALLS",
    "VALIDATION",
    "random_structure",
    "random_walls",
    "scene_spec",
    "make_scene",
    "load_scenes",
    "default_cache_dir",
    "jpeg_roundtrip",
]
