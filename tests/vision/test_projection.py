"""Feature projection: ellipses of log ends, silhouette lines of segments."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

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
from unseeable.vision import fit_ellipses, project_features, upper_silhouette
from unseeable.vision.projection import ellipse_points


@settings(max_examples=40, deadline=None)
@given(cx=st.floats(-500, 500), cy=st.floats(-500, 500), a=st.floats(2, 80),
       ratio=st.floats(0.05, 1.0), theta=st.floats(0, np.pi - 1e-3))
def test_fit_ellipses_recovers_ellipses(cx, cy, a, ratio, theta):
    b = a * ratio
    pts, _ = ellipse_points(np.array([cx, cy, a, b, theta]), 20)
    fit = fit_ellipses(pts[None])[0]
    assert fit[:4] == pytest.approx([cx, cy, a, b], abs=1e-6 * max(1.0, a, abs(cx), abs(cy)))
    if ratio < 0.99:  # the angle of a circle is arbitrary
        d = (fit[4] - theta + np.pi / 2) % np.pi - np.pi / 2
        assert abs(d) < 1e-5


def test_fit_ellipses_rejects_collinear_points():
    pts = np.stack([np.linspace(0, 10, 20), np.linspace(0, 5, 20)], axis=1)[None]
    assert np.isnan(fit_ellipses(pts)).all()


@pytest.fixture(scope="module")
def projected():
    extent = Extent(3, 2, 2)
    pose = GridPose(-64.0, -40.0, 20.0)
    cam = Camera.look_at(eye=[-300, 450, -650], target=[0, 20, 0], width=640, height=480,
                         fov_deg=50)
    return extent, pose, cam, project_features(extent, pose, cam)


def test_rim_points_lie_on_their_ellipse(projected):
    extent, pose, cam, fp = projected
    ends = np.flatnonzero(fp.is_end)
    assert len(ends) == 2 * extent.positions
    e = fp.ellipses[ends]
    # Map rim points into each ellipse's frame: x²/a² + y²/b² = 1.
    d = fp.rims[ends] - e[:, None, :2]
    c, s = np.cos(e[:, 4:5]), np.sin(e[:, 4:5])
    u = c * d[..., 0] + s * d[..., 1]
    v = -s * d[..., 0] + c * d[..., 1]
    assert np.allclose((u / e[:, 2:3]) ** 2 + (v / e[:, 3:4]) ** 2, 1.0, atol=1e-6)
    assert fp.in_image[ends].all()


def test_segments_are_projected_lower_silhouettes(projected):
    extent, pose, cam, fp = projected
    idx = feature_index(extent)
    axes = pose.grid_to_world(feature_axes(extent))
    seg = np.flatnonzero(~fp.is_end)
    a, b = lower_silhouette(axes[seg, 0], axes[seg, 1], cam.centre, LogGeometry().radius)
    assert np.allclose(fp.segments[seg, 0], cam.project(a))
    assert np.allclose(fp.segments[seg, 1], cam.project(b))
    # u and v detectors look only outside the notch slot: a shorter part of the segment.
    uv = seg[(idx.kind[seg] == FeatureKind.U) | (idx.kind[seg] == FeatureKind.V)]
    full = np.linalg.norm(fp.segments[uv, 1] - fp.segments[uv, 0], axis=1)
    part = np.linalg.norm(fp.detector_segments[uv, 1] - fp.detector_segments[uv, 0], axis=1)
    assert np.all(part < full)
    assert np.allclose(part / full, 1 - LogGeometry().radius / LogGeometry().l3, atol=0.05)


def test_upper_segments_only_where_a_log_two_layers_below_can_be(projected):
    extent, pose, cam, fp = projected
    idx = feature_index(extent)
    seg = ~fp.is_end
    has = np.all(np.isfinite(fp.upper_segments), axis=(1, 2))
    assert np.array_equal(has[seg], idx.at[seg, 1] >= 2)


def test_upper_silhouette_mirrors_lower():
    start = np.array([[0.0, 9.5, 0.0]])
    stop = np.array([[64.0, 9.5, 0.0]])
    cam = np.array([32.0, 400.0, -600.0])
    lo = lower_silhouette(start, stop, cam, 9.5)[0][0]
    up = upper_silhouette(start, stop, cam, 9.5)[0][0]
    assert lo[1] < 9.5 < up[1]
    # Both are tangent points: distance from the axis equals the radius.
    assert np.hypot(lo[1] - 9.5, lo[2]) == pytest.approx(9.5)
    assert np.hypot(up[1] - 9.5, up[2]) == pytest.approx(9.5)


def test_features_behind_the_camera_are_flagged():
    extent = Extent(2, 1, 2)
    cam = Camera.look_at(eye=[0, 300, -600], target=[0, 0, 0], width=320, height=240,
                         fov_deg=50)
    fp = project_features(extent, GridPose(0.0, -2000.0, 0.0), cam)  # far behind the camera
    assert not fp.in_front.any()
    assert not fp.in_image.any()


def test_segments_on_one_image_line_pair_up_and_nothing_else_does(projected):
    from unseeable.vision.projection import collinear_segment_pairs

    extent, pose, cam, fp = projected
    segments = ~fp.is_end & fp.in_image
    first, second = collinear_segment_pairs(fp, segments)
    assert len(first) > 0 and np.all(first != second)
    assert segments[first].all() and segments[second].all()
    seg = fp.detector_segments
    for f, a in zip(first, second):
        u = seg[f, 1] - seg[f, 0]
        u /= np.linalg.norm(u)
        normal = np.array([-u[1], u[0]])
        # Both end points of the second within a pixel of the first's line.
        assert np.all(np.abs((seg[a] - seg[f, 0]) @ normal) < 1.0)
    # Only judged features pair, and a bad mask is refused with its shape.
    none_judged = collinear_segment_pairs(fp, np.zeros(len(fp), bool))
    assert all(len(x) == 0 for x in none_judged)
    with pytest.raises(InputError, match="judged"):
        collinear_segment_pairs(fp, segments[:-1])


def test_segment_pairs_are_the_same_whatever_the_block_of_rows(projected, monkeypatch):
    # The pair tests run in row blocks to bound memory on large assemblies: the blocks
    # must not change which pairs are found (nor pair a segment with itself).
    import unseeable.vision.projection as projection

    extent, pose, cam, fp = projected
    segments = ~fp.is_end & fp.in_image
    whole = set(zip(*projection.collinear_segment_pairs(fp, segments)))
    monkeypatch.setattr(projection, "_PAIR_BLOCK", 3)
    blocked = projection.collinear_segment_pairs(fp, segments)
    assert set(zip(*blocked)) == whole and len(blocked[0]) == len(whole)
    assert np.all(blocked[0] != blocked[1])
