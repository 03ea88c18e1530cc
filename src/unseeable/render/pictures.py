"""Pictures of an estimate that a person reads at a glance.

* the **overlay**: the photograph at its own size, each estimated log drawn
  over it semi-transparent with a thin outline — blue where a view saw the log
  (judged one of its own features), orange where the grammar inferred it —
  and, hatched grey, the grid positions no view saw where the estimate built
  nothing (a log may hide there); a legend says which is which;
* the **rendering**: the estimated structure alone from the photograph's
  camera, shaded, in the same colours, cropped to the assembly;
* the **truth picture** (only against a truth): the photograph with each
  estimated log green when right and red when wrong, and the truth's logs the
  estimate missed in magenta.

Right and wrong never share a colour with seen and inferred. Every picture
comes from a z-buffer over the logs' CAD triangles
(:func:`~unseeable.render.zbuffer.rasterise_ids`, pixel for pixel the renderer's
id/depth pass without loading it), so the drawing is exact: every pixel shows
the log that covers it from that camera.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from unseeable.camera import Camera
from unseeable.domain import GridPose, Log, Structure
from unseeable.errors import InputError

__all__ = ["SEEN", "INFERRED", "UNKNOWN", "GREEN", "RED", "MAGENTA", "ORANGE",
           "PICTURE_MAX_SIDE", "LegendEntry", "shaded_rendering", "overlay_logs",
           "draw_legend", "draw_hidden", "estimate_pictures", "truth_picture", "crop_to"]

#: Longest side (pixels) the pictures of an estimate are drawn at (:func:`estimate_pictures`).
PICTURE_MAX_SIDE = 1600

#: A log some view saw (judged one of its own features).
SEEN = (30, 110, 230)
#: A log the grammar inferred (no view judged a feature of its own).
INFERRED = (250, 140, 20)
ORANGE = INFERRED
#: Grid positions no view saw, where the estimate built nothing.
UNKNOWN = (150, 150, 150)
#: Against a truth: a log that is right.
GREEN = (40, 170, 60)
#: Against a truth: a log that is wrong (not in the truth).
RED = (215, 40, 40)
#: Against a truth: a log of the truth the estimate does not have.
MAGENTA = (225, 50, 225)

_BACKGROUND = (238, 238, 238)


@dataclass(frozen=True)
class LegendEntry:
    """One line of a legend: a swatch of ``colour`` (``hatched`` as unknown positions are
    drawn) and ``label``."""

    colour: tuple[int, int, int]
    label: str
    hatched: bool = False


def _shading(depth: np.ndarray, camera: Camera) -> np.ndarray:
    """Lambert-like shading ``(H, W)`` in [0.35, 1] from surface normals of a depth map."""
    h, w = depth.shape
    finite = np.isfinite(depth)
    d = np.where(finite, depth, 0.0)
    u, v = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
    kinv = np.linalg.inv(camera.K)
    rays = np.stack([u, v, np.ones_like(u)], axis=-1) @ kinv.T
    pts = rays * d[..., None]
    du = np.gradient(pts, axis=1)
    dv = np.gradient(pts, axis=0)
    n = np.cross(du, dv)
    n /= np.linalg.norm(n, axis=-1, keepdims=True) + 1e-12
    view = -rays / np.linalg.norm(rays, axis=-1, keepdims=True)
    light = view + np.array([0.3, -0.5, 0.0])  # from above-left of the camera
    light /= np.linalg.norm(light, axis=-1, keepdims=True)
    lam = np.abs(np.sum(n * light, axis=-1))
    return np.where(finite, 0.35 + 0.65 * lam, 1.0)


def _boundaries(ids: np.ndarray) -> np.ndarray:
    """Pixels where the log id changes to the next pixel right or below (one pixel wide)."""
    edge = np.zeros(ids.shape, dtype=bool)
    edge[:, 1:] |= ids[:, 1:] != ids[:, :-1]
    edge[1:, :] |= ids[1:, :] != ids[:-1, :]
    return edge


def _outline(ids: np.ndarray) -> np.ndarray:
    """The pixels of each log (``ids >= 0``) that touch another log or the background."""
    on = ids >= 0
    edge = np.zeros(ids.shape, dtype=bool)
    edge[:, 1:] |= ids[:, 1:] != ids[:, :-1]
    edge[:, :-1] |= ids[:, :-1] != ids[:, 1:]
    edge[1:, :] |= ids[1:, :] != ids[:-1, :]
    edge[:-1, :] |= ids[:-1, :] != ids[1:, :]
    return edge & on


def _hatch(shape: tuple[int, int], *, period: int = 6) -> np.ndarray:
    """Diagonal stripes ``(H, W) bool``: two pixels on in every ``period``."""
    r, c = np.indices(shape)
    return ((r + c) % period) < 2


def shaded_rendering(ids: np.ndarray, depth: np.ndarray, camera: Camera,
                     colours: np.ndarray, *, background=_BACKGROUND) -> np.ndarray:
    """A flat-coloured, shaded rendering of logs.

    Parameters
    ----------
    ids : (H, W) int
        Log index per pixel (-1 background).
    depth : (H, W) float
        Camera z (mm), ``inf`` where nothing is hit.
    camera : Camera
    colours : (L, 3) uint8
        One colour per log.

    Returns
    -------
    (H, W, 3) uint8
    """
    colours = np.asarray(colours, dtype=float).reshape(-1, 3)
    if ids.max(initial=-1) >= len(colours):
        raise InputError("needs one colour per log", field="colours", value=len(colours))
    img = np.empty((*ids.shape, 3), dtype=float)
    img[:] = background
    on = ids >= 0
    img[on] = colours[ids[on]] * _shading(depth, camera)[on][:, None]
    img[_boundaries(ids) & on] *= 0.45
    return np.clip(img, 0, 255).astype(np.uint8)


def overlay_logs(image: np.ndarray, ids: np.ndarray, colours: np.ndarray, *,
                 alpha: float = 0.3, hatched: np.ndarray | None = None) -> np.ndarray:
    """The photograph with each log's pixels tinted by its colour and outlined thinly.

    Parameters
    ----------
    image : (H, W, 3) uint8
    ids : (H, W) int
        Log index per pixel (-1 where no log is drawn).
    colours : (L, 3)
        One colour per log.
    alpha : float
        How much of a log's colour covers the photograph (its outline is opaque), so
        that the wood stays visible under the drawing.
    hatched : (L,) bool, optional
        Logs drawn as diagonal stripes instead of a tint (the unknown positions).

    Returns
    -------
    (H, W, 3) uint8, the photograph's size.
    """
    if not 0.0 <= alpha <= 1.0:
        raise InputError("must be in [0, 1]", field="alpha", value=alpha)
    colours = np.asarray(colours, dtype=float).reshape(-1, 3)
    out = np.asarray(image, dtype=float).copy()
    on = ids >= 0
    fill = on.copy()
    if hatched is not None and len(hatched):
        striped = on & np.asarray(hatched, bool)[np.where(on, ids, 0)]
        fill &= ~striped
        stripes = striped & _hatch(ids.shape)
        out[stripes] = 0.35 * out[stripes] + 0.65 * colours[ids[stripes]]
    out[fill] = (1 - alpha) * out[fill] + alpha * colours[ids[fill]]
    edge = _outline(ids)
    out[edge] = colours[ids[edge]]
    return np.clip(out, 0, 255).astype(np.uint8)


def draw_hidden(picture: np.ndarray, ids: np.ndarray, alone: np.ndarray,
                colours: np.ndarray, *, dotted: np.ndarray | None = None) -> np.ndarray:
    """``picture`` with the outline of each log drawn where another log hides it.

    The logs a camera cannot see (inferred ones, positions nobody saw, logs a
    wrong estimate missed) are mostly hidden by those it can: their outlines are
    drawn through the logs in front, so the picture shows where they stand.

    Parameters
    ----------
    picture : (H, W, 3) uint8
    ids : (H, W) int
        The log seen at each pixel (-1 none), as drawn in ``picture``.
    alone : (H, W) int
        The log to outline at each pixel with the others taken away (-1 none), in
        the same numbering as ``colours``.
    colours : (L, 3)
    dotted : (L,) bool, optional
        Logs whose outline is dotted.

    Returns
    -------
    (H, W, 3) uint8
    """
    out = np.asarray(picture).copy()
    edge = _outline(alone) & (ids != alone)
    if dotted is not None and len(dotted):
        r, c = np.indices(alone.shape)
        gaps = np.asarray(dotted, bool)[np.where(alone >= 0, alone, 0)] & ((r + c) % 4 >= 2)
        edge &= ~gaps
    out[edge] = np.asarray(colours, dtype=np.uint8).reshape(-1, 3)[alone[edge]]
    return out


def _render_subset(structure: Structure, chosen: np.ndarray, pose: GridPose,
                   camera: Camera) -> tuple[np.ndarray, np.ndarray]:
    """Log ids ``(H, W)`` of the logs ``chosen`` of ``structure`` rendered alone, numbered
    as in ``structure`` (-1 elsewhere), and their depth (``inf`` elsewhere)."""
    from unseeable.render.zbuffer import rasterise_ids

    which = np.flatnonzero(chosen)
    if len(which) == 0:
        return (np.full((camera.height, camera.width), -1, np.int32),
                np.full((camera.height, camera.width), np.inf, np.float32))
    ids, depth = rasterise_ids(Structure(structure.extent, [structure.logs[i] for i in which]),
                               pose, camera)
    return np.where(ids >= 0, which[np.clip(ids, 0, None)], -1).astype(np.int32), depth


@lru_cache(maxsize=8)
def _font(size: int):
    """A sans-serif font of ``size`` pixels: matplotlib's DejaVu Sans (always installed
    with it), else Pillow's own."""
    import importlib.util
    from pathlib import Path

    from PIL import ImageFont

    # Found beside matplotlib's package, as ``matplotlib.get_data_path()`` does, without
    # importing it (0.1-0.3 s of every estimate's pictures).
    spec = importlib.util.find_spec("matplotlib")
    if spec is not None and spec.origin is not None:
        path = Path(spec.origin).with_name("mpl-data") / "fonts" / "ttf" / "DejaVuSans.ttf"
        try:
            return ImageFont.truetype(str(path), size)
        except OSError:
            pass
    return ImageFont.load_default(size=size)


def draw_legend(image: np.ndarray, entries, *, title: str | None = None,
                avoid: np.ndarray | None = None, band: bool = False,
                background=_BACKGROUND) -> np.ndarray:
    """``image`` with a legend in the corner that hides the least of ``avoid``, or in a
    band of its own above it.

    Parameters
    ----------
    image : (H, W, 3) uint8
    entries : sequence of LegendEntry
    title : str, optional
        A first line.
    avoid : (H, W) bool, optional
        What the legend should cover least (the drawn logs).
    band : bool
        Put the legend in a strip of ``background`` added above the image (for a
        rendering cropped close to the assembly), not over it.

    Returns
    -------
    (H, W, 3) uint8: the same size, or taller by the band.
    """
    from PIL import Image, ImageDraw

    entries = list(entries)
    if not entries and title is None:
        return np.asarray(image).copy()
    h, w = np.shape(image)[:2]
    size = int(np.clip(round(min(h, w) / 34), 10, 28))
    font = _font(size)
    pad = max(3, size // 3)
    swatch = size
    lines = ([title] if title else []) + [e.label for e in entries]
    probe = ImageDraw.Draw(Image.new("RGB", (1, 1)))
    widths = [probe.textlength(text, font=font) for text in lines]
    line_h = int(size * 1.35)
    box_w = int(min(w - 2, pad * 3 + swatch + max(widths)))
    box_h = int(min(h - 2, pad * 2 + line_h * len(lines)))
    margin = max(2, size // 2)
    if band:
        strip = np.empty((box_h + 2 * margin, w, 3), np.uint8)
        strip[:] = background
        image = np.concatenate([strip, np.asarray(image, np.uint8)], axis=0)
        h = image.shape[0]
        avoid = None
    corners = [(margin, margin), (w - box_w - margin, margin), (margin, h - box_h - margin),
               (w - box_w - margin, h - box_h - margin)]
    corners = [(max(0, x), max(0, y)) for x, y in corners]
    if avoid is not None:
        cover = [np.count_nonzero(avoid[y:y + box_h, x:x + box_w]) for x, y in corners]
        x0, y0 = corners[int(np.argmin(cover))]
    else:
        x0, y0 = corners[0]
    canvas = Image.fromarray(np.ascontiguousarray(image, dtype=np.uint8)).convert("RGBA")
    layer = Image.new("RGBA", canvas.size, (0, 0, 0, 0))
    draw = ImageDraw.Draw(layer)
    draw.rounded_rectangle((x0, y0, x0 + box_w, y0 + box_h), radius=pad,
                           fill=(255, 255, 255, 215), outline=(90, 90, 90, 255))
    y = y0 + pad
    text_x = x0 + pad * 2 + swatch
    if title:
        draw.text((x0 + pad, y), title, font=font, fill=(20, 20, 20, 255))
        y += line_h
    for entry in entries:
        top = y + (line_h - swatch) // 2
        box = (x0 + pad, top, x0 + pad + swatch, top + swatch)
        if entry.hatched:
            draw.rectangle(box, fill=(255, 255, 255, 255))
            for offset in range(-swatch, swatch, 6):
                draw.line((box[0] + max(0, offset), box[1] + max(0, -offset),
                           box[0] + min(swatch, swatch + offset),
                           box[1] + min(swatch, swatch - offset)),
                          fill=(*entry.colour, 255), width=2)
            draw.rectangle(box, outline=(*entry.colour, 255))
        else:
            light = tuple(int(0.45 * c + 0.55 * 255) for c in entry.colour)
            draw.rectangle(box, fill=(*light, 255), outline=(*entry.colour, 255), width=2)
        draw.text((text_x, y), entry.label, font=font, fill=(30, 30, 30, 255))
        y += line_h
    return np.asarray(Image.alpha_composite(canvas, layer).convert("RGB"))


def _fit(image: np.ndarray, camera: Camera, max_side: int) -> tuple[np.ndarray, Camera]:
    """``image`` and ``camera`` shrunk so that the longer side is at most ``max_side``: the
    pictures are for people, and drawing them at a 12-megapixel photograph's size took
    longer than the estimate."""
    import cv2

    if max_side < 16:
        raise InputError("must be at least 16 pixels", field="max_side", value=max_side)
    if max(camera.width, camera.height) > max_side:
        camera = camera.scaled(max_side / max(camera.width, camera.height))
        image = cv2.resize(np.asarray(image), (camera.width, camera.height),
                           interpolation=cv2.INTER_AREA)
    return np.asarray(image), camera


def _plural(n: int, word: str) -> str:
    return f"{n} {word}{'' if n == 1 else 's'}"


def _ghosts(structure: Structure, unknown: np.ndarray | None) -> list[Log]:
    """One 1-notch log at each unknown position (to draw them where they stand)."""
    if unknown is None:
        return []
    mask = np.asarray(unknown, bool)
    if mask.shape != structure.extent.shape:
        raise InputError(f"must be a {structure.extent.shape} mask", field="unknown",
                         value=mask.shape)
    mask = mask & (structure.occupancy == 0)
    return [Log(int(j), (int(i), int(k)), 1) for i, j, k in np.argwhere(mask)]


def estimate_pictures(image: np.ndarray, structure: Structure, pose: GridPose, camera: Camera,
                      *, correct: np.ndarray | None = None, seen: np.ndarray | None = None,
                      unknown: np.ndarray | None = None, crop: bool = True,
                      min_size: int = 480, max_side: int = PICTURE_MAX_SIDE,
                      legend: bool = True) -> dict[str, np.ndarray]:
    """The overlay and the rendering of an estimate.

    Parameters
    ----------
    image : (H, W, 3) uint8
        The photograph the estimate came from.
    structure, pose, camera
        The estimate and where it stands.
    correct : (L,) bool, optional
        Per log, right against the truth (green) or wrong (red); for figures that
        compare (the truth picture of a command is :func:`truth_picture`).
    seen : (L,) bool, optional
        Without ``correct``: per log, seen by a view (blue) or inferred by the
        grammar (orange). Without either, every log is drawn as seen.
    unknown : (I, J, K) bool, optional
        Grid positions no view saw; those the estimate leaves empty are drawn
        hatched grey.
    crop, min_size
        Crop the rendering to the assembly (:func:`crop_to`); the overlay keeps
        the photograph's frame.
    max_side : int
        A photograph larger than this (its longer side, pixels) is drawn on
        shrunk to it first.
    legend : bool
        Say in a corner what each colour means.

    Returns
    -------
    dict
        ``"overlay"`` (the photograph's size, unless shrunk to ``max_side``) and
        ``"rendering"`` (its legend in a band above), each ``(H, W, 3) uint8``.
    """
    from unseeable.render.zbuffer import rasterise_ids

    image, camera = _fit(image, camera, max_side)
    n = len(structure.logs)
    if correct is not None:
        right = np.asarray(correct, bool).reshape(n)
        colours = np.where(right[:, None], GREEN, RED)
        entries = [LegendEntry(GREEN, f"right: {_plural(int(right.sum()), 'log')}"),
                   LegendEntry(RED, f"wrong: {_plural(int((~right).sum()), 'log')}")]
        entries = [e for e, k in zip(entries, (right.sum(), (~right).sum())) if k]
        title = "against the truth"
        inferred = np.zeros(n, bool)
    else:
        seen_logs = (np.ones(n, bool) if seen is None else np.asarray(seen, bool).reshape(n))
        colours = np.where(seen_logs[:, None], SEEN, INFERRED)
        entries = [LegendEntry(SEEN, f"seen: {_plural(int(seen_logs.sum()), 'log')}"),
                   LegendEntry(INFERRED, f"inferred by the grammar: "
                                         f"{_plural(int((~seen_logs).sum()), 'log')}")]
        entries = [e for e, k in zip(entries, (seen_logs.sum(), (~seen_logs).sum())) if k]
        title = f"estimate: {_plural(n, 'log')}"
        inferred = ~seen_logs
    ghosts = _ghosts(structure, unknown)
    colours = np.asarray(colours, dtype=np.uint8).reshape(n, 3)
    if n == 0 and not ghosts:
        blank = np.full((camera.height, camera.width, 3), _BACKGROUND, np.uint8)
        overlay = np.asarray(image).copy()
        if legend:
            overlay = draw_legend(overlay, [], title="estimate: no logs")
            blank = draw_legend(blank, [], title="estimate: no logs", band=True)
        return {"overlay": overlay, "rendering": blank}
    # Numbered as the estimate's logs, then the unseen positions (n, n+1, ...).
    all_colours = np.concatenate([colours, np.tile(np.uint8(UNKNOWN), (len(ghosts), 1))])
    hatched = np.arange(n + len(ghosts)) >= n
    if ghosts:
        entries.append(LegendEntry(UNKNOWN, f"unseen, built empty: "
                                            f"{_plural(len(ghosts), 'position')}", hatched=True))
    # The estimate alone (the rendering shows it so), then what the camera cannot see
    # (inferred logs, unseen positions) alone: outlined through what hides it.
    real, depth = _render_subset(structure, np.ones(n, bool), pose, camera)
    alone, alone_depth = _render_subset(structure, inferred, pose, camera)
    if ghosts:
        ghost_structure = Structure(structure.extent, ghosts)  # sorted: its own numbering
        ghost_ids, ghost_depth = rasterise_ids(ghost_structure, pose, camera)
        ghost_ids = np.where(ghost_ids >= 0, ghost_ids + n, -1)
        front = (ghost_ids >= 0) & ((alone < 0) | (ghost_depth < alone_depth))
        alone = np.where(front, ghost_ids, alone)
        # Where no estimated log stands in front, the photograph shows the position.
        shown = (ghost_ids >= 0) & ((real < 0) | (ghost_depth < depth))
        ids = np.where(shown, ghost_ids, real)
    else:
        ids = real
    overlay = draw_hidden(overlay_logs(image, ids, all_colours, hatched=hatched), ids, alone,
                          all_colours, dotted=hatched)
    rendering = shaded_rendering(real, depth, camera, colours)
    inferred_alone = np.where(alone < n, alone, -1)
    rendering = draw_hidden(rendering, real, inferred_alone, all_colours)
    if crop:
        rendering = crop_to(rendering, (real >= 0) | (inferred_alone >= 0), min_size=min_size)
    if legend:
        overlay = draw_legend(overlay, entries, title=title, avoid=(ids >= 0) | (alone >= 0))
        rendering = draw_legend(rendering, [e for e in entries if not e.hatched], title=title,
                                band=True)
    return {"overlay": overlay, "rendering": rendering}


def truth_picture(image: np.ndarray, structure: Structure, pose: GridPose, camera: Camera,
                  *, correct: np.ndarray, truth: Structure | None = None,
                  truth_pose: GridPose | None = None, truth_correct: np.ndarray | None = None,
                  max_side: int = PICTURE_MAX_SIDE, legend: bool = True) -> np.ndarray:
    """The photograph with the estimate judged against the truth: each estimated log
    green when right, red when wrong, and the truth's logs it missed in magenta.

    Parameters
    ----------
    image : (H, W, 3) uint8
    structure, pose, camera
        The estimate and where it stands.
    correct : (L,) bool
        Per estimated log, whether the truth has it.
    truth, truth_pose, truth_correct : optional
        The truth, where it stands (default: ``pose``) and per truth log whether
        the estimate has it; the others are drawn as missed.
    max_side : int
        As :func:`estimate_pictures`.
    legend : bool

    Returns
    -------
    (H, W, 3) uint8, the photograph's size (unless shrunk to ``max_side``).
    """
    from unseeable.render.zbuffer import rasterise_ids

    image, camera = _fit(image, camera, max_side)
    n = len(structure.logs)
    right = np.asarray(correct, bool).reshape(n)
    out = np.asarray(image).copy()
    covered = np.zeros(out.shape[:2], bool)
    missed_logs: list[Log] = []
    if truth is not None and truth_correct is not None:
        found = np.asarray(truth_correct, bool).reshape(len(truth.logs))
        missed_logs = [log for log, ok in zip(truth.logs, found) if not ok]
    ids = np.full(out.shape[:2], -1, np.int32)
    colours = np.where(right[:, None], GREEN, RED).astype(np.uint8)
    if n:
        ids, _ = rasterise_ids(structure, pose, camera)
        out = overlay_logs(out, ids, colours, alpha=0.35)
        # A wrong log hidden behind others is outlined through them.
        out = draw_hidden(out, ids, _render_subset(structure, ~right, pose, camera)[0],
                          colours)
        covered |= ids >= 0
    if missed_logs:
        missed = Structure(truth.extent, missed_logs)
        alone, _ = rasterise_ids(missed, truth_pose if truth_pose is not None else pose, camera)
        magenta = np.tile(np.uint8(MAGENTA), (len(missed_logs), 1))
        # Hatched where no estimated log stands in front, outlined everywhere.
        out = overlay_logs(out, np.where(ids < 0, alone, -1), magenta, alpha=0.3,
                           hatched=np.ones(len(missed_logs), bool))
        out = draw_hidden(out, np.full_like(alone, -1), alone, magenta,
                          dotted=np.ones(len(missed_logs), bool))
        covered |= alone >= 0
    if legend:
        counts = (int(right.sum()), int((~right).sum()), len(missed_logs))
        entries = [LegendEntry(GREEN, f"right: {_plural(counts[0], 'log')}"),
                   LegendEntry(RED, f"wrong (not in the truth): {_plural(counts[1], 'log')}"),
                   LegendEntry(MAGENTA, f"missed (in the truth only): "
                                        f"{_plural(counts[2], 'log')}", hatched=True)]
        out = draw_legend(out, [e for e, k in zip(entries, counts) if k],
                          title="against the truth", avoid=covered)
    return out


def crop_to(image: np.ndarray, mask: np.ndarray, *, margin: float = 0.2,
            min_size: int = 480) -> np.ndarray:
    """Crop ``image`` to the bounding box of ``mask`` plus ``margin`` (a share of the
    box), enlarged (nearest neighbour, whole factors) until its longer side reaches
    ``min_size`` pixels; the whole image when the mask is empty."""
    rows = np.flatnonzero(mask.any(axis=1))
    cols = np.flatnonzero(mask.any(axis=0))
    if len(rows) == 0:
        return image
    h, w = mask.shape
    r0, r1, c0, c1 = rows[0], rows[-1] + 1, cols[0], cols[-1] + 1
    pad = int(margin * max(r1 - r0, c1 - c0))
    r0, r1 = max(0, r0 - pad), min(h, r1 + pad)
    c0, c1 = max(0, c0 - pad), min(w, c1 + pad)
    out = image[r0:r1, c0:c1]
    factor = max(1, int(min_size // max(out.shape[:2])))
    if factor > 1:
        out = np.repeat(np.repeat(out, factor, axis=0), factor, axis=1)
    return out
