"""Procedural textures made with numpy: wood side grain, end grain, table tops, sky.

Every texture tiles (noise is band-limited white noise filtered in the
Fourier domain, which is periodic) and is returned as linear reflectance,
``(H, W, 3) float32`` in [0, 1], row 0 at the top. Everything is a pure
function of its arguments and a seed, so renders are reproducible.

Examples
--------
>>> side = side_grain((0.45, 0.27, 0.13), seed=1, size=(64, 128))
>>> side.shape, side.dtype, bool(0 < side.min() and side.max() < 1)
((64, 128, 3), dtype('float32'), True)
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

__all__ = [
    "periodic_noise",
    "side_grain",
    "end_grain",
    "table_top",
    "TABLE_KINDS",
    "MORE_TABLE_KINDS",
    "ALL_TABLE_KINDS",
    "sky",
    "srgb_to_linear",
]


def srgb_to_linear(c) -> np.ndarray:
    """sRGB-encoded values in [0, 1] to linear reflectance."""
    c = np.asarray(c, dtype=np.float64)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def periodic_noise(shape: tuple[int, int], sigma: tuple[float, float], *,
                   rng: np.random.Generator) -> np.ndarray:
    """Tileable smooth noise: white noise low-passed by a Gaussian of ``sigma`` pixels.

    Parameters
    ----------
    shape : (H, W)
    sigma : (sigma_rows, sigma_cols)
        Correlation lengths in pixels; unequal values stretch the noise
        (e.g. fibres along the columns with ``sigma_cols >> sigma_rows``).
    rng : numpy.random.Generator

    Returns
    -------
    (H, W) float64
        Zero mean, unit standard deviation.
    """
    h, w = shape
    white = rng.standard_normal(shape)
    fy = np.fft.fftfreq(h)[:, None]
    fx = np.fft.rfftfreq(w)[None, :]
    # Fourier transform of a Gaussian of std sigma px is exp(-2 pi^2 sigma^2 f^2).
    gain = np.exp(-2 * np.pi**2 * ((sigma[0] * fy) ** 2 + (sigma[1] * fx) ** 2))
    out = np.fft.irfft2(np.fft.rfft2(white) * gain, s=shape)
    out -= out.mean()
    std = out.std()
    return out / std if std > 0 else out


def _wood_palette(base_srgb, tint) -> tuple[np.ndarray, np.ndarray]:
    """Earlywood (light) and latewood (dark) linear colours around an sRGB base colour."""
    base = srgb_to_linear(base_srgb) * np.asarray(tint, dtype=np.float64)
    early = base * 1.12
    late = base * np.array([0.52, 0.45, 0.40])  # latewood is darker and redder
    return early, late


def side_grain(base_srgb=(0.62, 0.42, 0.24), *, seed: int, size: tuple[int, int] = (128, 512),
               tint=(1.0, 1.0, 1.0), rings: float = 9.0) -> np.ndarray:
    """Side grain of a log: streaks running along the axis.

    Rows run around the log (texture v), columns along it (texture u): the
    streaks are the annual rings cut lengthwise, wavy and of uneven width,
    with fine fibre noise stretched along the axis.

    Parameters
    ----------
    base_srgb : (3,) float
        Mean sRGB colour of the wood.
    seed : int
    size : (H, W)
        ``H`` around the log, ``W`` along it (one repeat of the texture).
    tint : (3,) float
        Multiplier of the linear colour (per-log colour variation).
    rings : float
        Rings across one turn of the log.

    Returns
    -------
    (H, W, 3) float32
    """
    return _side_grain(tuple(map(float, base_srgb)), int(seed), tuple(size),
                       tuple(map(float, tint)), float(rings)).copy()


@lru_cache(maxsize=64)
def _side_grain(base_srgb, seed, size, tint, rings) -> np.ndarray:
    rng = np.random.default_rng([seed, 101])
    h, w = size
    v = np.arange(h)[:, None] / h
    # Whole numbers of rings per turn keep the texture tileable; the slow warp makes their
    # spacing uneven and lets lines drift and converge along the log, as in turned wood.
    n_rings = max(1, round(rings))
    slow = periodic_noise(size, (h / 3, w / 2), rng=rng)
    mid = periodic_noise(size, (h / 12, w / 6), rng=rng)
    phase = n_rings * v + 0.9 * slow + 0.25 * mid
    frac = phase - np.floor(phase)
    width = np.clip(0.16 + 0.06 * periodic_noise(size, (h / 8, w / 2), rng=rng), 0.06, None)
    # Latewood: a dark band with a sharp edge on one side and a soft one on the other.
    d = frac - 0.7
    late = np.exp(-(np.where(d > 0, d / (0.4 * width), d / width)) ** 2)
    fibres = periodic_noise(size, (0.7, 30.0), rng=rng)  # thin streaks along the axis
    blotch = periodic_noise(size, (h / 4, w / 8), rng=rng)  # slow colour variation
    early_c, late_c = _wood_palette(base_srgb, tint)
    late_c = 0.35 * early_c + 0.65 * late_c
    mix = np.clip(0.75 * late + 0.10 * fibres, 0.0, 1.0)[..., None]
    col = early_c * (1 - mix) + late_c * mix
    col *= (1.0 + 0.07 * blotch + 0.05 * fibres)[..., None]
    return np.clip(col, 0.005, 0.95).astype(np.float32)


def end_grain(base_srgb=(0.62, 0.42, 0.24), *, seed: int, size: int = 128,
              tint=(1.0, 1.0, 1.0), rings: float = 7.0) -> np.ndarray:
    """End grain of a log: concentric annual rings around an off-centre pith.

    The disc fills the unit square (log radius = half the side); outside it
    the texture just continues, as it is never mapped there.

    Returns
    -------
    (size, size, 3) float32
    """
    return _end_grain(tuple(map(float, base_srgb)), int(seed), int(size),
                      tuple(map(float, tint)), float(rings)).copy()


@lru_cache(maxsize=64)
def _end_grain(base_srgb, seed, size, tint, rings) -> np.ndarray:
    rng = np.random.default_rng([seed, 202])
    y, x = (np.mgrid[0:size, 0:size] + 0.5) / size
    pith = 0.5 + rng.uniform(-0.12, 0.12, size=2)
    # Logs are cut from bigger trees: the pith may lie outside the disc (then rings are arcs).
    if rng.random() < 0.5:
        direction = rng.normal(size=2)
        pith = 0.5 + direction / np.linalg.norm(direction) * rng.uniform(0.6, 1.6)
    r = np.hypot(x - pith[0], y - pith[1])
    warp = periodic_noise((size, size), (size / 8, size / 8), rng=rng)
    phase = rings * (r + 0.006 * warp)
    frac = phase - np.floor(phase)
    late = np.exp(-((frac - 0.8) / 0.12) ** 2)
    pores = periodic_noise((size, size), (0.7, 0.7), rng=rng)
    early_c, late_c = _wood_palette(base_srgb, tint)
    # End grain soaks up light: darker and a touch less saturated than the side.
    early_c = early_c * 0.78
    late_c = late_c * 0.85
    mix = np.clip(0.75 * late + 0.06 * pores, 0.0, 1.0)[..., None]
    col = early_c * (1 - mix) + late_c * mix
    col *= (1.0 + 0.05 * pores)[..., None]
    return np.clip(col, 0.005, 0.95).astype(np.float32)


#: Table tops the standard scene randomisation draws from.
TABLE_KINDS = ("oak", "walnut", "grey", "white", "green")
#: Further table tops a look may name, which no standard randomisation draws (so looks
#: drawn before they existed stay as they were): ``"planks"``, weathered boards a
#: hand's width wide with open dark seams between them, whose long straight edges
#: run across the whole view; ``"tiles"``, square glazed tiles a hand and a half wide
#: with dark grout lines along both of the table's axes; ``"cloth"``, a coarsely woven
#: tablecloth lying in soft folds; ``"patterned"``, a printed oilcloth of repeating
#: motifs (rosettes or diamonds); ``"stone"``, pale polished marble with grey veins.
#: Cloth and print are pale and neutral here: the renderer dyes them.
MORE_TABLE_KINDS = ("planks", "tiles", "cloth", "patterned", "stone")
#: Every table top :func:`table_top` can make.
ALL_TABLE_KINDS = TABLE_KINDS + MORE_TABLE_KINDS

#: The ``"planks"`` top (of one 1024-texel repeat, 900 mm on the renderer's table):
#: planks per repeat (about 110 mm boards), the seams' width as a share of the side
#: (about 4 mm: an open joint, against the oak top's glued 2-texel line) and the
#: reflectance left in a seam's shadow.
_PLANKS = 8
_PLANK_SEAM = 1 / 200
_PLANK_SEAM_SHADE = 0.12
#: The ``"tiles"`` top: tiles per repeat along each side (150 mm tiles), the grout
#: lines' width as a share of the side (about 3 mm) and their reflectance relative to
#: the tiles'.
_TILES = 6
_TILE_GROUT = 1 / 300
_TILE_GROUT_SHADE = 0.25
#: The ``"cloth"`` top: texels per thread (about 3.5 mm threads: a coarse canvas) and the
#: depth of the folds' shading.
_CLOTH_THREAD = 4
_CLOTH_FOLDS = 0.22
#: The ``"patterned"`` top: motifs per repeat along each side (75 mm motifs).
_MOTIFS = 12


def table_top(kind: str = "oak", *, seed: int, size: int = 1024, tint=(1.0, 1.0, 1.0)
              ) -> np.ndarray:
    """A tileable table-top texture.

    Parameters
    ----------
    kind : {"oak", "walnut", "grey", "white", "green", "planks", "tiles", "cloth", \
"patterned", "stone"}
        Light or dark wood planks, grey laminate, white melamine, green felt
        (:data:`TABLE_KINDS`); weathered boards with open seams, square tiles
        with dark grout, a woven cloth in folds, a printed pattern (seed 0:
        rosettes, 1: diamonds), veined marble (:data:`MORE_TABLE_KINDS`).
    seed : int
    size : int
        Pixels per side.
    tint : (3,) float
        Multiplier of the linear colour.

    Returns
    -------
    (size, size, 3) float32
    """
    return _table_top(str(kind), int(seed), int(size), tuple(map(float, tint))).copy()


@lru_cache(maxsize=10)
def _table_top(kind, seed, size, tint) -> np.ndarray:
    if kind not in ALL_TABLE_KINDS:
        raise ValueError(f"unknown table kind {kind!r}; expected one of {ALL_TABLE_KINDS}")
    rng = np.random.default_rng([seed, 303])
    shape = (size, size)
    tint = np.asarray(tint)
    if kind in ("oak", "walnut", "planks"):
        base = {"oak": (0.70, 0.55, 0.38), "walnut": (0.36, 0.24, 0.16),
                "planks": (0.62, 0.56, 0.47)}[kind]
        boards = kind == "planks"
        # Planks across one repeat, running along the columns.
        planks = _PLANKS if boards else 6
        plank_w = size // planks
        row = np.arange(size)
        plank = np.minimum(row // plank_w, planks - 1)
        early, late = _wood_palette(base, tint)
        late = early * 0.55 + late * 0.45  # finished table tops show soft grain
        phase = np.zeros(shape)
        shade = np.ones(size)
        for p in range(planks):  # a handful of planks, not pixels
            prng = np.random.default_rng([seed, 303, p])
            rows = plank == p
            # Flat-sawn grain: rings cut at a shallow angle, strongly warped along the plank.
            local = (row[rows, None] - p * plank_w) / plank_w
            warp = periodic_noise((rows.sum(), size), (plank_w / 3, size / 6), rng=prng)
            arch = 0.6 * np.cos(2 * np.pi * (np.arange(size)[None, :] / size
                                             * prng.integers(1, 3) + prng.random()))
            phase[rows] = (local - 0.5) ** 2 * prng.uniform(6, 14) + arch * (local - 0.5) \
                + 0.5 * warp + prng.random() * 10
            # Weathered boards differ more from one another than a finished top's.
            shade[rows] = prng.uniform(0.75, 1.2) if boards else prng.uniform(0.88, 1.1)
        frac = phase * 6.0 - np.floor(phase * 6.0)
        band = np.exp(-((frac - 0.5) / 0.2) ** 2)
        fib = periodic_noise(shape, (0.6, 40.0), rng=rng)
        pores = periodic_noise(shape, (0.5, 3.0), rng=rng)
        mix = np.clip(0.55 * band + 0.12 * fib + 0.06 * pores, 0, 1)[..., None]
        col = (early * (1 - mix) + late * mix) * shade[:, None, None]
        if boards:
            seam = (row % plank_w) < max(1, round(size * _PLANK_SEAM))
            col[seam] *= _PLANK_SEAM_SHADE
        else:
            seam = (row % plank_w) < max(1, size // 500)
            col[seam] *= 0.35
    elif kind == "tiles":
        lin = srgb_to_linear((0.78, 0.74, 0.66)) * tint
        tile_w = size // _TILES
        idx = np.minimum(np.arange(size) // tile_w, _TILES - 1)
        # Each tile its own shade and a faint cloud of glaze; grout along both axes.
        shades = rng.uniform(0.85, 1.12, size=(_TILES, _TILES))
        cloud = periodic_noise(shape, (size / 40, size / 40), rng=rng)
        col = lin * (shades[idx[:, None], idx[None, :]] * (1 + 0.04 * cloud))[..., None]
        grout_w = max(1, round(size * _TILE_GROUT))
        line = (np.arange(size) % tile_w) < grout_w
        col[line] *= _TILE_GROUT_SHADE
        col[:, line] *= _TILE_GROUT_SHADE
        col[np.ix_(line, line)] /= _TILE_GROUT_SHADE  # the crossings are grout once
    elif kind == "cloth":
        col = _cloth(rng, size) * (srgb_to_linear((0.80, 0.78, 0.74)) * tint)
    elif kind == "patterned":
        col = _print(seed, size, tint)
    elif kind == "stone":
        col = _stone(rng, size) * (srgb_to_linear((0.86, 0.85, 0.83)) * tint)
    else:
        base = {"grey": (0.55, 0.56, 0.57), "white": (0.86, 0.86, 0.84),
                "green": (0.16, 0.36, 0.20)}[kind]
        lin = srgb_to_linear(base) * tint
        speck = periodic_noise(shape, (0.8, 0.8), rng=rng)
        cloud = periodic_noise(shape, (size / 10, size / 10), rng=rng)
        amount = 0.10 if kind == "green" else 0.05
        col = lin * (1 + amount * speck + 0.04 * cloud)[..., None]
    return np.clip(col, 0.005, 0.95).astype(np.float32)


def _cloth(rng: np.random.Generator, size: int) -> np.ndarray:
    """Shading ``(size, size, 1)`` of a plain-woven cloth in soft folds (mean about 1)."""
    t = _CLOTH_THREAD
    idx = np.arange(size)
    # Plain weave: the warp (along the columns) and the weft cross over and under in turn;
    # each thread's colour varies a little, and each is brighter at its crown.
    over = ((idx[:, None] // t + idx[None, :] // t) % 2).astype(np.float64)
    crown = np.sin(np.pi * ((idx % t) + 0.5) / t)
    warp = 1 + 0.06 * rng.standard_normal(size // t + 1)[idx // t]
    weft = 1 + 0.06 * rng.standard_normal(size // t + 1)[idx // t]
    weave = over * (crown[:, None] * warp[None, :]) + (1 - over) * (crown[None, :] * weft[:, None])
    weave = 0.8 + 0.2 * weave
    # Folds: a smooth height field, long along one way, lit from the side (its slope).
    height = periodic_noise((size, size), (size / 14, size / 5), rng=rng)
    slope = np.gradient(height, axis=0) * size / 14
    fuzz = periodic_noise((size, size), (1.5, 1.5), rng=rng)
    shade = weave * (1 + _CLOTH_FOLDS * np.tanh(slope)) * (1 + 0.03 * fuzz)
    return shade[..., None]


def _print(seed: int, size: int, tint) -> np.ndarray:
    """A printed oilcloth ``(size, size, 3)``: motifs of a pale ink on a cream ground."""
    n = _MOTIFS
    y, x = (np.mgrid[0:size, 0:size] + 0.5) * (n / size)
    fy, fx = y - np.floor(y) - 0.5, x - np.floor(x) - 0.5  # position within the motif
    if seed % 2 == 0:  # rosettes of five petals, with dots between them
        r, theta = np.hypot(fx, fy), np.arctan2(fy, fx)
        ink = r < 0.28 * (0.75 + 0.25 * np.cos(5 * theta))
        eye = r < 0.06
        dots = np.hypot(np.abs(fx) - 0.5, np.abs(fy) - 0.5) < 0.06
        second = eye | dots
        ink &= ~eye
    else:  # diamonds in a lattice, with a thin line through them
        d = np.abs(fx) + np.abs(fy)
        ink = d < 0.32
        second = (d > 0.40) & (d < 0.44)
    ground = srgb_to_linear((0.90, 0.87, 0.80))
    first = srgb_to_linear((0.55, 0.50, 0.45))
    other = srgb_to_linear((0.30, 0.28, 0.26))
    col = np.where(ink[..., None], first, np.where(second[..., None], other, ground))
    return col * np.asarray(tint)


def _stone(rng: np.random.Generator, size: int) -> np.ndarray:
    """Shading ``(size, size, 1)`` of veined marble (1: the stone's ground)."""
    y, x = (np.mgrid[0:size, 0:size] + 0.5) / size
    turb = (periodic_noise((size, size), (size / 5, size / 5), rng=rng)
            + 0.35 * periodic_noise((size, size), (size / 40, size / 40), rng=rng)
            + 0.08 * periodic_noise((size, size), (size / 200, size / 200), rng=rng))
    # Whole numbers of waves per repeat keep the veins tileable; veins fade in and out.
    wave = np.sin(2 * np.pi * (2 * x + 3 * y) + 1.1 * turb)
    fade = np.clip(0.6 + 0.6 * periodic_noise((size, size), (size / 10, size / 10), rng=rng),
                   0, 1)
    veins = fade * (np.exp(-(wave / 0.05) ** 2) + 0.4 * np.exp(-(wave / 0.3) ** 2))
    cloud = periodic_noise((size, size), (size / 30, size / 30), rng=rng)
    shade = (1 - 0.45 * np.clip(veins, 0, 1)) * (1 + 0.03 * cloud)
    return shade[..., None]


def sky(*, size: tuple[int, int] = (64, 128), intensity: float = 1.0,
        warmth: float = 0.0) -> np.ndarray:
    """A latitude-longitude room/sky environment, ``(H, W, 3) float32`` radiance.

    Row 0 is straight up (+y). Bright diffuse ceiling light above, walls of a
    neutral room at the horizon, a darker floor below.
    """
    h, w = size
    theta = (np.arange(h) + 0.5) / h * np.pi  # polar angle from +y
    up = np.cos(theta)[:, None]
    top = np.array([1.0, 1.0, 1.02 - 0.1 * warmth])
    horizon = np.array([0.62, 0.58, 0.54 - 0.05 * warmth])
    floor = np.array([0.12, 0.10, 0.09])
    t = np.clip(up, 0, 1)[..., None]
    b = np.clip(-up, 0, 1)[..., None]
    col = horizon * (1 - t) + top * t
    col = np.where(up[..., None] >= 0, col, horizon * (1 - b) ** 4 + floor * (1 - (1 - b) ** 4))
    col = np.broadcast_to(col, (h, w, 3)) * intensity
    return np.ascontiguousarray(col, dtype=np.float32)
