"""The camera file format ``unseeable/camera@1`` (DESIGN.md §6)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from unseeable.camera.pinhole import Camera
from unseeable.errors import InputError
from unseeable.fileio import check_format, read_json, write_json

__all__ = ["CAMERA_FORMAT", "camera_from_json", "camera_to_json", "load_camera", "save_camera"]

CAMERA_FORMAT = "unseeable/camera@1"


def camera_to_json(camera: Camera) -> dict[str, Any]:
    data = {
        "format": CAMERA_FORMAT,
        "width": camera.width,
        "height": camera.height,
        "K": camera.K.tolist(),
        "R": camera.R.tolist(),
        "t": camera.t.tolist(),
    }
    if camera.has_distortion:
        data["dist"] = camera.dist.tolist()
    return data


def camera_from_json(data: Any, *, file: Any = None, field: str = "") -> Camera:
    """Build a :class:`Camera` from parsed JSON, with errors naming file and field."""
    prefix = f"{field}." if field else ""
    check_format(data, CAMERA_FORMAT, file=file, field=f"{prefix}format")
    for key in ("width", "height", "K", "R", "t"):
        if key not in data:
            raise InputError("is missing", file=file, field=f"{prefix}{key}")
    try:
        return Camera(data["width"], data["height"], data["K"], data["R"], data["t"],
                      data.get("dist"))
    except InputError as err:
        raise InputError(err.message, file=file, field=f"{prefix}{err.field}",
                         value=err.value) from None


def load_camera(path: str | Path) -> Camera:
    return camera_from_json(read_json(path), file=path)


def save_camera(camera: Camera, path: str | Path) -> None:
    write_json(path, camera_to_json(camera))
