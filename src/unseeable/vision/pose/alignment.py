"""Model-based edge tracking: where a pose's features meet image edges, and aligning them.

Each sample along an upper silhouette (or the rim of an end disc facing the
camera) looks along its image normal for the strongest edge, to sub-pixel
precision (:func:`match_edges`; one numba pass). The pose update ``(dx, dz,
turn)`` minimises the squared normal distances, with Tukey weights against
edges that belong to something else, and the search narrows as the pose
settles (:func:`refine_edges`, as in RAPiD). :func:`alignment_score` tells
how well a pose's features sit on edges: whole lines and rims, not scattered
samples.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from unseeable.camera import Camera
from unseeable.domain import Extent, GridPose, LogGeometry
from unseeable.vision.edges import EdgeMaps, kernel_tensor, profile_peak
from unseeable.vision.pose.lines import centre_grid, pose_from_centre
from unseeable.vision.pose.samples import FeatureSamples, feature_samples
from unseeable.vision.pose.settings import (
    EDGE_BIAS_PX,
    POLISH_REACH_PX,
    RIM_BIAS_PX,
    RIM_DROP_PX,
    PoseSettings,
)

__all__ = ["EdgeMatches", "match_edges", "alignment_score", "refine_edges", "align_and_score"]


@dataclass(frozen=True, eq=False)
class EdgeMatches:
    """Where the image edges are, across every sample of a pose's present-looking features."""

    pts: np.ndarray  # (M, 3) world sample points
    uv: np.ndarray  # (M, 2)
    normals: np.ndarray  # (M, 2) unit, out of the log / disc
    offset: np.ndarray  # (M,) signed distance (px) to the strongest edge along the normal
    peak: np.ndarray  # (M,) that edge's strength
    presence: np.ndarray  # (M,) how present the sample's line or rim looks, [0, 1]
    ok: np.ndarray  # (M,) bool
    group: np.ndarray  # (M,) int: the line or rim each sample belongs to
    # (M, 3) derivatives of each sample's normal displacement (see match_edges), when asked
    jacobian: np.ndarray | None = None

    def on_edges(self, *, tolerance_px: float = 0.75, strong: float = 0.3) -> np.ndarray:
        """(M,) bool: the sample's edge is within ``tolerance_px`` and stronger than ``strong``."""
        return (np.abs(self.offset) <= tolerance_px) & self.ok & (self.peak > strong)


def _kernel_samples(samples: FeatureSamples) -> tuple[np.ndarray, ...]:
    """``samples`` as :func:`_edge_match_kernel` reads them: points, tangents,
    references and edge biases (contiguous float64) and which are rims (bool)."""
    # Only a structure's samples mark their rims (the search's grid rims stay raw): the rim
    # edge offsets depend on each sample's image normal, known only inside the kernel.
    rim = (np.zeros(len(samples.group), np.bool_) if samples.rim is None
           else np.ascontiguousarray(samples.rim, dtype=np.bool_))
    return (*(np.ascontiguousarray(a, dtype=np.float64) for a in (
        samples.pts, samples.tangent, samples.reference, samples.bias)), rim)


def match_edges(maps: EdgeMaps, camera: Camera, extent: Extent, geometry: LogGeometry,
                pose: GridPose, *, spacing: float, reach: float, edge_bias_px: float,
                use_ends: bool, step: float = 0.25,
                samples: FeatureSamples | None = None,
                jacobian_about: tuple[np.ndarray, float, float] | None = None
                 ) -> EdgeMatches:
    """Sample the upper silhouettes (and end rims) of ``pose`` and find their image edges.

    With ``jacobian_about = (centre, angle, eps)`` the matches' ``jacobian`` holds the
    ``(M, 3)`` changes of each sample's normal displacement (px) when the pose moves by
    ``eps`` mm along world x, along world z, and turns by ``angle`` about ``centre``
    (world), each divided by ``eps`` (NaN and inf as :func:`numpy.nan_to_num` makes them):
    what each step of the alignment (:func:`refine_edges`) has the kernel compute; here
    for checking it. The per-sample work is one numba pass (:func:`_edge_match_kernel`).
    """
    if samples is None:
        samples = feature_samples(extent, pose, camera, geometry, spacing=spacing,
                                  edge_bias_px=edge_bias_px, use_ends=use_ends)
    lid, n_groups = samples.group, samples.n_groups
    offsets = np.arange(-reach, reach + 1e-9, step)
    centre, angle, eps = (jacobian_about if jacobian_about is not None
                          else (np.zeros(3), 0.0, 0.0))
    pts, uv, normals, d, peak, at_line, ok, jac = _edge_match_kernel(
        kernel_tensor(maps.tensor), *_kernel_samples(samples), RIM_BIAS_PX, RIM_DROP_PX,
        pose.rotation, pose.translation, camera.R, camera.t, camera.K, camera.dist,
        camera.has_distortion, offsets, int(np.argmin(np.abs(offsets))), float(step),
        np.asarray(centre, dtype=np.float64), float(angle), float(eps),
        jacobian_about is not None)
    mean_group = np.bincount(lid, weights=np.maximum(at_line, peak), minlength=n_groups) / \
        np.maximum(np.bincount(lid, minlength=n_groups), 1)
    presence = np.clip((mean_group - 0.15) / 0.3, 0.0, 1.0)[lid]
    return EdgeMatches(pts, uv, normals, d, peak, presence, ok, lid,
                       jac if jacobian_about is not None else None)


@numba.njit(cache=True, inline="always")
def _project_world(cam_r, cam_t, k, dist, distorted, x, y, z):
    """:meth:`Camera.project` of one world point: ``(u, v)``, NaN behind the camera."""
    cx = cam_r[0, 0] * x + cam_r[0, 1] * y + cam_r[0, 2] * z + cam_t[0]
    cy = cam_r[1, 0] * x + cam_r[1, 1] * y + cam_r[1, 2] * z + cam_t[1]
    cz = cam_r[2, 0] * x + cam_r[2, 1] * y + cam_r[2, 2] * z + cam_t[2]
    if not cz > 1e-9:
        return np.nan, np.nan
    a = cx / cz
    b = cy / cz
    if distorted:
        k1, k2, p1, p2, k3 = dist[0], dist[1], dist[2], dist[3], dist[4]
        r2 = a * a + b * b
        radial = 1 + k1 * r2 + k2 * r2 ** 2 + k3 * r2 ** 3
        ad = a * radial + 2 * p1 * a * b + p2 * (r2 + 2 * a * a)
        bd = b * radial + p1 * (r2 + 2 * b * b) + 2 * p2 * a * b
        a, b = ad, bd
    return k[0, 0] * a + k[0, 1] * b + k[0, 2], k[1, 1] * b + k[1, 2]


@numba.njit(cache=True, inline="always")
def _finite_or(value, default):
    """:func:`numpy.nan_to_num` of one float: NaN → ``default``, ±inf → ± the largest float."""
    if np.isnan(value):
        return default
    if np.isinf(value):
        return 1.7976931348623157e308 if value > 0 else -1.7976931348623157e308
    return value


@numba.njit(cache=True, nogil=True)
def _edge_match_kernel(tensor, grid_pts, grid_tangent, grid_ref, bias, rim, rim_bias,
                       rim_drop, pose_r, pose_t, cam_r, cam_t, k, dist, distorted, offsets,
                       zero_index, step, centre, angle, eps, want_jacobian):
    """Every per-sample step of :func:`match_edges` (and the refinement's Jacobian) in one
    pass: to the world, projected, the image normal (out of the log or disc), the edge
    peak along it, sub-pixel offset. Numerically the numpy steps it replaces."""
    m, n_off = grid_pts.shape[0], offsets.shape[0]
    pts = np.empty((m, 3))
    uv = np.empty((m, 2))
    normals = np.empty((m, 2))
    d = np.empty(m)
    peak = np.empty(m)
    at_line = np.empty(m)
    ok = np.empty(m, np.bool_)
    jac = np.zeros((m, 3) if want_jacobian else (0, 3))
    prof = np.empty(n_off)
    c, s = np.cos(angle), np.sin(angle)
    for i in range(m):
        g0, g1, g2 = grid_pts[i, 0], grid_pts[i, 1], grid_pts[i, 2]
        wx = pose_r[0, 0] * g0 + pose_r[0, 1] * g1 + pose_r[0, 2] * g2 + pose_t[0]
        wy = pose_r[1, 0] * g0 + pose_r[1, 1] * g1 + pose_r[1, 2] * g2 + pose_t[1]
        wz = pose_r[2, 0] * g0 + pose_r[2, 1] * g1 + pose_r[2, 2] * g2 + pose_t[2]
        pts[i, 0], pts[i, 1], pts[i, 2] = wx, wy, wz
        t0, t1, t2 = grid_tangent[i, 0], grid_tangent[i, 1], grid_tangent[i, 2]
        dx = pose_r[0, 0] * t0 + pose_r[0, 1] * t1 + pose_r[0, 2] * t2
        dy = pose_r[1, 0] * t0 + pose_r[1, 1] * t1 + pose_r[1, 2] * t2
        dz = pose_r[2, 0] * t0 + pose_r[2, 1] * t1 + pose_r[2, 2] * t2
        u, v = _project_world(cam_r, cam_t, k, dist, distorted, wx, wy, wz)
        u2, v2 = _project_world(cam_r, cam_t, k, dist, distorted, wx + dx * 2.0,
                                wy + dy * 2.0, wz + dz * 2.0)
        tu, tv = u2 - u, v2 - v
        norm = max(np.sqrt(tu * tu + tv * tv), 1e-12)
        nx, ny = -tv / norm, tu / norm
        r0, r1, r2 = grid_ref[i, 0], grid_ref[i, 1], grid_ref[i, 2]
        ru, rv = _project_world(
            cam_r, cam_t, k, dist, distorted,
            pose_r[0, 0] * r0 + pose_r[0, 1] * r1 + pose_r[0, 2] * r2 + pose_t[0],
            pose_r[1, 0] * r0 + pose_r[1, 1] * r1 + pose_r[1, 2] * r2 + pose_t[1],
            pose_r[2, 0] * r0 + pose_r[2, 1] * r1 + pose_r[2, 2] * r2 + pose_t[2])
        # Normals point out of the log or disc, so that the blur's pull of the edge into
        # the log can be taken off (a NaN comparison leaves them as they are).
        if (u - ru) * nx + (v - rv) * ny < 0:
            nx, ny = -nx, -ny
        uv[i, 0], uv[i, 1] = u, v
        normals[i, 0], normals[i, 1] = nx, ny
        ok[i] = np.isfinite(u) and np.isfinite(v)
        # The peak search sees NaN positions as numpy.nan_to_num makes them.
        kb, top, yl, yr, at_zero = profile_peak(tensor, _finite_or(u, 0.0),
                                                _finite_or(v, 0.0), nx, ny, offsets,
                                                zero_index, prof)
        # Sub-pixel: the parabola through the peak and its neighbours.
        denom = yl - 2 * top + yr
        frac = 0.5 * (yl - yr) / denom if (denom < 0 and 0 < kb < n_off - 1) else 0.0
        b = bias[i] + (rim_bias + rim_drop * ny if rim[i] else 0.0)
        d[i] = offsets[kb] + frac * step - b
        peak[i] = top
        at_line[i] = at_zero
        if want_jacobian:
            # The normal displacement of the sample when the pose moves eps along world x,
            # along world z, and turns by ``angle`` about ``centre``.
            ax, az = wx - centre[0], wz - centre[2]
            for q in range(3):
                if q == 0:
                    mx, mz = wx + eps, wz
                elif q == 1:
                    mx, mz = wx, wz + eps
                else:
                    mx, mz = centre[0] + c * ax + s * az, centre[2] - s * ax + c * az
                mu, mv = _project_world(cam_r, cam_t, k, dist, distorted, mx, wy, mz)
                jac[i, q] = _finite_or(((mu - u) / eps) * nx + ((mv - v) / eps) * ny, 0.0)
    return pts, uv, normals, d, peak, at_line, ok, jac


def alignment_score(matches: EdgeMatches, *, tolerance_px: float = 0.75,
                    strong: float = 0.3, mode: str = "coherent") -> float:
    """How well a pose's features sit on image edges.

    ``"coherent"``: Σ over lines and rims of ``n_g · f_g²`` with ``f_g`` the
    share of the group's ``n_g`` samples lying within ``tolerance_px`` of a
    strong edge; whole features aligned end to end count, scattered
    coincidences with other edges much less. ``"sum"``: the plain count.
    """
    close = matches.on_edges(tolerance_px=tolerance_px, strong=strong)
    if mode == "sum":
        return float(np.sum(close))
    n = np.bincount(matches.group)
    hit = np.bincount(matches.group, weights=close.astype(float), minlength=len(n))
    frac = hit / np.maximum(n, 1)
    return float(np.sum(n * frac**2))


def refine_edges(maps: EdgeMaps, camera: Camera, extent: Extent, geometry: LogGeometry,
                 start: GridPose, *, spacing: float, mm_per_px: float, iterations: int = 8,
                 reach_px: float = POLISH_REACH_PX, edge_bias_px: float = EDGE_BIAS_PX,
                 use_ends: bool = True, samples: FeatureSamples | None = None) -> GridPose:
    """Align the upper silhouettes and end rims with their image edges by robust least squares.

    Each sample along a present-looking upper silhouette (or the rim of an
    end disc facing the camera) looks along its image normal for the
    strongest matching edge (sub-pixel); the pose update ``(dx, dz, turn)``
    minimises the squared normal distances, with Tukey weights against
    edges that belong to something else, and the search narrows as the pose
    settles (model-based edge tracking, as in RAPiD). In rendered and real
    photographs alike the strongest gradient of a top edge lies a little
    inside the log (its rim is rounded and the optics blur it):
    ``edge_bias_px`` (:data:`EDGE_BIAS_PX`) takes that off.

    ``samples`` (in ``start``'s grid frame) replaces the grid's lines and
    rims; their ``weight``, when set, replaces how present each looks.
    ``iterations`` steps at most (two with ``reach_px``, then half of it),
    fewer once a step moves the pose by less than 0.02 px. Each step is two
    numba calls that release the GIL (the edge matching and
    :func:`_alignment_step`): the pose search runs ~70 alignments per image
    on threads, and numpy work between the calls held them up (corpus pose
    search 2–5 % faster, timed side by side with the numpy steps).
    """
    if samples is None:
        samples = feature_samples(extent, start, camera, geometry, spacing=spacing,
                                  edge_bias_px=edge_bias_px, use_ends=use_ends)
    tensor = kernel_tensor(maps.tensor)
    arrays = _kernel_samples(samples)
    group = np.ascontiguousarray(samples.group, dtype=np.int64)
    counts = np.bincount(group, minlength=samples.n_groups).astype(np.float64)
    weight = (np.zeros(0) if samples.weight is None
              else np.ascontiguousarray(samples.weight, dtype=np.float64))
    centre_g = centre_grid(extent, geometry)
    lever = 0.5 * max(extent.I, extent.K) * geometry.l1
    eps = 0.5
    current = start
    # Two wide steps, then the narrow ones (the search narrows as the pose settles).
    for reach in [reach_px] * min(iterations, 2) + [reach_px / 2.0] * max(iterations - 2, 0):
        step = 0.5 if reach > 2.0 else 0.25
        offsets = np.arange(-reach, reach + 1e-9, step)
        centre = current.grid_to_world(centre_g)
        # Jacobian of each sample's normal displacement w.r.t. (dx, dz, turn about the
        # centre, expressed as the displacement of a point ``lever`` mm from it).
        _, _, _, d, peak, at_line, ok, jac = _edge_match_kernel(
            tensor, *arrays, RIM_BIAS_PX, RIM_DROP_PX, current.rotation,
            current.translation, camera.R, camera.t, camera.K, camera.dist,
            camera.has_distortion, offsets, int(np.argmin(np.abs(offsets))), step, centre,
            eps / lever, eps, True)
        delta, total = _alignment_step(d, peak, at_line, ok, jac, group, counts, weight,
                                       samples.weight is not None, max(reach, 1.0))
        if total < 10:
            break
        current = pose_from_centre(np.array([centre[0] + delta[0], centre[2] + delta[1]]),
                                   current.yaw_deg + float(np.degrees(delta[2] / lever)),
                                   extent, geometry)
        if (np.hypot(delta[0], delta[1]) < 0.02 * mm_per_px
                and abs(delta[2]) < 0.02 * mm_per_px):
            break
    return current


@numba.njit(cache=True, nogil=True)
def _alignment_step(d, peak, at_line, ok, jac, group, counts, weight, weighted, c_tukey):
    """One step of :func:`refine_edges` from its edge matches: the weighted least-squares
    update ``(dx, dz, lever turn)`` and the total weight.

    Each sample weighs how present its line or rim looks (the mean of its
    samples' edge strengths, as :func:`match_edges` judges it; ``weight``
    instead when ``weighted``), times Tukey's weight of its offset (edges of
    something else), when its edge is strong enough and it is in view.
    """
    m = d.shape[0]
    sums = np.zeros(counts.shape[0])
    if not weighted:
        for i in range(m):
            sums[group[i]] += max(at_line[i], peak[i])
    a = np.zeros((3, 3))
    b = np.zeros(3)
    total = 0.0
    for i in range(m):
        di = _finite_or(d[i], 0.0)
        if weighted:
            presence = weight[i]
        else:
            mean = sums[group[i]] / max(counts[group[i]], 1.0)
            presence = min(max((mean - 0.15) / 0.3, 0.0), 1.0)
        r = di / c_tukey
        tukey = (1 - r * r) ** 2 if abs(di) < c_tukey else 0.0
        w = presence * tukey * (1.0 if peak[i] > 0.15 else 0.0) * (1.0 if ok[i] else 0.0)
        total += w
        for p in range(3):
            b[p] += jac[i, p] * w * di
            for q in range(3):
                a[p, q] += jac[i, p] * w * jac[i, q]
    if total < 10:
        return np.zeros(3), total
    for p in range(3):
        a[p, p] += 1e-6 * total
    return _solve3(a, b), total


@numba.njit(cache=True, inline="always")
def _solve3(a, b):
    """``a⁻¹ b`` for a 3×3 ``a``: Gaussian elimination with partial pivoting, as LAPACK's
    ``gesv`` (numba's ``np.linalg.solve`` adds seconds to the first compile)."""
    m = np.empty((3, 4))
    for i in range(3):
        for j in range(3):
            m[i, j] = a[i, j]
        m[i, 3] = b[i]
    for col in range(3):
        piv = col
        for r in range(col + 1, 3):
            if abs(m[r, col]) > abs(m[piv, col]):
                piv = r
        if piv != col:
            for j in range(4):
                m[col, j], m[piv, j] = m[piv, j], m[col, j]
        for r in range(col + 1, 3):
            f = m[r, col] / m[col, col]
            for j in range(col, 4):
                m[r, j] -= f * m[col, j]
    x = np.empty(3)
    for i in range(2, -1, -1):
        acc = m[i, 3]
        for j in range(i + 1, 3):
            acc -= m[i, j] * x[j]
        x[i] = acc / m[i, i]
    return x


def align_and_score(maps: EdgeMaps, camera: Camera, extent: Extent, geometry: LogGeometry,
                    pose: GridPose, *, settings: PoseSettings, mm_per_px: float, iterations: int,
                    samples: FeatureSamples | None = None) -> tuple[float, GridPose, EdgeMatches]:
    """``pose`` aligned ``iterations`` steps on the edges (none: as it is), its alignment
    score and edge matches: one candidate of :func:`estimate_pose`, and :func:`align_pose`.

    ``samples`` (``pose``'s grid features) serve both steps: a screen scores the aligned
    pose with the samples of the pose it started from.
    """
    aligned = (refine_edges(maps, camera, extent, geometry, pose,
                            spacing=settings.sample_spacing_px, mm_per_px=mm_per_px,
                            iterations=iterations, samples=samples) if iterations else pose)
    matches = match_edges(maps, camera, extent, geometry, aligned,
                          spacing=settings.sample_spacing_px, reach=1.5,
                          edge_bias_px=EDGE_BIAS_PX, use_ends=True, samples=samples)
    return alignment_score(matches), aligned, matches
