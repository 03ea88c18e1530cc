"""Calibrated pinhole cameras (OpenCV conventions), their file format, and calibration
of a real camera on a printed chessboard (:mod:`unseeable.camera.calibrate`)."""

from unseeable.camera.calibrate import (
    BoardPlacement,
    Calibration,
    CameraLocation,
    Chessboard,
    Intrinsics,
    calibrate_camera,
    calibrate_files,
    check_photo,
    find_chessboard,
    load_intrinsics,
    locate_camera,
    locate_file,
    save_intrinsics,
)
from unseeable.camera.io import camera_from_json, camera_to_json, load_camera, save_camera
from unseeable.camera.pinhole import Camera, look_at_rotation

__all__ = ["Camera", "look_at_rotation", "camera_from_json", "camera_to_json", "load_camera",
           "save_camera", "Chessboard", "BoardPlacement", "Intrinsics", "Calibration",
           "CameraLocation", "find_chessboard", "calibrate_camera", "calibrate_files",
           "locate_camera", "locate_file", "load_intrinsics", "save_intrinsics", "check_photo"]
