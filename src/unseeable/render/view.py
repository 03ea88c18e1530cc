"""Views and their ground truth, and their file formats (DESIGN.md §6).

A :class:`View` is what the estimator gets: a photograph, the camera that
took it, the grid's extent, and optionally the assembly's pose and how much
of it the arm took away. A :class:`ViewTruth` is what the simulator knows
about the same photograph: the assembly, its pose, the camera that really
took it (after jitter), which log each pixel shows, and which features are
present and visible.

This module does not import Mitsuba: every stage may import it cheaply.

View file (``unseeable/view@1``)::

    {"format": "unseeable/view@1", "image": "view1.png",
     "camera": {camera format} or "camera.json", "extent": [I, J, K],
     "pose": {"x": .., "z": .., "yaw_deg": ..},        (optional)
     "removed_from_layer": L,                          (optional)
     "removed_logs": [log index, ...]}                 (optional, this project's extension)

Truth file (``unseeable/truth@1``)::

    {"format": "unseeable/truth@1", "structure": {structure format},
     "pose": {...}, "camera": {...}, "removed_from_layer": L, "removed_logs": [...],
     "ids": "view1.ids.npz", "visibility_source": "model",
     "features": [{"kind": "end-", "at": [i, j, k], "present": true, "visible": false}, ...]}

Relative paths inside either file are resolved against the file's folder.
"""

from __future__ import annotations

import io
import logging
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from unseeable.camera import Camera
from unseeable.camera.io import camera_from_json, camera_to_json, load_camera
from unseeable.domain import (
    Extent,
    FeatureKind,
    GridPose,
    Structure,
    feature_index,
    structure_from_json,
    structure_to_json,
)
from unseeable.errors import InputError
from unseeable.fileio import (
    atomic_write_bytes,
    check_format,
    read_image,
    read_json,
    require,
    write_json,
)

__all__ = [
    "VIEW_FORMAT",
    "TRUTH_FORMAT",
    "View",
    "ViewTruth",
    "load_view",
    "save_view",
    "view_from_json",
    "view_to_json",
    "load_truth",
    "save_truth",
    "read_image",
    "write_image",
    "pose_from_json",
]

logger = logging.getLogger(__name__)

VIEW_FORMAT = "unseeable/view@1"
TRUTH_FORMAT = "unseeable/truth@1"


# --------------------------------------------------------------------------
# images


def _image_size(path: Path, *, file: Any, field: str) -> tuple[int, int]:
    """``(width, height)`` of an image file from its header."""
    from PIL import Image, UnidentifiedImageError

    try:
        with Image.open(path) as im:
            return im.size
    except FileNotFoundError:
        raise InputError("image file not found", file=file, field=field, value=str(path)) from None
    except (UnidentifiedImageError, OSError) as err:
        raise InputError(f"is not a readable image ({err})", file=file, field=field,
                         value=str(path)) from None


def encode_png(image: np.ndarray) -> bytes:
    """PNG bytes of an ``(H, W, 3) uint8`` RGB or ``(H, W) uint8`` image."""
    import cv2

    arr = np.asarray(image)
    if arr.ndim == 3:
        arr = arr[..., ::-1]  # OpenCV writes BGR
    ok, buf = cv2.imencode(".png", np.ascontiguousarray(arr))
    if not ok:  # pragma: no cover - only for unusable arrays
        raise InputError("cannot be encoded as PNG", field="image", value=arr.shape)
    return buf.tobytes()


def write_image(path: str | Path, image: np.ndarray) -> None:
    """Write an ``(H, W, 3) uint8`` RGB image as PNG, atomically."""
    atomic_write_bytes(path, encode_png(image))


# --------------------------------------------------------------------------
# View


def _check_image(image: np.ndarray, camera: Camera, *, file: Any = None,
                 field: str = "image") -> np.ndarray:
    arr = np.asarray(image)
    if arr.dtype != np.uint8 or arr.ndim != 3 or arr.shape[2] != 3:
        raise InputError("must be an (H, W, 3) uint8 RGB image", file=file, field=field,
                         value=f"{arr.dtype} {arr.shape}")
    if arr.shape[:2] != (camera.height, camera.width):
        raise InputError(f"is {arr.shape[1]}x{arr.shape[0]} but the camera's image is "
                         f"{camera.width}x{camera.height}", file=file, field=field,
                         value=f"{arr.shape[1]}x{arr.shape[0]}")
    return arr


@dataclass(frozen=True, eq=False, init=False)
class View:
    """One photograph of the assembly, as the estimator gets it.

    Parameters
    ----------
    image : (H, W, 3) uint8 array, path or None
        The photograph (RGB), or the file holding it (loaded on first use of
        :attr:`image`). ``None`` with ``image_path`` given also loads lazily.
    camera : Camera
        The calibrated camera (world = table frame).
    extent : Extent
        The symbolic grid the assembly is estimated in.
    pose : GridPose, optional
        The assembly's pose when known (else the vision stage estimates it).
    removed_from_layer : int, optional
        The arm had removed every log at layers ``>= removed_from_layer``.
    image_path : path, optional
        Where the image lives on disk, if anywhere.
    removed_logs : tuple of int, optional
        Indices (into the assembly's ``logs``) of further logs the arm had removed.

    Examples
    --------
    >>> from unseeable.domain import Extent
    >>> cam = Camera.look_at(eye=[0, 500, -800], target=[0, 0, 0], width=4, height=3, fov_deg=50)
    >>> v = View(np.zeros((3, 4, 3), np.uint8), cam, Extent(2, 2, 2))
    >>> v.image.shape, v.pose is None
    ((3, 4, 3), True)
    """

    camera: Camera
    extent: Extent
    pose: GridPose | None
    removed_from_layer: int | None
    image_path: Path | None
    removed_logs: tuple[int, ...] | None
    _pixels: np.ndarray | None = field(repr=False)

    def __init__(self, image: np.ndarray | str | Path | None, camera: Camera, extent: Extent,
                 pose: GridPose | None = None, removed_from_layer: int | None = None,
                 image_path: str | Path | None = None,
                 removed_logs: tuple[int, ...] | None = None) -> None:
        if not isinstance(camera, Camera):
            raise InputError("must be a Camera", field="camera", value=type(camera).__name__)
        if not isinstance(extent, Extent):
            extent = Extent.parse(extent)
        if pose is not None and not isinstance(pose, GridPose):
            raise InputError("must be a GridPose or None", field="pose", value=pose)
        if removed_from_layer is not None:
            if isinstance(removed_from_layer, bool) or not isinstance(
                    removed_from_layer, (int, np.integer)) or removed_from_layer < 0:
                raise InputError("must be a layer number >= 0", field="removed_from_layer",
                                 value=removed_from_layer)
            removed_from_layer = int(removed_from_layer)
        if removed_logs is not None:
            removed_logs = tuple(sorted({int(n) for n in removed_logs}))
        pixels = None
        if isinstance(image, (str, Path)):
            image_path = image
        elif image is not None:
            pixels = _check_image(image, camera)
            pixels = pixels.copy()
            pixels.setflags(write=False)
        if pixels is None and image_path is None:
            raise InputError("a view needs an image array or an image file", field="image")
        set_ = object.__setattr__
        set_(self, "camera", camera)
        set_(self, "extent", extent)
        set_(self, "pose", pose)
        set_(self, "removed_from_layer", removed_from_layer)
        set_(self, "image_path", None if image_path is None else Path(image_path))
        set_(self, "removed_logs", removed_logs)
        set_(self, "_pixels", pixels)

    @property
    def image(self) -> np.ndarray:
        """The photograph, ``(H, W, 3) uint8`` RGB (read from :attr:`image_path` once)."""
        if self._pixels is None:
            arr = _check_image(read_image(self.image_path), self.camera, file=self.image_path,
                               field="image")
            arr.setflags(write=False)
            object.__setattr__(self, "_pixels", arr)
        return self._pixels

    @property
    def loaded(self) -> bool:
        """Whether the pixels are in memory."""
        return self._pixels is not None

    def shown(self, structure: Structure) -> Structure:
        """The logs of ``structure`` still on the table in this view."""
        return shown_structure(structure, self.removed_from_layer, self.removed_logs)


def shown_structure(structure: Structure, removed_from_layer: int | None,
                    removed_logs: tuple[int, ...] | None) -> Structure:
    """``structure`` less the logs at layers ``>= removed_from_layer`` and ``removed_logs``."""
    gone = set(removed_logs or ())
    top = np.inf if removed_from_layer is None else removed_from_layer
    return structure.with_logs(log for n, log in enumerate(structure.logs)
                               if log.layer < top and n not in gone)


def pose_from_json(data: Any, *, file: Any = None, field: str = "pose") -> GridPose:
    """A :class:`GridPose` from ``{"x", "z", "yaw_deg"}``."""
    if not isinstance(data, dict):
        raise InputError("must be an object {x, z, yaw_deg}", file=file, field=field, value=data)
    values = {}
    for key in ("x", "z", "yaw_deg"):
        v = require(data, key, file=file, prefix=f"{field}.")
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise InputError("must be a number", file=file, field=f"{field}.{key}", value=v)
        values[key] = v
    try:
        return GridPose(**values)
    except InputError as err:
        raise InputError(err.message, file=file, field=err.field, value=err.value) from None


def _relative(target: Path, folder: Path) -> str:
    try:
        return Path(os.path.relpath(target.resolve(), folder.resolve())).as_posix()
    except ValueError:  # another drive (Windows)
        return str(target.resolve())


def view_to_json(view: View, *, image: str) -> dict[str, Any]:
    """The view as a JSON-ready dict whose image lives at ``image`` (as written)."""
    data: dict[str, Any] = {
        "format": VIEW_FORMAT,
        "image": image,
        "camera": camera_to_json(view.camera),
        "extent": view.extent.as_list(),
    }
    if view.pose is not None:
        data["pose"] = view.pose.to_json()
    if view.removed_from_layer is not None:
        data["removed_from_layer"] = view.removed_from_layer
    if view.removed_logs:
        data["removed_logs"] = list(view.removed_logs)
    return data


def view_from_json(data: Any, *, file: str | Path | None = None) -> View:
    """Validate a parsed view file and build the :class:`View` (image loaded lazily).

    Raises
    ------
    InputError
        Naming the file, field and value: a wrong format tag, a missing or
        unreadable image, an image whose size differs from the camera's, a bad
        camera, extent or pose.
    """
    check_format(data, VIEW_FORMAT, file=file)
    folder = Path(file).parent if file is not None else Path(".")
    extent = Extent.parse(require(data, "extent", file=file), file=file, field="extent")
    cam_data = require(data, "camera", file=file)
    if isinstance(cam_data, str):
        cam_path = folder / cam_data
        try:
            camera = load_camera(cam_path)
        except InputError as err:
            raise InputError(f"bad camera file ({err})", file=file, field="camera",
                             value=cam_data) from None
    elif isinstance(cam_data, dict):
        camera = camera_from_json(cam_data, file=file, field="camera")
    else:
        raise InputError("must be a camera object or the name of a camera file", file=file,
                         field="camera", value=cam_data)
    image = require(data, "image", file=file)
    if not isinstance(image, str) or not image:
        raise InputError("must be the image file's path", file=file, field="image", value=image)
    image_path = folder / image
    size = _image_size(image_path, file=file, field="image")
    if size != camera.size:
        raise InputError(f"is {size[0]}x{size[1]} but the camera's image is "
                         f"{camera.width}x{camera.height}", file=file, field="image", value=image)
    pose = None
    if data.get("pose") is not None:
        pose = pose_from_json(data["pose"], file=file)
    removed = data.get("removed_from_layer")
    if removed is not None and (isinstance(removed, bool) or not isinstance(removed, int)
                                or not 0 <= removed):
        raise InputError("must be a layer number >= 0", file=file, field="removed_from_layer",
                         value=removed)
    removed_logs = data.get("removed_logs")
    if removed_logs is not None:
        if not (isinstance(removed_logs, list)
                and all(isinstance(n, int) and not isinstance(n, bool) and n >= 0
                        for n in removed_logs)):
            raise InputError("must be a list of log indices", file=file, field="removed_logs",
                             value=removed_logs)
    return View(None, camera, extent, pose, removed, image_path=image_path,
                removed_logs=tuple(removed_logs) if removed_logs is not None else None)


def load_view(path: str | Path) -> View:
    """Load a view file (``unseeable/view@1``); the image is checked now, loaded on use."""
    return view_from_json(read_json(path), file=path)


def save_view(view: View, path: str | Path, *, image_path: str | Path | None = None) -> View:
    """Write a view file, and its image when it is not on disk yet.

    Parameters
    ----------
    view : View
    path : path
        The view file (JSON).
    image_path : path, optional
        Where to write the image; default: beside ``path`` with suffix ``.png``,
        unless the view already lives in a file (then that file is referenced).

    Returns
    -------
    View
        The same view, now pointing at its image file.
    """
    p = Path(path)
    if image_path is None and view.image_path is not None and view.image_path.exists():
        target = view.image_path
    else:
        target = Path(image_path) if image_path is not None else p.with_suffix(".png")
        write_image(target, view.image)
    write_json(p, view_to_json(view, image=_relative(target, p.parent)))
    return View(view.image if view.loaded else None, view.camera, view.extent, view.pose,
                view.removed_from_layer, image_path=target, removed_logs=view.removed_logs)


# --------------------------------------------------------------------------
# ViewTruth


@dataclass(frozen=True, eq=False)
class ViewTruth:
    """What the simulator knows about one photograph.

    Attributes
    ----------
    structure : Structure
        The whole assembly (before the arm removed anything).
    pose : GridPose
    camera : Camera
        The camera that really took the photograph (differs from the view's
        camera when the workspace jitters it).
    present : (N,) bool
        Features present in the photographed (shown) structure, in
        :func:`unseeable.domain.feature_index` order.
    visible : (N,) bool
        Features visible from the camera (True = visible).
    ids : (H, W) int32 or None
        Per pixel, the index into ``structure.logs`` of the log seen (-1: none).
    depth : (H, W) float32 or None
        Camera-frame z (mm) per pixel (``inf``: nothing).
    removed_from_layer : int or None
    removed_logs : tuple of int
    visibility_source : str
        ``"model"`` (:func:`unseeable.visibility.feature_visibility`) or
        ``"id_map"`` (read off the rendered ids, when the model was unavailable).
    look : dict or None
        The scene look used (:meth:`SceneParams.to_json`).
    """

    structure: Structure
    pose: GridPose
    camera: Camera
    present: np.ndarray
    visible: np.ndarray
    ids: np.ndarray | None = None
    depth: np.ndarray | None = None
    removed_from_layer: int | None = None
    removed_logs: tuple[int, ...] = ()
    visibility_source: str = "model"
    look: dict | None = None

    def __post_init__(self) -> None:
        n = len(feature_index(self.structure.extent))
        for name in ("present", "visible"):
            arr = np.asarray(getattr(self, name), dtype=bool)
            if arr.shape != (n,):
                raise InputError(f"must have shape ({n},) for extent {self.structure.extent}",
                                 field=name, value=arr.shape)
            arr = arr.copy()
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)
        object.__setattr__(self, "removed_logs", tuple(sorted(int(x) for x in self.removed_logs)))

    @property
    def shown(self) -> Structure:
        """The logs on the table in the photograph."""
        return shown_structure(self.structure, self.removed_from_layer, self.removed_logs)


def _truth_to_json(truth: ViewTruth, *, ids_name: str | None) -> dict[str, Any]:
    idx = feature_index(truth.structure.extent)
    kinds = [FeatureKind(int(k)).label for k in idx.kind]
    features = [{"kind": kinds[n], "at": idx.at[n].tolist(), "present": bool(truth.present[n]),
                 "visible": bool(truth.visible[n])} for n in range(len(idx))]
    data: dict[str, Any] = {
        "format": TRUTH_FORMAT,
        "structure": structure_to_json(truth.structure),
        "pose": truth.pose.to_json(),
        "camera": camera_to_json(truth.camera),
        "visibility_source": truth.visibility_source,
    }
    if truth.removed_from_layer is not None:
        data["removed_from_layer"] = truth.removed_from_layer
    if truth.removed_logs:
        data["removed_logs"] = list(truth.removed_logs)
    if ids_name is not None:
        data["ids"] = ids_name
    if truth.look is not None:
        data["look"] = truth.look
    data["features"] = features
    return data


def save_truth(truth: ViewTruth, path: str | Path, *, ids_path: str | Path | None = None) -> None:
    """Write a truth file and, when the truth has them, the ids/depth maps (``.npz``).

    ``ids_path`` defaults to ``path`` with ``.truth.json`` (or ``.json``)
    replaced by ``.ids.npz``.
    """
    p = Path(path)
    ids_name = None
    if truth.ids is not None:
        if ids_path is None:
            name = p.name
            stem = name[: -len(".truth.json")] if name.endswith(".truth.json") else p.stem
            ids_path = p.with_name(stem + ".ids.npz")
        ids_path = Path(ids_path)
        buf = io.BytesIO()
        arrays = {"ids": np.asarray(truth.ids, dtype=np.int32)}
        if truth.depth is not None:
            arrays["depth"] = np.asarray(truth.depth, dtype=np.float32)
        np.savez_compressed(buf, **arrays)
        atomic_write_bytes(ids_path, buf.getvalue())
        ids_name = _relative(ids_path, p.parent)
    write_json(p, _truth_to_json(truth, ids_name=ids_name), indent=None)


def load_reference(path: str | Path) -> tuple[Structure, GridPose | None]:
    """The structure to compare an estimate with, from a structure file
    (``unseeable/structure@1``: no pose) or a view's truth file
    (``unseeable/truth@1``: the logs on the table in the photograph, and the pose).

    Raises
    ------
    InputError
        Naming the file, and the format tag when it is neither.
    """
    from unseeable.domain.io import STRUCTURE_FORMAT, structure_from_json

    p = Path(path)
    data = read_json(p)
    fmt = data.get("format") if isinstance(data, dict) else None
    if fmt == STRUCTURE_FORMAT:
        return structure_from_json(data, file=p), None
    if fmt == TRUTH_FORMAT:
        truth = _truth_from_json(data, p)
        return truth.shown, truth.pose
    raise InputError(f"must be {STRUCTURE_FORMAT!r} or {TRUTH_FORMAT!r}", file=p,
                     field="format", value=fmt)


def load_truth(path: str | Path) -> ViewTruth:
    """Load a truth file (``unseeable/truth@1``) and its ids/depth maps when named.

    Raises
    ------
    InputError
        Naming file, field and value on any inconsistency.
    """
    p = Path(path)
    return _truth_from_json(read_json(p), p)


def _truth_from_json(data: Any, p: Path) -> ViewTruth:
    """:func:`load_truth` of the parsed file ``p`` (its ids/depth maps read beside it)."""
    check_format(data, TRUTH_FORMAT, file=p)
    structure = structure_from_json(require(data, "structure", file=p), file=p,
                                    field="structure", check_grammar=False)
    pose = pose_from_json(require(data, "pose", file=p), file=p)
    camera = camera_from_json(require(data, "camera", file=p), file=p, field="camera")
    idx = feature_index(structure.extent)
    feats = require(data, "features", file=p)
    if not isinstance(feats, list) or len(feats) != len(idx):
        raise InputError(f"must list all {len(idx)} features of extent {structure.extent}",
                         file=p, field="features",
                         value=len(feats) if isinstance(feats, list) else feats)
    present = np.zeros(len(idx), dtype=bool)
    visible = np.zeros(len(idx), dtype=bool)
    for n, item in enumerate(feats):
        where = f"features[{n}]"
        kind = FeatureKind.parse(require(item, "kind", file=p, prefix=f"{where}."), file=p,
                                 field=f"{where}.kind")
        at = require(item, "at", file=p, prefix=f"{where}.")
        try:
            m = idx.lookup(kind, tuple(at))
        except (InputError, TypeError, ValueError):
            raise InputError("no such feature in the structure's extent", file=p,
                             field=f"{where}.at", value=at) from None
        for name, arr in (("present", present), ("visible", visible)):
            v = require(item, name, file=p, prefix=f"{where}.")
            if not isinstance(v, bool):
                raise InputError("must be true or false", file=p, field=f"{where}.{name}", value=v)
            arr[m] = v
    ids = depth = None
    if data.get("ids") is not None:
        ids_path = p.parent / str(data["ids"])
        try:
            with np.load(ids_path) as npz:
                ids = npz["ids"].astype(np.int32)
                depth = npz["depth"].astype(np.float32) if "depth" in npz else None
        except FileNotFoundError:
            raise InputError("ids file not found", file=p, field="ids", value=data["ids"]) from None
        except (OSError, ValueError, KeyError) as err:
            raise InputError(f"cannot read the ids file: {err}", file=p, field="ids",
                             value=data["ids"]) from None
        if ids.shape != (camera.height, camera.width):
            raise InputError(f"ids map is {ids.shape[1]}x{ids.shape[0]}, the camera's image "
                             f"{camera.width}x{camera.height}", file=p, field="ids",
                             value=data["ids"])
    removed = data.get("removed_from_layer")
    removed_logs = data.get("removed_logs") or ()
    return ViewTruth(structure, pose, camera, present, visible, ids, depth, removed,
                     tuple(removed_logs), str(data.get("visibility_source", "model")),
                     data.get("look"))
