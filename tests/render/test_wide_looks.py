"""The wide looks: light colour, fill light, white balance, defocus, end grain, painted logs,
new table tops and the room's tint; at their defaults, the standard looks unchanged."""

from __future__ import annotations

from dataclasses import fields

import numpy as np
import pytest

from unseeable.camera import Camera
from unseeable.domain import Extent, GridPose, Log, Structure
from unseeable.errors import InputError
from unseeable.render.renderer import light_colour, render
from unseeable.render.settings import (
    LATER_FIELD,
    STANDARD_TEMPERATURE_K,
    RenderSettings,
    SceneParams,
    SceneRandomisation,
)
from unseeable.render.textures import ALL_TABLE_KINDS, MORE_TABLE_KINDS, TABLE_KINDS, table_top

#: The fields a look had before the wide looks; their draws must not move.
OLD_FIELDS = ("key_azimuth_deg", "key_elevation_deg", "key_intensity", "key_size_mm",
              "sky_intensity", "wood_brightness", "wood_redness", "wood_roughness",
              "log_variation", "table_kind", "table_brightness", "exposure", "noise",
              "texture_seed", "grain_contrast")
WIDE = SceneRandomisation(
    key_temperature_k=(2700.0, 9000.0), fill_intensity=(0.0, 0.6), fill_azimuth_deg=(90, 270),
    fill_elevation_deg=(10.0, 70.0), fill_temperature_k=(2700.0, 12000.0),
    white_balance_red=(0.8, 1.2), white_balance_blue=(0.8, 1.2), defocus_px=(0.0, 1.5),
    end_grain_contrast=(0.0, 1.5), painted_share=(0.0, 0.5), environment_red=(0.7, 1.3),
    environment_blue=(0.7, 1.3))
NEW_FIELDS = tuple(f.name for f in fields(SceneParams) if f.name not in OLD_FIELDS)


@pytest.fixture(scope="module")
def small_scene():
    """Two logs seen from above at 64x48, without sensor noise: about a second a render."""
    s = Structure(Extent(2, 2, 2), [Log(0, (0, 0), 2), Log(1, (0, 0), 2)])
    cam = Camera.look_at(eye=[40, 260, -120], target=[40, 10, 40], width=64, height=48,
                         fov_deg=45)
    return s, cam


def _render(small_scene, **look):
    s, cam = small_scene
    return render(s, GridPose(), cam, settings=RenderSettings(spp=4), seed=1,
                  look=SceneParams(**{"noise": 0.0, **look}))


@pytest.fixture(scope="module")
def standard(small_scene):
    return _render(small_scene)


def _red_blue(image: np.ndarray) -> float:
    mean = image.reshape(-1, 3).astype(float).mean(0)
    return mean[0] / mean[2]


def _edge_energy(image: np.ndarray) -> float:
    grey = image.astype(float).mean(axis=2)
    return float(np.mean(np.abs(np.diff(grey, axis=0))) + np.mean(np.abs(np.diff(grey, axis=1))))


def test_the_new_fields_are_later_fields_left_out_of_the_records_at_their_defaults():
    assert set(NEW_FIELDS) == set(WIDE.__dataclass_fields__) - set(OLD_FIELDS) - {
        "table_kinds", "camera_position_mm", "camera_rotation_deg"}
    for record in (SceneParams, SceneRandomisation):
        for name in NEW_FIELDS:
            assert record.__dataclass_fields__[name].metadata.get(LATER_FIELD)
    assert set(SceneParams().to_json()) == set(OLD_FIELDS) - {"grain_contrast"}


def test_the_standard_randomisation_draws_what_it_drew_before():
    for seed in range(5):
        standard = SceneParams.sample(SceneRandomisation(), np.random.default_rng(seed))
        wide = SceneParams.sample(WIDE, np.random.default_rng(seed))
        # The new fields are drawn after the old ones: the old draws stay as they were.
        for name in OLD_FIELDS:
            assert getattr(standard, name) == getattr(wide, name)
        for name in NEW_FIELDS:
            assert getattr(standard, name) == SceneParams.__dataclass_fields__[name].default
        assert all(getattr(wide, n) != getattr(standard, n) for n in NEW_FIELDS)


@pytest.mark.parametrize("field, bad", [
    ("key_temperature_k", (1000.0, 3000.0)), ("fill_intensity", (-0.1, 0.5)),
    ("fill_elevation_deg", (10.0, 95.0)), ("fill_temperature_k", (3000.0, 2000.0)),
    ("white_balance_red", (0.0, 1.0)), ("white_balance_blue", (1.0, float("nan"))),
    ("defocus_px", (0.0, 12.0)), ("end_grain_contrast", (-1.0, 1.0)),
    ("painted_share", (0.5, 1.5)), ("environment_red", 1.0), ("environment_blue", (1.0,)),
])
def test_bad_ranges_are_input_errors_naming_the_field(field, bad):
    with pytest.raises(InputError) as err:
        SceneRandomisation(**{field: bad})
    assert err.value.field == field


@pytest.mark.parametrize("field, bad", [
    ("key_temperature_k", 800.0), ("fill_intensity", -1.0), ("fill_elevation_deg", 0.0),
    ("white_balance_red", 0.0), ("defocus_px", 11.0), ("painted_share", 1.2),
    ("end_grain_contrast", float("inf")), ("environment_blue", -0.5),
])
def test_bad_values_are_input_errors_naming_the_field(field, bad):
    with pytest.raises(InputError) as err:
        SceneParams(**{field: bad})
    assert err.value.field == field


def test_new_table_tops_are_named_but_never_drawn_by_the_standard_looks():
    for kind in ("cloth", "patterned", "stone"):
        assert kind in MORE_TABLE_KINDS and kind in ALL_TABLE_KINDS and kind not in TABLE_KINDS
        tops = [table_top(kind, seed=seed, size=128) for seed in (0, 1)]
        for top in tops:
            assert top.shape == (128, 128, 3) and top.dtype == np.float32
            assert 0 < top.min() and top.max() < 1 and top.std() > 0.01
        assert not np.array_equal(*tops)
    assert SceneRandomisation().table_kinds == TABLE_KINDS


def test_light_colour_is_the_standard_key_at_its_temperature_and_warmer_below_it():
    standard = light_colour(STANDARD_TEMPERATURE_K)
    np.testing.assert_array_equal(standard, [1.0, 0.97, 0.92])
    luma = np.array([0.2126, 0.7152, 0.0722])
    ratios = []
    for kelvin in (1900, 2700, 4000, 6500, 9000, 15000):
        c = light_colour(kelvin)
        assert c.min() > 0 and c @ luma == pytest.approx(standard @ luma)
        ratios.append(c[0] / c[2])
    assert all(a > b for a, b in zip(ratios, ratios[1:]))


def test_warm_light_raises_the_red_to_blue_ratio(small_scene, standard):
    warm = _render(small_scene, key_temperature_k=2200.0).image
    assert _red_blue(warm) > 1.2 * _red_blue(standard.image)


def test_a_warm_room_raises_the_red_to_blue_ratio(small_scene, standard):
    warm = _render(small_scene, environment_red=1.4, environment_blue=0.6).image
    assert _red_blue(warm) > 1.05 * _red_blue(standard.image)


def test_white_balance_error_tints_the_image(small_scene, standard):
    tinted = _render(small_scene, white_balance_red=1.3, white_balance_blue=0.8).image
    assert _red_blue(tinted) > 1.15 * _red_blue(standard.image)
    # Green is left alone (up to the path tracer's sampling, the same seed).
    assert abs(tinted[..., 1].mean() - standard.image[..., 1].mean()) < 1


def test_a_fill_light_brightens_the_scene(small_scene, standard):
    filled = _render(small_scene, fill_intensity=0.8, fill_temperature_k=9000.0).image
    assert filled.mean() > standard.image.mean() + 5


def test_defocus_lowers_the_edge_energy(small_scene, standard):
    blurred = _render(small_scene, defocus_px=2.5).image
    assert _edge_energy(blurred) < 0.7 * _edge_energy(standard.image)
    assert abs(blurred.mean() - standard.image.mean()) < 3


def test_painted_logs_change_only_the_logs_colours(small_scene, standard):
    wood = standard
    painted = _render(small_scene, painted_share=1.0)
    logs = wood.ids >= 0
    assert logs.any()
    diff = np.abs(wood.image.astype(int) - painted.image.astype(int)).sum(axis=2)
    assert diff[logs].mean() > 20
    assert diff[~logs].mean() < diff[logs].mean() / 4  # the table only sees reflections
    np.testing.assert_array_equal(wood.ids, painted.ids)


def test_end_grain_contrast_hides_or_strengthens_the_rings(small_scene):
    s, _ = small_scene
    # Seen along the lower log's axis from close by, its end fills the view; at 0 its rings
    # are gone (what is left is the path tracer's sampling noise), at 2 they are strong.
    cam = Camera.look_at(eye=[-150, 10, 0], target=[0, 10, 0], width=48, height=48, fov_deg=7)
    images = [render(s, GridPose(), cam, settings=RenderSettings(spp=4), seed=1,
                     look=SceneParams(end_grain_contrast=c, noise=0.0)).image
              for c in (0.0, 2.0)]
    spread = [im[12:36, 12:36].astype(float).mean(axis=2).std() for im in images]
    assert spread[1] > 1.25 * spread[0]
