"""Physically based rendering of an assembly on the table with Mitsuba 3.

:func:`render_view` is the one entry point: it builds the scene (textured
logs, some of them painted, table, a tinted room, a key light of a colour
temperature and a soft fill light), path-traces the photograph, develops it
(exposure, blur, noise, white balance, tone curve) and casts one ray through
every pixel centre for the ground truth (which log each pixel shows, and its
depth).

Mitsuba is imported lazily, inside these functions, so that importing
:mod:`unseeable.render` (e.g. for :mod:`unseeable.render.view`) stays cheap.

Variant. ``llvm_ad_rgb`` (vectorised, multi-threaded) needs an LLVM shared
library that Dr.Jit can drive: LLVM 14 and 15 (Debian bookworm's defaults)
abort the process while compiling Mitsuba's kernels, LLVM 19 (Debian package
``libllvm19``) works. :func:`select_variant` looks for ``libLLVM.so.19*`` or
newer and points ``DRJIT_LIBLLVM_PATH`` at it, else falls back to
``scalar_rgb`` (same images, several times slower).
"""

from __future__ import annotations

import colorsys
import glob
import logging
import os
import re
import time
from dataclasses import dataclass

import numpy as np

from unseeable.camera import Camera
from unseeable.domain import GridPose, Structure
from unseeable.errors import InputError, RenderError
from unseeable.render.chessboard import TableChessboard
from unseeable.render.settings import STANDARD_TEMPERATURE_K, RenderSettings, SceneParams

__all__ = [
    "render_view",
    "render_ground_truth",
    "pinhole_proxy",
    "truth_from_proxy",
    "check_scene_inputs",
    "select_variant",
    "find_libllvm",
    "MIN_LLVM_MAJOR",
    "Rendered",
    "render",
]

logger = logging.getLogger(__name__)

#: Oldest LLVM major version known to run Mitsuba's llvm variants here.
MIN_LLVM_MAJOR = 19

#: How many wood textures a scene holds; logs pick one and shift it.
WOOD_VARIANTS = 6

#: Standard radiances (the look's intensities multiply them).
_KEY_IRRADIANCE = 5.0  # irradiance of the key light at the table's centre
_KEY_DISTANCE_MM = 2500.0
_SKY_RADIANCE = 1.0
_BASE_EXPOSURE = 0.72
#: Table texture: one repeat covers this many millimetres.
_TABLE_PERIOD_MM = 900.0
#: Mean sRGB colour of the logs' wood.
_WOOD_SRGB = (0.60, 0.38, 0.21)
#: Colour of the key light (linear RGB multiplier) at :data:`STANDARD_TEMPERATURE_K`.
_KEY_COLOUR = (1.0, 0.97, 0.92)
#: Side of the square fill light (large: soft).
_FILL_SIZE_MM = 1500.0
#: Painted logs: how much of the wood's grain shows through the paint (side, ends).
_PAINT_GRAIN = (0.12, 0.2)

_variant_in_use: str | None = None
_auto_variant: str | None = None
#: Multi-jittered sampling: at 16 spp about as clean as 50 independent samples here.
_SAMPLER = "multijitter"


def find_libllvm(min_major: int = MIN_LLVM_MAJOR) -> str | None:
    """Path of the newest installed ``libLLVM`` shared library of at least ``min_major``."""
    best: tuple[int, str] | None = None
    for folder in ("/usr/lib/x86_64-linux-gnu", "/usr/lib/aarch64-linux-gnu", "/usr/lib64",
                   "/usr/lib", "/usr/local/lib"):
        for path in glob.glob(os.path.join(folder, "libLLVM*.so*")):
            m = re.search(r"libLLVM[-.]?(?:so\.)?(\d+)", os.path.basename(path))
            if m and int(m.group(1)) >= min_major and (best is None or int(m.group(1)) > best[0]):
                best = (int(m.group(1)), path)
    return None if best is None else best[1]


def select_variant(preferred: str = "auto") -> str:
    """Choose and activate the Mitsuba variant; return its name.

    ``UNSEEABLE_MITSUBA_VARIANT`` in the environment overrides ``preferred``.
    ``"auto"`` picks ``llvm_ad_rgb`` when :func:`find_libllvm` finds a usable
    LLVM (or ``DRJIT_LIBLLVM_PATH`` is set), else ``scalar_rgb``.
    """
    global _variant_in_use, _auto_variant
    wanted = os.environ.get("UNSEEABLE_MITSUBA_VARIANT", preferred) or "auto"
    if wanted == "auto":
        if _auto_variant is None:
            if os.environ.get("DRJIT_LIBLLVM_PATH") or find_libllvm() is not None:
                _auto_variant = "llvm_ad_rgb"
            else:
                logger.warning("no LLVM >= %d found (apt package libllvm19); rendering with "
                               "the slower scalar_rgb variant", MIN_LLVM_MAJOR)
                _auto_variant = "scalar_rgb"
        wanted = _auto_variant
    if wanted not in ("llvm_ad_rgb", "scalar_rgb"):
        raise InputError("must be llvm_ad_rgb or scalar_rgb", field="UNSEEABLE_MITSUBA_VARIANT",
                         value=wanted)
    if wanted == "llvm_ad_rgb" and not os.environ.get("DRJIT_LIBLLVM_PATH"):
        lib = find_libllvm()
        if lib is None:
            # An older LLVM would abort the whole process while compiling kernels.
            raise RenderError(f"the llvm_ad_rgb variant needs LLVM >= {MIN_LLVM_MAJOR} "
                              "(Debian: apt-get install libllvm19), or DRJIT_LIBLLVM_PATH")
        os.environ["DRJIT_LIBLLVM_PATH"] = lib
    try:
        import mitsuba as mi
    except ImportError as err:  # pragma: no cover - mitsuba is a dependency
        raise RenderError(f"mitsuba is not installed: {err}") from None
    if _variant_in_use != wanted:
        try:
            mi.set_variant(wanted)
            # Mitsuba logs warnings (e.g. a rounded sample count) straight to the terminal.
            mi.set_log_level(mi.LogLevel.Error)
        except Exception as err:  # mitsuba raises plain exceptions for unusable variants
            raise RenderError(f"cannot use Mitsuba variant {wanted}: {err}") from None
        _variant_in_use = wanted
        logger.info("Mitsuba variant %s", wanted)
    return wanted


# --------------------------------------------------------------------------
# camera


def _is_plain_pinhole(camera: Camera) -> bool:
    K = camera.K
    return (not camera.has_distortion and abs(K[0, 1]) < 1e-9
            and abs(K[0, 0] - K[1, 1]) <= 1e-6 * K[0, 0])


def pinhole_proxy(camera: Camera) -> tuple[Camera, tuple[np.ndarray, np.ndarray] | None]:
    """A square-pixel undistorted camera Mitsuba can render, and the remap to ``camera``.

    Cameras with distortion, skew or fx != fy are rendered through a plain
    pinhole at the same place that sees every ray of ``camera``; the image is
    then resampled with the returned maps (``cv2.remap`` maps, ``(H, W)``
    float32 each).
    """
    if _is_plain_pinhole(camera):
        return camera, None
    w, h = camera.width, camera.height
    f = float(max(camera.K[0, 0], camera.K[1, 1]))
    vv, uu = np.mgrid[0:h, 0:w].astype(np.float64)
    uv = np.stack([uu, vv], axis=-1).reshape(-1, 2)
    rays = camera.pixel_rays(uv)
    d_cam = rays @ camera.R.T
    x = d_cam[:, 0] / d_cam[:, 2]
    y = d_cam[:, 1] / d_cam[:, 2]
    lo_x, hi_x = np.percentile(x, [0, 100])
    lo_y, hi_y = np.percentile(y, [0, 100])
    pw = int(np.ceil(f * (hi_x - lo_x))) + 3
    ph = int(np.ceil(f * (hi_y - lo_y))) + 3
    if pw * ph > 16 * w * h:
        raise RenderError(f"camera distortion is too strong to render ({camera!r})")
    K = np.array([[f, 0.0, 1.0 - f * lo_x], [0.0, f, 1.0 - f * lo_y], [0.0, 0.0, 1.0]])
    proxy = Camera(pw, ph, K, camera.R, camera.t)
    map_x = (f * x + K[0, 2]).reshape(h, w).astype(np.float32)
    map_y = (f * y + K[1, 2]).reshape(h, w).astype(np.float32)
    return proxy, (map_x, map_y)


def _sensor_dict(mi, camera: Camera, *, spp: int, ground_truth: bool) -> dict:
    """Mitsuba perspective sensor equal to a plain pinhole ``camera``.

    Mitsuba's camera looks along +z with +y up and +x to the left: OpenCV's
    axes with x and y negated. OpenCV puts pixel centres at whole coordinates,
    Mitsuba at half-integers: hence the half-pixel shift of the principal point.
    """
    w, h = camera.width, camera.height
    K = camera.K
    to_world = np.eye(4)
    to_world[:3, :3] = camera.R.T @ np.diag([-1.0, -1.0, 1.0])
    to_world[:3, 3] = camera.centre
    fov_x = float(np.rad2deg(2 * np.arctan(w / (2 * K[0, 0]))))
    depth = np.linalg.norm(camera.centre) + 1.0
    sampler = ({"type": "stratified", "sample_count": 1, "jitter": False} if ground_truth
               else {"type": _SAMPLER, "sample_count": spp})
    return {
        "type": "perspective",
        "fov": fov_x,
        "fov_axis": "x",
        "principal_point_offset_x": -float(K[0, 2] + 0.5 - w / 2) / w,
        "principal_point_offset_y": -float(K[1, 2] + 0.5 - h / 2) / h,
        "near_clip": 1.0,
        "far_clip": float(max(1e5, 100 * depth)),
        "to_world": mi.ScalarTransform4f(to_world),
        "film": {
            "type": "hdrfilm", "width": w, "height": h, "pixel_format": "rgb",
            "component_format": "float32",
            # A box filter keeps every sample in its own pixel: splatting into neighbours
            # adds up in thread order, which would make renders irreproducible.
            "rfilter": {"type": "box"},
        },
        "sampler": sampler,
    }


# --------------------------------------------------------------------------
# scene


@dataclass(frozen=True, eq=False)
class _BuiltScene:
    scene: object
    shape_log: np.ndarray  # (n_shapes + 1,) int32: shape_index -> log id (-1: not a log)


def _fill_mesh(mi, name: str, vertices: np.ndarray, faces: np.ndarray, normals: np.ndarray,
               uv: np.ndarray, bsdf) -> object:
    props = mi.Properties()
    props["bsdf"] = bsdf
    mesh = mi.Mesh(name, len(vertices), len(faces), props=props, has_vertex_normals=True,
                   has_vertex_texcoords=True)
    params = mi.traverse(mesh)
    for key, arr in (("vertex_positions", vertices), ("vertex_normals", normals),
                     ("vertex_texcoords", uv), ("faces", faces)):
        params[key] = type(params[key])(np.ascontiguousarray(arr).ravel())
    params.update()
    return mesh


def _bitmap_texture(mi, image: np.ndarray, *, scale: float = 1.0,
                    offset: tuple[float, float] = (0.0, 0.0)) -> dict:
    tex = {"type": "bitmap", "bitmap": mi.Bitmap(np.ascontiguousarray(image, dtype=np.float32)),
           "filter_type": "bilinear", "wrap_mode": "repeat", "raw": True}
    if scale != 1.0 or offset != (0.0, 0.0):
        tex["to_uv"] = mi.ScalarTransform4f().translate([offset[0], offset[1], 0.0]).scale(
            [scale, scale, 1.0])
    return tex


#: Luminance weights of linear sRGB.
_LUMA = np.array([0.2126, 0.7152, 0.0722])


#: A camera's red, green and blue sensitivities: Gaussians (centre, sigma in nm), broad
#: and overlapping as a sensor's are, so that a warm light still has some blue.
_CHANNELS_NM = ((600.0, 40.0), (540.0, 40.0), (460.0, 30.0))


def _planck_rgb(kelvin: float) -> np.ndarray:
    """Camera RGB ``(3,)`` of a black body at ``kelvin``: Planck's law integrated over
    the channels' sensitivities (:data:`_CHANNELS_NM`), in arbitrary units."""
    lam = np.arange(380.0, 721.0, 5.0)
    spectrum = lam**-5.0 / np.expm1(1.4388e7 / (lam * float(kelvin)))  # c2 = hc/k in nm K
    sens = np.stack([np.exp(-0.5 * ((lam - c) / w) ** 2) for c, w in _CHANNELS_NM])
    return sens @ spectrum


def light_colour(kelvin: float) -> np.ndarray:
    """Linear RGB multiplier ``(3,)`` of a light at ``kelvin``: the standard key light's
    colour shifted as a black body's from :data:`STANDARD_TEMPERATURE_K`, at the same
    luminance."""
    base = np.asarray(_KEY_COLOUR)
    if kelvin == STANDARD_TEMPERATURE_K:
        return base
    c = base * _planck_rgb(kelvin) / _planck_rgb(STANDARD_TEMPERATURE_K)
    return c * (base @ _LUMA) / (c @ _LUMA)


def _square_light(mi, direction: np.ndarray, size: float, radiance: np.ndarray) -> dict:
    """A square area light of side ``size`` at the lights' distance along ``direction``,
    aimed at the table's centre."""
    up = [0.0, 1.0, 0.0] if abs(direction[1]) < 0.99 else [1.0, 0.0, 0.0]
    return {
        "type": "rectangle",
        "to_world": mi.ScalarTransform4f().look_at(
            origin=(direction * _KEY_DISTANCE_MM).tolist(), target=[0, 0, 0], up=up
        ).scale([size / 2, size / 2, 1.0]),
        "emitter": {"type": "area", "radiance": {"type": "rgb",
                                                 "value": [float(v) for v in radiance]}},
    }


def _direction(azimuth_deg: float, elevation_deg: float) -> np.ndarray:
    az, el = np.deg2rad(azimuth_deg), np.deg2rad(elevation_deg)
    return np.array([np.cos(el) * np.cos(az), np.sin(el), -np.cos(el) * np.sin(az)])


def _wood_colour(look: SceneParams) -> tuple[float, float, float]:
    r, g, b = _WOOD_SRGB
    red = look.wood_redness
    s = look.wood_brightness ** (1 / 2.2)  # brightness is linear; the base colour is sRGB
    return (min(0.95, s * r * (1 + red)), min(0.95, s * g), min(0.95, s * b * (1 - 1.5 * red)))


def _with_contrast(texture: np.ndarray, contrast: float) -> np.ndarray:
    """``texture`` (H, W, 3) with its variation about its mean colour scaled by ``contrast``."""
    mean = texture.reshape(-1, 3).mean(axis=0)
    return np.clip(mean + np.float32(contrast) * (texture - mean), 0.0, 1.0).astype(np.float32)


#: Materials of recent looks, by (variant, look, table size): building textures is slow.
_MATERIALS: dict = {}
_MATERIALS_KEPT = 4


#: Table tops the renderer dyes a random colour (their textures are pale and neutral).
_DYED_TABLES = ("cloth", "patterned")


def _dye(rng: np.random.Generator) -> np.ndarray:
    """A random fabric colour: linear RGB multiplier ``(3,)`` of a pale neutral texture."""
    from unseeable.render.textures import srgb_to_linear

    hsv = rng.uniform(0.0, 1.0), rng.uniform(0.0, 0.7), rng.uniform(0.45, 1.0)
    return srgb_to_linear(colorsys.hsv_to_rgb(*hsv)).astype(np.float32)


def _paint(mi, side: np.ndarray, ends: np.ndarray, rng: np.random.Generator) -> tuple:
    """BSDFs (side, ends) of a painted log: a solid colour of random hue, glossier than
    wood, with the wood's grain (``side``, ``ends``: its textures) showing faintly."""
    from unseeable.render.textures import srgb_to_linear

    colour = srgb_to_linear(colorsys.hsv_to_rgb(rng.uniform(0.0, 1.0), rng.uniform(0.4, 0.9),
                                                rng.uniform(0.35, 0.85)))
    alpha = float(rng.uniform(0.1, 0.35))
    out = []
    for texture, faint, shade, rough in ((side, _PAINT_GRAIN[0], 1.0, 1.0),
                                         (ends, _PAINT_GRAIN[1], 0.85, 1.6)):
        lum = texture @ _LUMA.astype(np.float32)
        grain = 1 + faint * (lum / lum.mean() - 1)
        paint = np.clip(grain[..., None] * (colour * shade).astype(np.float32), 0.005, 0.95)
        out.append(mi.load_dict({"type": "roughplastic", "distribution": "ggx",
                                 "alpha": min(1.0, alpha * rough), "int_ior": 1.5,
                                 "nonlinear": True,
                                 "diffuse_reflectance": _bitmap_texture(mi, paint)}))
    return tuple(out)


def _materials(mi, look: SceneParams, table_size_mm: float
               ) -> tuple[list, object, object, list]:
    """Wood BSDFs (side, ends) per wood variant, the table's BSDF, the environment and
    the painted logs' BSDFs (side, ends) per wood variant (none when no log is painted)."""
    from unseeable.render import textures

    key = (mi.variant(), look, float(table_size_mm))
    if key in _MATERIALS:
        return _MATERIALS[key]
    rng = np.random.default_rng([look.texture_seed, 11])
    paint_rng = np.random.default_rng([look.texture_seed, 19])
    base = _wood_colour(look)
    wood, painted = [], []
    for n in range(WOOD_VARIANTS):
        tint = np.exp(rng.normal(0.0, look.log_variation, size=3) * np.array([1.0, 0.9, 0.8])
                      + rng.normal(0.0, look.log_variation))
        side = textures.side_grain(base, seed=look.texture_seed * 31 + n, tint=tuple(tint))
        ends = textures.end_grain(base, seed=look.texture_seed * 31 + n, tint=tuple(tint))
        raw = side, ends  # a painted log's faint grain
        if look.end_grain_contrast != 1.0:
            ends = _with_contrast(ends, look.grain_contrast * look.end_grain_contrast)
            if look.grain_contrast != 1.0:
                side = _with_contrast(side, look.grain_contrast)
        elif look.grain_contrast != 1.0:
            side, ends = (_with_contrast(t, look.grain_contrast) for t in (side, ends))
        common = {"type": "roughplastic", "distribution": "ggx",
                  "alpha": float(np.clip(look.wood_roughness, 0.02, 1.0)), "int_ior": 1.5,
                  "nonlinear": True}
        wood.append((
            mi.load_dict({**common, "diffuse_reflectance": _bitmap_texture(mi, side)}),
            mi.load_dict({**common, "alpha": float(np.clip(look.wood_roughness * 1.6, 0.05, 1)),
                          "diffuse_reflectance": _bitmap_texture(mi, ends)}),
        ))
        if look.painted_share > 0:
            painted.append(_paint(mi, *raw, paint_rng))
    # Two table tops per kind (a 1024² top takes ~0.5 s to make, 12 MB to keep); looks
    # differ by where the texture starts.
    table_tex = textures.table_top(look.table_kind, seed=look.texture_seed % 2)
    if look.table_kind in _DYED_TABLES:
        table_tex = table_tex * _dye(np.random.default_rng([look.texture_seed, 23]))
    table_tex = np.clip(table_tex * np.float32(look.table_brightness), 0.005, 0.95)
    table = mi.load_dict({
        "type": "roughplastic", "distribution": "ggx", "alpha": 0.25, "int_ior": 1.5,
        "nonlinear": True,
        "diffuse_reflectance": _bitmap_texture(mi, table_tex,
                                               scale=table_size_mm / _TABLE_PERIOD_MM,
                                               offset=tuple(rng.random(2)))})
    room = textures.sky(intensity=_SKY_RADIANCE * look.sky_intensity)
    if look.environment_red != 1.0 or look.environment_blue != 1.0:
        room = room * np.array([look.environment_red, 1.0, look.environment_blue],
                               dtype=np.float32)
    environment = mi.load_dict({"type": "envmap", "bitmap": mi.Bitmap(room)})
    while len(_MATERIALS) >= _MATERIALS_KEPT:
        _MATERIALS.pop(next(iter(_MATERIALS)))
    _MATERIALS[key] = (wood, table, environment, painted)
    return wood, table, environment, painted


def _chessboard_shape(mi, chessboard: TableChessboard, *, plain: bool) -> object:
    """A printed chessboard lying on the table (:mod:`unseeable.render.chessboard`): its
    print looked up texel by texel, so the squares' edges stay sharp at any distance."""
    vertices, faces, normals, uv = chessboard.mesh()
    if plain:
        bsdf = mi.load_dict({"type": "diffuse"})
    else:
        print_rgb = np.repeat(chessboard.texture()[..., None], 3, axis=2)
        bsdf = mi.load_dict({
            "type": "diffuse",
            "reflectance": {"type": "bitmap", "bitmap": mi.Bitmap(print_rgb),
                            "filter_type": "nearest", "wrap_mode": "clamp", "raw": True}})
    return _fill_mesh(mi, "chessboard", vertices, faces, normals, uv, bsdf)


def _build_scene(structure: Structure, pose: GridPose, *, settings: RenderSettings,
                 look: SceneParams, plain: bool = False) -> _BuiltScene:
    """The Mitsuba scene; ``plain``: one grey diffuse material everywhere, for a caller
    that reads only the geometry (ids and depth), not the textures (~0.6 s to make)."""
    import mitsuba as mi

    from unseeable.render.cad import log_surfaces, log_to_world

    g = settings.geometry
    if plain:
        grey = mi.load_dict({"type": "diffuse"})
        wood, table_bsdf = [(grey, grey)] * WOOD_VARIANTS, grey
        environment = mi.load_dict({"type": "constant"})
        painted = []
    else:
        wood, table_bsdf, environment, painted = _materials(mi, look, settings.table_size_mm)
    # Per-log choices depend on the look and the log, so a log keeps its look when others
    # are removed.
    scene: dict = {"type": "scene"}
    for idx, log in enumerate(structure.logs):
        side, ends = log_surfaces(log.notches, g, settings.segments)
        m = log_to_world(log, pose, g)
        rot, trans = m[:3, :3], m[:3, 3]
        rng = np.random.default_rng([look.texture_seed, 13, log.layer, *log.at, log.notches])
        variant = int(rng.integers(WOOD_VARIANTS))
        shift = rng.uniform(0.0, 1.0, size=2)
        turn = rng.uniform(0.0, 2 * np.pi)
        c, s = np.cos(turn), np.sin(turn)
        side_bsdf, ends_bsdf = wood[variant]
        if painted and np.random.default_rng(
                [look.texture_seed, 17, log.layer, *log.at, log.notches]).random() \
                < look.painted_share:
            side_bsdf, ends_bsdf = painted[variant]
        for part, surf, bsdf in (("side", side, side_bsdf), ("ends", ends, ends_bsdf)):
            if len(surf.faces) == 0:
                continue
            verts = (surf.vertices @ rot.T + trans).astype(np.float32)
            normals = (surf.normals @ rot.T).astype(np.float32)
            if part == "side":
                uv = surf.uv + shift.astype(np.float32)
            else:  # turn the end grain about the disc's centre
                d = surf.uv - 0.5
                uv = np.stack([c * d[:, 0] - s * d[:, 1], s * d[:, 0] + c * d[:, 1]], 1) + 0.5
            scene[f"log{idx:05d}_{part}"] = _fill_mesh(
                mi, f"log{idx:05d}_{part}", verts, surf.faces, normals,
                uv.astype(np.float32), bsdf)

    # Table: a square at y = 0 facing up.
    half = settings.table_size_mm / 2
    scene["table"] = {
        "type": "rectangle",
        "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, 0], target=[0, 1, 0],
                                                   up=[0, 0, 1]).scale([half, half, 1.0]),
        "bsdf": table_bsdf,
    }
    if settings.chessboard is not None:
        scene["chessboard"] = _chessboard_shape(mi, settings.chessboard, plain=plain)
    # Environment: a bright diffuse room.
    scene["environment"] = environment
    # Key light: a square area light aimed at the table's centre.
    direction = _direction(look.key_azimuth_deg, look.key_elevation_deg)
    size = float(look.key_size_mm)
    radiance = _KEY_IRRADIANCE * look.key_intensity * _KEY_DISTANCE_MM**2 / size**2
    if look.key_temperature_k == STANDARD_TEMPERATURE_K:
        colour = [radiance, radiance * 0.97, radiance * 0.92]
    else:
        colour = radiance * light_colour(look.key_temperature_k)
    scene["key_light"] = _square_light(mi, direction, size, colour)
    if look.fill_intensity > 0:
        # Fill light: large and soft, at an azimuth from the key light's.
        fill = _KEY_IRRADIANCE * look.fill_intensity * _KEY_DISTANCE_MM**2 / _FILL_SIZE_MM**2
        scene["fill_light"] = _square_light(
            mi, _direction(look.key_azimuth_deg + look.fill_azimuth_deg,
                           look.fill_elevation_deg),
            _FILL_SIZE_MM, fill * light_colour(look.fill_temperature_k))
    try:
        built = mi.load_dict(scene)
    except Exception as err:
        raise RenderError(f"Mitsuba could not build the scene: {err}") from None
    shapes = built.shapes()
    shape_log = np.full(len(shapes) + 1, -1, dtype=np.int32)
    for n, shape in enumerate(shapes):
        name = shape.id()
        if name.startswith("log"):
            shape_log[n + 1] = int(name[3:8])
    return _BuiltScene(built, shape_log)


# --------------------------------------------------------------------------
# rendering


def _tonemap(linear: np.ndarray) -> np.ndarray:
    """Filmic response (Narkowicz's ACES fit) then sRGB encoding, values in [0, 1]."""
    x = np.maximum(linear, 0.0)
    y = (x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14)
    y = np.clip(y, 0.0, 1.0)
    return np.where(y <= 0.0031308, 12.92 * y, 1.055 * np.power(y, 1 / 2.4) - 0.055)


def _develop(radiance: np.ndarray, *, look: SceneParams, settings: RenderSettings,
             rng: np.random.Generator) -> np.ndarray:
    """Camera response: exposure, lens blur and defocus, sensor noise, white balance, tone
    curve, 8 bits."""
    import cv2

    lin = radiance.astype(np.float32) * np.float32(_BASE_EXPOSURE * look.exposure)
    blur = settings.blur_px
    if look.defocus_px > 0:
        blur = float(np.hypot(blur, look.defocus_px))  # Gaussian blurs add in quadrature
    if blur > 0:
        lin = cv2.GaussianBlur(lin, (0, 0), blur)
    if look.noise > 0:
        # Shot noise grows with the signal, read noise does not.
        sigma = look.noise * np.sqrt(0.25 + np.clip(lin, 0, 4))
        lin = lin + sigma * rng.standard_normal(lin.shape, dtype=np.float32)
    if look.white_balance_red != 1.0 or look.white_balance_blue != 1.0:
        lin = lin * np.array([look.white_balance_red, 1.0, look.white_balance_blue],
                             dtype=np.float32)
    out = _tonemap(lin)
    return np.clip(np.rint(out * 255.0), 0, 255).astype(np.uint8)


@dataclass(frozen=True, eq=False)
class Rendered:
    """A render with its ground truth.

    Attributes
    ----------
    image : (H, W, 3) uint8
    ids : (H, W) int32
        Index into ``structure.logs`` of the log each pixel centre sees; -1
        for the table and the background.
    depth : (H, W) float32
        Camera-frame z (mm) of what each pixel centre sees; ``inf`` where the
        ray meets nothing.
    look : SceneParams
        The scene look used.
    variant : str
        Mitsuba variant used.
    seconds : float
        Wall time of the render.
    timings : dict of str to float
        Seconds spent building the scene, path tracing, casting the ground
        truth and developing the image.
    """

    image: np.ndarray
    ids: np.ndarray
    depth: np.ndarray
    look: SceneParams
    variant: str
    seconds: float
    timings: dict


def check_scene_inputs(structure, pose, camera) -> None:
    """Raise :class:`InputError` naming the argument that is not a Structure, GridPose or
    Camera."""
    if not isinstance(structure, Structure):
        raise InputError("must be a Structure", field="structure", value=type(structure).__name__)
    if not isinstance(pose, GridPose):
        raise InputError("must be a GridPose", field="pose", value=type(pose).__name__)
    if not isinstance(camera, Camera):
        raise InputError("must be a Camera", field="camera", value=type(camera).__name__)


def _aov_truth(mi, built: _BuiltScene, proxy: Camera) -> tuple[np.ndarray, np.ndarray]:
    sensor = mi.load_dict(_sensor_dict(mi, proxy, spp=1, ground_truth=True))
    integrator = mi.load_dict({"type": "aov", "aovs": "si:shape_index,p:position"})
    out = np.array(mi.render(built.scene, sensor=sensor, integrator=integrator, spp=1, seed=0))
    index = np.rint(out[..., 0]).astype(np.int64)
    index = np.clip(index, 0, len(built.shape_log) - 1)
    ids = built.shape_log[index]
    pos = out[..., 1:4].astype(np.float64)
    depth = (pos @ proxy.R[2] + proxy.t[2]).astype(np.float32)
    depth[index == 0] = np.inf
    return ids.astype(np.int32), depth


def render(structure: Structure, pose: GridPose, camera: Camera, *,
           settings: RenderSettings = RenderSettings(), seed: int = 0,
           look: SceneParams | None = None) -> Rendered:
    """Render ``structure`` at ``pose`` on the table through ``camera``, with ground truth.

    Parameters
    ----------
    structure : Structure
        The logs on the table (already without any removed logs).
    pose : GridPose
        Where the assembly stands (world = table frame).
    camera : Camera
        Image size, intrinsics, distortion and pose of the camera.
    settings : RenderSettings
    seed : int
        Seeds the path tracer, the sensor noise and (when
        ``settings.randomisation`` is set and ``look`` is None) the scene look.
    look : SceneParams, optional
        Force this scene look (e.g. the same scene seen from several views).

    Returns
    -------
    Rendered

    Raises
    ------
    RenderError
        When Mitsuba fails.
    """
    check_scene_inputs(structure, pose, camera)
    seed = int(seed)
    if not 0 <= seed < 2**32:
        raise InputError("must be in 0..2**32-1", field="seed", value=seed)
    start = time.perf_counter()
    variant = select_variant(settings.variant)
    import mitsuba as mi

    look = settings.scene_for(seed) if look is None else look
    timings = {}
    built = _build_scene(structure, pose, settings=settings, look=look)
    proxy, maps = pinhole_proxy(camera)
    sensor = mi.load_dict(_sensor_dict(mi, proxy, spp=settings.spp, ground_truth=False))
    integrator = mi.load_dict({"type": "path", "max_depth": settings.max_depth,
                               "hide_emitters": False})
    timings["scene"] = time.perf_counter() - start
    try:
        radiance = np.array(mi.render(built.scene, sensor=sensor, integrator=integrator,
                                      spp=settings.spp, seed=seed))
        timings["path_tracing"] = time.perf_counter() - start - sum(timings.values())
        ids, depth = _aov_truth(mi, built, proxy)
        timings["ground_truth"] = time.perf_counter() - start - sum(timings.values())
    except Exception as err:
        raise RenderError(f"Mitsuba failed to render: {err}") from None
    radiance = np.nan_to_num(radiance[..., :3], nan=0.0, posinf=0.0, neginf=0.0)
    if maps is not None:
        import cv2

        radiance = cv2.remap(radiance.astype(np.float32), maps[0], maps[1], cv2.INTER_LINEAR,
                             borderMode=cv2.BORDER_REPLICATE)
        ids = cv2.remap(ids, maps[0], maps[1], cv2.INTER_NEAREST,
                        borderMode=cv2.BORDER_CONSTANT, borderValue=-1)
        depth = cv2.remap(depth, maps[0], maps[1], cv2.INTER_NEAREST,
                          borderMode=cv2.BORDER_CONSTANT, borderValue=float("inf"))
    rng = np.random.default_rng([seed, 3])
    image = _develop(radiance, look=look, settings=settings, rng=rng)
    seconds = time.perf_counter() - start
    timings["develop"] = seconds - sum(timings.values())
    logger.debug("rendered %dx%d at %d spp in %.2f s (%s)", camera.width, camera.height,
                 settings.spp, seconds, variant)
    return Rendered(image, ids.astype(np.int32), depth.astype(np.float32), look, variant, seconds,
                    timings)


def render_view(structure: Structure, pose: GridPose, camera: Camera, *,
                settings: RenderSettings = RenderSettings(), seed: int = 0,
                look: SceneParams | None = None
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Render a photograph of ``structure`` and its per-pixel ground truth.

    Parameters
    ----------
    structure : Structure
    pose : GridPose
    camera : Camera
    settings : RenderSettings
    seed : int
        Same seed, same inputs: the same image, bit for bit.
    look : SceneParams, optional

    Returns
    -------
    image : (H, W, 3) uint8
        sRGB photograph.
    ids : (H, W) int32
        Index into ``structure.logs`` seen at each pixel centre (-1: table/background).
    depth : (H, W) float32
        Camera-frame z in mm (``inf``: nothing).

    Examples
    --------
    >>> from unseeable.domain import Extent, Log, Structure, GridPose
    >>> from unseeable.camera import Camera
    >>> s = Structure(Extent(2, 1, 1), [Log(layer=0, at=(0, 0), notches=2)])
    >>> cam = Camera.look_at(eye=[0, 300, -400], target=[32, 10, 0], width=32, height=24,
    ...                      fov_deg=50)
    >>> image, ids, depth = render_view(s, GridPose(), cam, settings=RenderSettings(spp=2))
    >>> image.shape, ids.dtype.name, int(ids.max())
    ((24, 32, 3), 'int32', 0)
    """
    r = render(structure, pose, camera, settings=settings, seed=seed, look=look)
    return r.image, r.ids, r.depth


def render_ground_truth(structure: Structure, pose: GridPose, camera: Camera, *,
                        settings: RenderSettings = RenderSettings()
                        ) -> tuple[np.ndarray, np.ndarray]:
    """Only the ground truth of a view (no path tracing): ``ids (H, W) int32, depth (H, W)``."""
    check_scene_inputs(structure, pose, camera)
    select_variant(settings.variant)
    import mitsuba as mi

    built = _build_scene(structure, pose, settings=settings, look=settings.look, plain=True)
    proxy, maps = pinhole_proxy(camera)
    return truth_from_proxy(*_aov_truth(mi, built, proxy), maps)


def truth_from_proxy(ids: np.ndarray, depth: np.ndarray,
                     maps: tuple[np.ndarray, np.ndarray] | None) -> tuple[np.ndarray, np.ndarray]:
    """Id and depth maps drawn through :func:`pinhole_proxy`'s camera, resampled (nearest
    pixel) to the camera it stands for; unchanged when ``maps`` is None."""
    if maps is None:
        return ids, depth
    import cv2

    ids = cv2.remap(ids, maps[0], maps[1], cv2.INTER_NEAREST,
                    borderMode=cv2.BORDER_CONSTANT, borderValue=-1)
    depth = cv2.remap(depth, maps[0], maps[1], cv2.INTER_NEAREST,
                      borderMode=cv2.BORDER_CONSTANT, borderValue=float("inf"))
    return ids, depth
