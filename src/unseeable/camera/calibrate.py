"""Your own camera: calibrate it on a printed chessboard and locate it on the table.

Two steps, as OpenCV does them:

1. :func:`calibrate_camera` — intrinsics (focal lengths, principal point, lens
   distortion) from several photographs of a chessboard held at varied angles
   (``findChessboardCorners`` + ``cornerSubPix`` + ``calibrateCamera``).
2. :func:`locate_camera` — the camera's rotation and position in the table
   frame from one photograph of the chessboard lying flat on the table
   (``solvePnP``, iterative, refined by ``solvePnPRefineLM``).

The board and its frame
-----------------------
A board of ``COLSxROWS`` counts *inner* corners (where four squares meet): it
has ``(COLS + 1) x (ROWS + 1)`` squares of side ``square_mm``, and a plain
light border around them. Printed upright, it has COLS inner corners along
its width and ROWS down its height, and its **top-left square is dark**
(OpenCV's ``pattern.png``, 9x6, is such a board).

To locate a camera the board must look different turned half round, so
``COLS + ROWS`` must be odd (9x6, 7x4, 8x5, ...); calibration takes any board.

Board frame: origin at the board's top-left inner corner (the one whose
outside diagonal neighbour is the dark corner square); ``u`` along the width
(COLS corners at ``u = 0, s, ..., (COLS-1) s``), ``v`` down the page (ROWS
corners at ``v = 0, ..., (ROWS-1) s``), ``w = u × v`` pointing *into* the
table (OpenCV's object frame: the camera sees the board from ``w < 0``).
Corners are numbered row by row: corner ``n = j * COLS + i`` at ``(i s, j s)``.

Lying face up on the table (:class:`BoardPlacement` ``x, z, yaw_deg,
thickness_mm``), the board's corner ``(u, v)`` is at the table-frame point::

    table = Rot_y(yaw) @ (u, 0, v) + (x, thickness, z)

so with the defaults (0, 0, 0°, 0 mm) the board's origin *is* the table
frame's origin, the board's width runs along the table's +x, its height (down
the page) along +z, and +y points up out of the board — a right-handed frame
(x × z = -y; seen from above, with x to the right, z points towards you, as
the page's "down" does). ``thickness_mm`` lifts the printed surface above
the table (y = 0 is the table, where the logs stand). ``Rot_y`` is the
right-handed rotation about +y of :func:`unseeable.domain.rot_y` (positive
yaw turns counter-clockwise seen from above), the same as a
:class:`~unseeable.domain.GridPose`'s.

Intrinsics file (``unseeable/intrinsics@1``)::

    {"format": "unseeable/intrinsics@1",
     "width": W, "height": H,                       image size (px)
     "K": [[fx, 0, cx], [0, fy, cy], [0, 0, 1]],    px; pixel centres at whole numbers
     "dist": [k1, k2, p1, p2, k3],                  OpenCV's model (optional: none)
     "rms_px": 0.21,                                calibration's RMS reprojection error
     "images": 9}                                   photographs it used (both optional)

Examples
--------
>>> board = Chessboard.parse("9x6", square_mm=25.0)
>>> board.object_points()[[0, 1, 9]].tolist()
[[0.0, 0.0, 0.0], [25.0, 0.0, 0.0], [0.0, 25.0, 0.0]]
>>> BoardPlacement(x=100.0, yaw_deg=90.0).to_table(board.object_points()[[1, 9]]).round(6).tolist()
[[100.0, 0.0, -25.0], [125.0, 0.0, 0.0]]
"""

from __future__ import annotations

import logging
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from unseeable.camera.pinhole import Camera
from unseeable.errors import InputError
from unseeable.fileio import check_format, read_image, read_json, write_json

__all__ = [
    "INTRINSICS_FORMAT",
    "DISTORTION_MODELS",
    "Chessboard",
    "BoardPlacement",
    "Intrinsics",
    "Calibration",
    "CameraLocation",
    "find_chessboard",
    "calibrate_camera",
    "calibrate_files",
    "locate_camera",
    "locate_file",
    "intrinsics_to_json",
    "intrinsics_from_json",
    "load_intrinsics",
    "save_intrinsics",
    "read_photo",
    "check_photo",
]

logger = logging.getLogger(__name__)

INTRINSICS_FORMAT = "unseeable/intrinsics@1"

#: Lens distortion models :func:`calibrate_camera` can fit (OpenCV's coefficients).
DISTORTION_MODELS = {
    "none": "no distortion",
    "radial": "k1, k2",
    "radial-tangential": "k1, k2, p1, p2",
    "full": "k1, k2, p1, p2, k3",
}

#: Photographs fewer than this cannot calibrate a camera.
MIN_CALIBRATION_IMAGES = 3

#: Longest side of the image the board is searched in; corners are then refined at full size
#: (the search is slow on large photographs, the refinement is not).
_SEARCH_SIDE_PX = 1600


# --------------------------------------------------------------------------
# the board


@dataclass(frozen=True)
class Chessboard:
    """A printed chessboard: ``cols x rows`` inner corners, squares of ``square_mm``.

    Parameters
    ----------
    cols, rows : int
        Inner corners along the board's width and down its height (each >= 2).
    square_mm : float
        Side of a square (mm).

    Examples
    --------
    >>> Chessboard(9, 6, 25.0).asymmetric, Chessboard(8, 6, 25.0).asymmetric
    (True, False)
    """

    cols: int
    rows: int
    square_mm: float

    def __post_init__(self) -> None:
        for name in ("cols", "rows"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not 2 <= v <= 200:
                raise InputError("must be a whole number of inner corners in 2..200",
                                 field=f"chessboard.{name}", value=v)
            object.__setattr__(self, name, int(v))
        s = self.square_mm
        if isinstance(s, bool) or not isinstance(s, (int, float, np.integer, np.floating)) \
                or not np.isfinite(s) or not 0 < s <= 1000:
            raise InputError("must be a square side in (0, 1000] mm", field="square_mm", value=s)
        object.__setattr__(self, "square_mm", float(s))

    @classmethod
    def parse(cls, text: str, *, square_mm: float, field: str = "--chessboard") -> Chessboard:
        """A board from ``"COLSxROWS"`` (inner corners) and the square's side in mm."""
        try:
            cols, rows = (int(p) for p in str(text).lower().split("x"))
        except ValueError:
            raise InputError("must be COLSxROWS inner corners, e.g. 9x6", field=field,
                             value=text) from None
        try:
            return cls(cols, rows, square_mm)
        except InputError as err:
            name = field if err.field.startswith("chessboard.") else "--square"
            raise InputError(err.message, field=name, value=err.value) from None

    @property
    def size(self) -> tuple[int, int]:
        """``(cols, rows)``: OpenCV's ``patternSize``."""
        return (self.cols, self.rows)

    @property
    def corners(self) -> int:
        return self.cols * self.rows

    @property
    def asymmetric(self) -> bool:
        """Whether the board looks different turned half round (``cols + rows`` odd), so that
        a photograph fixes its origin and axes."""
        return (self.cols + self.rows) % 2 == 1

    def object_points(self) -> np.ndarray:
        """The inner corners in the board frame, ``(cols * rows, 3)`` float (mm), row by row:
        corner ``j * cols + i`` at ``(i s, j s, 0)``."""
        j, i = np.mgrid[0:self.rows, 0:self.cols]
        pts = np.stack([i.ravel(), j.ravel(), np.zeros(i.size)], axis=1)
        return pts * self.square_mm

    def __str__(self) -> str:
        return f"{self.cols}x{self.rows}"


#: The board frame's axes in the table frame at yaw 0: u → +x, v → +z, w → -y (columns).
_BOARD_AXES = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])


@dataclass(frozen=True)
class BoardPlacement:
    """Where a chessboard lies on the table (see the module's board frame).

    Parameters
    ----------
    x, z : float
        Table-frame position (mm) of the board's origin (its top-left inner corner).
    yaw_deg : float
        Turn of the board about the table's vertical (+y, counter-clockwise seen from
        above); 0 puts the board's width along +x and its height along +z.
    thickness_mm : float
        Height of the printed surface above the table.
    """

    x: float = 0.0
    z: float = 0.0
    yaw_deg: float = 0.0
    thickness_mm: float = 0.0

    def __post_init__(self) -> None:
        for name in ("x", "z", "yaw_deg", "thickness_mm"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)) \
                    or not np.isfinite(v):
                raise InputError("must be a finite number", field=name, value=v)
            object.__setattr__(self, name, float(v))
        if not 0.0 <= self.thickness_mm <= 100.0:
            raise InputError("must be in [0, 100] mm", field="thickness_mm",
                             value=self.thickness_mm)

    @property
    def rotation(self) -> np.ndarray:
        """Board → table rotation, ``(3, 3)`` (columns: the board's u, v, w in the table)."""
        from unseeable.domain import rot_y

        return rot_y(np.deg2rad(self.yaw_deg)) @ _BOARD_AXES

    @property
    def origin(self) -> np.ndarray:
        """Table-frame position of the board's origin, ``(3,)`` (mm)."""
        return np.array([self.x, self.thickness_mm, self.z])

    def to_table(self, points: np.ndarray) -> np.ndarray:
        """Board-frame points ``(N, 3)`` → table frame ``(N, 3)``."""
        return np.asarray(points, dtype=float) @ self.rotation.T + self.origin


# --------------------------------------------------------------------------
# intrinsics


@dataclass(frozen=True, eq=False)
class Intrinsics:
    """What calibration finds: image size, camera matrix and lens distortion.

    Parameters
    ----------
    width, height : int
        Image size (px).
    K : (3, 3) float
        ``[[fx, s, cx], [0, fy, cy], [0, 0, 1]]`` in pixels.
    dist : (5,) float
        OpenCV's ``k1, k2, p1, p2, k3``.
    """

    width: int
    height: int
    K: np.ndarray
    dist: np.ndarray

    def __post_init__(self) -> None:
        # The camera's checks are the intrinsics' checks (a camera at the origin).
        cam = Camera(self.width, self.height, self.K, np.eye(3), np.zeros(3), self.dist)
        for name in ("width", "height", "K", "dist"):
            object.__setattr__(self, name, getattr(cam, name))

    @classmethod
    def of(cls, camera: Camera) -> Intrinsics:
        """The intrinsics of ``camera``."""
        return cls(camera.width, camera.height, camera.K, camera.dist)

    @property
    def size(self) -> tuple[int, int]:
        return (self.width, self.height)

    def camera(self, R: np.ndarray, t: np.ndarray) -> Camera:
        """A :class:`Camera` with these intrinsics and extrinsics ``R``, ``t``."""
        return Camera(self.width, self.height, self.K, R, t, self.dist)

    def __repr__(self) -> str:
        K = self.K
        return (f"Intrinsics({self.width}x{self.height}, fx={K[0, 0]:.1f}, fy={K[1, 1]:.1f}, "
                f"cx={K[0, 2]:.1f}, cy={K[1, 2]:.1f})")


def intrinsics_to_json(intrinsics: Intrinsics, *, rms_px: float | None = None,
                       images: int | None = None) -> dict[str, Any]:
    """The ``unseeable/intrinsics@1`` record of ``intrinsics`` (with the calibration's
    RMS error and image count when given)."""
    data: dict[str, Any] = {
        "format": INTRINSICS_FORMAT,
        "width": intrinsics.width,
        "height": intrinsics.height,
        "K": intrinsics.K.tolist(),
        "dist": intrinsics.dist.tolist(),
    }
    if rms_px is not None:
        data["rms_px"] = float(rms_px)
    if images is not None:
        data["images"] = int(images)
    return data


def intrinsics_from_json(data: Any, *, file: Any = None) -> Intrinsics:
    """Validate a parsed intrinsics file; errors name the file and the field."""
    check_format(data, INTRINSICS_FORMAT, file=file)
    for key in ("width", "height", "K"):
        if key not in data:
            raise InputError("is missing", file=file, field=key)
    for key in ("rms_px", "images"):
        v = data.get(key)
        if v is not None and (isinstance(v, bool) or not isinstance(v, (int, float))
                              or not np.isfinite(v) or v < 0):
            raise InputError("must be a number >= 0", file=file, field=key, value=v)
    try:
        return Intrinsics(data["width"], data["height"], data["K"], data.get("dist"))
    except InputError as err:
        raise InputError(err.message, file=file, field=err.field, value=err.value) from None


def load_intrinsics(path: str | Path) -> Intrinsics:
    """Read an ``unseeable/intrinsics@1`` file."""
    return intrinsics_from_json(read_json(path), file=path)


def save_intrinsics(intrinsics: Intrinsics, path: str | Path, *, rms_px: float | None = None,
                    images: int | None = None) -> None:
    """Write an ``unseeable/intrinsics@1`` file atomically."""
    write_json(path, intrinsics_to_json(intrinsics, rms_px=rms_px, images=images))


# --------------------------------------------------------------------------
# finding the board


def _grey(image: np.ndarray) -> np.ndarray:
    import cv2

    arr = np.asarray(image)
    if arr.dtype != np.uint8 or arr.ndim not in (2, 3) or (arr.ndim == 3 and arr.shape[2] != 3):
        raise InputError("must be an (H, W, 3) RGB or (H, W) grey uint8 image", field="image",
                         value=f"{arr.dtype} {arr.shape}")
    return cv2.cvtColor(arr, cv2.COLOR_RGB2GRAY) if arr.ndim == 3 else arr


def _orient(grid: np.ndarray, grey: np.ndarray) -> np.ndarray:
    """Renumber the corners ``(rows, cols, 2)`` of an asymmetric board to its board frame.

    OpenCV may number a board from any of the corners that fit the pattern's size,
    in either sense. Two facts fix the frame. (1) The board is seen from its printed
    side, from ``w < 0``: then ``u`` and ``v`` turn in the image as the image's x
    and y do (the image is y down), else the numbering is mirrored. (2) The square
    between corners ``(i, j)`` and ``(i+1, j+1)`` is dark when ``i + j`` is even;
    turned half round, as ``cols + rows`` is odd, the dark squares are the others.
    """
    import cv2

    du = grid[0, -1] - grid[0, 0]
    dv = grid[-1, 0] - grid[0, 0]
    if du[0] * dv[1] - du[1] * dv[0] < 0:
        grid = grid[:, ::-1]
    # Each inner square's brightness: its four corners' mean and points towards them.
    centres = 0.25 * (grid[:-1, :-1] + grid[1:, :-1] + grid[:-1, 1:] + grid[1:, 1:])
    samples = [centres] + [centres + 0.5 * (c - centres)
                           for c in (grid[:-1, :-1], grid[1:, :-1], grid[:-1, 1:], grid[1:, 1:])]
    pts = np.ascontiguousarray(np.stack(samples), dtype=np.float32)
    values = cv2.remap(grey.astype(np.float32), pts.reshape(-1, 1, 2), None, cv2.INTER_LINEAR,
                       borderMode=cv2.BORDER_REPLICATE).reshape(pts.shape[:-1]).mean(axis=0)
    j, i = np.mgrid[0:values.shape[0], 0:values.shape[1]]
    even = (i + j) % 2 == 0
    if values[even].mean() > values[~even].mean():
        grid = grid[::-1, ::-1]
    return grid


def _detect(grey: np.ndarray, size: tuple[int, int]) -> np.ndarray | None:
    """Whole-pixel corners ``(N, 2)`` of a ``size`` board in OpenCV's numbering, or None.

    OpenCV's quad detector misses a board now and then under one thresholding and
    finds it under another (small squares, uneven light), so several are tried in
    turn, then the image doubled (squares under ~20 px), then the sector-based
    detector.
    """
    import cv2

    adaptive, normalise = cv2.CALIB_CB_ADAPTIVE_THRESH, cv2.CALIB_CB_NORMALIZE_IMAGE

    def attempts():
        for flags in (adaptive | normalise, adaptive, 0):
            yield grey, 1.0, flags
        if max(grey.shape) < 1000:
            yield (cv2.resize(grey, None, fx=2.0, fy=2.0, interpolation=cv2.INTER_LINEAR), 2.0,
                   adaptive | normalise)

    for image, scale, flags in attempts():
        found, corners = cv2.findChessboardCorners(image, size, flags=flags)
        if found:
            # Pixel centres at whole numbers: u in the doubled image is at (u + ½)/2 - ½.
            return (corners.reshape(-1, 2).astype(np.float64) + 0.5) / scale - 0.5
    found, corners = cv2.findChessboardCornersSB(grey, size)
    return corners.reshape(-1, 2).astype(np.float64) if found else None


def find_chessboard(image: np.ndarray, board: Chessboard, *, oriented: bool = False
                    ) -> np.ndarray | None:
    """The board's inner corners in a photograph, to a fraction of a pixel.

    Parameters
    ----------
    image : (H, W, 3) or (H, W) uint8
        RGB or grey photograph.
    board : Chessboard
    oriented : bool
        Number the corners in the board frame (module docstring): needs an
        asymmetric board. Else OpenCV's numbering, which may start at any
        corner that fits the pattern (enough for calibration).

    Returns
    -------
    (cols * rows, 2) float or None
        Pixel coordinates, corner ``j * cols + i`` at index ``j * cols + i``;
        None when the whole board is not found.
    """
    import cv2

    if oriented and not board.asymmetric:
        raise InputError("must have an odd number of inner corners in all (e.g. 9x6) to fix "
                         "the table's axes: this board looks the same turned half round",
                         field="--chessboard", value=str(board))
    grey = _grey(image)
    h, w = grey.shape
    scale = min(1.0, _SEARCH_SIDE_PX / max(h, w))
    search = grey if scale == 1.0 else cv2.resize(grey, (round(w * scale), round(h * scale)),
                                                  interpolation=cv2.INTER_AREA)
    corners = _detect(search, board.size)
    if corners is None:
        return None
    if scale != 1.0:
        # Pixel centres at whole numbers: a point at u in the small image is at (u + ½)/s - ½.
        corners = (corners + 0.5) / scale - 0.5
    grid = corners.reshape(board.rows, board.cols, 2)
    spacing = min(np.linalg.norm(np.diff(grid, axis=0), axis=2).min(),
                  np.linalg.norm(np.diff(grid, axis=1), axis=2).min())
    # The refinement window must hold one corner's edges and no neighbour's.
    half = int(np.clip(0.4 * spacing, 2, 11))
    criteria = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_MAX_ITER, 100, 1e-4)
    refined = cv2.cornerSubPix(grey, corners.astype(np.float32).reshape(-1, 1, 2),
                               (half, half), (-1, -1), criteria)
    grid = refined.reshape(board.rows, board.cols, 2).astype(np.float64)
    if oriented:
        grid = _orient(grid, grey)
    return grid.reshape(-1, 2)


def read_photo(path: str | Path) -> np.ndarray:
    """A photograph as ``(H, W, 3) uint8`` RGB, read as the estimator reads a view's image
    (:func:`unseeable.fileio.read_image`: the pixels as stored, not turned by the file's
    orientation tag), so that intrinsics, camera and view speak of the same pixels.

    Raises
    ------
    InputError
        When the file is missing or is not an image.
    """
    return read_image(path)


# --------------------------------------------------------------------------
# calibration


@dataclass(frozen=True, eq=False)
class Calibration:
    """The outcome of :func:`calibrate_camera`.

    Attributes
    ----------
    intrinsics : Intrinsics
    rms_px : float
        RMS reprojection error over every corner of every photograph used (px).
    used : tuple of str
        Names of the photographs the board was found in (and that were used).
    skipped : tuple of str
        Names of the photographs without a (whole) board.
    image_rms_px : (N,) float
        RMS reprojection error per photograph used, in the order of ``used``.
    """

    intrinsics: Intrinsics
    rms_px: float
    used: tuple[str, ...]
    skipped: tuple[str, ...]
    image_rms_px: np.ndarray


def _calibration_flags(distortion: str) -> int:
    import cv2

    fixed = {
        "none": cv2.CALIB_FIX_K1 | cv2.CALIB_FIX_K2 | cv2.CALIB_FIX_K3
        | cv2.CALIB_ZERO_TANGENT_DIST,
        "radial": cv2.CALIB_FIX_K3 | cv2.CALIB_ZERO_TANGENT_DIST,
        "radial-tangential": cv2.CALIB_FIX_K3,
        "full": 0,
    }
    if distortion not in fixed:
        raise InputError(f"must be one of {sorted(DISTORTION_MODELS)}", field="--distortion",
                         value=distortion)
    return fixed[distortion]


def calibrate_camera(images: Iterable[np.ndarray], board: Chessboard, *,
                     names: Sequence[str] | None = None,
                     distortion: str = "radial") -> Calibration:
    """Intrinsics from photographs of a chessboard (OpenCV's ``calibrateCamera``).

    Parameters
    ----------
    images : iterable of (H, W, 3) or (H, W) uint8
        Photographs of the board from varied directions, all of one size; the
        board should fill a good part of each and be tilted differently in each
        (a board always square to the camera leaves the focal length unknown).
        Taken one at a time (a generator reading files keeps one in memory).
    board : Chessboard
    names : sequence of str, optional
        How to call each photograph in messages (default ``image 0``, ...).
    distortion : {"radial", "none", "radial-tangential", "full"}
        Which of OpenCV's distortion coefficients to fit (:data:`DISTORTION_MODELS`);
        the others stay 0. ``"radial"`` (k1, k2) suits most lenses; ``"full"`` needs
        many photographs reaching into the image's corners.

    Returns
    -------
    Calibration

    Raises
    ------
    InputError
        Photographs of differing sizes (naming the first that differs), or fewer
        than 3 photographs with the whole board in them (naming those without).
    """
    import cv2

    flags = _calibration_flags(distortion)
    names = None if names is None else list(names)
    size: tuple[int, int] | None = None
    first = ""
    used, skipped, found = [], [], []
    for n, image in enumerate(images):
        name = names[n] if names is not None else f"image {n}"
        grey = _grey(image)
        this = (grey.shape[1], grey.shape[0])
        if size is None:
            size, first = this, name
        elif this != size:
            raise InputError(f"is {this[0]}x{this[1]} but {first} is {size[0]}x{size[1]}: "
                             "calibrate on photographs of one size", file=name, field="size",
                             value=f"{this[0]}x{this[1]}")
        corners = find_chessboard(grey, board)
        if corners is None:
            logger.warning("%s: no %s chessboard found; skipped", name, board)
            skipped.append(name)
            continue
        used.append(name)
        found.append(corners)
    if len(found) < MIN_CALIBRATION_IMAGES:
        missing = f" (none in {', '.join(skipped)})" if skipped else ""
        raise InputError(f"the whole {board} chessboard was found in {len(found)} of "
                         f"{len(found) + len(skipped)} photographs{missing}; calibration "
                         f"needs at least {MIN_CALIBRATION_IMAGES}", field="images",
                         value=len(found))
    obj = board.object_points().astype(np.float32)
    image_points = [c.astype(np.float32).reshape(-1, 1, 2) for c in found]
    criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 200, 1e-12)
    rms, K, dist, rvecs, tvecs = cv2.calibrateCamera([obj] * len(found), image_points, size,
                                                     None, None, flags=flags, criteria=criteria)
    dist = np.asarray(dist, dtype=float).ravel()[:5]
    per_image = np.array([
        np.sqrt(np.mean(np.sum((cv2.projectPoints(obj, r, t, K, dist)[0].reshape(-1, 2)
                                - c) ** 2, axis=1)))
        for r, t, c in zip(rvecs, tvecs, found)])
    intrinsics = Intrinsics(size[0], size[1], np.asarray(K, dtype=float), dist)
    logger.info("calibrated on %d photographs: RMS %.3f px, %r", len(found), rms, intrinsics)
    return Calibration(intrinsics, float(rms), tuple(used), tuple(skipped), per_image)


def calibrate_files(paths: Sequence[str | Path], board: Chessboard, *,
                    distortion: str = "radial") -> Calibration:
    """:func:`calibrate_camera` on image files, read one at a time (an unreadable file is
    an :class:`InputError` naming it)."""
    paths = [Path(p) for p in paths]
    if not paths:
        raise InputError("must name at least one photograph", field="images", value=0)
    _calibration_flags(distortion)  # a bad option or a missing file fails before any work
    for p in paths:
        if not p.is_file():
            raise InputError("no such image file", file=p)
    return calibrate_camera((read_photo(p) for p in paths), board,
                            names=[str(p) for p in paths], distortion=distortion)


# --------------------------------------------------------------------------
# locating the camera


@dataclass(frozen=True, eq=False)
class CameraLocation:
    """The outcome of :func:`locate_camera`.

    Attributes
    ----------
    camera : Camera
        The camera in the table frame.
    rms_px, max_px : float
        RMS and largest reprojection error of the board's corners (px).
    corners : (N, 2) float
        The corners found, in board-frame order.
    """

    camera: Camera
    rms_px: float
    max_px: float
    corners: np.ndarray


#: :func:`locate_camera` refuses a location whose corners reproject worse than this (px).
MAX_LOCATE_RMS_PX = 2.0


def locate_camera(image: np.ndarray, intrinsics: Intrinsics | Camera, board: Chessboard, *,
                  placement: BoardPlacement = BoardPlacement(),
                  max_rms_px: float = MAX_LOCATE_RMS_PX, name: str | None = None
                  ) -> CameraLocation:
    """The camera in the table frame, from a photograph of a chessboard lying on the table.

    Parameters
    ----------
    image : (H, W, 3) or (H, W) uint8
        The photograph, of the intrinsics' size.
    intrinsics : Intrinsics or Camera
        The camera's intrinsics (a camera's extrinsics are ignored).
    board : Chessboard
        An asymmetric board (``cols + rows`` odd).
    placement : BoardPlacement
        Where the board lies in the table frame (module docstring).
    max_rms_px : float
        Refuse (:class:`InputError`) when the corners reproject worse than this.
    name : str, optional
        The photograph's name in messages.

    Returns
    -------
    CameraLocation

    Raises
    ------
    InputError
        The photograph is not of the intrinsics' size, the board is not found, or
        the fit is worse than ``max_rms_px`` (a wrong board size, wrong intrinsics,
        or a board that does not lie flat).
    """
    import cv2

    if isinstance(intrinsics, Camera):
        intrinsics = Intrinsics.of(intrinsics)
    grey = _grey(image)
    if (grey.shape[1], grey.shape[0]) != intrinsics.size:
        raise InputError(f"is {grey.shape[1]}x{grey.shape[0]} but the intrinsics are for "
                         f"{intrinsics.width}x{intrinsics.height} photographs", file=name,
                         field="size", value=f"{grey.shape[1]}x{grey.shape[0]}")
    corners = find_chessboard(grey, board, oriented=True)
    if corners is None:
        raise InputError(f"no {board} chessboard found (the whole board, with its light "
                         "border, must be in the picture)", file=name, field="chessboard",
                         value=str(board))
    obj = board.object_points()
    K, dist = intrinsics.K, intrinsics.dist
    ok, rvec, tvec = cv2.solvePnP(obj, corners, K, dist, flags=cv2.SOLVEPNP_ITERATIVE)
    if not ok:
        raise InputError("the board's corners admit no camera position", file=name,
                         field="chessboard", value=str(board))
    criteria = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 100, 1e-12)
    rvec, tvec = cv2.solvePnPRefineLM(obj, corners, K, dist, rvec, tvec, criteria=criteria)
    projected = cv2.projectPoints(obj, rvec, tvec, K, dist)[0].reshape(-1, 2)
    residual = np.linalg.norm(projected - corners, axis=1)
    rms, worst = float(np.sqrt(np.mean(residual**2))), float(residual.max())
    if not rms <= max_rms_px:
        raise InputError(f"the board's corners reproject {rms:.2f} px RMS from where they "
                         f"were found (at most {max_rms_px:g} px allowed): wrong intrinsics, "
                         "wrong --chessboard, or a board that does not lie flat", file=name,
                         field="reprojection", value=round(rms, 3))
    R_board = cv2.Rodrigues(rvec)[0]
    # X_cam = R_b X_board + t_b and X_table = A X_board + o  ⇒  R = R_b Aᵀ, t = t_b - R o.
    R = R_board @ placement.rotation.T
    t = tvec.ravel() - R @ placement.origin
    camera = intrinsics.camera(R, t)
    logger.info("located %r: reprojection %.3f px RMS, %.3f px at most", camera, rms, worst)
    return CameraLocation(camera, rms, worst, corners)


def locate_file(path: str | Path, intrinsics: Intrinsics | Camera, board: Chessboard, *,
                placement: BoardPlacement = BoardPlacement(),
                max_rms_px: float = MAX_LOCATE_RMS_PX) -> CameraLocation:
    """:func:`locate_camera` on an image file; errors name the file."""
    return locate_camera(read_photo(path), intrinsics, board, placement=placement,
                         max_rms_px=max_rms_px, name=str(path))


# --------------------------------------------------------------------------
# photographs for a view


def check_photo(photo: str | Path, camera: Camera | Intrinsics, *,
                camera_file: str | Path | None = None) -> np.ndarray:
    """Read a photograph taken by ``camera`` and check that it is the camera's size.

    Parameters
    ----------
    photo : path
    camera : Camera or Intrinsics
    camera_file : path, optional
        Where ``camera`` came from, for messages.

    Returns
    -------
    (H, W, 3) uint8
        The photograph (:func:`read_photo`).

    Raises
    ------
    InputError
        An unreadable photograph, or one whose size is not the camera's (naming the
        file and ``size``): a resized or cropped photograph needs its own camera.
    """
    image = read_photo(photo)
    height, width = image.shape[:2]
    if (width, height) != camera.size:
        source = f" ({camera_file})" if camera_file is not None else ""
        raise InputError(f"is {width}x{height} but the camera{source} is for "
                         f"{camera.width}x{camera.height} photographs", file=photo,
                         field="size", value=f"{width}x{height}")
    return image
