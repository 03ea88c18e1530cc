"""A second, independent renderer: flat-shaded rasterisation with OpenCV.

Everything the vision stage was calibrated and tuned on is path traced by
Mitsuba (:mod:`unseeable.render.renderer`). To measure how much of that is
the renderer's look rather than the assembly's geometry, this module draws
the same scenes in a different way: the logs' CAD triangles, back faces
culled, sorted far to near (painter's algorithm) and filled with one
Lambert-shaded colour each; hard shadows cast by a point-like light onto a
plain table; supersampled, then blurred a little, with sensor noise. No
textures, no soft shadows, no interreflection, no tone curve — a look the
calibration never saw (the benchmark family ``other-renderer`` of
``benchmarks/vision.py``).

It is also fast (a 640×480 view of 30 logs in a few tenths of a second),
but it is a measuring instrument, not a preview: the painter's order can
misdraw a few pixels where notched logs interlock.

Examples
--------
>>> from unseeable.camera import Camera
>>> from unseeable.domain import Extent, GridPose, Log, Structure
>>> s = Structure(Extent(2, 1, 1), [Log(layer=0, at=(0, 0), notches=2)])
>>> cam = Camera.look_at(eye=[0, 300, -400], target=[32, 10, 0], width=64, height=48,
...                      fov_deg=50)
>>> image = rasterise_view(s, GridPose(), cam, look=RasterLook())
>>> image.shape, image.dtype.name
((48, 64, 3), 'uint8')
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import cv2
import numpy as np

from unseeable.camera import Camera
from unseeable.domain import GridPose, LogGeometry, Structure
from unseeable.errors import InputError

if TYPE_CHECKING:
    from unseeable.render.chessboard import TableChessboard

__all__ = ["RasterLook", "random_raster_look", "rasterise_view"]


@dataclass(frozen=True)
class RasterLook:
    """Colours and light of one rasterised scene (sRGB colours in [0, 1]).

    Attributes
    ----------
    wood : (3,) tuple
        Base colour of the logs.
    log_variation : float
        Standard deviation of each log's brightness factor.
    table : (3,) tuple
    light_azimuth_deg, light_elevation_deg : float
        Direction towards the light, from the table.
    ambient : float
        Share of the light that is ambient (shadows and faces turned away get only it).
    noise : float
        Standard deviation of the sensor noise (fraction of full scale).
    blur_px : float
        Gaussian lens blur.
    """

    wood: tuple[float, float, float] = (0.62, 0.42, 0.24)
    log_variation: float = 0.06
    table: tuple[float, float, float] = (0.55, 0.55, 0.52)
    light_azimuth_deg: float = 60.0
    light_elevation_deg: float = 50.0
    ambient: float = 0.35
    noise: float = 0.01
    blur_px: float = 0.6


def random_raster_look(rng: np.random.Generator) -> RasterLook:
    """A look drawn from wide ranges: wood from pale to dark, tables grey, brown, green, white."""
    tables = ((0.55, 0.55, 0.52), (0.35, 0.24, 0.15), (0.30, 0.42, 0.30), (0.82, 0.82, 0.80),
              (0.20, 0.20, 0.22))
    shade = rng.uniform(0.6, 1.3)
    wood = np.clip(np.array([0.62, 0.42, 0.24]) * shade * rng.normal(1.0, 0.08, 3), 0.03, 0.95)
    table = np.clip(np.asarray(tables[int(rng.integers(len(tables)))])
                    * rng.uniform(0.8, 1.15), 0.02, 0.98)
    return RasterLook(wood=tuple(float(v) for v in wood),
                      log_variation=float(rng.uniform(0.0, 0.1)),
                      table=tuple(float(v) for v in table),
                      light_azimuth_deg=float(rng.uniform(-180.0, 180.0)),
                      light_elevation_deg=float(rng.uniform(25.0, 80.0)),
                      ambient=float(rng.uniform(0.2, 0.5)), noise=float(rng.uniform(0.003, 0.02)),
                      blur_px=float(rng.uniform(0.3, 1.0)))


def _fill(canvas: np.ndarray, polygons: np.ndarray, colours: np.ndarray, shift: int) -> None:
    """Fill each ``(3, 2)`` fixed-point triangle with its colour, in order."""
    for tri, colour in zip(polygons, colours):
        cv2.fillConvexPoly(canvas, tri, colour.tolist(), lineType=cv2.LINE_8, shift=shift)


def _draw_chessboard(canvas: np.ndarray, chessboard: TableChessboard, camera: Camera,
                     shift: int) -> None:
    """Paint the printed sheet onto the table (paper, then the dark squares)."""
    paper, ink = chessboard.srgb()
    placement = chessboard.placement
    sheet = camera.project(placement.to_table(chessboard.sheet_board()))
    squares = chessboard.dark_squares_board()
    quads = camera.project(placement.to_table(squares.reshape(-1, 3))).reshape(-1, 4, 2)
    for polygons, colour in ((sheet[None], paper), (quads, ink)):
        keep = np.all(np.isfinite(polygons), axis=(1, 2))
        pts = np.round(polygons[keep] * (1 << shift)).astype(np.int32)
        _fill(canvas, pts, np.full((len(pts), 3), colour, np.float32), shift)


def rasterise_view(structure: Structure, pose: GridPose, camera: Camera, *,
                   look: RasterLook = RasterLook(), seed: int = 0, supersample: int = 3,
                   geometry: LogGeometry = LogGeometry(),
                   chessboard: TableChessboard | None = None) -> np.ndarray:
    """A flat-shaded photograph of ``structure`` at ``pose`` seen by ``camera``.

    Parameters
    ----------
    structure : Structure
    pose : GridPose
    camera : Camera
    look : RasterLook
    seed : int
        Seeds the per-log brightness and the sensor noise.
    supersample : int
        Pixels per image pixel along each axis while drawing (anti-aliasing).
    geometry : LogGeometry
    chessboard : TableChessboard, optional
        A printed chessboard lying on the table (:mod:`unseeable.render.chessboard`),
        drawn flat, with the logs' shadows falling on it.

    Returns
    -------
    (H, W, 3) uint8
        sRGB image of ``camera``'s size.
    """
    from unseeable.render.cad import placed_logs

    if not isinstance(supersample, int) or supersample < 1:
        raise InputError("must be a whole number >= 1", field="supersample", value=supersample)
    rng = np.random.default_rng([int(seed), 31])
    big = camera.scaled(float(supersample)) if supersample > 1 else camera
    height, width = big.height, big.width
    table = np.asarray(look.table, float)
    canvas = np.empty((height, width, 3), np.float32)
    canvas[:] = table

    az, el = np.radians(look.light_azimuth_deg), np.radians(look.light_elevation_deg)
    light = np.array([np.cos(el) * np.cos(az), np.sin(el), np.cos(el) * np.sin(az)])
    shift = 4  # fixed-point sub-pixel bits of cv2's polygon filling
    if chessboard is not None:
        _draw_chessboard(canvas, chessboard, big, shift)
    if structure.logs:
        verts, faces, owner = placed_logs(structure, pose, geometry=geometry)
        tri = verts[faces]  # (F, 3, 3)
        normals = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-12)

        # Hard shadows: every triangle projected along the light onto the table (y = 0).
        flat = tri - (tri[..., 1:2] / light[1]) * light
        uv = big.project(flat.reshape(-1, 3)).reshape(-1, 3, 2)
        keep = np.all(np.isfinite(uv), axis=(1, 2))
        shadow = np.zeros((height, width), np.uint8)
        pts = np.round(uv[keep] * (1 << shift)).astype(np.int32)
        _fill(shadow, pts, np.ones((len(pts), 1), np.uint8), shift)
        if chessboard is None:
            canvas[shadow > 0] = table * look.ambient
        else:  # the shadows darken the sheet as they do the table
            canvas[shadow > 0] *= np.float32(look.ambient)

        # The logs: front faces, far to near, each one colour.
        centroid = tri.mean(axis=1)
        front = np.sum(normals * (big.centre - centroid), axis=1) > 0
        depth = big.depth(centroid)
        uv = big.project(tri.reshape(-1, 3)).reshape(-1, 3, 2)
        keep = front & np.all(np.isfinite(uv), axis=(1, 2)) & (depth > 0)
        order = np.flatnonzero(keep)[np.argsort(-depth[keep], kind="stable")]
        factor = 1.0 + rng.normal(0.0, look.log_variation, len(structure.logs))
        lambert = np.clip(normals[order] @ light, 0.0, 1.0)
        light_in = look.ambient + (1.0 - look.ambient) * lambert
        colours = (np.asarray(look.wood)[None] * (factor[owner[order]] * light_in)[:, None])
        pts = np.round(uv[order] * (1 << shift)).astype(np.int32)
        _fill(canvas, pts, np.clip(colours, 0.0, 1.0).astype(np.float32), shift)

    image = cv2.resize(canvas, (camera.width, camera.height), interpolation=cv2.INTER_AREA)
    if look.blur_px > 0:
        image = cv2.GaussianBlur(image, (0, 0), look.blur_px)
    image = image + rng.normal(0.0, look.noise, image.shape).astype(np.float32)
    return np.clip(np.round(image * 255.0), 0, 255).astype(np.uint8)
