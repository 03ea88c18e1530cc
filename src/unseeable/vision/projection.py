"""Where every feature of an extent appears in an image (issue item 1).

For a camera and a grid pose, each log end becomes an ellipse (the projected
end disc) and each segment feature an image line segment along the log's
lower silhouette as seen from that camera (DESIGN.md §2, §4). All features
are projected at once, in :func:`unseeable.domain.feature_index` order.

Ellipses are ``(cx, cy, a, b, theta)``: centre in pixels, semi-major and
semi-minor axes in pixels, and the major axis' angle in radians (image
frame, x right, y down), in ``[0, pi)``.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from unseeable.camera import Camera
from unseeable.domain import (
    Extent,
    FeatureKind,
    GridPose,
    LogGeometry,
    feature_axes,
    feature_index,
    lower_silhouette,
)
from unseeable.errors import InputError

__all__ = [
    "FeatureProjection",
    "project_features",
    "upper_silhouette",
    "fit_ellipses",
    "ellipse_points",
    "RIM_POINTS",
    "collinear_segment_pairs",
    "parallel_edge_pairs",
]

logger = logging.getLogger(__name__)

#: Rows of the segment-pair tests of :func:`collinear_segment_pairs` done at once.
_PAIR_BLOCK = 256

#: Number of rim points projected per end disc (the paper's 20).
RIM_POINTS = 20


@dataclass(frozen=True, eq=False)
class FeatureProjection:
    """Every feature of an extent in one image.

    Attributes
    ----------
    extent : Extent
    kind : (N,) int8
        :class:`FeatureKind` codes (feature index order).
    ellipses : (N, 5) float
        ``(cx, cy, a, b, theta)`` of each log end; NaN rows for segments.
    rims : (N, R, 2) float
        The projected rim points each ellipse was fitted to; NaN for segments.
    segments : (N, 2, 2) float
        Image end points of each segment's lower silhouette; NaN for ends.
    detector_segments : (N, 2, 2) float
        The part of each segment a detector should look at: for ``u`` and
        ``v`` only the stretch outside the notch slot (``|offset from q| >=
        l2/2``), since the crossing log fills the slot; the whole segment for
        ``w``. NaN for ends.
    upper_segments : (N, 2, 2) float
        The same stretch (trimmed like ``detector_segments``) on the *upper*
        silhouette of a log two layers below (layer ``j - 2``): a segment
        feature is also present when only that log is there, and its top
        edge is seen there, up to half a radius away from the lower
        silhouette of layer ``j`` in the image (the two only coincide when
        both logs are present and touch). NaN for ends and layers 0 and 1.
    normals_world : (N, 3) float
        World direction of each end disc's outward normal; NaN for segments.
    centres_world : (N, 3) float
        World position of each end disc's centre, or each segment's silhouette midpoint.
    in_front : (N,) bool
        The whole feature lies in front of the camera.
    in_image : (N,) bool
        In front of the camera and fully inside the image (1 px margin).
    """

    extent: Extent
    kind: np.ndarray
    ellipses: np.ndarray
    rims: np.ndarray
    segments: np.ndarray
    detector_segments: np.ndarray
    upper_segments: np.ndarray
    normals_world: np.ndarray
    centres_world: np.ndarray
    in_front: np.ndarray
    in_image: np.ndarray

    def __len__(self) -> int:
        return len(self.kind)

    @property
    def is_end(self) -> np.ndarray:
        """``(N,) bool``: log-end features."""
        return self.kind <= FeatureKind.END_PLUS


def _rim_offsets(n_points: int, radius: float) -> np.ndarray:
    """Unit-disc rim points for a disc whose normal is grid x, as (R, 3) offsets (y, z plane)."""
    t = np.linspace(0.0, 2.0 * np.pi, n_points, endpoint=False)
    return np.stack([np.zeros_like(t), radius * np.cos(t), radius * np.sin(t)], axis=1)


def project_features(extent: Extent, pose: GridPose, camera: Camera, *,
                     geometry: LogGeometry = LogGeometry(),
                     rim_points: int = RIM_POINTS) -> FeatureProjection:
    """Project every feature of ``extent`` into ``camera`` for the assembly at ``pose``.

    Parameters
    ----------
    extent : Extent
    pose : GridPose
        Grid → world (table frame).
    camera : Camera
    geometry : LogGeometry
    rim_points : int
        Rim points per end disc used for the ellipse fit.

    Returns
    -------
    FeatureProjection

    Examples
    --------
    >>> from unseeable.domain import Extent, GridPose
    >>> cam = Camera.look_at(eye=[0, 300, -500], target=[0, 0, 0], width=640, height=480,
    ...                      fov_deg=50)
    >>> fp = project_features(Extent(2, 1, 1), GridPose(-32, 0, 0), cam)
    >>> bool(fp.in_image.all())
    True
    """
    idx = feature_index(extent)
    kind = idx.kind
    n = len(kind)
    axes = feature_axes(extent, geometry)  # (N, 2, 3) grid frame
    world = pose.grid_to_world(axes)
    is_end = kind <= FeatureKind.END_PLUS
    centre_cam = camera.centre

    ellipses = np.full((n, 5), np.nan)
    rims = np.full((n, rim_points, 2), np.nan)
    segments = np.full((n, 2, 2), np.nan)
    detector_segments = np.full((n, 2, 2), np.nan)
    upper_segments = np.full((n, 2, 2), np.nan)
    normals = np.full((n, 3), np.nan)
    centres = np.full((n, 3), np.nan)
    in_front = np.zeros(n, dtype=bool)
    in_image = np.zeros(n, dtype=bool)

    # --- log ends: rim circle of radius l2/2 around the disc centre, ⊥ the axis.
    e = np.flatnonzero(is_end)
    if len(e):
        c_grid = axes[e, 0]
        normal_grid = axes[e, 1] - axes[e, 0]
        base = _rim_offsets(rim_points, geometry.radius)  # normal along grid x
        along_k = np.abs(normal_grid[:, 2]) > 0.5
        offs = np.broadcast_to(base, (len(e), rim_points, 3)).copy()
        # Odd layers run along k: the disc lies in the grid x-y plane instead.
        offs[along_k] = base[:, [2, 1, 0]]
        rim_world = pose.grid_to_world(c_grid[:, None, :] + offs)
        uv = camera.project(rim_world)
        rims[e] = uv
        front = np.all(camera.depth(rim_world) > 1e-6, axis=1)
        ok = front & np.all(np.isfinite(uv), axis=(1, 2))
        fitted = np.full((len(e), 5), np.nan)
        if ok.any():
            fitted[ok] = fit_ellipses(uv[ok])
        ellipses[e] = fitted
        normals[e] = pose.directions_to_world(normal_grid)
        centres[e] = world[e, 0]
        in_front[e] = ok
        inside = camera.in_image(uv, margin=1.0).all(axis=1)
        in_image[e] = ok & inside & np.isfinite(fitted).all(axis=1)

    # --- segments: lower silhouette as seen from the camera centre.
    s = np.flatnonzero(~is_end)
    if len(s):
        a, b = lower_silhouette(world[s, 0], world[s, 1], centre_cam, geometry.radius)
        ends3 = np.stack([a, b], axis=1)
        uv = camera.project(ends3)
        segments[s] = uv
        # Detector stretch: u and v only outside the notch slot.
        frac_lo = np.zeros(len(s))
        frac_hi = np.ones(len(s))
        slot = geometry.radius / geometry.l3
        k_s = kind[s]
        frac_hi[k_s == FeatureKind.U] = 1.0 - slot  # u = [q - l3, q]: keep [q-l3, q-l2/2]
        frac_lo[k_s == FeatureKind.V] = slot  # v = [q, q + l3]: keep [q+l2/2, q+l3]
        d3 = np.stack([a + frac_lo[:, None] * (b - a), a + frac_hi[:, None] * (b - a)], axis=1)
        detector_segments[s] = camera.project(d3)
        # Upper silhouette of the log two layers below (its axis is l2 lower).
        below = world[s] - np.array([0.0, geometry.l2, 0.0])
        ua, ub = upper_silhouette(below[:, 0], below[:, 1], centre_cam, geometry.radius)
        u3 = np.stack([ua + frac_lo[:, None] * (ub - ua), ua + frac_hi[:, None] * (ub - ua)],
                      axis=1)
        up = camera.project(u3)
        up[idx.at[s, 1] < 2] = np.nan
        upper_segments[s] = up
        centres[s] = (a + b) / 2
        front = np.all(camera.depth(ends3) > 1e-6, axis=1) & np.all(np.isfinite(uv), axis=(1, 2))
        in_front[s] = front
        in_image[s] = front & camera.in_image(uv, margin=1.0).all(axis=1)

    for arr in (kind, ellipses, rims, segments, detector_segments, upper_segments, normals,
                centres, in_front, in_image):
        if isinstance(arr, np.ndarray) and arr.flags.writeable:
            arr.setflags(write=False)
    return FeatureProjection(extent, kind, ellipses, rims, segments, detector_segments,
                             upper_segments, normals, centres, in_front, in_image)


def upper_silhouette(start: np.ndarray, stop: np.ndarray, camera_centre: np.ndarray,
                     radius: float) -> tuple[np.ndarray, np.ndarray]:
    """The upper silhouette line of horizontal cylinders seen from a point.

    The mirror image of :func:`unseeable.domain.lower_silhouette`: the
    generator line where rays from ``camera_centre`` graze each cylinder on
    its upper side (a log's top edge against what lies behind it).

    Parameters
    ----------
    start, stop : (N, 3) float
        Axis end points, y up.
    camera_centre : (3,) float
    radius : float

    Returns
    -------
    start, stop : (N, 3) float
    """
    flip = np.array([1.0, -1.0, 1.0])
    a, b = lower_silhouette(np.asarray(start) * flip, np.asarray(stop) * flip,
                            np.asarray(camera_centre, dtype=float).reshape(3) * flip, radius)
    return a * flip, b * flip


def fit_ellipses(points: np.ndarray) -> np.ndarray:
    """Least-squares ellipses through point sets, vectorised over sets.

    Fits the conic ``A x² + B xy + C y² + D x + E y + F = 0`` (unit-norm
    coefficients, points centred and scaled per set for conditioning) and
    converts it to centre, semi-axes and angle.

    Parameters
    ----------
    points : (N, R, 2) float
        ``R >= 5`` points per set.

    Returns
    -------
    (N, 5) float
        ``(cx, cy, a, b, theta)``, ``a >= b``, ``theta`` in ``[0, pi)``; NaN
        rows where the points do not determine an ellipse.

    Examples
    --------
    >>> t = np.linspace(0, 2 * np.pi, 20, endpoint=False)
    >>> pts = np.stack([10 + 5 * np.cos(t), 20 + 2 * np.sin(t)], axis=1)[None]
    >>> np.round(fit_ellipses(pts), 6).tolist()
    [[10.0, 20.0, 5.0, 2.0, 0.0]]
    """
    p = np.asarray(points, dtype=float)
    mean = p.mean(axis=1, keepdims=True)
    q = p - mean
    scale = np.sqrt(np.mean(np.sum(q**2, axis=2), axis=1))  # (N,)
    scale = np.where(scale > 0, scale, 1.0)
    q = q / scale[:, None, None]
    x, y = q[..., 0], q[..., 1]
    design = np.stack([x * x, x * y, y * y, x, y, np.ones_like(x)], axis=2)  # (N, R, 6)
    # Smallest right singular vector of each design matrix.
    _, _, vt = np.linalg.svd(design, full_matrices=False)
    coef = vt[:, -1, :]
    # Fix the overall sign so that the quadratic part is positive definite for an ellipse.
    coef = coef * np.where(coef[:, 0] + coef[:, 2] < 0, -1.0, 1.0)[:, None]
    A, B, C, D, E, F = np.moveaxis(coef, 1, 0)
    det = 4 * A * C - B * B
    out = np.full((len(p), 5), np.nan)
    good = det > 1e-12 * (A * A + C * C + B * B)
    with np.errstate(divide="ignore", invalid="ignore"):
        cx = (B * E - 2 * C * D) / det
        cy = (B * D - 2 * A * E) / det
        f_c = A * cx * cx + B * cx * cy + C * cy * cy + D * cx + E * cy + F
        m = np.stack([np.stack([A, B / 2], -1), np.stack([B / 2, C], -1)], -2)  # (N, 2, 2)
        m_safe = np.where(good[:, None, None], m, np.eye(2))
        lam, vec = np.linalg.eigh(m_safe)  # ascending
        ax2 = -f_c[:, None] / lam  # squared semi-axes; smallest λ → largest axis
        good &= np.all(ax2 > 0, axis=1)
        a = np.sqrt(np.abs(ax2[:, 0]))
        b = np.sqrt(np.abs(ax2[:, 1]))
        theta = np.mod(np.arctan2(vec[:, 1, 0], vec[:, 0, 0]), np.pi)
        theta = np.where(theta > np.pi - 1e-9, 0.0, theta)
    res = np.stack([mean[:, 0, 0] + scale * cx, mean[:, 0, 1] + scale * cy, scale * a,
                    scale * b, theta], axis=1)
    out[good] = res[good]
    return out


def ellipse_points(ellipses: np.ndarray, n_points: int) -> tuple[np.ndarray, np.ndarray]:
    """Evenly spaced (in parameter) points on ellipses and their outward unit normals.

    Parameters
    ----------
    ellipses : (..., 5) float
        ``(cx, cy, a, b, theta)``.
    n_points : int

    Returns
    -------
    points, normals : (..., n_points, 2) float
    """
    e = np.asarray(ellipses, dtype=float)
    t = np.linspace(0.0, 2.0 * np.pi, n_points, endpoint=False)
    cx, cy, a, b, th = (e[..., i, None] for i in range(5))
    ct, st = np.cos(t), np.sin(t)
    cth, sth = np.cos(th), np.sin(th)
    lx, ly = a * ct, b * st
    px = cx + lx * cth - ly * sth
    py = cy + lx * sth + ly * cth
    # Outward normal of (a cos t, b sin t) is ∝ (b cos t, a sin t), then rotate by theta.
    nx_l, ny_l = b * ct, a * st
    nx = nx_l * cth - ny_l * sth
    ny = nx_l * sth + ny_l * cth
    norm = np.sqrt(nx * nx + ny * ny)
    norm = np.where(norm > 0, norm, 1.0)
    return np.stack([px, py], axis=-1), np.stack([nx / norm, ny / norm], axis=-1)


def collinear_segment_pairs(projection: FeatureProjection, judged: np.ndarray, *,
                            angle_deg: float = 3.0, distance_px: float = 1.0,
                            overlap_px: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Pairs of judged segment features that lie on one image line and overlap on it.

    Such features are image aliases: a log two layers up and a pitch along, say, draws
    the same edge (a depth axis seen from above), so one edge answers both detectors.

    Parameters
    ----------
    projection : FeatureProjection
    judged : (N,) bool
        Features to pair (others never are).
    angle_deg, distance_px, overlap_px : float
        A segment lies on another's line when their directions differ by under
        ``angle_deg``, both its end points lie within ``distance_px`` of that line,
        and it overlaps the other along it by more than ``overlap_px``.

    Returns
    -------
    first, second : (M,) int
        Feature indices: ``second[m]`` lies on ``first[m]``'s line.

    Examples
    --------
    >>> from unseeable.domain import Extent, GridPose
    >>> cam = Camera.look_at(eye=[0, 300, -500], target=[0, 0, 0], width=640, height=480,
    ...                      fov_deg=50)
    >>> fp = project_features(Extent(2, 3, 2), GridPose(-32, 0, -32), cam)
    >>> first, second = collinear_segment_pairs(fp, ~fp.is_end)
    >>> first.shape == second.shape
    True
    """
    judged = np.asarray(judged, dtype=bool)
    if judged.shape != (len(projection),):
        raise InputError(f"judged must have shape ({len(projection)},)", field="judged",
                         value=judged.shape)
    seg = projection.detector_segments
    ok = np.flatnonzero(judged & ~projection.is_end
                        & np.all(np.isfinite(seg.reshape(len(seg), -1)), axis=1))
    a, b = seg[ok, 0], seg[ok, 1]
    length = np.linalg.norm(b - a, axis=1)
    u = (b - a) / np.maximum(length, 1e-9)[:, None]
    n = np.stack([-u[:, 1], u[:, 0]], axis=1)
    min_cos = np.cos(np.radians(angle_deg))
    firsts, seconds = [], []
    # Row blocks of the (M, M) tests: memory O(block * M) however large the assembly.
    for start in range(0, len(ok), _PAIR_BLOCK):
        rows = slice(start, start + _PAIR_BLOCK)
        ur, nr, ar = u[rows], n[rows], a[rows]
        cos = np.abs(ur @ u.T)
        offset_n = np.einsum("ik,ik->i", ar, nr)[:, None]
        offset_u = np.einsum("ik,ik->i", ar, ur)[:, None]
        da = np.abs(nr @ a.T - offset_n)
        db = np.abs(nr @ b.T - offset_n)
        ta = ur @ a.T - offset_u
        tb = ur @ b.T - offset_u
        overlap = (np.minimum(np.maximum(ta, tb), length[rows, None])
                   - np.maximum(np.minimum(ta, tb), 0.0))
        pair = (cos > min_cos) & (da < distance_px) & (db < distance_px) & (overlap > overlap_px)
        i, j = np.nonzero(pair)
        i += start
        keep = i != j
        firsts.append(i[keep])
        seconds.append(j[keep])
    i = np.concatenate(firsts) if firsts else np.zeros(0, dtype=np.intp)
    j = np.concatenate(seconds) if seconds else np.zeros(0, dtype=np.intp)
    return ok[i], ok[j]


def parallel_edge_pairs(projection: FeatureProjection, judged: np.ndarray, *,
                        reach_px: float = 4.0, angle_deg: float = 3.0,
                        overlap_px: float = 1.0
                        ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Judged segment features with another feature's silhouette edge within a detector's
    reach, running beside them.

    A segment detector searches a few pixels across its stretch for the strongest
    edge (:attr:`~unseeable.vision.DetectorSettings.segment_shift`, plus a pixel of
    wiggle). Where a log's lower silhouette (another segment's ``detector_segments``)
    or upper silhouette (its ``upper_segments``) runs parallel to a stretch within that
    reach, the detector answers to that log's edge when its own is absent, as when the
    camera looks steeply down onto a log two layers up beside the stretch.

    Parameters
    ----------
    projection : FeatureProjection
    judged : (N,) bool
        Features whose stretches are tested (``first``); every segment feature with a
        finite stretch may be ``second``.
    reach_px : float
        Both end points of the stretch lie within this distance of the other edge's line.
    angle_deg, overlap_px : float
        Directions within ``angle_deg``; overlap along the stretch over ``overlap_px``.

    Returns
    -------
    first, second : (M,) int
        Feature indices: an edge of ``second`` runs beside ``first``'s stretch.
    upper : (M,) bool
        The edge is ``second``'s upper silhouette (of the log two layers below
        ``second``'s layer); else its lower one (of the log at its layer).

    Examples
    --------
    >>> from unseeable.domain import Extent, GridPose
    >>> cam = Camera.look_at(eye=[0, 500, -300], target=[0, 0, 0], width=640, height=480,
    ...                      fov_deg=50)
    >>> fp = project_features(Extent(2, 5, 2), GridPose(-32, 0, -32), cam)
    >>> first, second, upper = parallel_edge_pairs(fp, ~fp.is_end)
    >>> first.shape == second.shape == upper.shape
    True
    """
    judged = np.asarray(judged, dtype=bool)
    if judged.shape != (len(projection),):
        raise InputError(f"judged must have shape ({len(projection)},)", field="judged",
                         value=judged.shape)
    if not (np.isfinite(reach_px) and reach_px > 0):
        raise InputError("must be a positive number of pixels", field="reach_px",
                         value=reach_px)
    seg = projection.detector_segments
    finite = np.all(np.isfinite(seg.reshape(len(seg), -1)), axis=1) & ~projection.is_end
    rows_all = np.flatnonzero(judged & finite)
    firsts, seconds, uppers = [], [], []
    min_cos = np.cos(np.radians(angle_deg))
    for is_upper, edges in ((False, projection.detector_segments),
                            (True, projection.upper_segments)):
        cand = np.flatnonzero(~projection.is_end
                              & np.all(np.isfinite(edges.reshape(len(edges), -1)), axis=1))
        if not len(rows_all) or not len(cand):
            continue
        ea, eb = edges[cand, 0], edges[cand, 1]
        el = np.linalg.norm(eb - ea, axis=1)
        eu = (eb - ea) / np.maximum(el, 1e-9)[:, None]
        en = np.stack([-eu[:, 1], eu[:, 0]], axis=1)
        off_n = np.einsum("ik,ik->i", ea, en)
        for start in range(0, len(rows_all), _PAIR_BLOCK):
            rows = rows_all[start:start + _PAIR_BLOCK]
            a, b = seg[rows, 0], seg[rows, 1]
            length = np.linalg.norm(b - a, axis=1)
            u = (b - a) / np.maximum(length, 1e-9)[:, None]
            cos = np.abs(u @ eu.T)
            da = np.abs(a @ en.T - off_n[None])
            db = np.abs(b @ en.T - off_n[None])
            # overlap measured along the stretch
            ta = np.einsum("mk,ck->mc", u, ea) - np.einsum("mk,mk->m", u, a)[:, None]
            tb = np.einsum("mk,ck->mc", u, eb) - np.einsum("mk,mk->m", u, a)[:, None]
            overlap = (np.minimum(np.maximum(ta, tb), length[:, None])
                       - np.maximum(np.minimum(ta, tb), 0.0))
            pair = ((cos > min_cos) & (da < reach_px) & (db < reach_px)
                    & (overlap > overlap_px))
            i, c = np.nonzero(pair)
            keep = rows[i] != cand[c]
            firsts.append(rows[i][keep])
            seconds.append(cand[c][keep])
            uppers.append(np.full(int(keep.sum()), is_upper))
    if not firsts:
        empty = np.zeros(0, dtype=np.intp)
        return empty, empty.copy(), np.zeros(0, dtype=bool)
    return (np.concatenate(firsts).astype(np.intp), np.concatenate(seconds).astype(np.intp),
            np.concatenate(uppers))
