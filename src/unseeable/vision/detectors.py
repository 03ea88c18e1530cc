"""Detectors focused on each feature's expected place and shape (issue item 2).

Log end
    An elliptical edge filter: the response of the Laplacian of a Gaussian
    of the ellipse's indicator equals (divergence theorem) the flux of the
    smoothed image gradient through the ellipse, so the filter is evaluated
    on the rim: the edge strength across the rim, ``sqrt(nᵀ S n)`` with ``n``
    the rim's outward normal, averaged over rim samples, and maximised over
    small perturbations of the five ellipse parameters (the paper's search).
    The signed flux (the paper's filter itself) is kept as one statistic.
    Context along the log's axis: whether the log's band (both silhouettes
    showing edges) runs inward from the disc and stops at it, and how the
    disc's colour compares with the patches just inside and outside it.
    Against rims made up by other logs' edges (a log behind, a crossing
    log's body): the rim's edges must follow the ellipse (alignment), on
    every side of it (weakest quadrant), and stand out from rings a little
    smaller and larger (radial peak) and from the same ellipse moved a
    radius along the log's axis inward and outward (axial peak), where a
    log body or background only shows its straight silhouettes.
Log segment
    Oriented edge energy along the expected silhouette line (the colour
    structure tensor in the line's normal direction: gradient energy times
    cos² of the orientation difference), maximised over small shifts across
    the line, and the longest run of samples whose energy exceeds a
    threshold in a narrow band around it (the paper's longest line segment).
    A segment at layer j is present when the log at j is there (its lower
    silhouette) *or* the log at j-2 is (its top edge, the upper silhouette,
    up to half a radius away in the image): both lines are scored and the
    stronger kept; whole-log evidence (both silhouettes of each of the two
    logs) and a wood-colour model learnt on the image itself complete the
    statistics. The lower and upper line's scores are also kept apart
    (which log shows matters), with the edge energy parallel to the axis
    *inside* each log's band (a log body's shading, against the silhouettes
    of logs behind, seen where the expected log is missing).

Profiles
    Both detectors also hand the calibration the raw appearance of the log's
    band around the feature, rectified by the pose: the band between the
    expected log's two silhouettes (for a segment: across it, from a log and
    a half below its lower silhouette to one and a half above its upper one,
    averaged along the segment; for an end: a grid along the log's axis from
    three radii inside the end to two outside, across the band), sampled in
    units of the log's width in the image. The edge energy across and along
    the axis, the lightness and the woodness at every sample let the
    calibration's network learn what a present log looks like there, which
    the hand-made statistics summarise only partly (docs/benchmarks.md,
    "Profiles").

Strengths are divided by the edge contrast inside the assembly's image
region. Every detector returns its statistics per feature (see
:data:`END_STATS`, :data:`SEGMENT_STATS`); :mod:`unseeable.vision.calibration`
maps them to a probability. Everything is vectorised over features.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import cv2
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
from unseeable.errors import InputError, check_whole_number
from unseeable.parallel import map_in_threads
from unseeable.vision.edges import (
    EdgeMaps,
    as_rgb_image,
    edge_maps,
    ellipse_rim_strength,
    fill_convex_hull,
    image_window,
    mask_box,
    sample_maps,
    segment_edge_strength,
    woodness_map,
)
from unseeable.vision.projection import (
    FeatureProjection,
    ellipse_points,
    project_features,
    upper_silhouette,
)
from unseeable.vision.scale import working_view

__all__ = [
    "END_STATS",
    "SEGMENT_STATS",
    "END_PROFILE_STATS",
    "SEGMENT_PROFILE_STATS",
    "DetectorSettings",
    "FeatureScores",
    "score_ends",
    "score_segments",
    "score_features",
    "check_feature_mask",
    "band_grid",
    "silhouette_lines",
    "detector_stretch",
]

logger = logging.getLogger(__name__)

#: Where a segment's profile samples across the log's band, in widths of the log at the
#: segment's layer in the image (0: its lower silhouette, 1: its upper one).
SEGMENT_PROFILE_ACROSS = tuple(float(t) for t in np.linspace(-1.5, 2.5, 33))
#: Where an end's profile samples along the log's axis, in radii from the end's centre
#: (positive: outward, past the end).
END_PROFILE_ALONG = tuple(float(t) for t in np.linspace(-3.0, 2.0, 11))
#: Where an end's profile samples across the log's band (0: lower silhouette, 1: upper).
END_PROFILE_ACROSS = tuple(float(t) for t in np.linspace(-0.5, 1.5, 7))
_SEGMENT_CHANNELS = ("edge", "support", "signed", "trace", "lightness", "wood")
_END_CHANNELS = ("edge_across", "edge_along", "lightness", "wood")
#: The profile columns of :data:`SEGMENT_STATS`: per channel and place across the band,
#: then the band's width in pixels.
SEGMENT_PROFILE_STATS = tuple(f"profile_{c}_{k:02d}" for c in _SEGMENT_CHANNELS
                              for k in range(len(SEGMENT_PROFILE_ACROSS))) + ("profile_width",)
#: The profile columns of :data:`END_STATS`: per channel, place across and place along.
END_PROFILE_STATS = tuple(f"profile_{c}_{k}_{a:02d}" for c in _END_CHANNELS
                          for k in range(len(END_PROFILE_ACROSS))
                          for a in range(len(END_PROFILE_ALONG))) + ("profile_width",)

#: Statistics of the log-end detector, columns of :attr:`FeatureScores.end_stats`.
END_STATS = ("strength", "coverage", "outer", "inner", "flux", "polarity", "minor_px",
             "rim_alignment", "quadrant_min", "quadrant_spread", "radial_peak",
             "band_in", "band_out", "wood_disc", "wood_in", "wood_out", "shade_in", "shade_out",
             "axial_peak", "rim_in", "rim_out") + END_PROFILE_STATS
#: Statistics of the segment detector, columns of :attr:`FeatureScores.segment_stats`.
SEGMENT_STATS = ("strength", "coverage", "run", "alignment", "peak", "polarity", "length_px",
                 "upper", "band_here", "band_below", "band_max", "wood_here", "wood_below",
                 "wood_max", "lower_strength", "upper_strength", "lower_run", "upper_run",
                 "lower_alignment", "upper_alignment", "interior_here", "interior_below"
                 ) + SEGMENT_PROFILE_STATS


@dataclass(frozen=True)
class DetectorSettings:
    """Tunable detector constants (pixels unless stated).

    Parameters
    ----------
    sigma : float
        Gaussian smoothing before differentiation.
    rim_samples : int
        Samples on each ellipse.
    end_shift : float
        Largest ellipse-centre perturbation in x and y.
    end_scales : tuple of float
        Relative perturbations of both semi-axes.
    end_angles_deg : tuple of float
        Perturbations of the ellipse angle.
    segment_samples : int
        Samples along each segment.
    segment_shift : int
        Largest shift across a segment searched for its edge.
    flank : int
        Distance of the flanks compared with the edge for the ``peak`` statistic.
    threshold : float
        Normalised edge strength that counts a sample as supported.
    min_minor_px, min_length_px : float
        Smaller ellipses / shorter segments are not judged. Ends are judged however
        thin their ellipse: an end seen edge-on still shows whether the log's band
        stops there (at a joint, the gap to the next log), and those are a quarter of
        the visible ends (docs/benchmarks.md).
    region_percentile : float
        Strengths are divided by this percentile of the edge strength inside
        the assembly's image region (the convex hull of its features).
    band_near_mm, band_far_mm : float
        The stretch of log axis beside an end disc (inward and outward) whose
        silhouettes tell whether the log runs on or stops there.
    photometric_shift : float
        Distance (in log diameters) along the log's axis from an end disc to
        the patches inside and outside it whose colour is compared with the disc's.
    radial_scales : (float, float)
        The smaller and larger rings (relative to the fitted ellipse) the rim's
        strength is compared with (``radial_peak``).
    axial_shift : float
        Distance (in log radii) along the axis of the ellipses the rim's strength is
        compared with (``axial_peak``, ``rim_in``, ``rim_out``).
    interior_fractions : tuple of float
        Where, between a log's lower (0) and upper (1) silhouette, the band's
        interior is sampled for edges parallel to the axis.
    """

    sigma: float = 1.0
    rim_samples: int = 40
    end_shift: float = 2.0
    end_scales: tuple[float, ...] = (0.88, 1.0, 1.12)
    end_angles_deg: tuple[float, ...] = (-6.0, 0.0, 6.0)
    segment_samples: int = 24
    segment_shift: int = 3
    flank: int = 4
    threshold: float = 0.15
    min_minor_px: float = 0.0
    min_length_px: float = 3.0
    region_percentile: float = 95.0
    band_near_mm: float = 2.0
    band_far_mm: float = 10.0
    photometric_shift: float = 0.7
    radial_scales: tuple[float, float] = (0.6, 1.45)
    axial_shift: float = 1.0
    interior_fractions: tuple[float, ...] = (0.3, 0.5, 0.7)


@dataclass(frozen=True, eq=False)
class FeatureScores:
    """Detector statistics for the features of one view.

    Attributes
    ----------
    extent : Extent
    judged : (N,) bool
        Features the detectors scored (requested, in the image, large enough).
    end_stats : (N, len(END_STATS)) float
        NaN except for judged log ends.
    segment_stats : (N, len(SEGMENT_STATS)) float
        NaN except for judged segments.
    ellipses : (N, 5) float
        The best-fitting perturbed ellipse of each judged end (NaN elsewhere).
    projection : FeatureProjection
        Where every feature was expected.

    Image coordinates (``ellipses``, ``projection``) are those of the image
    the detectors looked at: the photograph resampled to the calibrated
    scale when it was outside it (:func:`~unseeable.vision.scale.working_view`).
    """

    extent: Extent
    judged: np.ndarray
    end_stats: np.ndarray
    segment_stats: np.ndarray
    ellipses: np.ndarray
    projection: FeatureProjection

    @property
    def kind(self) -> np.ndarray:
        return self.projection.kind


def _longest_run(mask: np.ndarray) -> np.ndarray:
    """Length of the longest run of True along the last axis, ``(..., S) → (...)``."""
    m = np.asarray(mask, dtype=bool)
    s = m.shape[-1]
    flat = m.reshape(-1, s)
    # Position of the last False at or before each sample; run length = index - that.
    idx = np.arange(s)
    last_false = np.where(~flat, idx, -1)
    last_false = np.maximum.accumulate(last_false, axis=1)
    runs = idx - last_false
    return runs.max(axis=1).reshape(m.shape[:-1]) if s else np.zeros(m.shape[:-1], int)


def _directional(tensor: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """``nᵀ S n`` for sampled tensors ``(..., 3)`` and unit normals ``(..., 2)``."""
    nx, ny = normal[..., 0], normal[..., 1]
    return tensor[..., 0] * nx * nx + 2 * tensor[..., 1] * nx * ny + tensor[..., 2] * ny * ny


def _sample_all(maps: EdgeMaps, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    t = sample_maps(maps.tensor, points)
    g = sample_maps(maps.gradient, points)
    return t, g


def score_ends(maps: EdgeMaps, ellipses: np.ndarray, outward: np.ndarray, *,
               settings: DetectorSettings = DetectorSettings(),
               ) -> tuple[np.ndarray, np.ndarray]:
    """Elliptical edge filter responses of expected log ends.

    Parameters
    ----------
    maps : EdgeMaps
    ellipses : (M, 5) float
        Expected ``(cx, cy, a, b, theta)``.
    outward : (M, 2) float
        Image direction in which the log end's outward normal points (the
        ``outer`` arc is the half of the rim on that side).
    settings : DetectorSettings

    Returns
    -------
    stats : (M, len(END_STATS)) float
    best : (M, 5) float
        The perturbed ellipse with the highest response.
    """
    ell = np.asarray(ellipses, dtype=float)
    m = len(ell)
    st = settings
    if m == 0:
        return np.zeros((0, len(END_STATS))), np.zeros((0, 5))
    r = st.rim_samples

    def rim_strength(cands: np.ndarray) -> np.ndarray:
        return _rim_strength(maps, cands, r)  # (M, P)

    # Stage 1: centre; stage 2: axes and angle at the best centre.
    shifts = np.arange(-st.end_shift, st.end_shift + 1e-9, 1.0)
    dx, dy = np.meshgrid(shifts, shifts, indexing="ij")
    pert1 = np.zeros((dx.size, 5))
    pert1[:, 0] = dx.ravel()
    pert1[:, 1] = dy.ravel()
    cands = ell[:, None, :] + pert1[None]
    best1 = cands[np.arange(m), np.argmax(rim_strength(cands), axis=1)]
    sa, sb, th = np.meshgrid(st.end_scales, st.end_scales, np.deg2rad(st.end_angles_deg),
                             indexing="ij")
    cands = np.repeat(best1[:, None, :], sa.size, axis=1)
    cands[..., 2] *= sa.ravel()
    cands[..., 3] *= sb.ravel()
    cands[..., 4] += th.ravel()
    best = cands[np.arange(m), np.argmax(rim_strength(cands), axis=1)]

    pts, nrm = ellipse_points(best, r)  # (M, R, 2)
    t, g = _sample_all(maps, pts)
    e = np.sqrt(np.maximum(_directional(t, nrm), 0.0))  # (M, R)
    signed = np.sum(g * nrm, axis=-1)  # grey gradient across the rim, + = brighter outside
    out_dir = np.asarray(outward, dtype=float)
    out_norm = np.linalg.norm(out_dir, axis=1, keepdims=True)
    out_dir = out_dir / np.where(out_norm > 0, out_norm, 1.0)
    side = np.sum((pts - best[:, None, :2]) * out_dir[:, None, :], axis=-1)
    outer = side > 0
    inner = ~outer
    # End-on views (no outward direction): both halves count as outer and inner.
    flat = out_norm[:, 0] < 1e-6
    outer[flat] = True
    inner[flat] = True
    strength = e.mean(axis=1)
    coverage = (e > st.threshold).mean(axis=1)
    outer_mean = np.sum(e * outer, axis=1) / np.maximum(outer.sum(axis=1), 1)
    inner_mean = np.sum(e * inner, axis=1) / np.maximum(inner.sum(axis=1), 1)
    flux = np.abs(signed.mean(axis=1))
    polarity = flux / np.maximum(np.abs(signed).mean(axis=1), 1e-9)
    minor = np.minimum(best[:, 2], best[:, 3])
    # A rim made up by other edges (a log behind, a crossing log's silhouettes) is
    # supported on some sides only, by edges across the ellipse's normal, and so are
    # rings a little smaller or larger than it.
    trace = t[..., 0] + t[..., 2]
    alignment = np.sum(e * e, axis=1) / np.maximum(trace.sum(axis=1), 1e-12)
    quadrant = np.arange(r) * 4 // r
    quads = np.stack([e[:, quadrant == k].mean(axis=1) for k in range(4)], axis=1)
    quad_min = quads.min(axis=1)
    quad_spread = quads.std(axis=1) / (strength + 0.02)
    rings = []
    for scale in st.radial_scales:
        ring = best.copy()
        ring[:, 2:4] *= scale
        rings.append(_rim_strength(maps, ring, r))
    radial = strength / (np.mean(rings, axis=0) + 0.02)
    stats = np.stack([strength, coverage, outer_mean, inner_mean, flux, polarity, minor,
                      alignment, quad_min, quad_spread, radial], axis=1)
    return stats, best


def _rim_strength(maps: EdgeMaps, ellipses: np.ndarray, samples: int) -> np.ndarray:
    """Mean edge strength across the rims of ellipses ``(..., 5)``, ``(...)``."""
    return ellipse_rim_strength(maps.tensor, ellipses, samples)


def score_segments(maps: EdgeMaps, segments: np.ndarray, *,
                   settings: DetectorSettings = DetectorSettings()) -> np.ndarray:
    """Oriented edge energy and longest supported run along expected line segments.

    Parameters
    ----------
    maps : EdgeMaps
    segments : (M, 2, 2) float
        Image end points of each expected segment.
    settings : DetectorSettings

    Returns
    -------
    (M, len(SEGMENT_STATS)) float
    """
    seg = np.asarray(segments, dtype=float)
    m = len(seg)
    st = settings
    if m == 0:
        return np.zeros((0, len(SEGMENT_STATS)))
    p0, p1 = seg[:, 0], seg[:, 1]
    d = p1 - p0
    length = np.linalg.norm(d, axis=1)
    tangent = d / np.where(length > 0, length, 1.0)[:, None]
    normal = np.stack([-tangent[:, 1], tangent[:, 0]], axis=1)
    s = (np.arange(st.segment_samples) + 0.5) / st.segment_samples
    reach = st.segment_shift + st.flank
    offs = np.arange(-reach, reach + 1, dtype=float)  # (J,)
    pts = (p0[:, None, None, :] + s[None, None, :, None] * d[:, None, None, :]
           + offs[None, :, None, None] * normal[:, None, None, :])  # (M, J, S, 2)
    t = sample_maps(maps.tensor, pts)
    nrm = normal[:, None, None, :]
    e2 = np.maximum(_directional(t, nrm), 0.0)
    e = np.sqrt(e2)  # (M, J, S)
    profile = e.mean(axis=2)  # (M, J)
    centre = reach
    inner = slice(centre - st.segment_shift, centre + st.segment_shift + 1)
    j_best = centre - st.segment_shift + np.argmax(profile[:, inner], axis=1)  # (M,)
    rows = np.arange(m)
    # Tolerate a pixel of wiggle per sample around the best shift.
    band = np.stack([e[rows, j_best - 1], e[rows, j_best], e[rows, j_best + 1]], axis=1)
    e_best = band.max(axis=1)  # (M, S)
    supported = e_best > st.threshold
    strength = e_best.mean(axis=1)
    coverage = supported.mean(axis=1)
    run = _longest_run(supported) / st.segment_samples
    tr = t[rows, j_best, :, 0] + t[rows, j_best, :, 2]
    alignment = e2[rows, j_best].sum(axis=1) / np.maximum(tr.sum(axis=1), 1e-12)
    flanks = 0.5 * (profile[rows, j_best - st.flank] + profile[rows, j_best + st.flank])
    peak = profile[rows, j_best] / np.maximum(flanks + 0.02, 1e-6)
    # The gradient's sign is read at the best shift only (a fifteenth of the places).
    g = sample_maps(maps.gradient, pts[rows, j_best])  # (M, S, 2)
    signed = np.sum(g * normal[:, None, :], axis=-1)  # (M, S)
    polarity = np.abs(signed.mean(axis=1)) / np.maximum(np.abs(signed).mean(axis=1), 1e-9)
    return np.stack([strength, coverage, run, alignment, peak, polarity, length], axis=1)


def proj_layers(projection: FeatureProjection) -> np.ndarray:
    """Layer ``j`` of every feature of a projection, ``(N,)``."""
    return feature_index(projection.extent).at[:, 1]


def check_feature_mask(mask: np.ndarray | None, extent: Extent) -> np.ndarray:
    """A ``(N,) bool`` mask of requested features (all when ``None``), checked for ``extent``."""
    n = len(feature_index(extent))
    if mask is None:
        return np.ones(n, dtype=bool)
    arr = np.asarray(mask)
    if arr.shape != (n,) or arr.dtype != bool:
        raise InputError(f"must be a ({n},) boolean array for extent {extent}", field="mask",
                         value=(arr.shape, str(arr.dtype)))
    return arr


def score_features(image: np.ndarray, camera: Camera, pose: GridPose,
                   extent: Extent, *, mask: np.ndarray | None = None,
                   geometry: LogGeometry = LogGeometry(),
                   settings: DetectorSettings = DetectorSettings(),
                   maps: EdgeMaps | None = None, threads: int = 1) -> FeatureScores:
    """Run the log-end and segment detectors on the requested features of one image.

    Parameters
    ----------
    image : (H, W, 3) uint8
        The photograph.
    camera : Camera
        Must match the image size.
    pose : GridPose
        The assembly's pose (estimated or known).
    extent : Extent
    mask : (N,) bool, optional
        Features to judge (e.g. the visible ones); all by default.
    geometry : LogGeometry
    settings : DetectorSettings
    maps : EdgeMaps, optional
        Precomputed :func:`edge_maps` of ``image`` (``sigma = settings.sigma``).
    threads : int
        The ends and the segments are scored side by side on two threads when above 1
        (the same statistics).

    Returns
    -------
    FeatureScores
    """
    want = check_feature_mask(mask, extent)
    threads = check_whole_number(threads, field="threads", minimum=1)
    # The filters and the calibration are in pixels of the calibrated scale (the image is
    # checked against the camera there).
    img, camera = working_view(as_rgb_image(image), camera)
    if maps is None or maps.shape != img.shape[:2]:
        maps = edge_maps(img, sigma=settings.sigma)
    proj = project_features(extent, pose, camera, geometry=geometry)
    region = _region_mask(proj, maps.shape)
    # Every map derived from the image is made only in the window the detectors sample
    # (zero elsewhere, never read): the assembly often covers a small part of the photograph.
    window = _sampling_window(extent, pose, camera, geometry, maps.shape, region=region)
    rows, cols = window
    maps = _region_normalised(maps, region, settings.region_percentile, window=window)
    wood = woodness_map(img, region, window=window)
    lum = np.zeros(maps.shape, np.float32)
    lum[window] = cv2.cvtColor(np.ascontiguousarray(img[rows, cols]), cv2.COLOR_RGB2Lab)[..., 0]
    lum_scale = float(np.std(lum[region])) + 1.0 if region.any() else 1.0
    lum[window] /= np.float32(lum_scale)
    # Lightness centred, beside woodness, for the profiles, which read it directly (the other
    # statistics only compare lightness); and the two stacked for the end discs' means.
    appearance = np.zeros((*maps.shape, 2), np.float32)
    appearance[rows, cols, 0] = lum[window] - np.float32(np.mean(lum[region])
                                                         if region.any() else 0.0)
    appearance[rows, cols, 1] = wood[window]
    wood_lum = np.zeros((*maps.shape, 2), np.float32)
    wood_lum[rows, cols, 0] = wood[window]
    wood_lum[rows, cols, 1] = lum[window]
    wood = wood[..., None]
    n = len(proj)
    is_end = proj.is_end
    ell = proj.ellipses
    minor = np.minimum(ell[:, 2], ell[:, 3])
    ds = proj.detector_segments
    seg_len = np.linalg.norm(ds[:, 1] - ds[:, 0], axis=1)
    judged = want & proj.in_image
    with np.errstate(invalid="ignore"):
        judged &= np.where(is_end, minor >= settings.min_minor_px,
                           seg_len >= settings.min_length_px)
    end_stats = np.full((n, len(END_STATS)), np.nan)
    seg_stats = np.full((n, len(SEGMENT_STATS)), np.nan)
    best_ell = np.full((n, 5), np.nan)

    axes = feature_axes(extent, geometry)
    layer_all = proj_layers(proj)

    e_idx = np.flatnonzero(judged & is_end)
    s_idx = np.flatnonzero(judged & ~is_end)

    def end_statistics() -> None:  # end_stats and best_ell of the judged ends
        if len(e_idx):
            c = proj.centres_world[e_idx]
            tip = c + proj.normals_world[e_idx] * geometry.l2
            outward = camera.project(tip) - camera.project(c)
            outward = np.nan_to_num(outward)
            stats, best = score_ends(maps, ell[e_idx], outward, settings=settings)
            # Context: the log's band should run inward from the disc and stop at it.
            cg = axes[e_idx, 0]
            ng = axes[e_idx, 1] - axes[e_idx, 0]
            near, far = settings.band_near_mm, settings.band_far_mm
            band_in = _band_scores(maps, camera, pose, cg - far * ng, cg - near * ng, geometry,
                                   settings)
            band_out = _band_scores(maps, camera, pose, cg + near * ng, cg + far * ng, geometry,
                                    settings)
            shift = geometry.l2 * settings.photometric_shift
            disc = best
            d_in = camera.project(c - proj.normals_world[e_idx] * shift) - camera.project(c)
            d_out = camera.project(c + proj.normals_world[e_idx] * shift) - camera.project(c)
            w_disc, l_disc = _ellipse_means(wood_lum, disc, np.zeros_like(d_in))
            w_in, l_in = _ellipse_means(wood_lum, disc, np.nan_to_num(d_in))
            w_out, l_out = _ellipse_means(wood_lum, disc, np.nan_to_num(d_out))
            # The rim against the same ellipse moved along the axis: on a log body (or the
            # table) a moved ellipse meets the same straight silhouettes, past a real end not.
            step = geometry.radius * settings.axial_shift
            normals = proj.normals_world[e_idx]
            rims = []
            for sign in (-1.0, 1.0):
                moved = disc.copy()
                moved[:, :2] += np.nan_to_num(camera.project(c + sign * step * normals)
                                              - camera.project(c))
                rims.append(_rim_strength(maps, moved, settings.rim_samples))
            axial = stats[:, 0] / (0.5 * (rims[0] + rims[1]) + 0.02)
            profile = _end_profiles(maps, appearance, camera, pose, cg, ng, geometry)
            end_stats[e_idx] = np.concatenate(
                [stats, band_in[:, None], band_out[:, None],
                 np.stack([w_disc, w_in, w_out, np.abs(l_disc - l_in), np.abs(l_disc - l_out),
                           axial, rims[0], rims[1]], axis=1), profile], axis=1)
            best_ell[e_idx] = best

    def segment_statistics(s_idx: np.ndarray) -> None:  # seg_stats of these segments
        if len(s_idx):
            # A segment is present when its layer's log is there (an edge on the lower
            # silhouette) or the log two layers below is (its top edge, the upper silhouette).
            layer = layer_all[s_idx]
            J = extent.J
            lower = score_segments(maps, ds[s_idx], settings=settings)
            up_seg = proj.upper_segments[s_idx]
            has_up = np.all(np.isfinite(up_seg), axis=(1, 2))
            upper = np.full_like(lower, np.nan)
            if has_up.any():
                upper[has_up] = score_segments(maps, up_seg[has_up], settings=settings)
            use_up = has_up & ((layer >= J) | (np.nan_to_num(upper[:, 0], nan=-1.0) > lower[:, 0]))
            chosen = np.where(use_up[:, None], upper, lower)
            lower_kept = np.where((layer < J)[:, None], lower, 0.0)
            upper_kept = np.nan_to_num(upper, nan=0.0)
            # Whole-log evidence: both silhouettes of the log at j, and of the log at j-2.
            a_g, b_g = detector_stretch(axes[s_idx], proj.kind[s_idx], geometry)
            drop = np.array([0.0, geometry.l2, 0.0])
            here = _band_scores(maps, camera, pose, a_g, b_g, geometry, settings)
            below = _band_scores(maps, camera, pose, a_g - drop, b_g - drop, geometry, settings)
            here[layer >= J] = 0.0
            below[layer < 2] = 0.0
            wood_here = _axis_mean(wood, camera, pose, a_g, b_g)
            wood_below = _axis_mean(wood, camera, pose, a_g - drop, b_g - drop)
            wood_here[layer >= J] = 0.0
            wood_below[layer < 2] = 0.0
            inside_here = _band_interior(maps, camera, pose, a_g, b_g, geometry, settings)
            inside_below = _band_interior(maps, camera, pose, a_g - drop, b_g - drop, geometry,
                                          settings)
            inside_here[layer >= J] = 1.0
            inside_below[layer < 2] = 1.0
            which = [SEGMENT_STATS.index(name) for name in ("strength", "run", "alignment")]
            seg_stats[s_idx] = np.concatenate(
                [chosen, use_up[:, None].astype(float), here[:, None], below[:, None],
                 np.maximum(here, below)[:, None], wood_here[:, None], wood_below[:, None],
                 np.maximum(wood_here, wood_below)[:, None],
                 np.stack([lower_kept[:, which[0]], upper_kept[:, which[0]],
                           lower_kept[:, which[1]], upper_kept[:, which[1]],
                           lower_kept[:, which[2]], upper_kept[:, which[2]],
                           inside_here, inside_below], axis=1),
                 _segment_profiles(maps, appearance, camera, pose, a_g, b_g, geometry, settings)],
                axis=1)

    # The ends and the segments read the same maps and fill their own rows (each row
    # alone): on two threads the ends and the first segments go on one, the other
    # segments on the other, overlapping where numba, OpenCV and numpy release the GIL.
    # An end costs about 1.2 segments (the lodge's): the threads' shares even out.
    cut = int(np.clip((len(s_idx) - 1.2 * len(e_idx)) / 2, 0, len(s_idx)))

    def first() -> None:
        end_statistics()
        segment_statistics(s_idx[:cut])

    map_in_threads(lambda job: job(), [first, lambda: segment_statistics(s_idx[cut:])],
                   threads=threads)
    logger.debug("scored %d ends and %d segments", len(e_idx), len(s_idx))
    return FeatureScores(extent, judged, end_stats, seg_stats, best_ell, proj)


def detector_stretch(axes: np.ndarray, kind: np.ndarray, geometry: LogGeometry
                      ) -> tuple[np.ndarray, np.ndarray]:
    """Grid-frame axis stretch each segment detector looks at (u, v outside the notch slot)."""
    a, b = axes[:, 0], axes[:, 1]
    slot = geometry.radius / geometry.l3
    lo = np.where(kind == FeatureKind.V, slot, 0.0)
    hi = np.where(kind == FeatureKind.U, 1.0 - slot, 1.0)
    return a + lo[:, None] * (b - a), a + hi[:, None] * (b - a)


def _band_scores(maps: EdgeMaps, camera: Camera, pose: GridPose, start: np.ndarray,
                 stop: np.ndarray, geometry: LogGeometry, settings: DetectorSettings
                 ) -> np.ndarray:
    """Evidence for a log along grid-frame axis stretches: both its silhouettes show edges.

    Returns ``sqrt(strength(lower) * strength(upper))`` per stretch, ``(M,)``;
    0 where a stretch does not project into the image.
    """
    low, up, ok = silhouette_lines(camera, pose, start, stop, geometry)
    out = np.zeros((2, len(start)))
    if ok.any():
        # (a stretch with one silhouette off the image scores 0 either way)
        for row, line in zip(out, (low, up)):
            row[ok] = segment_edge_strength(maps.tensor, line[ok],
                                            samples=settings.segment_samples,
                                            shift=settings.segment_shift)
    return np.sqrt(np.maximum(out[0], 0.0) * np.maximum(out[1], 0.0))


def silhouette_lines(camera: Camera, pose: GridPose, start: np.ndarray, stop: np.ndarray,
                      geometry: LogGeometry) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Image lines of the lower and upper silhouettes of grid-frame axis stretches.

    Returns
    -------
    lower, upper : (M, 2, 2) float
        End points (0 where a stretch does not project).
    ok : (M,) bool
        Whether both project.
    """
    wa = pose.grid_to_world(start)
    wb = pose.grid_to_world(stop)
    lines = []
    for fn in (lower_silhouette, upper_silhouette):
        sa, sb = fn(wa, wb, camera.centre, geometry.radius)
        lines.append(camera.project(np.stack([sa, sb], axis=1)))  # (M, 2, 2)
    low, up = lines
    ok = np.all(np.isfinite(low), axis=(1, 2)) & np.all(np.isfinite(up), axis=(1, 2))
    return np.nan_to_num(low), np.nan_to_num(up), ok


def band_grid(low: np.ndarray, up: np.ndarray, along: np.ndarray, across: np.ndarray
               ) -> np.ndarray:
    """Points ``(M, len(across), len(along), 2)`` of a log's band: ``along`` in [0, 1] from
    the lines' first to their second end points, ``across`` from the lower line (0) to the
    upper one (1)."""
    lo = low[:, None, 0] + along[None, :, None] * (low[:, 1] - low[:, 0])[:, None, :]
    hi = up[:, None, 0] + along[None, :, None] * (up[:, 1] - up[:, 0])[:, None, :]
    return lo[:, None] + across[None, :, None, None] * (hi - lo)[:, None]


def _axis_normal(low: np.ndarray, up: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit image directions ``(M, 2)`` along the lower line and across it, the latter
    pointing towards the upper line."""
    d = low[:, 1] - low[:, 0]
    d = d / np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-9)
    normal = np.stack([-d[:, 1], d[:, 0]], axis=1)
    towards = np.sum(normal * (up.mean(axis=1) - low.mean(axis=1)), axis=1)
    return d, normal * np.where(towards < 0, -1.0, 1.0)[:, None]


def _band_interior(maps: EdgeMaps, camera: Camera, pose: GridPose, start: np.ndarray,
                   stop: np.ndarray, geometry: LogGeometry, settings: DetectorSettings,
                   samples: int = 12) -> np.ndarray:
    """Edge energy parallel to the axis inside a log's band, between its silhouettes, ``(M,)``.

    A log body shows its shading there; where the expected log is missing,
    the logs behind it show their own silhouettes at other offsets. 1 (a
    strong edge) where a stretch does not project into the image.
    """
    low, up, ok = silhouette_lines(camera, pose, start, stop, geometry)
    t = (np.arange(samples) + 0.5) / samples
    pts = band_grid(low, up, t, np.asarray(settings.interior_fractions, dtype=float))
    _, normal = _axis_normal(low, up)
    tensor = sample_maps(maps.tensor, pts)
    energy = np.sqrt(np.maximum(_directional(tensor, normal[:, None, None, :]), 0.0))
    energy = energy.mean(axis=(1, 2))
    return np.where(ok, energy, 1.0)


def _segment_profiles(maps: EdgeMaps, appearance: np.ndarray, camera: Camera, pose: GridPose,
                      start: np.ndarray, stop: np.ndarray, geometry: LogGeometry,
                      settings: DetectorSettings, samples: int = 12) -> np.ndarray:
    """A segment's cross-section: the band of the log at its layer, and below and above it.

    ``appearance``: ``(H, W, 2)`` centred lightness and woodness.

    Per place of :data:`SEGMENT_PROFILE_ACROSS` (averaged over ``samples``
    places along the segment): the edge energy across the axis, the share of
    samples where it passes ``settings.threshold``, the signed gradient
    across (positive: brighter towards the upper silhouette), the whole edge
    energy, the lightness and the woodness; then the band's width in pixels.
    ``(M, len(SEGMENT_PROFILE_STATS))``.
    """
    low, up, ok = silhouette_lines(camera, pose, start, stop, geometry)
    along = (np.arange(samples) + 0.5) / samples
    pts = band_grid(low, up, along, np.asarray(SEGMENT_PROFILE_ACROSS))  # (M, T, S, 2)
    _, normal = _axis_normal(low, up)
    n = normal[:, None, None, :]
    tensor = sample_maps(maps.tensor, pts)
    edge = np.sqrt(np.maximum(_directional(tensor, n), 0.0))
    signed = np.sum(sample_maps(maps.gradient, pts) * n, axis=-1)
    trace = np.sqrt(np.maximum(tensor[..., 0] + tensor[..., 2], 0.0))
    values = sample_maps(appearance, pts)
    width = np.linalg.norm((up - low).mean(axis=1), axis=1)
    out = np.concatenate([edge.mean(2), (edge > settings.threshold).mean(2), signed.mean(2),
                          trace.mean(2), values[..., 0].mean(2), values[..., 1].mean(2),
                          width[:, None]], axis=1)
    out[~ok] = 0.0
    return out


def _end_profiles(maps: EdgeMaps, appearance: np.ndarray, camera: Camera, pose: GridPose,
                  centre: np.ndarray, outward: np.ndarray, geometry: LogGeometry) -> np.ndarray:
    """The band of an end's log around it: a grid along its axis and across its silhouettes.

    ``appearance``: ``(H, W, 2)`` centred lightness and woodness.

    ``centre``, ``outward``: grid-frame end centres and unit outward axis
    directions ``(M, 3)``. Per place (:data:`END_PROFILE_ACROSS` ×
    :data:`END_PROFILE_ALONG`): the edge energy across the axis (the log's
    silhouettes) and along it (the end's rim), the lightness and the
    woodness; then the band's width in pixels. ``(M, len(END_PROFILE_STATS))``.
    """
    along = np.asarray(END_PROFILE_ALONG)
    r = geometry.radius
    low, up, ok = silhouette_lines(camera, pose, centre + along[0] * r * outward,
                                    centre + along[-1] * r * outward, geometry)
    pts = band_grid(low, up, (along - along[0]) / (along[-1] - along[0]),
                     np.asarray(END_PROFILE_ACROSS))  # (M, C, A, 2)
    axis, normal = _axis_normal(low, up)
    tensor = sample_maps(maps.tensor, pts)
    across = np.sqrt(np.maximum(_directional(tensor, normal[:, None, None, :]), 0.0))
    lengthwise = np.sqrt(np.maximum(_directional(tensor, axis[:, None, None, :]), 0.0))
    values = sample_maps(appearance, pts)
    m = len(centre)
    width = np.linalg.norm((up - low).mean(axis=1), axis=1)
    out = np.concatenate([across.reshape(m, -1), lengthwise.reshape(m, -1),
                          values[..., 0].reshape(m, -1), values[..., 1].reshape(m, -1),
                          width[:, None]], axis=1)
    out[~ok] = 0.0
    return out


def _region_mask(proj: FeatureProjection, shape: tuple[int, int]) -> np.ndarray:
    """``(H, W) bool``: the convex hull of every projected feature (the assembly's image region)."""
    h, w = shape
    region = np.zeros((h, w), np.uint8)
    pts = np.concatenate([proj.segments.reshape(-1, 2), proj.rims.reshape(-1, 2)])
    pts = pts[np.all(np.isfinite(pts), axis=1)]
    if len(pts) >= 3:
        fill_convex_hull(region, pts)
    return region > 0


def _ellipse_means(wood_lum: np.ndarray, ellipses: np.ndarray, shift: np.ndarray,
                   shrink: float = 0.7) -> tuple[np.ndarray, np.ndarray]:
    """Mean woodness and lightness in ellipses (shrunk, moved by ``shift``), ``(M,)`` each;
    ``wood_lum`` ``(H, W, 2)``: the two maps, stacked."""
    # Fixed sample pattern in the unit disc: centre and two rings.
    ang = np.linspace(0, 2 * np.pi, 8, endpoint=False)
    unit = np.concatenate([[[0.0, 0.0]], 0.5 * np.stack([np.cos(ang), np.sin(ang)], 1),
                           np.stack([np.cos(ang + 0.4), np.sin(ang + 0.4)], 1)])
    e = np.asarray(ellipses, dtype=float)
    a = e[:, 2, None] * shrink
    b = e[:, 3, None] * shrink
    ct, st = np.cos(e[:, 4, None]), np.sin(e[:, 4, None])
    lx, ly = a * unit[None, :, 0], b * unit[None, :, 1]
    px = e[:, 0, None] + shift[:, 0, None] + lx * ct - ly * st
    py = e[:, 1, None] + shift[:, 1, None] + lx * st + ly * ct
    vals = sample_maps(wood_lum, np.stack([px, py], axis=-1))
    return vals[..., 0].mean(axis=1), vals[..., 1].mean(axis=1)


def _axis_mean(wood: np.ndarray, camera: Camera, pose: GridPose, start: np.ndarray,
               stop: np.ndarray, samples: int = 8) -> np.ndarray:
    """Mean of a map along projected grid-frame axis stretches, ``(M,)``."""
    t = (np.arange(samples) + 0.5) / samples
    pts = start[:, None, :] + t[None, :, None] * (stop - start)[:, None, :]
    uv = camera.project(pose.grid_to_world(pts))
    return sample_maps(wood, uv)[..., 0].mean(axis=1)


def _region_normalised(maps: EdgeMaps, region: np.ndarray, percentile: float, *,
                       window: tuple[slice, slice]) -> EdgeMaps:
    """Edge maps rescaled by the contrast inside the assembly's image region.

    The assembly may cover a small part of the photograph; its own edges,
    not the table's texture, set the scale of every strength statistic.
    Only the pixels of ``window`` (which holds ``region``) are rescaled; the
    rest is 0.
    """
    if not region.any():
        return maps
    rows, cols = window
    tensor = maps.tensor[rows, cols]
    strength = np.sqrt(tensor[..., 0] + tensor[..., 2])[region[rows, cols]]
    if strength.size < 50:
        return maps
    local = float(np.percentile(strength, percentile))
    if not np.isfinite(local) or local <= 1e-6:
        return maps
    f = np.float32(1.0 / local)
    out_tensor = np.zeros_like(maps.tensor)
    out_gradient = np.zeros_like(maps.gradient)
    out_tensor[rows, cols] = tensor * f * f
    out_gradient[rows, cols] = maps.gradient[rows, cols] * f
    return EdgeMaps(out_tensor, out_gradient, maps.contrast * local, maps.sigma)


def _sampling_window(extent: Extent, pose: GridPose, camera: Camera, geometry: LogGeometry,
                     shape: tuple[int, int], *, region: np.ndarray | None = None,
                     margin_mm: float | None = None,
                     margin_px: int = 16) -> tuple[slice, slice]:
    """The image rows and columns every detector sample of ``extent`` at ``pose`` lies in.

    The box every log lies in, with the two segment layers above the top,
    grown by ``margin_mm`` (default two log diameters: the bands beside an
    end, the patches beside a disc and the profiles below and above a log
    reach about one) on every side, its edges projected (a distorting lens
    bends them) and grown by ``margin_px`` more (the searches across a
    segment and around a rim, in pixels). The whole image when part of the
    box is behind the camera. It holds ``region`` ``(H, W) bool`` too, when given
    (the image region whose statistics normalise the maps).
    """
    g = geometry
    m = 2.0 * g.l2 if margin_mm is None else float(margin_mm)
    xs = (-g.l3 - m, (extent.I - 1) * g.l1 + g.l3 + m)
    zs = (-g.l3 - m, (extent.K - 1) * g.l1 + g.l3 + m)
    # (the segments of the two layers above the top are judged too, by their upper line)
    ys = (-m, float(g.layer_height(extent.J + 2)) + g.radius + m)
    corners = np.array([[x, y, z] for x in xs for y in ys for z in zs])
    t = np.linspace(0.0, 1.0, 9)[:, None, None]
    # The twelve edges: corner pairs that differ in one coordinate.
    pairs = [(a, b) for a in range(8) for b in range(a + 1, 8)
             if np.count_nonzero(corners[a] != corners[b]) == 1]
    starts = corners[[a for a, _ in pairs]]
    stops = corners[[b for _, b in pairs]]
    pts = (starts[None] + t * (stops - starts)[None]).reshape(-1, 3)
    uv = camera.project(pose.grid_to_world(pts))
    if region is not None:
        uv = np.concatenate([uv, mask_box(region)])
    return image_window(uv, shape, margin_px=margin_px)


def feature_kind_groups(kind: np.ndarray) -> dict[str, np.ndarray]:
    """Boolean masks of the detector groups calibrated separately: ``end``, ``short``, ``long``."""
    k = np.asarray(kind)
    return {
        "end": k <= FeatureKind.END_PLUS,
        "short": (k == FeatureKind.U) | (k == FeatureKind.V),
        "long": k == FeatureKind.W,
    }
