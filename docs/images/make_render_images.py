"""Make the README's rendered photograph of a log cabin and its ground-truth id map.

Usage: ``python docs/images/make_render_images.py`` (writes ``cabin_view.png`` and
``cabin_ids.png`` beside this script).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image

from unseeable.domain import Extent, Log, Structure
from unseeable.render.renderer import render
from unseeable.render.settings import RenderSettings
from unseeable.render.workspace import PendulumArm, default_pose

HERE = Path(__file__).resolve().parent


def cabin() -> Structure:
    """A 3x6x3 cabin: a door in the front wall (k = 0), a window in the left wall (i = 0)."""
    L = Log
    return Structure(Extent(3, 6, 3), [
        L(0, (0, 0), 1), L(0, (2, 0), 1), L(0, (0, 2), 3), L(1, (0, 0), 3), L(1, (2, 0), 3),
        L(2, (0, 0), 1), L(2, (2, 0), 1), L(2, (0, 2), 3), L(3, (0, 0), 1), L(3, (0, 2), 1),
        L(3, (2, 0), 3), L(4, (0, 0), 3), L(4, (0, 2), 3), L(5, (0, 0), 3), L(5, (2, 0), 3)])


def id_colours(ids: np.ndarray) -> np.ndarray:
    """Colour each log id distinctly (golden-angle hues); the background dark grey."""
    import colorsys

    n = int(ids.max()) + 1
    palette = np.array([colorsys.hsv_to_rgb((k * 0.618034) % 1.0, 0.65, 0.95)
                        for k in range(max(n, 1))]) * 255
    out = np.full(ids.shape + (3,), 40, dtype=np.uint8)
    logs = ids >= 0
    out[logs] = palette[ids[logs]].astype(np.uint8)
    return out


def main() -> None:
    structure = cabin()
    arm = PendulumArm(radius_mm=380.0, elevation_deg=24.0, look_at=(0.0, 30.0, 0.0),
                      width=512, height=384)
    result = render(structure, default_pose(structure.extent), arm.camera(140.0),
                    settings=RenderSettings(spp=96), seed=1)
    photo = Image.fromarray(result.image)
    # An adaptive palette keeps the PNG small (< 200 kB) at no visible cost.
    photo.quantize(colors=256, method=Image.Quantize.MEDIANCUT,
                   dither=Image.Dither.FLOYDSTEINBERG).save(HERE / "cabin_view.png",
                                                            optimize=True)
    Image.fromarray(id_colours(result.ids)).save(HERE / "cabin_ids.png", optimize=True)
    for name in ("cabin_view.png", "cabin_ids.png"):
        print(f"{name}: {(HERE / name).stat().st_size / 1000:.0f} kB")


if __name__ == "__main__":
    main()
