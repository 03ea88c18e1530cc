"""Procedural textures: the table tops a look may name."""

from __future__ import annotations

import numpy as np
import pytest

from unseeable.errors import InputError
from unseeable.render.settings import SceneParams, SceneRandomisation
from unseeable.render.textures import (
    ALL_TABLE_KINDS,
    MORE_TABLE_KINDS,
    TABLE_KINDS,
    table_top,
)


def _luminance(texture: np.ndarray) -> np.ndarray:
    return texture @ np.array([0.2126, 0.7152, 0.0722], dtype=np.float32)


def test_planked_table_has_long_dark_seams_between_boards():
    top = table_top("planks", seed=0, size=512)
    assert top.shape == (512, 512, 3) and top.dtype == np.float32
    assert 0 < top.min() and top.max() < 1
    rows = _luminance(top).mean(axis=1)  # the boards run along the columns
    dark = rows < 0.5 * np.median(rows)
    # A seam is a band of dark rows across the whole repeat, one per board.
    starts = np.flatnonzero(dark & ~np.roll(dark, 1))
    assert len(starts) == 8
    # Straight: every column is dark on the seams' rows.
    assert np.all(_luminance(top)[dark].max(axis=0) < np.median(rows))
    # The boards differ in shade from one another, as weathered boards do.
    boards = [rows[a + 8:b - 2].mean() for a, b in zip(starts, np.r_[starts[1:], 512])]
    assert np.ptp(boards) > 0.02


def test_a_look_may_name_the_planks_but_no_standard_randomisation_draws_them():
    assert set(ALL_TABLE_KINDS) == set(TABLE_KINDS) | set(MORE_TABLE_KINDS)
    assert SceneParams(table_kind="planks").table_kind == "planks"
    assert SceneRandomisation(table_kinds=("planks",)).table_kinds == ("planks",)
    # The standard ranges draw the kinds they always drew, so their looks stay as they were.
    assert SceneRandomisation().table_kinds == TABLE_KINDS
    assert not set(MORE_TABLE_KINDS) & set(TABLE_KINDS)
    with pytest.raises(InputError):
        SceneParams(table_kind="marble")
    with pytest.raises(ValueError):
        table_top("marble", seed=0, size=64)


def test_table_tops_are_reproducible_and_tile():
    a, b = table_top("planks", seed=1, size=256), table_top("planks", seed=1, size=256)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, table_top("planks", seed=0, size=256))
    # The repeat's two edges meet as neighbouring texels do inside it (the noise is periodic).
    lum = _luminance(a)
    wrap = np.abs(lum[:, 0] - lum[:, -1]).mean()
    inside = np.abs(np.diff(lum, axis=1)).mean()
    assert wrap < 3 * inside


def test_the_renderer_draws_a_look_on_the_planked_table():
    from unseeable.camera import Camera
    from unseeable.domain import Extent, GridPose, Log, Structure
    from unseeable.render.renderer import render_view
    from unseeable.render.settings import RenderSettings

    s = Structure(Extent(1, 1, 1), [Log(0, (0, 0), 1)])
    cam = Camera.look_at(eye=[0, 400, 0.1], target=[0, 0, 0], width=64, height=48,
                         fov_deg=60)
    images = [render_view(s, GridPose(), cam, settings=RenderSettings(spp=2),
                          look=SceneParams(table_kind=kind))[0] for kind in ("oak", "planks")]
    assert images[1].shape == (48, 64, 3)
    assert not np.array_equal(images[0], images[1])
