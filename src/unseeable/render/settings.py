"""Render settings and scene randomisation records (no Mitsuba import here).

:class:`RenderSettings` says how to render (samples, variant, noise).
:class:`SceneParams` is one concrete scene look (lights and their colours, wood or
paint, table, room, exposure, white balance, blur);
:class:`SceneRandomisation` holds the ranges :meth:`SceneParams.sample` draws
from, so the vision stage can train on scenes that vary the way photographs do.

Examples
--------
>>> import numpy as np
>>> look = SceneParams.sample(SceneRandomisation(), np.random.default_rng(0))
>>> look.table_kind in TABLE_KINDS
True
"""

from __future__ import annotations

from dataclasses import Field, dataclass, field, fields, replace

import numpy as np

from unseeable.domain import LogGeometry
from unseeable.errors import InputError
from unseeable.render.chessboard import TableChessboard
from unseeable.render.textures import ALL_TABLE_KINDS, MORE_TABLE_KINDS, TABLE_KINDS

__all__ = ["RenderSettings", "SceneRandomisation", "SceneParams", "VARIANTS", "TABLE_KINDS",
           "MORE_TABLE_KINDS", "ALL_TABLE_KINDS", "STANDARD_TEMPERATURE_K"]

#: Metadata key of a field added after files were written with its record: at its default
#: it is left out of the record's JSON and of the corpus's settings hash, so those files
#: (and corpora built before it) stay as they were.
LATER_FIELD = "unseeable_later_field"


def recorded_fields(record) -> list[Field]:
    """The fields of dataclass ``record`` that its files and hashes hold: all but those
    added later (:data:`LATER_FIELD`) that hold their default."""
    return [f for f in fields(record)
            if not (f.metadata.get(LATER_FIELD) and getattr(record, f.name) == f.default)]


#: Mitsuba variants the renderer may use ("auto": llvm_ad_rgb when usable, else scalar_rgb).
VARIANTS = ("auto", "llvm_ad_rgb", "scalar_rgb")


def _check_range(name: str, value, low: float = -np.inf, high: float = np.inf) -> None:
    ok = (isinstance(value, tuple) and len(value) == 2
          and all(isinstance(v, (int, float)) and np.isfinite(v) for v in value)
          and low <= value[0] <= value[1] <= high)
    if not ok:
        raise InputError(f"must be a pair (low, high) with {low} <= low <= high <= {high}",
                         field=name, value=value)


_LATER = {LATER_FIELD: True}

#: Colour temperature (K) of the standard key light: a look at this temperature keeps the
#: key light's standard, nearly white colour.
STANDARD_TEMPERATURE_K = 6500.0

#: Bounds (low, high) of the looks' later fields: ranges must lie within them, values too.
_BOUNDS = {
    "key_temperature_k": (1700.0, 25000.0),
    "fill_intensity": (0.0, 10.0),
    "fill_azimuth_deg": (-720.0, 720.0),
    "fill_elevation_deg": (5.0, 90.0),
    "fill_temperature_k": (1700.0, 25000.0),
    "white_balance_red": (0.2, 5.0),
    "white_balance_blue": (0.2, 5.0),
    "defocus_px": (0.0, 10.0),
    "end_grain_contrast": (0.0, 10.0),
    "painted_share": (0.0, 1.0),
    "environment_red": (0.0, 5.0),
    "environment_blue": (0.0, 5.0),
}


@dataclass(frozen=True)
class SceneRandomisation:
    """Ranges of scene randomisation; each ``(low, high)`` is drawn uniformly.

    Attributes
    ----------
    key_azimuth_deg, key_elevation_deg : (float, float)
        Direction of the key light from the table's centre (azimuth about +y
        from +x, elevation above the table).
    key_intensity, sky_intensity : (float, float)
        Multipliers of the default key light and environment radiance.
    key_size_mm : (float, float)
        Side of the square key light: larger gives softer shadows.
    grain_contrast : (float, float)
        Contrast of the wood's grain textures against their mean colour (1: as
        drawn; 0: plain, evenly coloured logs). Drawn only when the range is not
        a single value, so the standard ranges give the looks they always gave.
    wood_brightness : (float, float)
        Multiplier of the wood's colour.
    wood_redness : (float, float)
        Shifts the wood from yellow-brown (< 0) to red-brown (> 0).
    wood_roughness : (float, float)
        GGX roughness of the logs' finish.
    log_variation : (float, float)
        Spread of per-log colour variation (relative, 1 sigma).
    table_kinds : tuple of str
        Table tops to choose from (see :data:`TABLE_KINDS`; any of
        :data:`ALL_TABLE_KINDS` may be named).
    table_brightness : (float, float)
    exposure : (float, float)
        Multiplier of the camera's exposure.
    noise : (float, float)
        Sensor noise standard deviation (fraction of full scale).
    camera_position_mm : float
        Standard deviation of the camera's position jitter (per axis).
    camera_rotation_deg : float
        Standard deviation of the camera's rotation jitter (per axis).
    key_temperature_k : (float, float)
        Colour temperature of the key light in kelvin (1700-25000; 6500: the
        standard, nearly white key light; 2000-3000: tungsten, 8000 and up: blue sky).
    fill_intensity : (float, float)
        Irradiance of a second, large and soft (fill) light at the table's centre,
        relative to the standard key light's (0: no fill light).
    fill_azimuth_deg : (float, float)
        Azimuth of the fill light from the key light's (180: opposite it).
    fill_elevation_deg : (float, float)
        Elevation of the fill light above the table.
    fill_temperature_k : (float, float)
        Colour temperature of the fill light in kelvin.
    white_balance_red, white_balance_blue : (float, float)
        The camera's white-balance error: gains of the image's red and blue channels
        (green 1) applied to the linear image before the tone curve (1: none).
    defocus_px : (float, float)
        Standard deviation (pixels) of a Gaussian defocus blur on top of the lens
        blur (:attr:`RenderSettings.blur_px`).
    end_grain_contrast : (float, float)
        Contrast of the end grain's rings relative to the side grain's
        (``grain_contrast``): 0 hides the rings, 1 keeps them as the side's, 2 doubles.
    painted_share : (float, float)
        Probability that a log is painted: a solid colour of random hue with faint grain.
    environment_red, environment_blue : (float, float)
        Tint of the room around the table (the environment's light and the background
        beyond the table): gains of its red and blue radiance (green 1).

    Every field from ``key_temperature_k`` on is drawn only when its range is not a
    single value, after all the others: at their defaults the looks drawn, the records'
    JSON and the corpus's settings hash are what they were before the fields existed.
    """

    key_azimuth_deg: tuple[float, float] = (0.0, 360.0)
    key_elevation_deg: tuple[float, float] = (30.0, 75.0)
    key_intensity: tuple[float, float] = (0.6, 1.5)
    key_size_mm: tuple[float, float] = (150.0, 900.0)
    sky_intensity: tuple[float, float] = (0.5, 1.6)
    wood_brightness: tuple[float, float] = (0.75, 1.25)
    wood_redness: tuple[float, float] = (-0.08, 0.08)
    wood_roughness: tuple[float, float] = (0.2, 0.6)
    log_variation: tuple[float, float] = (0.03, 0.12)
    table_kinds: tuple[str, ...] = TABLE_KINDS
    table_brightness: tuple[float, float] = (0.75, 1.25)
    exposure: tuple[float, float] = (0.75, 1.3)
    noise: tuple[float, float] = (0.004, 0.02)
    camera_position_mm: float = 5.0
    camera_rotation_deg: float = 0.5
    grain_contrast: tuple[float, float] = field(default=(1.0, 1.0),
                                                metadata={LATER_FIELD: True})
    key_temperature_k: tuple[float, float] = field(default=(STANDARD_TEMPERATURE_K,) * 2,
                                                   metadata=_LATER)
    fill_intensity: tuple[float, float] = field(default=(0.0, 0.0), metadata=_LATER)
    fill_azimuth_deg: tuple[float, float] = field(default=(180.0, 180.0), metadata=_LATER)
    fill_elevation_deg: tuple[float, float] = field(default=(30.0, 30.0), metadata=_LATER)
    fill_temperature_k: tuple[float, float] = field(default=(STANDARD_TEMPERATURE_K,) * 2,
                                                    metadata=_LATER)
    white_balance_red: tuple[float, float] = field(default=(1.0, 1.0), metadata=_LATER)
    white_balance_blue: tuple[float, float] = field(default=(1.0, 1.0), metadata=_LATER)
    defocus_px: tuple[float, float] = field(default=(0.0, 0.0), metadata=_LATER)
    end_grain_contrast: tuple[float, float] = field(default=(1.0, 1.0), metadata=_LATER)
    painted_share: tuple[float, float] = field(default=(0.0, 0.0), metadata=_LATER)
    environment_red: tuple[float, float] = field(default=(1.0, 1.0), metadata=_LATER)
    environment_blue: tuple[float, float] = field(default=(1.0, 1.0), metadata=_LATER)

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name in _BOUNDS:
                _check_range(f.name, value, *_BOUNDS[f.name])
            elif f.name == "table_kinds":
                if not value or any(k not in ALL_TABLE_KINDS for k in value):
                    raise InputError(f"must be a non-empty tuple of {ALL_TABLE_KINDS}",
                                     field=f.name, value=value)
            elif f.name.startswith("camera_"):
                if not (isinstance(value, (int, float)) and 0 <= value < 1000):
                    raise InputError("must be a standard deviation >= 0", field=f.name,
                                     value=value)
            elif f.name == "key_elevation_deg":
                _check_range(f.name, value, 5.0, 90.0)
            elif f.name == "wood_redness":
                _check_range(f.name, value, -0.5, 0.5)
            elif f.name == "key_azimuth_deg":
                _check_range(f.name, value)
            else:
                _check_range(f.name, value, 0.0)


@dataclass(frozen=True)
class SceneParams:
    """One concrete look of the scene; the defaults are the standard look.

    Attributes
    ----------
    key_azimuth_deg, key_elevation_deg : float
        Key light direction from the table's centre.
    key_intensity, sky_intensity : float
        Multipliers of the standard radiances.
    key_size_mm : float
    wood_brightness, wood_redness, wood_roughness, log_variation : float
    table_kind : str
        One of :data:`ALL_TABLE_KINDS`.
    table_brightness : float
    exposure : float
    noise : float
        Sensor noise standard deviation (fraction of full scale).
    texture_seed : int
        Seed of the procedural textures and of the per-log variation.
    grain_contrast : float
        Contrast of the wood's grain against its mean colour (1: as drawn, 0: plain).
    key_temperature_k : float
        Colour temperature of the key light (K; :data:`STANDARD_TEMPERATURE_K`: its
        standard colour).
    fill_intensity, fill_azimuth_deg, fill_elevation_deg, fill_temperature_k : float
        The fill light: irradiance relative to the standard key light's (0: none),
        azimuth from the key light's, elevation, colour temperature (K).
    white_balance_red, white_balance_blue : float
        Gains of the image's red and blue channels (1: a correct white balance).
    defocus_px : float
        Gaussian defocus (pixels, 1 sigma) on top of the lens blur.
    end_grain_contrast : float
        Contrast of the end grain relative to ``grain_contrast``.
    painted_share : float
        Probability that a log is painted (a solid colour of random hue, faint grain).
    environment_red, environment_blue : float
        Gains of the room's red and blue radiance.
    """

    key_azimuth_deg: float = 60.0
    key_elevation_deg: float = 45.0
    key_intensity: float = 1.0
    key_size_mm: float = 450.0
    sky_intensity: float = 1.0
    wood_brightness: float = 1.0
    wood_redness: float = 0.0
    wood_roughness: float = 0.35
    log_variation: float = 0.07
    table_kind: str = "oak"
    table_brightness: float = 1.0
    exposure: float = 1.0
    noise: float = 0.008
    texture_seed: int = 0
    grain_contrast: float = field(default=1.0, metadata={LATER_FIELD: True})
    key_temperature_k: float = field(default=STANDARD_TEMPERATURE_K, metadata=_LATER)
    fill_intensity: float = field(default=0.0, metadata=_LATER)
    fill_azimuth_deg: float = field(default=180.0, metadata=_LATER)
    fill_elevation_deg: float = field(default=30.0, metadata=_LATER)
    fill_temperature_k: float = field(default=STANDARD_TEMPERATURE_K, metadata=_LATER)
    white_balance_red: float = field(default=1.0, metadata=_LATER)
    white_balance_blue: float = field(default=1.0, metadata=_LATER)
    defocus_px: float = field(default=0.0, metadata=_LATER)
    end_grain_contrast: float = field(default=1.0, metadata=_LATER)
    painted_share: float = field(default=0.0, metadata=_LATER)
    environment_red: float = field(default=1.0, metadata=_LATER)
    environment_blue: float = field(default=1.0, metadata=_LATER)

    def __post_init__(self) -> None:
        if self.table_kind not in ALL_TABLE_KINDS:
            raise InputError(f"must be one of {ALL_TABLE_KINDS}", field="table_kind",
                             value=self.table_kind)
        for f in fields(self):
            v = getattr(self, f.name)
            if f.name != "table_kind" and not (isinstance(v, (int, float)) and np.isfinite(v)):
                raise InputError("must be a finite number", field=f.name, value=v)
            if f.name in _BOUNDS and not _BOUNDS[f.name][0] <= v <= _BOUNDS[f.name][1]:
                low, high = _BOUNDS[f.name]
                raise InputError(f"must be in [{low:g}, {high:g}]", field=f.name, value=v)

    @classmethod
    def sample(cls, randomisation: SceneRandomisation, rng: np.random.Generator) -> SceneParams:
        """Draw a scene look from ``randomisation`` with ``rng``."""
        r = randomisation

        def u(pair: tuple[float, float]) -> float:
            return float(rng.uniform(pair[0], pair[1]))

        return cls(
            key_azimuth_deg=u(r.key_azimuth_deg),
            key_elevation_deg=u(r.key_elevation_deg),
            key_intensity=u(r.key_intensity),
            key_size_mm=u(r.key_size_mm),
            sky_intensity=u(r.sky_intensity),
            wood_brightness=u(r.wood_brightness),
            wood_redness=u(r.wood_redness),
            wood_roughness=u(r.wood_roughness),
            log_variation=u(r.log_variation),
            table_kind=str(r.table_kinds[int(rng.integers(len(r.table_kinds)))]),
            table_brightness=u(r.table_brightness),
            exposure=u(r.exposure),
            noise=u(r.noise),
            texture_seed=int(rng.integers(2**31 - 1)),
            # Drawn last, and only from a real range: the standard looks' draws stay as
            # they were before this field existed.
            grain_contrast=(u(r.grain_contrast) if r.grain_contrast[0] != r.grain_contrast[1]
                            else float(r.grain_contrast[0])),
            # The later fields likewise, after every field above, in :data:`_BOUNDS`'s order.
            **{name: (u(getattr(r, name)) if getattr(r, name)[0] != getattr(r, name)[1]
                      else float(getattr(r, name)[0])) for name in _BOUNDS},
        )

    def to_json(self) -> dict:
        return {f.name: getattr(self, f.name) for f in recorded_fields(self)}


@dataclass(frozen=True)
class RenderSettings:
    """How to render.

    Attributes
    ----------
    spp : int
        Samples per pixel of the path tracer.
    max_depth : int
        Longest light path (3: direct light and one bounce; deeper paths change the
        image's mean by < 0.1 %).
    variant : {"auto", "llvm_ad_rgb", "scalar_rgb"}
        Mitsuba variant; ``"auto"`` uses ``llvm_ad_rgb`` when an LLVM >= 19
        shared library is installed (Debian package ``libllvm19``), else
        ``scalar_rgb``. The environment variable ``UNSEEABLE_MITSUBA_VARIANT``
        overrides it.
    randomisation : SceneRandomisation or None
        When given, every render draws its scene look (and :class:`Workspace`
        its camera jitter) from these ranges with the render's seed; else the
        standard look is used.
    look : SceneParams
        The scene look when ``randomisation`` is None.
    geometry : LogGeometry
    segments : int
        Segments around each log's circumference.
    table_size_mm : float
        Side of the square table top (large enough to fill every view).
    blur_px : float
        Standard deviation of the lens blur in pixels (0: none).
    chessboard : TableChessboard or None
        A printed chessboard lying on the table (for locating cameras); None: none.

    Examples
    --------
    >>> RenderSettings(spp=4).spp
    4
    """

    spp: int = 16
    max_depth: int = 3
    variant: str = "auto"
    randomisation: SceneRandomisation | None = None
    look: SceneParams = field(default_factory=SceneParams)
    geometry: LogGeometry = field(default_factory=LogGeometry)
    segments: int = 48
    table_size_mm: float = 6000.0
    blur_px: float = 0.45
    chessboard: TableChessboard | None = field(default=None, metadata={LATER_FIELD: True})

    def __post_init__(self) -> None:
        for name, low, high in (("spp", 1, 1 << 16), ("max_depth", 1, 64), ("segments", 8, 512)):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not low <= v <= high:
                raise InputError(f"must be a whole number in {low}..{high}", field=name, value=v)
        if self.variant not in VARIANTS:
            raise InputError(f"must be one of {VARIANTS}", field="variant", value=self.variant)
        if not (isinstance(self.table_size_mm, (int, float)) and self.table_size_mm > 0):
            raise InputError("must be a positive length", field="table_size_mm",
                             value=self.table_size_mm)
        if not (isinstance(self.blur_px, (int, float)) and 0 <= self.blur_px <= 10):
            raise InputError("must be in [0, 10] pixels", field="blur_px", value=self.blur_px)
        if self.chessboard is not None and not isinstance(self.chessboard, TableChessboard):
            raise InputError("must be a TableChessboard or None", field="chessboard",
                             value=type(self.chessboard).__name__)

    def with_(self, **changes) -> RenderSettings:
        """A copy with some fields changed."""
        return replace(self, **changes)

    def scene_for(self, seed: int) -> SceneParams:
        """The scene look of a render with ``seed``: drawn when randomising, else :attr:`look`."""
        if self.randomisation is None:
            return self.look
        rng = np.random.default_rng([int(seed), 7])
        return SceneParams.sample(self.randomisation, rng)
