"""An OpenCV pinhole camera: ``X_cam = R @ X_world + t``; x right, y down, z forward."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from unseeable.errors import InputError

__all__ = ["Camera", "look_at_rotation"]


def _as_matrix(value, shape, name) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"must be a numeric array of shape {shape}", field=name,
                         value=value) from None
    if arr.shape != shape:
        raise InputError(f"must have shape {shape}", field=name, value=arr.shape)
    if not np.all(np.isfinite(arr)):
        raise InputError("must be finite", field=name, value=arr.tolist())
    return arr


@dataclass(frozen=True, eq=False)
class Camera:
    """A calibrated camera.

    Parameters
    ----------
    width, height : int
        Image size in pixels.
    K : (3, 3) float
        Intrinsics ``[[fx, 0, cx], [0, fy, cy], [0, 0, 1]]`` (skew allowed).
    R : (3, 3) float
        World → camera rotation (orthonormal, det +1).
    t : (3,) float
        World → camera translation (mm).
    dist : (5,) float
        OpenCV distortion ``k1, k2, p1, p2, k3`` (zeros: none).

    Examples
    --------
    >>> cam = Camera.look_at(eye=[0, 0, -1000], target=[0, 0, 0], width=640, height=480, fov_deg=60)
    >>> cam.project(np.array([[0.0, 0.0, 0.0]])).round(3).tolist()
    [[320.0, 240.0]]
    """

    width: int
    height: int
    K: np.ndarray
    R: np.ndarray
    t: np.ndarray
    dist: np.ndarray = field(default_factory=lambda: np.zeros(5))

    def __post_init__(self) -> None:
        for name in ("width", "height"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not 1 <= v <= 20000:
                raise InputError("must be a whole number of pixels in 1..20000", field=name,
                                 value=v)
            object.__setattr__(self, name, int(v))
        K = _as_matrix(self.K, (3, 3), "K")
        if K[0, 0] <= 0 or K[1, 1] <= 0:
            raise InputError("focal lengths fx, fy must be positive", field="K",
                             value=[float(K[0, 0]), float(K[1, 1])])
        if not np.allclose(K[2], [0, 0, 1]) or K[1, 0] != 0:
            raise InputError("must be upper triangular with last row [0, 0, 1]", field="K",
                             value=K.tolist())
        R = _as_matrix(self.R, (3, 3), "R")
        if not np.allclose(R @ R.T, np.eye(3), atol=1e-6) or np.linalg.det(R) < 0:
            raise InputError("must be a rotation (orthonormal, determinant +1)", field="R",
                             value=np.round(R, 4).tolist())
        t = _as_matrix(self.t, (3,), "t")
        dist = np.zeros(5) if self.dist is None else np.asarray(self.dist, dtype=float).ravel()
        if dist.size not in (4, 5, 8) or not np.all(np.isfinite(dist)):
            raise InputError("must hold 4, 5 or 8 finite OpenCV coefficients", field="dist",
                             value=dist.tolist())
        if dist.size == 4:
            dist = np.concatenate([dist, [0.0]])
        for name, arr in (("K", K), ("R", R), ("t", t), ("dist", dist)):
            arr = arr.copy()
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    # -- construction ------------------------------------------------------
    @classmethod
    def look_at(cls, *, eye, target, width: int, height: int, fov_deg: float | None = None,
                fx: float | None = None, up=(0.0, 1.0, 0.0), dist=None) -> Camera:
        """A camera at ``eye`` looking at ``target`` with the world's ``up`` pointing up.

        Give either the horizontal field of view ``fov_deg`` or the focal length ``fx``
        in pixels (square pixels, principal point at the image centre).
        """
        if (fov_deg is None) == (fx is None):
            raise InputError("give exactly one of fov_deg and fx", field="fov_deg", value=fov_deg)
        if fx is None:
            if not 1.0 < fov_deg < 179.0:
                raise InputError("must be in (1, 179) degrees", field="fov_deg", value=fov_deg)
            fx = width / 2.0 / np.tan(np.deg2rad(fov_deg) / 2.0)
        K = np.array([[fx, 0.0, width / 2.0], [0.0, fx, height / 2.0], [0.0, 0.0, 1.0]])
        eye = np.asarray(eye, dtype=float)
        R = look_at_rotation(eye, np.asarray(target, dtype=float), np.asarray(up, dtype=float))
        return cls(width, height, K, R, -R @ eye, np.zeros(5) if dist is None else dist)

    # -- properties --------------------------------------------------------
    @property
    def centre(self) -> np.ndarray:
        """Camera centre in the world, ``(3,)``: ``-R.T @ t``."""
        return -self.R.T @ self.t

    @property
    def size(self) -> tuple[int, int]:
        return (self.width, self.height)

    @property
    def has_distortion(self) -> bool:
        return bool(np.any(self.dist != 0))

    def world_to_camera(self, points: np.ndarray) -> np.ndarray:
        """``(N, 3)`` world points in the camera frame."""
        return np.asarray(points, dtype=float) @ self.R.T + self.t

    def project(self, points: np.ndarray) -> np.ndarray:
        """Pixel coordinates of world points.

        Parameters
        ----------
        points : (..., 3) float

        Returns
        -------
        (..., 2) float
            ``(u, v)``; points behind the camera give NaN.
        """
        p = np.asarray(points, dtype=float)
        shape = p.shape[:-1]
        pc = self.world_to_camera(p.reshape(-1, 3))
        z = pc[:, 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            x = pc[:, 0] / z
            y = pc[:, 1] / z
        if self.has_distortion:
            k1, k2, p1, p2, k3 = self.dist[:5]
            r2 = x * x + y * y
            radial = 1 + k1 * r2 + k2 * r2**2 + k3 * r2**3
            xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
            yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
            x, y = xd, yd
        K = self.K
        uv = np.stack([K[0, 0] * x + K[0, 1] * y + K[0, 2], K[1, 1] * y + K[1, 2]], axis=-1)
        uv[z <= 1e-9] = np.nan
        return uv.reshape(*shape, 2)

    def depth(self, points: np.ndarray) -> np.ndarray:
        """Camera-frame z of world points, ``(...,)``."""
        p = np.asarray(points, dtype=float)
        return (p.reshape(-1, 3) @ self.R[2] + self.t[2]).reshape(p.shape[:-1])

    def normalised(self, uv: np.ndarray) -> np.ndarray:
        """Pixels ``(..., 2)`` → normalised, undistorted camera coordinates ``(..., 2)``.

        ``(x, y)`` with the ray through the pixel along ``(x, y, 1)`` in the camera frame.
        """
        uv = np.asarray(uv, dtype=float)
        flat = uv.reshape(-1, 2)
        if self.has_distortion:
            import cv2

            norm = cv2.undistortPoints(flat.reshape(-1, 1, 2), self.K, self.dist).reshape(-1, 2)
        else:
            Kinv = np.linalg.inv(self.K)
            norm = flat @ Kinv[:2, :2].T + Kinv[:2, 2]
        return norm.reshape(uv.shape)

    def pixel_rays(self, uv: np.ndarray) -> np.ndarray:
        """Unit world-frame directions of the rays through pixels ``(..., 2)`` → ``(..., 3)``."""
        uv = np.asarray(uv, dtype=float)
        shape = uv.shape[:-1]
        norm = self.normalised(uv).reshape(-1, 2)
        d_cam = np.concatenate([norm, np.ones((len(norm), 1))], axis=1)
        d = d_cam @ self.R  # R.T @ d_cam for each row
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        return d.reshape(*shape, 3)

    def in_image(self, uv: np.ndarray, margin: float = 0.0) -> np.ndarray:
        """Whether pixel coordinates ``(..., 2)`` fall inside the image (less ``margin``)."""
        uv = np.asarray(uv)
        return ((uv[..., 0] >= margin) & (uv[..., 0] <= self.width - 1 - margin)
                & (uv[..., 1] >= margin) & (uv[..., 1] <= self.height - 1 - margin))

    def scaled(self, factor: float) -> Camera:
        """The same camera for this image resized by ``factor`` (as ``cv2.resize`` does).

        The new size is ``round(width * factor)`` × ``round(height * factor)``;
        each axis is scaled by its own exact ratio ``s`` (new size / old size),
        and since pixel centres sit at whole coordinates (OpenCV's convention,
        and the renderer's), a point at ``u`` moves to ``s (u + ½) - ½``: scaling
        ``K`` alone would misplace the resized image by ``(s - 1) / 2`` pixels.

        Examples
        --------
        >>> cam = Camera.look_at(eye=[0, 0, -1000], target=[0, 0, 0], width=640, height=480,
        ...                      fov_deg=60)
        >>> half = cam.scaled(0.5)
        >>> origin = np.zeros((1, 3))
        >>> half.size, cam.project(origin).tolist(), half.project(origin).tolist()
        ((320, 240), [[320.0, 240.0]], [[159.75, 119.75]])
        """
        width = max(1, round(self.width * factor))
        height = max(1, round(self.height * factor))
        s = np.array([width / self.width, height / self.height])
        A = np.diag([s[0], s[1], 1.0])
        A[:2, 2] = 0.5 * (s - 1.0)
        return Camera(width, height, A @ self.K, self.R, self.t, self.dist)

    def __repr__(self) -> str:
        c = np.round(self.centre, 1).tolist()
        return f"Camera({self.width}x{self.height}, fx={self.K[0, 0]:.1f}, centre={c})"


def look_at_rotation(eye: np.ndarray, target: np.ndarray, up: np.ndarray) -> np.ndarray:
    """World → camera rotation of a camera at ``eye`` looking at ``target`` (OpenCV axes)."""
    forward = target - eye
    n = np.linalg.norm(forward)
    if n == 0:
        raise InputError("eye and target must differ", field="eye", value=eye.tolist())
    z = forward / n
    x = np.cross(z, up)  # right = forward × up gives image x to the right with y down
    if np.linalg.norm(x) < 1e-9:
        raise InputError("viewing direction is parallel to up", field="target",
                         value=target.tolist())
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    return np.stack([x, y, z])
