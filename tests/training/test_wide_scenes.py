"""The wide-look training family and the held-out looks it must stay clear of."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

from unseeable.domain import LogGeometry
from unseeable.render.settings import SceneRandomisation, recorded_fields
from unseeable.training.scenes import (
    _FAMILIES,
    TRAIN_WIDE,
    _render_settings,
    scene_spec,
)

#: Cache keys of the families made before the wide looks (2026-12-06): their cached
#: renders stay valid only while these stay the same.
KEYS = {"train": "0c78f967ff", "train-walls": "5946c78d28", "train-tall": "a93ff58b9a",
        "train-looks": "c487db18d3", "train-halls": "fa7d2d4738", "validation": "19a5ed6e14"}
BENCH_KEYS = {"other-cameras": "c3b6a4d719", "other-cameras-1024": "44df7fd119",
              "other-renderer": "6bbe4092c1", "validation-halls": "5d3298d6b6",
              "held-out-looks": "37f3aac37f", "held-out-looks-2": "5ee822bec3",
              "seamed-tables-dev": "40e4fc59c4"}
#: The fields of the renderer's randomisation before the wide looks.
OLD_RANDOMISATION = {"key_azimuth_deg", "key_elevation_deg", "key_intensity", "key_size_mm",
                     "sky_intensity", "wood_brightness", "wood_redness", "wood_roughness",
                     "log_variation", "table_kinds", "table_brightness", "exposure", "noise",
                     "camera_position_mm", "camera_rotation_deg", "grain_contrast"}


@pytest.fixture(scope="module")
def benchmark_families() -> dict:
    path = Path(__file__).resolve().parents[2] / "benchmarks" / "vision.py"
    spec = importlib.util.spec_from_file_location("vision_benchmark", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.FAMILIES


def _apart(a: tuple, b: tuple) -> bool:
    return a[1] < b[0] or b[1] < a[0]


def test_the_families_made_before_keep_their_cache_keys(benchmark_families):
    assert {name: _FAMILIES[name].key() for name in KEYS} == KEYS
    assert {name: benchmark_families[name].key() for name in BENCH_KEYS} == BENCH_KEYS


def test_the_families_made_before_render_with_the_randomisation_they_had():
    for name in KEYS:
        rnd = _render_settings(_FAMILIES[name], LogGeometry()).randomisation
        assert {f.name for f in recorded_fields(rnd)} <= OLD_RANDOMISATION
        assert rnd.noise == SceneRandomisation().noise


def test_the_wide_family_is_registered_and_draws_its_looks():
    assert scene_spec("train-wide") is TRAIN_WIDE
    rnd = _render_settings(TRAIN_WIDE, LogGeometry()).randomisation
    assert isinstance(rnd, SceneRandomisation)
    assert rnd.key_temperature_k == TRAIN_WIDE.key_temperature_k
    assert rnd.painted_share == TRAIN_WIDE.painted_share
    assert {"cloth", "patterned"} <= set(rnd.table_kinds)


def test_no_training_family_overlaps_the_held_out_looks(benchmark_families):
    held_out = {name: benchmark_families[name]
                for name in ("held-out-looks", "held-out-looks-2", "held-out-looks-3")}
    training = [spec for name, spec in _FAMILIES.items() if name != "validation"]
    # Planks and stone tables are in no training scene ("white" is in the standard looks:
    # held-out-looks-2 differs from them in its wood and exposure).
    for spec in training:
        for name in ("held-out-looks", "held-out-looks-3"):
            assert not set(spec.table_kinds) & set(held_out[name].table_kinds), (spec.name, name)
    # The wide family stops short of each held-out look on every range it widens.
    for name, look in held_out.items():
        assert not set(TRAIN_WIDE.table_kinds) & set(look.table_kinds), name
    for name in ("held-out-looks", "held-out-looks-2"):
        look = held_out[name]
        for field in ("wood_brightness", "wood_redness", "exposure", "jpeg_quality"):
            assert _apart(getattr(TRAIN_WIDE, field), getattr(look, field)), (name, field)
    assert _apart(TRAIN_WIDE.grain_contrast, held_out["held-out-looks"].grain_contrast)
    third = held_out["held-out-looks-3"]
    for field in ("key_temperature_k", "defocus_px", "environment_red", "environment_blue"):
        assert _apart(getattr(TRAIN_WIDE, field), getattr(third, field)), field
    assert third.key_temperature_k[1] < min(TRAIN_WIDE.fill_temperature_k)
