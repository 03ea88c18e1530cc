"""Rectified feature patches and the numpy patch network."""

import numpy as np
import pytest
from scipy.signal import correlate

from unseeable.camera import Camera
from unseeable.domain import Extent, GridPose, LogGeometry
from unseeable.errors import InputError
from unseeable.vision.patches import (
    PatchNetwork,
    feature_patches,
    load_patch_networks,
    normalise_patches,
    patch_logits,
    save_patch_networks,
)
from unseeable.vision.projection import project_features

CAMERA = Camera.look_at(eye=[-200, 350, -520], target=[40, 20, 40], width=320, height=240,
                        fov_deg=50)
EXTENT = Extent(2, 2, 2)


def ramp(axis: int) -> np.ndarray:
    """An RGB image brightening along x (axis 1) or down y (axis 0)."""
    h, w = CAMERA.height, CAMERA.width
    t = np.linspace(0, 1, (h, w)[axis])
    grey = (30 + 200 * t)[:, None] if axis == 0 else (30 + 200 * t)[None, :]
    return np.repeat(np.broadcast_to(grey, (h, w))[..., None], 3, axis=2).astype(np.uint8)


def test_patches_have_fixed_shapes_and_one_per_judged_feature():
    fp = feature_patches(ramp(0), CAMERA, GridPose(), EXTENT, rescale=False)
    assert fp.end.shape[1:] == (1, 20, 20) and fp.segment.shape[1:] == (1, 32, 12)
    assert len(fp.end) + len(fp.segment) == len(fp.index) > 0
    assert set(fp.segment_group) <= {"short", "long"}
    lab = feature_patches(ramp(0), CAMERA, GridPose(), EXTENT, channels="lab", rescale=False)
    assert lab.end.shape[1] == 3
    with pytest.raises(InputError, match="channels"):
        feature_patches(ramp(0), CAMERA, GridPose(), EXTENT, channels="rgb")


def test_patch_rows_run_top_down_and_end_columns_run_outward():
    # Lighter down the image: a patch's top row (above the upper silhouette) is darker.
    fp = feature_patches(ramp(0), CAMERA, GridPose(), EXTENT, rescale=False)
    for p in (fp.end, fp.segment):
        assert np.all(p[:, 0, 0].mean(axis=1) < p[:, 0, -1].mean(axis=1))
    # Brighter to the right: an end's last column (outward) is lighter where its log points
    # right in the image.
    fp = feature_patches(ramp(1), CAMERA, GridPose(), EXTENT, rescale=False)
    proj = project_features(EXTENT, GridPose(), CAMERA, geometry=LogGeometry())
    c = proj.centres_world[fp.end_index]
    out = CAMERA.project(c + 10 * proj.normals_world[fp.end_index]) - CAMERA.project(c)
    right = out[:, 0] > 2
    assert right.any() and (~right).any()
    first, last = fp.end[:, 0, :, 0].mean(axis=1), fp.end[:, 0, :, -1].mean(axis=1)
    assert np.all(last[right] > first[right])
    assert np.all(last[out[:, 0] < -2] < first[out[:, 0] < -2])


def random_network(rng, shape=(2, 12, 10), conv=(3, 4), hidden=5) -> PatchNetwork:
    c, h, w = shape
    ws, bs = [], []
    for f in conv:
        ws.append(rng.normal(size=(f, c, 3, 3)).astype(np.float32))
        bs.append(rng.normal(size=f).astype(np.float32))
        c, h, w = f, h // 2, w // 2
    return PatchNetwork(tuple(ws), tuple(bs),
                        rng.normal(size=(c * h * w, hidden)).astype(np.float32),
                        rng.normal(size=hidden).astype(np.float32),
                        rng.normal(size=hidden).astype(np.float32), 0.3, shape, "lab"
                        if shape[0] == 3 else "grey")


def reference_logits(net: PatchNetwork, x: np.ndarray) -> np.ndarray:
    out = []
    for patch in x.astype(np.float64):
        h = patch
        for w, b in zip(net.conv_weights, net.conv_biases):
            z = np.stack([sum(correlate(h[c], w[f, c], mode="same") for c in range(len(h)))
                          + b[f] for f in range(len(w))])
            a = np.maximum(z, 0.0)
            hh, ww = a.shape[1] // 2, a.shape[2] // 2
            h = np.array([[[a[f, 2 * i:2 * i + 2, 2 * j:2 * j + 2].max() for j in range(ww)]
                           for i in range(hh)] for f in range(len(a))])
        hid = np.maximum(h.ravel() @ net.hidden_weight + net.hidden_bias, 0.0)
        out.append(hid @ net.out_weight + net.out_bias)
    return np.array(out)


def test_numpy_inference_equals_a_reference_correlation():
    rng = np.random.default_rng(4)
    net = random_network(rng, shape=(1, 12, 10))
    x = rng.normal(size=(7, 1, 12, 10)).astype(np.float32)
    got = net.logits(x, normalised=True, batch=3)
    assert got == pytest.approx(reference_logits(net, x), rel=1e-4, abs=1e-4)
    # Raw patches are normalised first: a brighter photograph gives the same logits, and a
    # higher contrast the same patches but for the floor on their spread.
    raw = 40 + 10 * x
    assert net.logits(raw + 25) == pytest.approx(net.logits(raw), rel=1e-4, abs=1e-3)
    assert normalise_patches(raw).mean(axis=(2, 3)) == pytest.approx(0.0, abs=1e-5)
    assert normalise_patches(3 * raw, floor=0) == pytest.approx(
        normalise_patches(raw, floor=0), abs=1e-4)


def test_networks_round_trip_and_logits_fill_judged_features(tmp_path):
    rng = np.random.default_rng(5)
    nets = {"end": random_network(rng, (1, 20, 20)), "short": random_network(rng, (1, 32, 12)),
            "long": random_network(rng, (1, 32, 12))}
    path = tmp_path / "nets.npz"
    save_patch_networks(path, nets, info="test")
    back = load_patch_networks(path)
    x = rng.normal(size=(4, 1, 32, 12))
    assert back["short"].logits(x) == pytest.approx(nets["short"].logits(x), rel=1e-6)
    fp = feature_patches(ramp(0), CAMERA, GridPose(), EXTENT, rescale=False)
    n = int(fp.index.max()) + 3
    z = patch_logits(back, fp, n)
    assert np.isfinite(z[fp.index]).all() and np.isnan(np.delete(z, fp.index)).all()


def test_weights_file_errors_name_the_file_and_field(tmp_path):
    rng = np.random.default_rng(6)
    good = tmp_path / "nets.npz"
    save_patch_networks(good, {"end": random_network(rng, (1, 20, 20))})
    arrays = dict(np.load(good))
    bad = tmp_path / "bad.npz"
    np.savez(bad, **{k: v for k, v in arrays.items() if k != "end.hidden.bias"})
    with pytest.raises(InputError, match=r"bad\.npz: end\.hidden\.bias: missing"):
        load_patch_networks(bad)
    arrays["end.conv1.weight"] = arrays["end.conv1.weight"][:, :2]
    np.savez(bad, **arrays)
    with pytest.raises(InputError, match=r"bad\.npz: end\.conv1\.weight"):
        load_patch_networks(bad)
    (tmp_path / "junk.npz").write_text("not a zip")
    with pytest.raises(InputError, match=r"junk\.npz"):
        load_patch_networks(tmp_path / "junk.npz")
    np.savez(bad, format=np.array("something/else"))
    with pytest.raises(InputError, match=r"bad\.npz: format"):
        load_patch_networks(bad)
