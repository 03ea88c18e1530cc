"""Ray–cylinder occlusion tests: a numba kernel and a plain-numpy reference.

A ray runs from a sample point to the camera centre; it is *blocked* when it
meets a solid capped cylinder (a log's bounding cylinder) other than the
feature's own logs. Both implementations use exactly the same arithmetic, so
they agree bit for bit; the numba one prunes with the cone each cylinder's
bounding sphere subtends at the camera (every ray ends there), tries the
cylinders nearest the camera first and stops at the first blocking one. The
rays cast past their points (:func:`rays_beyond`, :func:`first_log_beyond`)
lie on lines through the camera too and are pruned the same way.

Grazing rays. Sample points lie on (or touch) their own logs and logs touch
each other, so two small margins keep tangencies from counting as hits:

* the ray starts :data:`START_OFFSET_MM` along the way to the camera, and
* every cylinder is shrunk by :data:`CYLINDER_SHRINK_MM` in radius and at
  both caps.

Both are far below a pixel's footprint at any sensible camera distance.

The kernels are single-threaded on purpose: they already test > 100 M
segment–cylinder pairs per second, and numba's parallel runtimes (GNU OpenMP,
workqueue) are not safe to use from forked worker processes or several Python
threads at once, which the corpus and experiment drivers do.
"""

from __future__ import annotations

import logging

import numba
import numpy as np

from unseeable.errors import InputError, check_whole_number
from unseeable.parallel import map_in_threads

__all__ = [
    "START_OFFSET_MM",
    "CYLINDER_SHRINK_MM",
    "prepare_cylinders",
    "blocked_rays",
    "blocked_rays_reference",
    "count_ray_cylinder_hits",
    "rays_beyond",
    "first_log_beyond",
    "BEYOND_REACH_MM",
]

log = logging.getLogger(__name__)

#: How far (mm) towards the camera each ray starts from its sample point.
START_OFFSET_MM = 0.05
#: How much (mm) every cylinder is shrunk, in radius and at each cap.
CYLINDER_SHRINK_MM = 0.1
#: How far (mm) :func:`rays_beyond` follows each ray past its sample point.
BEYOND_REACH_MM = 2000.0
# Below this |d|^2 (mm^2) a direction counts as parallel to / within a cylinder's axis.
_PARALLEL_EPS = 1e-12


def prepare_cylinders(axes: np.ndarray, radius: float | np.ndarray, *,
                      shrink: float = CYLINDER_SHRINK_MM) -> dict[str, np.ndarray]:
    """Per-cylinder quantities the tests use, after shrinking.

    Parameters
    ----------
    axes : (L, 2, 3) float
        Axis end points.
    radius : float or (L,) float
    shrink : float
        Taken off the radius and off each end of the axis (mm).

    Returns
    -------
    dict
        ``base (L, 3)`` first cap centre, ``axis (L, 3)`` unit axis, ``length (L,)``,
        ``radius (L,)``.
        Degenerate cylinders (length or radius not positive after shrinking)
        get ``length = -1`` and never block.
    """
    axes = np.asarray(axes, dtype=float).reshape(-1, 2, 3)
    n_cyl = len(axes)
    radius = np.broadcast_to(np.asarray(radius, dtype=float), (n_cyl,)).copy()
    d = axes[:, 1] - axes[:, 0]
    full = np.sqrt(d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1] + d[:, 2] * d[:, 2])
    unit = d / np.where(full > 0, full, 1.0)[:, None]
    base = axes[:, 0] + shrink * unit
    length = full - 2.0 * shrink
    radius = radius - shrink
    dead = (length <= 0) | (radius <= 0) | (full <= 0)
    length = np.where(dead, -1.0, length)
    return {"base": np.ascontiguousarray(base), "axis": np.ascontiguousarray(unit),
            "length": length, "radius": radius}


@numba.njit(cache=True, inline="always")
def _hits(px, py, pz, dx, dy, dz, bx, by, bz, nx, ny, nz, length, radius):
    """Does the segment p + t d, t in [0, 1], meet the solid capped cylinder?"""
    return _entry(px, py, pz, dx, dy, dz, bx, by, bz, nx, ny, nz, length, radius) <= 1.0


@numba.njit(cache=True, inline="always")
def _entry(px, py, pz, dx, dy, dz, bx, by, bz, nx, ny, nz, length, radius):
    """Where (t in [0, 1]) the segment p + t d enters the solid capped cylinder; inf if never."""
    if length < 0.0:
        return np.inf
    wx = px - bx
    wy = py - by
    wz = pz - bz
    s0 = wx * nx + wy * ny + wz * nz  # axial coordinate of p
    ds = dx * nx + dy * ny + dz * nz  # its rate along the segment
    # components perpendicular to the axis
    wpx = wx - s0 * nx
    wpy = wy - s0 * ny
    wpz = wz - s0 * nz
    dpx = dx - ds * nx
    dpy = dy - ds * ny
    dpz = dz - ds * nz
    a = dpx * dpx + dpy * dpy + dpz * dpz
    b = 2.0 * (wpx * dpx + wpy * dpy + wpz * dpz)
    c = wpx * wpx + wpy * wpy + wpz * wpz - radius * radius
    t_lo = 0.0
    t_hi = 1.0
    if a <= _PARALLEL_EPS:
        if c > 0.0:
            return np.inf
    else:
        disc = b * b - 4.0 * a * c
        if disc < 0.0:
            return np.inf
        root = np.sqrt(disc)
        t0 = (-b - root) / (2.0 * a)
        t1 = (-b + root) / (2.0 * a)
        if t0 > t_lo:
            t_lo = t0
        if t1 < t_hi:
            t_hi = t1
    if ds * ds <= _PARALLEL_EPS:
        if s0 < 0.0 or s0 > length:
            return np.inf
    else:
        ta = (0.0 - s0) / ds
        tb = (length - s0) / ds
        if ta > tb:
            ta, tb = tb, ta
        if ta > t_lo:
            t_lo = ta
        if tb < t_hi:
            t_hi = tb
    return t_lo if t_lo <= t_hi else np.inf


@numba.njit(cache=True, inline="always")
def _excluded(exclude, f, cyl):
    """Is cylinder ``cyl`` one of feature ``f``'s own logs?"""
    for e in range(exclude.shape[1]):
        if exclude[f, e] == cyl:
            return True
    return False


@numba.njit(cache=True, inline="always")
def _outside_cone(ex, ey, ez, towards, cos_limit, cyl):
    """Whether the ray from the camera along the unit ``(ex, ey, ez)`` misses cylinder
    ``cyl``'s bounding sphere: it lies outside the cone the sphere subtends at the camera
    (``towards``, ``cos_limit`` of :func:`_seen_from_camera`)."""
    return (ex * towards[cyl, 0] + ey * towards[cyl, 1] + ez * towards[cyl, 2]
            < cos_limit[cyl])


@numba.njit(cache=True, nogil=True)
def _blocked_kernel(points, valid, exclude, camera, base, axis, length, radius, near, order,
                    towards, cos_limit, start_offset):
    n_feat, n_samp = valid.shape
    out = np.zeros((n_feat, n_samp), dtype=np.bool_)
    for f in range(n_feat):
        for s in range(n_samp):
            if not valid[f, s]:
                continue
            px, py, pz = _ray_start(points[f, s], camera, start_offset)
            dx = camera[0] - px
            dy = camera[1] - py
            dz = camera[2] - pz
            ray_len = np.sqrt(dx * dx + dy * dy + dz * dz)
            if ray_len <= 0.0:  # the point is at the camera: nothing in between
                continue
            # unit direction from the camera out along the ray
            ex = -dx / ray_len
            ey = -dy / ray_len
            ez = -dz / ray_len
            # cylinders nearest the camera first: they block most often, and once
            # one lies wholly farther from the camera than the ray is long, all
            # the rest do too
            for m in range(order.shape[0]):
                cyl = order[m]
                if near[cyl] > ray_len:
                    break
                if _excluded(exclude, f, cyl):
                    continue
                # every ray passes through the camera: it can only meet the cylinder's
                # bounding sphere inside the cone the sphere subtends there
                if _outside_cone(ex, ey, ez, towards, cos_limit, cyl):
                    continue
                if _hits(px, py, pz, dx, dy, dz, base[cyl, 0], base[cyl, 1], base[cyl, 2],
                         axis[cyl, 0], axis[cyl, 1], axis[cyl, 2], length[cyl], radius[cyl]):
                    out[f, s] = True
                    break
    return out


@numba.njit(cache=True, inline="always")
def _ray_start(point, camera, start_offset):
    dx = camera[0] - point[0]
    dy = camera[1] - point[1]
    dz = camera[2] - point[2]
    norm = np.sqrt(dx * dx + dy * dy + dz * dz)
    step = start_offset / norm if norm > start_offset else 1.0
    return point[0] + step * dx, point[1] + step * dy, point[2] + step * dz


@numba.njit(cache=True, inline="always")
def _ray_past(point, camera, start_offset):
    """Start and unit direction of the ray from the camera out through ``point`` and on
    past it, starting ``start_offset`` beyond it; ``ok`` False at the camera centre."""
    ex = point[0] - camera[0]
    ey = point[1] - camera[1]
    ez = point[2] - camera[2]
    norm = np.sqrt(ex * ex + ey * ey + ez * ez)
    if norm <= 0.0:
        return False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    ex /= norm
    ey /= norm
    ez /= norm
    return (True, point[0] + start_offset * ex, point[1] + start_offset * ey,
            point[2] + start_offset * ez, ex, ey, ez)


@numba.njit(cache=True, nogil=True)
def _first_beyond_kernel(points, valid, exclude, camera, base, axis, length, radius, reach,
                         start_offset, near, order, towards, cos_limit):
    n_feat, n_samp = valid.shape
    out = np.full((n_feat, n_samp), -1, dtype=np.int64)
    for f in range(n_feat):
        for s in range(n_samp):
            if not valid[f, s]:
                continue
            ok, px, py, pz, ex, ey, ez = _ray_past(points[f, s], camera, start_offset)
            if not ok:
                continue
            # The ray lies on the half-line from the camera through the point: cylinders
            # outside it by their bounding cone are skipped, and once a cylinder lies
            # wholly farther from the camera than the nearest entry found, all the rest
            # (nearest first) do too.
            start = np.sqrt((px - camera[0]) ** 2 + (py - camera[1]) ** 2
                            + (pz - camera[2]) ** 2)
            nearest = np.inf
            for m in range(order.shape[0]):
                cyl = order[m]
                if near[cyl] > start + nearest * reach:
                    break
                if _excluded(exclude, f, cyl):
                    continue
                if _outside_cone(ex, ey, ez, towards, cos_limit, cyl):
                    continue
                t = _entry(px, py, pz, reach * ex, reach * ey, reach * ez, base[cyl, 0],
                           base[cyl, 1], base[cyl, 2], axis[cyl, 0], axis[cyl, 1], axis[cyl, 2],
                           length[cyl], radius[cyl])
                # On an exact tie the lowest index, whatever order the cylinders came in.
                if t < nearest or (t == nearest and t < np.inf and cyl < out[f, s]):
                    nearest = t
                    out[f, s] = cyl
    return out


@numba.njit(cache=True, nogil=True)
def _count_kernel(points, valid, camera, base, axis, length, radius, start_offset):
    """Every (ray, cylinder) pair, no pruning, no early exit (for benchmarks)."""
    n_feat, n_samp = valid.shape
    n_cyl = base.shape[0]
    counts = np.zeros(n_feat, dtype=np.int64)
    for f in range(n_feat):
        for s in range(n_samp):
            if not valid[f, s]:
                continue
            px, py, pz = _ray_start(points[f, s], camera, start_offset)
            dx = camera[0] - px
            dy = camera[1] - py
            dz = camera[2] - pz
            for cyl in range(n_cyl):
                if _hits(px, py, pz, dx, dy, dz, base[cyl, 0], base[cyl, 1], base[cyl, 2],
                         axis[cyl, 0], axis[cyl, 1], axis[cyl, 2], length[cyl], radius[cyl]):
                    counts[f] += 1
    return counts


@numba.njit(cache=True, nogil=True)
def _beyond_kernel(points, valid, exclude, camera, base, axis, length, radius, reach,
                   start_offset, near, order, towards, cos_limit):
    n_feat, n_samp = valid.shape
    out = np.zeros((n_feat, n_samp), dtype=np.bool_)
    for f in range(n_feat):
        for s in range(n_samp):
            if not valid[f, s]:
                continue
            ok, px, py, pz, ex, ey, ez = _ray_past(points[f, s], camera, start_offset)
            if not ok:
                continue
            start = np.sqrt((px - camera[0]) ** 2 + (py - camera[1]) ** 2
                            + (pz - camera[2]) ** 2)
            # As :func:`_first_beyond_kernel` prunes; the first cylinder met decides.
            for m in range(order.shape[0]):
                cyl = order[m]
                if near[cyl] > start + reach:
                    break
                if _excluded(exclude, f, cyl):
                    continue
                if _outside_cone(ex, ey, ez, towards, cos_limit, cyl):
                    continue
                if _hits(px, py, pz, reach * ex, reach * ey, reach * ez, base[cyl, 0],
                         base[cyl, 1], base[cyl, 2], axis[cyl, 0], axis[cyl, 1], axis[cyl, 2],
                         length[cyl], radius[cyl]):
                    out[f, s] = True
                    break
    return out


def _check(points, valid, camera_centre, exclude):
    points = np.ascontiguousarray(points, dtype=float)
    if points.ndim != 3 or points.shape[2] != 3:
        raise InputError("must have shape (N, S, 3)", field="points", value=points.shape)
    valid = np.ascontiguousarray(valid, dtype=bool)
    if valid.shape != points.shape[:2]:
        raise InputError(f"must have shape {points.shape[:2]}", field="valid", value=valid.shape)
    camera = np.ascontiguousarray(np.asarray(camera_centre, dtype=float).reshape(-1))
    if camera.shape != (3,) or not np.all(np.isfinite(camera)):
        raise InputError("must be 3 finite coordinates", field="camera_centre",
                         value=camera.tolist())
    if exclude is None:
        exclude = np.full((len(points), 1), -1, dtype=np.int64)
    exclude = np.ascontiguousarray(exclude, dtype=np.int64)
    if exclude.ndim == 1:
        exclude = exclude[:, None]
    if exclude.shape[0] != len(points):
        raise InputError(f"must have {len(points)} rows", field="exclude", value=exclude.shape)
    return points, valid, camera, exclude


def blocked_rays(points: np.ndarray, valid: np.ndarray, camera_centre: np.ndarray,
                 cylinders: np.ndarray, radius: float | np.ndarray, *,
                 exclude: np.ndarray | None = None, threads: int = 1) -> np.ndarray:
    """Which rays from sample points to the camera centre meet a cylinder (numba).

    Parameters
    ----------
    points : (N, S, 3) float
        Sample points, grouped by feature.
    valid : (N, S) bool
        Which points are samples; the others are never blocked.
    camera_centre : (3,) float
        Same frame as ``points``.
    cylinders : (L, 2, 3) float
        Axis end points of solid capped cylinders.
    radius : float or (L,) float
    exclude : (N, E) int, optional
        Cylinder ids that never block feature ``n``'s rays (``-1``: none).
    threads : int
        Above 1, the features are split in two halves cast on two threads (each
        feature's rays alone: the same answer).

    Returns
    -------
    (N, S) bool
        True where the ray is blocked (see the module notes on grazing rays).

    Examples
    --------
    >>> pts = np.zeros((1, 1, 3)); ok = np.ones((1, 1), bool)
    >>> wall = np.array([[[-50.0, 0, 100], [50.0, 0, 100]]])
    >>> blocked_rays(pts, ok, np.array([0.0, 0, 500]), wall, 10.0).tolist()
    [[True]]
    """
    points, valid, camera, exclude = _check(points, valid, camera_centre, exclude)
    cyl = prepare_cylinders(cylinders, radius)
    seen = _seen_from_camera(cyl, camera)
    return _by_rows(_blocked_kernel, (points, valid, exclude, camera, cyl["base"], cyl["axis"],
                                      cyl["length"], cyl["radius"], *seen, START_OFFSET_MM),
                    threads)


#: Fewest features worth splitting over two threads.
_SPLIT_ROWS_MIN = 64


def _by_rows(kernel, args: tuple, threads: int) -> np.ndarray:
    """``kernel(*args)``, with ``threads`` above 1 on two threads: the first three
    arguments (points, valid, exclude: one row a feature) split in halves, each
    feature's rays cast alone, so the halves' answers are the whole's."""
    n = len(args[0])
    if check_whole_number(threads, field="threads", minimum=1) < 2 or n < _SPLIT_ROWS_MIN:
        return kernel(*args)
    rows, rest = args[:3], args[3:]
    halves = [slice(0, n // 2), slice(n // 2, n)]
    return np.concatenate(map_in_threads(lambda half: kernel(*(a[half] for a in rows), *rest),
                                         halves, threads=2))


def rays_beyond(points: np.ndarray, valid: np.ndarray, camera_centre: np.ndarray,
                cylinders: np.ndarray, radius: float | np.ndarray, *,
                exclude: np.ndarray | None = None,
                reach: float = BEYOND_REACH_MM, threads: int = 1) -> np.ndarray:
    """Which rays from the camera, continued *past* their sample points, meet a cylinder.

    The mirror of :func:`blocked_rays`: what lies behind a feature in the
    image rather than in front of it. Each ray starts :data:`START_OFFSET_MM`
    beyond its point, runs ``reach`` mm on, directly away from the camera,
    and is tested against every cylinder but the feature's own (pruned as
    :func:`blocked_rays` prunes: the same answer as testing every pair).

    Parameters
    ----------
    points, valid, camera_centre, cylinders, radius, exclude, threads
        As for :func:`blocked_rays`.
    reach : float
        How far past the point the ray is followed (mm).

    Returns
    -------
    (N, S) bool

    Examples
    --------
    >>> pts = np.zeros((1, 1, 3)); ok = np.ones((1, 1), bool)
    >>> wall = np.array([[[-50.0, 0, -100], [50.0, 0, -100]]])  # behind the point
    >>> rays_beyond(pts, ok, np.array([0.0, 0, 500]), wall, 10.0).tolist()
    [[True]]
    """
    return _by_rows(_beyond_kernel, _beyond_args(points, valid, camera_centre, cylinders,
                                                 radius, exclude, reach), threads)


def _beyond_args(points, valid, camera_centre, cylinders, radius, exclude, reach,
                 prune: bool = True) -> tuple:
    """The checked arguments of a kernel that casts rays past their sample points
    (``prune`` False: every cylinder tested, in index order, as a reference)."""
    points, valid, camera, exclude = _check(points, valid, camera_centre, exclude)
    if not (np.isfinite(reach) and reach > 0):
        raise InputError("must be a positive number of mm", field="reach", value=reach)
    cyl = prepare_cylinders(cylinders, radius)
    if prune:
        seen = _seen_from_camera(cyl, camera)
    else:
        n_cyl = len(cyl["length"])
        seen = (np.full(n_cyl, -np.inf), np.arange(n_cyl, dtype=np.int64),
                np.zeros((n_cyl, 3)), np.full(n_cyl, -np.inf))
    return (points, valid, exclude, camera, cyl["base"], cyl["axis"], cyl["length"],
            cyl["radius"], float(reach), START_OFFSET_MM, *seen)


def first_log_beyond(points: np.ndarray, valid: np.ndarray, camera_centre: np.ndarray,
                     cylinders: np.ndarray, radius: float | np.ndarray, *,
                     exclude: np.ndarray | None = None,
                     reach: float = BEYOND_REACH_MM, threads: int = 1) -> np.ndarray:
    """The nearest cylinder each ray meets past its sample point, as :func:`rays_beyond` casts it.

    Parameters
    ----------
    points, valid, camera_centre, cylinders, radius, exclude, reach, threads
        As for :func:`rays_beyond`.

    Returns
    -------
    (N, S) int
        Cylinder index, ``-1`` where the ray meets none (or the point is not valid).

    Examples
    --------
    >>> pts = np.zeros((1, 2, 3)); pts[0, 1, 0] = 80.0; ok = np.ones((1, 2), bool)
    >>> walls = np.array([[[-50.0, 0, -300], [50.0, 0, -300]],   # far
    ...                   [[-50.0, 0, -100], [50.0, 0, -100]]])  # near
    >>> first_log_beyond(pts, ok, np.array([0.0, 0, 500]), walls, 10.0).tolist()
    [[1, -1]]
    """
    return _by_rows(_first_beyond_kernel, _beyond_args(points, valid, camera_centre, cylinders,
                                                       radius, exclude, reach), threads)


def _seen_from_camera(cyl: dict[str, np.ndarray], camera: np.ndarray) -> tuple[np.ndarray, ...]:
    """Each cylinder's bounding sphere as seen from the camera, for pruning.

    Returns
    -------
    near : (L,) float
        Distance from the camera to the sphere (a lower bound on the distance
        to the cylinder; ``inf`` for cylinders that never block).
    order : (L,) int
        Cylinder ids by ``near``.
    towards : (L, 3) float
        Unit direction from the camera to the sphere's centre.
    cos_limit : (L,) float
        Cosine of the half-angle of the cone the sphere subtends at the camera
        (``-inf``, no pruning, when the camera is inside the sphere).
    """
    half = np.maximum(cyl["length"], 0.0) / 2.0
    centre = cyl["base"] + half[:, None] * cyl["axis"]
    # a hair larger than the sphere, so rounding in the cone test never prunes a hit
    sphere = np.sqrt(half**2 + np.maximum(cyl["radius"], 0.0) ** 2) + 1e-6
    offset = centre - camera[None, :]
    dist = np.linalg.norm(offset, axis=1)
    inside = dist <= sphere
    safe_dist = np.where(inside, 1.0, dist)
    towards = np.where(inside[:, None], 0.0, offset / safe_dist[:, None])
    cos_limit = np.sqrt(np.maximum(1.0 - (sphere / safe_dist) ** 2, 0.0)) - 1e-9
    cos_limit = np.where(inside, -np.inf, cos_limit)
    near = np.where(cyl["length"] < 0, np.inf, dist - sphere)
    order = np.argsort(near, kind="stable").astype(np.int64)
    return (np.ascontiguousarray(near), order, np.ascontiguousarray(towards),
            np.ascontiguousarray(cos_limit))


def count_ray_cylinder_hits(points: np.ndarray, valid: np.ndarray, camera_centre: np.ndarray,
                            cylinders: np.ndarray, radius: float | np.ndarray) -> np.ndarray:
    """How many cylinders each feature's rays meet in total, testing every pair.

    No pruning and no early exit: ``valid.sum() * L`` segment–cylinder tests,
    which makes it the benchmark of the raw test rate.

    Returns
    -------
    (N,) int
    """
    points, valid, camera, _ = _check(points, valid, camera_centre, None)
    cyl = prepare_cylinders(cylinders, radius)
    return _count_kernel(points, valid, camera, cyl["base"], cyl["axis"], cyl["length"],
                         cyl["radius"], START_OFFSET_MM)


def blocked_rays_reference(points: np.ndarray, valid: np.ndarray, camera_centre: np.ndarray,
                           cylinders: np.ndarray, radius: float | np.ndarray, *,
                           exclude: np.ndarray | None = None,
                           chunk: int = 4096) -> np.ndarray:
    """Plain-numpy :func:`blocked_rays`: every ray against every cylinder, no pruning.

    Same arguments and result; the reference the numba kernel is tested against.
    ``chunk`` rays are tested at a time to bound memory (``chunk * L`` pairs).
    """
    points, valid, camera, exclude = _check(points, valid, camera_centre, exclude)
    cyl = prepare_cylinders(cylinders, radius)
    n_feat, n_samp = valid.shape
    flat = points.reshape(-1, 3)
    flat_valid = valid.reshape(-1)
    flat_excl = np.repeat(exclude, n_samp, axis=0)
    out = np.zeros(len(flat), dtype=bool)
    n_cyl = len(cyl["length"])
    if n_cyl == 0:
        return out.reshape(n_feat, n_samp)
    ids = np.arange(n_cyl)
    bx, by, bz = (cyl["base"][:, a][None, :] for a in range(3))
    nx, ny, nz = (cyl["axis"][:, a][None, :] for a in range(3))
    length = cyl["length"][None, :]
    rad = cyl["radius"][None, :]
    for s in range(0, len(flat), chunk):
        p = flat[s:s + chunk]
        # nudge the start towards the camera exactly as the kernel does
        d0 = camera[None, :] - p
        norm = np.sqrt(d0[:, 0] * d0[:, 0] + d0[:, 1] * d0[:, 1] + d0[:, 2] * d0[:, 2])
        step = np.where(norm > START_OFFSET_MM,
                        START_OFFSET_MM / np.where(norm > 0, norm, 1.0), 1.0)
        p = p + step[:, None] * d0
        px, py, pz = (p[:, a][:, None] for a in range(3))
        dx = camera[0] - px
        dy = camera[1] - py
        dz = camera[2] - pz
        wx, wy, wz = px - bx, py - by, pz - bz
        s0 = wx * nx + wy * ny + wz * nz
        ds = dx * nx + dy * ny + dz * nz
        wpx, wpy, wpz = wx - s0 * nx, wy - s0 * ny, wz - s0 * nz
        dpx, dpy, dpz = dx - ds * nx, dy - ds * ny, dz - ds * nz
        a = dpx * dpx + dpy * dpy + dpz * dpz
        b = 2.0 * (wpx * dpx + wpy * dpy + wpz * dpz)
        c = wpx * wpx + wpy * wpy + wpz * wpz - rad * rad
        parallel = a <= _PARALLEL_EPS
        disc = b * b - 4.0 * a * c
        with np.errstate(divide="ignore", invalid="ignore"):
            root = np.sqrt(np.maximum(disc, 0.0))
            t0 = np.where(parallel, 0.0, (-b - root) / (2.0 * a))
            t1 = np.where(parallel, 1.0, (-b + root) / (2.0 * a))
            radial_ok = np.where(parallel, c <= 0.0, disc >= 0.0)
            along = ds * ds <= _PARALLEL_EPS
            ta = (0.0 - s0) / ds
            tb = (length - s0) / ds
        ta, tb = np.minimum(ta, tb), np.maximum(ta, tb)
        ta = np.where(along, 0.0, ta)
        tb = np.where(along, 1.0, tb)
        axial_ok = np.where(along, (s0 >= 0.0) & (s0 <= length), True)
        t_lo = np.maximum(np.maximum(0.0, t0), ta)
        t_hi = np.minimum(np.minimum(1.0, t1), tb)
        hit = radial_ok & axial_ok & (t_lo <= t_hi) & (length >= 0.0)
        own = (flat_excl[s:s + chunk, :, None] == ids[None, None, :]).any(axis=1)
        at_camera = norm <= START_OFFSET_MM  # nothing lies between point and camera
        out[s:s + chunk] = ((hit & ~own).any(axis=1) & flat_valid[s:s + chunk]
                            & ~at_camera)
    return out.reshape(n_feat, n_samp)
