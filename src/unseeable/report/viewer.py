"""An interactive 3-D view of an estimate, as one self-contained HTML page.

The page shows the estimated logs where the estimate puts them on the table
(the reference view's pose; the grid frame at the origin for bare evidence),
coloured by how they were seen — *seen* (some view judged one of the log's own
features) or *inferred* (the grammar put it there without direct evidence) —
and, given the truth, *right* or *wrong* by the paper's metric with the
truth's missed logs drawn faintly. The cameras of the views are drawn as
frustums. Clicking a log lists its evidence: the reference view's prior,
value and visibility of each of its features.

Everything the page needs is inlined (a small canvas renderer: perspective
projection, painter's algorithm), so it works offline and can be mailed or
archived with the estimate.

Examples
--------
>>> from unseeable.domain import Extent, Log, Structure, simulate_evidence
>>> from unseeable.pipeline import estimate_evidence, write_estimate
>>> truth = Structure(Extent(2, 1, 2), [Log(0, (0, 0), 2), Log(0, (0, 1), 2)])
>>> est = estimate_evidence(simulate_evidence(truth, accuracy=1.0, seed=0))
>>> import tempfile
>>> with tempfile.TemporaryDirectory() as folder:
...     page = write_estimate_page(write_estimate(est, folder), Path(folder) / "view.html")
...     "estimate.json" in page.read_text()
True
"""

from __future__ import annotations

import html
import json
import logging
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from unseeable.domain.features import FeatureKind, feature_axes, feature_index
from unseeable.domain.frames import GridPose
from unseeable.domain.geometry import LogGeometry
from unseeable.domain.io import structure_from_json
from unseeable.domain.structure import Log, Structure
from unseeable.errors import InputError, UnseeableError
from unseeable.fileio import atomic_write_bytes

__all__ = ["estimate_scene", "estimate_page_html", "write_estimate_page", "scene_page_html",
           "write_scene_page", "log_feature_keys", "SceneNote", "FRUSTUM_REACH"]

logger = logging.getLogger(__name__)

#: Frustums are drawn this share of the way from each camera to the assembly's centre.
FRUSTUM_REACH = 0.15

# Decimals kept for millimetre coordinates in the page (0.01 mm: far below a pixel).
_MM_DECIMALS = 2


@dataclass(frozen=True)
class SceneNote:
    """A warning shown on the page (e.g. a view whose file could not be read)."""

    text: str


def log_feature_keys(structure: Structure, log_id: int) -> list[tuple[str, tuple[int, int, int]]]:
    """The features of one log, as (kind label, grid position) pairs.

    The same list :func:`~unseeable.pipeline.evidence_checks.log_support` judges a
    log "seen" by: its ``end-`` at its first notch, ``end+`` at its last, ``u`` and
    ``v`` at every notch and ``w`` between consecutive notches.

    Examples
    --------
    >>> from unseeable.domain import Extent, Log
    >>> s = Structure(Extent(2, 1, 1), [Log(0, (0, 0), 2)])
    >>> [f"{kind}@{at}" for kind, at in log_feature_keys(s, 0)][:3]
    ['end-@(0, 0, 0)', 'end+@(1, 0, 0)', 'u@(0, 0, 0)']
    """
    pos = structure.logs[log_id].positions()
    keys = [(FeatureKind.END_MINUS.label, pos[0]), (FeatureKind.END_PLUS.label, pos[-1])]
    for q in pos:
        keys += [(FeatureKind.U.label, q), (FeatureKind.V.label, q)]
    keys += [(FeatureKind.W.label, q) for q in pos[:-1]]
    return keys


def _round(points: np.ndarray) -> list:
    return np.round(np.asarray(points, dtype=float), _MM_DECIMALS).tolist()


def _log_axes(structure: Structure, pose: GridPose, geometry: LogGeometry) -> np.ndarray:
    """(L, 2, 3) world end points of each log's bounding-cylinder axis."""
    from unseeable.visibility.geometry import log_cylinders

    return pose.grid_to_world(log_cylinders(structure, geometry=geometry))


#: Points on the ring drawn around a log end's disc.
_RING_POINTS = 16


def _feature_shapes(extent, pose: GridPose, geometry: LogGeometry) -> list[list]:
    """Per feature of ``extent`` (in :func:`~unseeable.domain.feature_index` order), the
    world polyline the page draws it as: a segment's stretch of its layer's bottom edge
    (straight below the log axis), or a ring around a log end's disc."""
    ax = feature_axes(extent, geometry)  # (N, 2, 3) grid frame
    kind = feature_index(extent).kind
    is_end = (kind == FeatureKind.END_MINUS) | (kind == FeatureKind.END_PLUS)
    r = geometry.radius
    # Segments: the axis stretch lowered to the bottom edge, a hair outside the log.
    lines = ax - np.array([0.0, 1.02 * r, 0.0])
    # Ends: a ring around the disc, in the plane across the axis.
    normal = ax[:, 1] - ax[:, 0]
    side = np.cross(normal, [0.0, 1.0, 0.0])
    t = np.linspace(0.0, 2 * np.pi, _RING_POINTS + 1)
    ring = (ax[:, None, 0] + 0.5 * normal[:, None] + 0.95 * r
            * (np.cos(t)[None, :, None] * side[:, None] + np.sin(t)[None, :, None]
               * np.array([0.0, 1.0, 0.0])))
    world_lines = _round(pose.grid_to_world(lines))
    world_rings = _round(pose.grid_to_world(ring))
    return [world_rings[n] if is_end[n] else world_lines[n] for n in range(len(kind))]


def _resolve_source(source: str, estimate_path: Path) -> Path | None:
    """Where a view file named in an estimate is: as written (absolute, or relative to
    the working folder), else relative to the estimate's folder."""
    p = Path(source)
    candidates = [p] if p.is_absolute() else [p, estimate_path.parent / p]
    for c in candidates:
        if c.is_file():
            return c
    return None


def _camera_drawing(camera, to_reference, target: np.ndarray) -> dict[str, Any]:
    """The frustum of ``camera`` in the reference world: its centre, the four image
    corners at a depth reaching :data:`FRUSTUM_REACH` of the way to ``target``, and
    the image's up direction (for the little roof that tells the image's top)."""
    centre = camera.centre
    depth = FRUSTUM_REACH * float(np.linalg.norm(target - centre))
    w, h = camera.width, camera.height
    pixels = np.array([[0.0, 0.0, 1.0], [w, 0.0, 1.0], [w, h, 1.0], [0.0, h, 1.0]])
    rays_cam = pixels @ np.linalg.inv(camera.K).T  # z = 1 in the camera frame
    corners = centre + depth * (rays_cam @ camera.R)  # R.T @ ray per row
    top_mid = (corners[0] + corners[1]) / 2
    up = -camera.R[1]  # image up (-y of the camera) in the world
    roof = top_mid + up * 0.2 * float(np.linalg.norm(corners[1] - corners[0]))
    pts = to_reference(np.vstack([centre, corners, roof]))
    return {"centre": _round(pts[0]), "corners": _round(pts[1:5]), "roof": _round(pts[5])}


def _view_cameras(data, estimate_path: Path, reference: GridPose | None,
                  target: np.ndarray) -> tuple[list[dict], list[SceneNote]]:
    """The cameras of the estimate's views (those with a pose), in the reference world:
    as calibrated when the views share one table frame (the default), mapped through
    each view's pose when they were posed independently (``settings.pose.independent``)."""
    from unseeable.render.view import load_view

    cameras: list[dict] = []
    notes: list[SceneNote] = []
    pose_settings = data.settings.get("pose")
    independent = isinstance(pose_settings, dict) and bool(pose_settings.get("independent"))
    for n, v in enumerate(data.views):
        label = f"view {n + 1}" + (" (reference)" if n == 0 else "")
        if v.pose is None or reference is None:
            continue  # bare evidence: no camera
        if not v.source:
            notes.append(SceneNote(f"{label}: no view file recorded; its camera is not drawn"))
            continue
        path = _resolve_source(v.source, estimate_path)
        if path is None:
            notes.append(SceneNote(f"{label}: cannot read {v.source} (no such file); its "
                                   "camera is not drawn"))
            logger.warning("%s: view file %s not found; its camera is not drawn", label,
                           v.source)
            continue
        try:
            view = load_view(path)
        except UnseeableError as err:
            notes.append(SceneNote(f"{label}: cannot read {v.source} ({err}); its camera is "
                                   "not drawn"))
            logger.warning("%s: %s; its camera is not drawn", label, err)
            continue
        view_pose = GridPose(v.pose.x, v.pose.z, v.pose.yaw_deg)

        # Views in one table frame: the camera is where its calibration says. Independent
        # views: a view's pose places the joint (reference) grid in that view's own table
        # frame, so through the grid its camera lands in the reference view's frame.
        def to_reference(points, view_pose=view_pose, own_frame=independent and n > 0):
            if not own_frame:
                return np.asarray(points, dtype=float)
            return reference.grid_to_world(view_pose.world_to_grid(points))

        drawing = _camera_drawing(view.camera, to_reference, target)
        drawing.update(label=label, source=str(v.source), reference=n == 0,
                       removed_from_layer=v.removed_from_layer,
                       size=[view.camera.width, view.camera.height])
        cameras.append(drawing)
    return cameras, notes


def _truth_comparison(truth_path: Path, estimate: Structure, estimate_pose: GridPose | None,
                      drawn_pose: GridPose, geometry: LogGeometry):
    """(comparison, truth structure, pose the truth is drawn at). With poses on both sides
    the logs are compared physically; otherwise the truth is taken in the estimate's grid."""
    from unseeable.evaluate.metric import compare_structures
    from unseeable.render.view import load_reference

    truth, truth_pose = load_reference(truth_path)
    if truth_pose is not None and estimate_pose is not None:
        comparison = compare_structures(truth, estimate, truth_pose=truth_pose,
                                        estimate_pose=estimate_pose, geometry=geometry,
                                        on_misaligned="count")
        return comparison, truth, truth_pose
    # One side has no pose: the truth is taken to be in the estimate's grid.
    if truth.extent != estimate.extent:
        raise InputError(f"has extent {truth.extent} but the estimate's is {estimate.extent}, "
                         "and without poses on both sides they cannot be compared physically",
                         file=truth_path, field="extent", value=truth.extent.as_list())
    return compare_structures(truth, estimate, geometry=geometry), truth, drawn_pose


def _summary(data, structure: Structure | None, seen: np.ndarray | None) -> dict[str, Any]:
    c = data.confidence
    out: dict[str, Any] = {
        "status": data.status,
        "log_probability": data.log_probability,
        "confident": data.confident,
        "tolerance": None if c is None else c.tolerance,
        "delta_star": None if c is None else c.delta_star,
        "views": len(data.views),
        "backend": data.backend,
        "pose": None if data.pose is None else data.pose.model_dump(),
    }
    if structure is not None:
        out["extent"] = structure.extent.as_list()
        out["logs"] = len(structure.logs)
        if seen is not None:
            out["seen"] = int(seen.sum())
    return out


def estimate_scene(estimate_path: str | Path, *, truth: str | Path | None = None,
                   geometry: LogGeometry = LogGeometry()) -> dict[str, Any]:
    """Everything the page draws, in the world (table) frame, as a JSON-ready dict.

    Parameters
    ----------
    estimate_path : path
        An ``unseeable/estimate@2`` file.
    truth : path, optional
        A structure file (``unseeable/structure@1``, in the estimate's grid) or a
        view's truth file (``unseeable/truth@1``, with the true pose).
    geometry : LogGeometry

    Returns
    -------
    dict
        ``logs`` (per estimated log: ``axis`` (2, 3) world end points of its
        cylinder, ``notches``, ``layer``, ``at``, ``positions``, ``seen``,
        ``correct`` (None without truth) and ``features``), ``missed`` (the truth's
        unmatched logs), ``cameras``, ``grid`` (the grid frame and the extent's
        footprint), ``radius``, ``summary``, ``notes``, ``truth``.

    Raises
    ------
    InputError
        A file that cannot be read or validated, naming the file, field and value.
    """
    from unseeable.pipeline.record import load_estimate

    path = Path(estimate_path)
    data = load_estimate(path)
    structure = None
    if data.structure is not None:
        structure = structure_from_json(data.structure.model_dump(mode="json"), file=path,
                                        field="structure", check_grammar=False)
    estimate_pose = None if data.pose is None else GridPose(data.pose.x, data.pose.z,
                                                            data.pose.yaw_deg)
    # Bare evidence: the grid frame is drawn at the table's origin.
    drawn_pose = estimate_pose if estimate_pose is not None else GridPose()

    logs: list[dict] = []
    seen = None
    if structure is not None:
        if data.logs_seen and len(data.logs_seen) != len(structure.logs):
            raise InputError(f"must have one entry per log ({len(structure.logs)})", file=path,
                             field="logs_seen", value=len(data.logs_seen))
        seen = None
        if data.logs_seen:
            # ``logs_seen`` follows the file's logs; log ids are indices into the
            # structure's (sorted) logs, which an estimate writes in that order anyway.
            file_logs = [Log(g.layer, g.at, g.notches) for g in data.structure.logs]
            order = [file_logs.index(log) for log in structure.logs]
            seen = np.array(data.logs_seen, dtype=bool)[order]
        features = {(f.kind, tuple(f.at)): f for f in data.features}
        axes = _log_axes(structure, drawn_pose, geometry)
        shapes = _feature_shapes(structure.extent, drawn_pose, geometry)
        index = feature_index(structure.extent)
        for n, log in enumerate(structure.logs):
            feats = []
            for kind, at in log_feature_keys(structure, n):
                f = features.get((kind, tuple(at)))
                if f is not None:
                    shape = shapes[index.lookup(FeatureKind.parse(kind), at)]
                    feats.append({"kind": kind, "at": list(at), "p": f.p, "value": f.value,
                                  "visible": f.visible, "shape": shape})
            logs.append({"id": n, "notches": log.notches, "layer": log.layer,
                         "at": list(log.at), "positions": [list(q) for q in log.positions()],
                         "axis": _round(axes[n]),
                         "seen": None if seen is None else bool(seen[n]),
                         "correct": None, "features": feats})

    missed: list[dict] = []
    truth_info = None
    if truth is not None:
        truth_path = Path(truth)
        if structure is None:
            raise InputError("has no structure to compare with the truth", file=path,
                             field="structure", value=None)
        comparison, truth_structure, truth_drawn_pose = _truth_comparison(
            truth_path, structure, estimate_pose, drawn_pose, geometry)
        for entry, ok in zip(logs, comparison.estimate_correct):
            entry["correct"] = bool(ok)
        truth_axes = _log_axes(truth_structure, truth_drawn_pose, geometry)
        for n, log in enumerate(truth_structure.logs):
            if not comparison.truth_correct[n]:
                missed.append({"id": n, "notches": log.notches, "layer": log.layer,
                               "at": list(log.at), "axis": _round(truth_axes[n])})
        truth_info = {"source": truth_path.name, "errors": int(comparison.errors),
                      "right": int(comparison.estimate_correct.sum()),
                      "wrong": int((~comparison.estimate_correct).sum()),
                      "missed": len(missed), "logs": len(truth_structure.logs),
                      "errors_by_kind": comparison.errors_by_kind()}

    extent = structure.extent if structure is not None else None
    grid = _grid_drawing(drawn_pose, extent, geometry)
    centre = np.array(grid["centre"])
    cameras, notes = _view_cameras(data, path, estimate_pose, centre)
    if structure is None:
        notes.insert(0, SceneNote(f"no structure was found (status {data.status})"))
    return {
        "title": path.name,
        "geometry": {"l1": geometry.l1, "l2": geometry.l2, "l3": geometry.l3},
        "radius": geometry.radius,
        "logs": logs,
        "missed": missed,
        "cameras": cameras,
        "grid": grid,
        "summary": _summary(data, structure, seen),
        "truth": truth_info,
        "notes": [note.text for note in notes],
    }


def _grid_drawing(pose: GridPose, extent, geometry: LogGeometry) -> dict[str, Any]:
    """The grid frame (origin and unit i, j, k directions), the footprint's grid lines
    on the table and the assembly's centre, in the world."""
    l1 = geometry.l1
    I, J, K = (1, 1, 1) if extent is None else extent.shape
    lines = []
    for i in range(I):
        lines.append([[i * l1, 0.0, 0.0], [i * l1, 0.0, (K - 1) * l1]])
    for k in range(K):
        lines.append([[0.0, 0.0, k * l1], [(I - 1) * l1, 0.0, k * l1]])
    top = geometry.layer_height(J - 1) + geometry.radius
    centre = [(I - 1) * l1 / 2, top / 2, (K - 1) * l1 / 2]
    origin = pose.grid_to_world(np.zeros(3))
    dirs = pose.directions_to_world(np.eye(3))
    return {"origin": _round(origin), "i": _round(dirs[0]), "j": _round(dirs[1]),
            "k": _round(dirs[2]), "lines": _round(pose.grid_to_world(np.array(lines)))
            if lines else [], "centre": _round(pose.grid_to_world(np.array(centre))),
            "size": [(I - 1) * l1 + 2 * geometry.l3, top, (K - 1) * l1 + 2 * geometry.l3],
            "extent": None if extent is None else extent.as_list()}


def _json_for_script(value: Any) -> str:
    """JSON safe inside a ``<script>`` element (no ``</script>``, no HTML comment)."""
    text = json.dumps(value, separators=(",", ":"), allow_nan=False)
    return text.replace("<", "\\u003c").replace(">", "\\u003e").replace("&", "\\u0026")


def scene_page_html(scene: dict[str, Any], *, file: Any = None) -> str:
    """The page (one HTML document, script and style inline) of a scene made by
    :func:`estimate_scene`; ``file`` names the estimate in errors."""
    from unseeable.report.page import PAGE_TEMPLATE

    _check_finite(scene, file)
    title = f"unseeable — {scene['title']}"
    return (PAGE_TEMPLATE.replace("@TITLE@", html.escape(title))
            .replace("@SCENE@", _json_for_script(scene)))


def estimate_page_html(estimate_path: str | Path, *, truth: str | Path | None = None,
                       geometry: LogGeometry = LogGeometry()) -> str:
    """The interactive page of an estimate, as one HTML document (see the module).

    Parameters
    ----------
    estimate_path : path
        An ``unseeable/estimate@2`` file.
    truth : path, optional
        A structure file or a view's truth file to judge the logs right or wrong by.
    geometry : LogGeometry

    Returns
    -------
    str
        A complete HTML document with its script and style inline, to write to a file
        or embed (e.g. in an ``<iframe srcdoc>``).

    Raises
    ------
    InputError
        Naming the file, field and value at fault.
    """
    scene = estimate_scene(estimate_path, truth=truth, geometry=geometry)
    return scene_page_html(scene, file=estimate_path)


def _check_finite(value: Any, file: Any, where: str = "") -> None:
    """Non-finite numbers cannot go into the page's JSON: name the first one."""
    if isinstance(value, float) and not math.isfinite(value):
        raise InputError("must be a finite number", file=file, field=where or None,
                         value=value)
    if isinstance(value, dict):
        for key, item in value.items():
            _check_finite(item, file, f"{where}.{key}" if where else str(key))
    elif isinstance(value, list):
        for n, item in enumerate(value):
            _check_finite(item, file, f"{where}[{n}]")


def write_scene_page(scene: dict[str, Any], out_path: str | Path) -> Path:
    """Write the page of a scene (:func:`scene_page_html`) atomically; return its path."""
    out = Path(out_path)
    atomic_write_bytes(out, scene_page_html(scene).encode("utf-8"))
    return out


def write_estimate_page(estimate_path: str | Path, out_path: str | Path, *,
                        truth: str | Path | None = None,
                        geometry: LogGeometry = LogGeometry()) -> Path:
    """Write the interactive page of an estimate (:func:`estimate_page_html`) atomically
    (no half-written page is ever left at ``out_path``; its folder is made if needed).

    Returns
    -------
    Path
        ``out_path``.

    Raises
    ------
    InputError
        Naming the file, field and value at fault.
    """
    out = Path(out_path)
    text = estimate_page_html(estimate_path, truth=truth, geometry=geometry)
    atomic_write_bytes(out, text.encode("utf-8"))
    return out
