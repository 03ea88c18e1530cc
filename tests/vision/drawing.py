"""A tiny OpenCV painter of Lincoln Log assemblies, for fast detector and pose tests.

Each log is drawn as its bounding cylinder: the visible half of the side in
shaded strips between generator lines, and the end discs that face the
camera; logs are painted far to near. No notches, no shadows: enough for
edges to be where the real renderer puts them.
"""

from __future__ import annotations

import cv2
import numpy as np

from unseeable.camera import Camera
from unseeable.domain import GridPose, LogGeometry, Structure


def log_axes(structure: Structure, geometry: LogGeometry) -> np.ndarray:
    """(L, 2, 3) grid-frame axis end points of every log."""
    g = geometry
    out = []
    for log in structure.logs:
        first, last = log.positions()[0], log.positions()[-1]
        y = float(g.layer_height(log.layer))
        d = np.array([1.0, 0, 0]) if log.layer % 2 == 0 else np.array([0, 0, 1.0])
        a = np.array([first[0] * g.l1, y, first[2] * g.l1]) - g.l3 * d
        b = np.array([last[0] * g.l1, y, last[2] * g.l1]) + g.l3 * d
        out.append([a, b])
    return np.array(out).reshape(-1, 2, 3)


def draw_structure(structure: Structure, pose: GridPose, camera: Camera, *,
                   geometry: LogGeometry = LogGeometry(), wood=(150, 110, 70),
                   table=(90, 90, 100), light=(0.4, 1.0, -0.5), noise: float = 4.0,
                   seed: int = 0, strips: int = 10,
                   background: np.ndarray | None = None) -> np.ndarray:
    """An (H, W, 3) uint8 picture of ``structure`` at ``pose`` seen by ``camera``
    (on ``background``, an (H, W, 3) picture of the table, else a plain ``table``)."""
    rng = np.random.default_rng(seed)
    h, w = camera.height, camera.width
    img = np.empty((h, w, 3), np.float32)
    img[:] = np.array(table, np.float32) if background is None else background
    lvec = np.asarray(light, float)
    lvec = lvec / np.linalg.norm(lvec)
    wood_c = np.array(wood, np.float32)
    r = geometry.radius
    c = camera.centre
    axes = pose.grid_to_world(log_axes(structure, geometry))
    order = np.argsort(-np.linalg.norm(axes.mean(axis=1) - c, axis=1))
    scale = 16  # fixed-point subpixel drawing
    for n in order:
        a, b = axes[n]
        ax = (b - a) / np.linalg.norm(b - a)
        mid = (a + b) / 2
        d = c - mid
        d = d - d.dot(ax) * ax
        dist = np.linalg.norm(d)
        u = d / dist
        wv = np.cross(ax, u)
        t0 = np.arccos(min(r / dist, 1.0))
        phis = np.linspace(-t0, t0, strips + 1)
        for p0, p1 in zip(phis[:-1], phis[1:]):
            pm = (p0 + p1) / 2
            normal = np.cos(pm) * u + np.sin(pm) * wv
            shade = 0.35 + 0.65 * max(normal.dot(lvec), 0.0)
            o0 = r * (np.cos(p0) * u + np.sin(p0) * wv)
            o1 = r * (np.cos(p1) * u + np.sin(p1) * wv)
            quad = np.array([a + o0, b + o0, b + o1, a + o1])
            uv = camera.project(quad)
            if not np.all(np.isfinite(uv)):
                continue
            cv2.fillPoly(img, [np.round(uv * scale).astype(np.int32)],
                         (wood_c * shade).tolist(), lineType=cv2.LINE_AA, shift=4)
        for end, sign in ((a, -1.0), (b, 1.0)):
            normal = sign * ax
            if normal.dot(c - end) <= 0:
                continue
            e1 = np.array([0.0, 1.0, 0.0])
            e2 = np.cross(normal, e1)
            t = np.linspace(0, 2 * np.pi, 48, endpoint=False)
            rim = end + r * (np.cos(t)[:, None] * e1 + np.sin(t)[:, None] * e2)
            uv = camera.project(rim)
            if not np.all(np.isfinite(uv)):
                continue
            shade = 0.45 + 0.55 * max(normal.dot(lvec), 0.0)
            cv2.fillPoly(img, [np.round(uv * scale).astype(np.int32)],
                         (wood_c * 1.1 * shade).tolist(), lineType=cv2.LINE_AA, shift=4)
    img += rng.normal(0.0, noise, img.shape).astype(np.float32)
    return np.clip(img, 0, 255).astype(np.uint8)


def draw_planks(camera: Camera, *, yaw_deg: float, width_mm: float = 90.0,
                length_mm: float = 700.0,
                tones=((196, 150, 100), (176, 128, 84)), seam=(70, 50, 35),
                seam_mm: float = 2.5, seed: int = 0) -> np.ndarray:
    """An (H, W, 3) float32 picture of a table of parallel planks along a grid's i axis
    at yaw ``yaw_deg``, ``width_mm`` wide and ``length_mm`` long (their ends staggered),
    each of one of ``tones``, with dark seams between them."""
    from unseeable.vision.scale import table_point

    rng = np.random.default_rng(seed)
    h, w = camera.height, camera.width
    v, u = np.mgrid[0:h, 0:w]
    pts = table_point(camera, np.stack([u.ravel(), v.ravel()], axis=1).astype(float), 0.0)
    rotation = GridPose(0.0, 0.0, yaw_deg).rotation  # planks along the grid's i axis
    along = pts @ rotation[:, 0] / length_mm
    across = pts @ rotation[:, 2] / width_mm
    across, along = np.nan_to_num(across, nan=0.0), np.nan_to_num(along, nan=0.0)
    row = np.floor(across).astype(int) - int(np.floor(across.min()))
    along += rng.random(row.max() + 1)[row]  # staggered ends
    plank = (row * 7919 + np.floor(along).astype(int)) % 1024
    img = np.asarray(tones, np.float32)[rng.integers(0, len(tones), 1024)[plank]]
    at_seam = ((np.abs(across - np.round(across)) * width_mm < seam_mm / 2)
               | (np.abs(along - np.round(along)) * length_mm < seam_mm / 2))
    img[at_seam] = np.asarray(seam, np.float32)
    return img.reshape(h, w, 3)
