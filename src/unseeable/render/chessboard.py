"""A printed chessboard lying on the simulated table, for locating cameras.

A :class:`TableChessboard` is a sheet of paper with a chessboard printed on
it (:class:`~unseeable.camera.calibrate.Chessboard`: ``cols x rows`` inner
corners, dark top-left square), lying face up at a
:class:`~unseeable.camera.calibrate.BoardPlacement` on the table, in the
board frame of :mod:`unseeable.camera.calibrate`: a photograph of it locates
the camera that took it in the table frame.

Put one in :attr:`RenderSettings.chessboard
<unseeable.render.settings.RenderSettings>` and every Mitsuba render with those
settings — :func:`~unseeable.render.renderer.render`, a
:class:`~unseeable.render.workspace.Workspace`'s views — shows it; the flat
raster renderer takes it as ``rasterise_view(..., chessboard=...)``. It is
not a log: the ground truth's ids read -1 on it, as on the table.

The print is a texture of whole texels (``texels_per_square`` per square's
side) looked up without interpolation, so the squares' edges are sharp at any
distance and the corners sit exactly where :meth:`TableChessboard.corners_table`
says.

Examples
--------
>>> from unseeable.camera.calibrate import BoardPlacement, Chessboard
>>> sheet = TableChessboard(Chessboard(5, 4, 20.0), BoardPlacement(x=-40, z=-30, thickness_mm=0.2))
>>> sheet.corners_table()[[0, 1, 5]].round(3).tolist()
[[-40.0, 0.2, -30.0], [-20.0, 0.2, -30.0], [-40.0, 0.2, -10.0]]
>>> sheet.texture().shape  # (rows + 1) and (cols + 1) squares plus a square's margin each side
(112, 128)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from unseeable.camera.calibrate import BoardPlacement, Chessboard
from unseeable.errors import InputError

__all__ = ["TableChessboard", "MIN_THICKNESS_MM"]

#: A rendered sheet lies at least this far above the table, so that the two surfaces do not
#: coincide (the renderer would show either, pixel by pixel).
MIN_THICKNESS_MM = 0.05


@dataclass(frozen=True)
class TableChessboard:
    """A printed chessboard lying on the table.

    Parameters
    ----------
    board : Chessboard
        The printed pattern.
    placement : BoardPlacement
        Where it lies (its printed surface ``thickness_mm`` above the table, at
        least :data:`MIN_THICKNESS_MM`).
    margin_mm : float or None
        Width of the plain border around the squares (default: one square),
        rounded to whole texels.
    paper, ink : float
        Linear reflectance of the paper and of the dark squares.
    texels_per_square : int
        Texels along a square's side in the print's texture.
    """

    board: Chessboard
    placement: BoardPlacement = BoardPlacement(thickness_mm=0.2)
    margin_mm: float | None = None
    paper: float = 0.75
    ink: float = 0.04
    texels_per_square: int = 16

    def __post_init__(self) -> None:
        if not isinstance(self.board, Chessboard):
            raise InputError("must be a Chessboard", field="chessboard.board",
                             value=type(self.board).__name__)
        if not isinstance(self.placement, BoardPlacement):
            raise InputError("must be a BoardPlacement", field="chessboard.placement",
                             value=type(self.placement).__name__)
        if self.placement.thickness_mm < MIN_THICKNESS_MM:
            raise InputError(f"must be at least {MIN_THICKNESS_MM} mm for a rendered sheet",
                             field="chessboard.placement.thickness_mm",
                             value=self.placement.thickness_mm)
        if self.margin_mm is not None and not (
                isinstance(self.margin_mm, (int, float)) and 0 <= self.margin_mm <= 1e4):
            raise InputError("must be a border width in [0, 10000] mm",
                             field="chessboard.margin_mm", value=self.margin_mm)
        for name in ("paper", "ink"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and 0 <= v <= 1):
                raise InputError("must be a reflectance in [0, 1]", field=f"chessboard.{name}",
                                 value=v)
        if not self.ink < self.paper:
            raise InputError("the ink must be darker than the paper", field="chessboard.ink",
                             value=self.ink)
        n = self.texels_per_square
        if isinstance(n, bool) or not isinstance(n, int) or not 1 <= n <= 256:
            raise InputError("must be a whole number in 1..256",
                             field="chessboard.texels_per_square", value=n)

    # -- geometry -----------------------------------------------------------
    @property
    def margin_texels(self) -> int:
        s = self.board.square_mm
        margin = s if self.margin_mm is None else float(self.margin_mm)
        return int(round(margin / s * self.texels_per_square))

    def sheet_board(self) -> np.ndarray:
        """The sheet's corners in the board frame, ``(4, 3)``: ``(u0, v0), (u1, v0), (u1, v1),
        (u0, v1)`` (mm; ``u0 = v0`` = minus a square minus the border)."""
        b = self.board
        border = self.margin_texels * b.square_mm / self.texels_per_square
        u0 = v0 = -b.square_mm - border
        u1 = b.cols * b.square_mm + border
        v1 = b.rows * b.square_mm + border
        return np.array([[u0, v0, 0.0], [u1, v0, 0.0], [u1, v1, 0.0], [u0, v1, 0.0]])

    def corners_table(self) -> np.ndarray:
        """The inner corners in the table frame, ``(cols * rows, 3)`` (mm), in the board's
        numbering."""
        return self.placement.to_table(self.board.object_points())

    def dark_squares_board(self) -> np.ndarray:
        """The dark squares' corners in the board frame, ``(M, 4, 3)`` (mm), each
        counter-clockwise in (u, v)."""
        b = self.board
        a, c = np.meshgrid(np.arange(b.cols + 1), np.arange(b.rows + 1), indexing="xy")
        dark = (a + c) % 2 == 0
        u0 = (a[dark] - 1) * b.square_mm
        v0 = (c[dark] - 1) * b.square_mm
        s = b.square_mm
        quad = np.array([[0.0, 0.0], [s, 0.0], [s, s], [0.0, s]])
        pts = np.stack([u0, v0], axis=1)[:, None, :] + quad[None]
        return np.concatenate([pts, np.zeros(pts.shape[:2] + (1,))], axis=2)

    def texture(self) -> np.ndarray:
        """The print as linear reflectance, ``(H, W) float32``: row 0 at ``v0``, column 0
        at ``u0`` (:meth:`sheet_board`), ``texels_per_square`` texels per square."""
        b, n, m = self.board, self.texels_per_square, self.margin_texels
        height, width = (b.rows + 1) * n + 2 * m, (b.cols + 1) * n + 2 * m
        rows = np.arange(height) - m
        cols = np.arange(width) - m
        a = cols // n  # square index along u (0 .. cols), outside: border
        c = rows // n
        inside = ((c >= 0) & (c <= b.rows))[:, None] & ((a >= 0) & (a <= b.cols))[None, :]
        dark = inside & ((c[:, None] + a[None, :]) % 2 == 0)
        return np.where(dark, np.float32(self.ink), np.float32(self.paper)).astype(np.float32)

    # -- drawing ------------------------------------------------------------
    def mesh(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The sheet as two triangles facing up, for a renderer.

        Returns
        -------
        vertices : (4, 3) float32
            The sheet's corners in the table frame (:meth:`sheet_board` order).
        faces : (2, 3) uint32
            Counter-clockwise seen from above, so their normals point up (+y).
        normals : (4, 3) float32
        uv : (4, 2) float32
            Texture coordinates: u along the board's width, v down it, as
            :meth:`texture`'s columns and rows.
        """
        vertices = self.placement.to_table(self.sheet_board()).astype(np.float32)
        faces = np.array([[0, 2, 1], [0, 3, 2]], dtype=np.uint32)
        normals = np.tile(np.float32([0.0, 1.0, 0.0]), (4, 1))
        uv = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]], dtype=np.float32)
        return vertices, faces, normals, uv

    def srgb(self) -> tuple[float, float]:
        """``(paper, ink)`` sRGB-encoded, for renderers that paint in sRGB."""
        def encode(c: float) -> float:
            return float(12.92 * c if c <= 0.0031308 else 1.055 * c ** (1 / 2.4) - 0.055)

        return encode(self.paper), encode(self.ink)
