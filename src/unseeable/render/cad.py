"""CAD of Lincoln Logs (DESIGN.md §3): notched log meshes and whole assemblies.

An m-notch log is a cylinder of diameter ``l2`` and length ``(m-1)*l1 + 2*l3``.
At every notch a rectangular slot is cut on top and one below, ``l2`` wide
along the log's axis and ``l2/4`` deep, across the log, so that orthogonal
layers interlock with layer ``j``'s axis at ``y_j = l2/2 + j*l2/2``.

Log frame: the axis runs along +x, notch 0's centre is the origin, y is up;
the log spans ``x`` in ``[-l3, (m-1)*l1 + l3]``. :func:`log_to_grid` places a
:class:`~unseeable.domain.Log` in the grid frame and a
:class:`~unseeable.domain.GridPose` takes it on to the world.

Examples
--------
>>> mesh = log_mesh(2)
>>> bool(mesh.is_watertight), round(float(mesh.extents[0]), 3)
(True, 108.0)
"""

from __future__ import annotations

import io
import logging
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from unseeable.domain import GridPose, Log, LogGeometry, Structure, rot_y
from unseeable.errors import InputError
from unseeable.fileio import atomic_write_bytes

__all__ = [
    "MESH_SUFFIXES",
    "log_mesh",
    "log_to_grid",
    "log_to_world",
    "structure_mesh",
    "placed_logs",
    "export_mesh",
    "LogSurface",
    "log_surfaces",
]

logger = logging.getLogger(__name__)

#: File suffixes :func:`export_mesh` accepts, and the trimesh file type of each.
MESH_SUFFIXES = {".stl": "stl", ".ply": "ply", ".obj": "obj"}

#: Segments around a log's circumference (smooth normals hide the facets when rendering).
DEFAULT_SEGMENTS = 48


def _check_notches(notches: int) -> int:
    if isinstance(notches, bool) or notches not in (1, 2, 3):
        raise InputError("a log has 1, 2 or 3 notches", field="notches", value=notches)
    return int(notches)


@lru_cache(maxsize=32)
def _log_arrays(notches: int, geometry: LogGeometry, segments: int
                ) -> tuple[np.ndarray, np.ndarray]:
    """Vertices ``(V, 3)`` and triangles ``(F, 3)`` of a notched log in the log frame (cached)."""
    from manifold3d import Manifold

    g = geometry
    r = g.radius
    length = g.log_length(notches)
    # manifold's cylinder runs along +z from 0: turn it onto +x (rot_y(+90°) maps z to x).
    body = (Manifold.cylinder(length, r, r, segments)
            .rotate((0.0, 90.0, 0.0))
            .translate((-g.l3, 0.0, 0.0)))
    depth = g.notch_depth
    spare = 1.0  # slot boxes stick out of the log so the cut leaves no sliver faces
    slots = []
    for n in range(notches):
        x = n * g.l1
        for sign in (1.0, -1.0):
            # y range of the slot: [r - depth, r + spare] on top, mirrored below.
            y_centre = sign * (r - depth + (depth + spare) / 2.0)
            box = Manifold.cube((g.l2, depth + spare, g.l2 + 2 * spare), True)
            slots.append(box.translate((x, y_centre, 0.0)))
    cut = body - Manifold.batch_boolean(slots, _union_op()) if slots else body
    mesh = cut.to_mesh()
    verts = np.asarray(mesh.vert_properties, dtype=np.float64)[:, :3].copy()
    faces = np.asarray(mesh.tri_verts, dtype=np.int64).copy()
    verts.setflags(write=False)
    faces.setflags(write=False)
    return verts, faces


def _union_op():
    from manifold3d import OpType

    return OpType.Add


def log_mesh(notches: int, *, geometry: LogGeometry = LogGeometry(),
             segments: int = DEFAULT_SEGMENTS):
    """The watertight mesh of an ``notches``-notch log in the log frame.

    Parameters
    ----------
    notches : int
        1, 2 or 3.
    geometry : LogGeometry
    segments : int
        Straight segments around the circumference.

    Returns
    -------
    trimesh.Trimesh
        Axis along +x, notch 0 at the origin, millimetres.

    Examples
    --------
    >>> m = log_mesh(3)
    >>> m.bounds.round(2).tolist()
    [[-22.0, -9.5, -9.5], [150.0, 9.5, 9.5]]
    """
    import trimesh

    notches = _check_notches(notches)
    if isinstance(segments, bool) or not isinstance(segments, (int, np.integer)) \
            or not 8 <= segments <= 512:
        raise InputError("must be a whole number in 8..512", field="segments", value=segments)
    verts, faces = _log_arrays(notches, geometry, int(segments))
    return trimesh.Trimesh(vertices=verts.copy(), faces=faces.copy(), process=False)


def log_to_grid(log: Log, geometry: LogGeometry = LogGeometry()) -> np.ndarray:
    """Log frame → grid frame for ``log``, a ``(4, 4)`` homogeneous transform.

    Even layers run along the grid's i (x), odd layers along k (z): the log
    frame's +x is turned onto +z by ``Rot_y(-90°)``.
    """
    i, k = log.at
    m = np.eye(4)
    if log.layer % 2 == 1:
        m[:3, :3] = rot_y(np.deg2rad(-90.0))
    m[:3, 3] = (i * geometry.l1, float(geometry.layer_height(log.layer)), k * geometry.l1)
    return m


def log_to_world(log: Log, pose: GridPose | None,
                 geometry: LogGeometry = LogGeometry()) -> np.ndarray:
    """Log frame → world frame (or the grid frame when ``pose`` is None), ``(4, 4)``."""
    m = log_to_grid(log, geometry)
    return m if pose is None else pose.matrix() @ m


def structure_mesh(structure: Structure, pose: GridPose | None = None, *,
                   geometry: LogGeometry = LogGeometry(), segments: int = DEFAULT_SEGMENTS,
                   fuse: bool = True):
    """The mesh of a whole assembly, in the world frame at ``pose`` (grid frame when None).

    Parameters
    ----------
    structure : Structure
    pose : GridPose, optional
    geometry : LogGeometry
    segments : int
    fuse : bool
        Fuse touching logs into one watertight solid (a boolean union); else
        concatenate the logs' own watertight meshes (faster; logs that touch
        then share coincident faces, which some tools merge into a mesh that
        is no longer 2-manifold).

    Returns
    -------
    trimesh.Trimesh
        ``mesh.metadata["log_of_face"]`` maps every triangle to its log's
        index in ``structure.logs``.
    """
    import trimesh

    verts_out = np.zeros((0, 3))
    faces_out = np.zeros((0, 3), dtype=np.int64)
    owner = np.zeros(0, dtype=np.int32)
    if structure.logs and fuse:
        from manifold3d import Manifold, Mesh

        parts, originals = [], {}
        for idx, log in enumerate(structure.logs):
            verts, faces = _log_arrays(log.notches, geometry, int(segments))
            m = log_to_world(log, pose, geometry)
            placed = verts @ m[:3, :3].T + m[:3, 3]
            part = Manifold(Mesh(vert_properties=placed.astype(np.float32),
                                 tri_verts=faces.astype(np.uint32))).as_original()
            originals[part.original_id()] = idx
            parts.append(part)
        fused = Manifold.batch_boolean(parts, _union_op()).to_mesh()
        verts_out = np.asarray(fused.vert_properties, dtype=np.float64)[:, :3]
        faces_out = np.asarray(fused.tri_verts, dtype=np.int64)
        owner = np.full(len(faces_out), -1, dtype=np.int32)
        runs = np.asarray(fused.run_index, dtype=np.int64) // 3
        for r, original in enumerate(np.asarray(fused.run_original_id)):
            owner[runs[r]:runs[r + 1]] = originals.get(int(original), -1)
    elif structure.logs:
        verts_out, faces_out, owner = placed_logs(structure, pose, geometry=geometry,
                                                  segments=segments)
    mesh = trimesh.Trimesh(vertices=verts_out, faces=faces_out, process=False)
    mesh.metadata["log_of_face"] = owner
    return mesh


def placed_logs(structure: Structure, pose: GridPose | None = None, *,
                geometry: LogGeometry = LogGeometry(), segments: int = DEFAULT_SEGMENTS
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every log's own watertight mesh placed at ``pose`` (the grid frame when None),
    concatenated, without building a mesh object (for drawing: no trimesh import).

    Returns
    -------
    vertices : (V, 3) float64
    faces : (F, 3) int64
        Indices into ``vertices``.
    log_of_face : (F,) int32
        Each triangle's log, an index into ``structure.logs``.
    """
    parts_v, parts_f, owners = [], [], []
    offset = 0
    for idx, log in enumerate(structure.logs):
        verts, faces = _log_arrays(log.notches, geometry, int(segments))
        m = log_to_world(log, pose, geometry)
        parts_v.append(verts @ m[:3, :3].T + m[:3, 3])
        parts_f.append(faces + offset)
        owners.append(np.full(len(faces), idx, dtype=np.int32))
        offset += len(verts)
    if not parts_v:
        return np.zeros((0, 3)), np.zeros((0, 3), np.int64), np.zeros(0, np.int32)
    return np.concatenate(parts_v), np.concatenate(parts_f), np.concatenate(owners)


def export_mesh(mesh, path: str | Path) -> None:
    """Write ``mesh`` as STL, PLY or OBJ by ``path``'s suffix, atomically.

    Raises
    ------
    InputError
        When the suffix is not one of ``.stl``, ``.ply``, ``.obj``.
    """
    p = Path(path)
    kind = MESH_SUFFIXES.get(p.suffix.lower())
    if kind is None:
        raise InputError(f"unknown mesh format; use one of {sorted(MESH_SUFFIXES)}",
                         field="out", value=str(p))
    data = mesh.export(file_type=kind)
    if isinstance(data, str):
        data = data.encode("utf-8")
    elif not isinstance(data, bytes):  # some exporters hand back a stream
        buf = io.BytesIO()
        mesh.export(buf, file_type=kind)
        data = buf.getvalue()
    atomic_write_bytes(p, data)
    logger.info("wrote %s (%d triangles)", p, len(mesh.faces))


# --------------------------------------------------------------------------
# Surfaces for the renderer: per-corner normals and texture coordinates.


@dataclass(frozen=True, eq=False)
class LogSurface:
    """One textured part of a log's surface, ready for a renderer (log frame).

    Triangles do not share corners, so every corner carries its own normal and
    texture coordinate (no seams to stitch).

    Attributes
    ----------
    vertices : (V, 3) float32
    faces : (F, 3) uint32
    normals : (V, 3) float32
        Smooth (radial) on the cylinder, flat on cut faces.
    uv : (V, 2) float32
        Side grain: ``u`` = distance along the axis / ``side_period`` mm,
        ``v`` = angle around the axis / 2π. End grain: the end disc mapped
        onto the unit square, pith at (0.5, 0.5).
    """

    vertices: np.ndarray
    faces: np.ndarray
    normals: np.ndarray
    uv: np.ndarray


#: Length of log (mm) one repeat of the side-grain texture covers along the axis.
SIDE_PERIOD_MM = 240.0


@lru_cache(maxsize=32)
def log_surfaces(notches: int, geometry: LogGeometry = LogGeometry(),
                 segments: int = DEFAULT_SEGMENTS) -> tuple[LogSurface, LogSurface]:
    """The side-grain and end-grain surfaces of a notched log (cached).

    End grain covers the faces whose normal runs along the axis (the end
    discs and the slots' walls); side grain covers the rest (the cylinder and
    the slots' floors).

    Returns
    -------
    side, ends : LogSurface
    """
    notches = _check_notches(notches)
    verts, faces = _log_arrays(notches, geometry, int(segments))
    r = geometry.radius
    corners = verts[faces]  # (F, 3, 3)
    e1 = corners[:, 1] - corners[:, 0]
    e2 = corners[:, 2] - corners[:, 0]
    fn = np.cross(e1, e2)
    area2 = np.linalg.norm(fn, axis=1)
    keep = area2 > 1e-9  # drop degenerate slivers a boolean may leave
    corners, fn = corners[keep], fn[keep] / area2[keep, None]
    is_end = np.abs(fn[:, 0]) > 0.9
    radial = np.linalg.norm(corners[:, :, 1:], axis=2)  # (F, 3) distance from the axis
    centroid_r = np.linalg.norm(corners.mean(axis=1)[:, 1:], axis=1)
    # A facet of the cylinder has all corners on the radius and its centroid just inside it;
    # a slot floor's centroid lies well inside.
    on_cylinder = (np.all(np.abs(radial - r) < 1e-3 * r, axis=1)
                   & (centroid_r > r * np.cos(np.pi / segments) - 1e-3 * r) & ~is_end)

    def pack(mask: np.ndarray, uv: np.ndarray, normals: np.ndarray) -> LogSurface:
        c = corners[mask].reshape(-1, 3).astype(np.float32)
        n = normals[mask].reshape(-1, 3).astype(np.float32)
        t = uv[mask].reshape(-1, 2).astype(np.float32)
        f = np.arange(len(c), dtype=np.uint32).reshape(-1, 3)
        for a in (c, n, t, f):
            a.setflags(write=False)
        return LogSurface(c, f, n, t)

    # Normals: radial on the cylinder, the facet's own elsewhere.
    normals = np.repeat(fn[:, None, :], 3, axis=1)
    rad = corners.copy()
    rad[:, :, 0] = 0.0
    rad /= np.maximum(np.linalg.norm(rad, axis=2, keepdims=True), 1e-12)
    normals[on_cylinder] = rad[on_cylinder]

    # Side grain: cylindrical coordinates, the angle unwrapped per facet across the seam.
    angle = np.arctan2(corners[:, :, 2], corners[:, :, 1]) / (2 * np.pi)  # (F, 3) in (-.5, .5]
    lo = angle.min(axis=1, keepdims=True)
    angle = np.where(angle - lo > 0.5, angle - 1.0, angle)
    side_uv = np.stack([corners[:, :, 0] / SIDE_PERIOD_MM, angle], axis=2)
    # End grain: the disc's (y, z) onto the unit square.
    end_uv = np.stack([corners[:, :, 1] / geometry.l2 + 0.5, corners[:, :, 2] / geometry.l2 + 0.5],
                      axis=2)
    return pack(~is_end, side_uv, normals), pack(is_end, end_uv, normals)
