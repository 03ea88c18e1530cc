"""Calibrated pinhole cameras (OpenCV conventions) and their file format."""

from unseeable.camera.io import camera_from_json, camera_to_json, load_camera, save_camera
from unseeable.camera.pinhole import Camera, look_at_rotation

__all__ = ["Camera", "look_at_rotation", "camera_from_json", "camera_to_json", "load_camera",
           "save_camera"]
