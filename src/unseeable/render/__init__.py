"""The simulated workspace: CAD of the logs, a physically based renderer, views and truth.

Submodules:

* :mod:`~unseeable.render.cad` — notched log meshes, assembly meshes, STL/PLY/OBJ export;
* :mod:`~unseeable.render.renderer` — :func:`render_view` (Mitsuba 3, imported lazily);
* :mod:`~unseeable.render.zbuffer` — :func:`rasterise_ids`: the log each pixel shows, without
  the renderer (the pictures of an estimate);
* :mod:`~unseeable.render.settings` — :class:`RenderSettings`, :class:`SceneRandomisation`;
* :mod:`~unseeable.render.workspace` — :class:`Workspace`, :class:`PendulumArm`;
* :mod:`~unseeable.render.view` — :class:`View`, :class:`ViewTruth` and their files;
* :mod:`~unseeable.render.truth` — feature presence and visibility of a view.

Names are loaded on first use, so ``import unseeable.render`` costs nothing.
"""

from __future__ import annotations

import importlib
from typing import Any

_EXPORTS = {
    "log_mesh": "cad", "structure_mesh": "cad", "export_mesh": "cad", "log_to_grid": "cad",
    "log_to_world": "cad", "log_surfaces": "cad", "placed_logs": "cad",
    "render_view": "renderer", "render": "renderer", "render_ground_truth": "renderer",
    "Rendered": "renderer", "select_variant": "renderer", "rasterise_ids": "zbuffer",
    "RenderSettings": "settings", "SceneRandomisation": "settings", "SceneParams": "settings",
    "PendulumArm": "workspace", "Workspace": "workspace", "default_pose": "workspace",
    "jitter_camera": "workspace", "DEFAULT_STATIONS": "workspace",
    "View": "view", "ViewTruth": "view", "load_view": "view", "save_view": "view",
    "load_truth": "view", "save_truth": "view", "load_reference": "view",
    "read_image": "view", "write_image": "view",
    "feature_truth": "truth", "rendered_visibility": "truth", "feature_owners": "truth",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'unseeable.render' has no attribute {name!r}")
    value = getattr(importlib.import_module(f"unseeable.render.{module}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_EXPORTS))
