"""The simulated robot workspace: a table, an assembly, a pendulum camera arm, a removal arm.

Angle convention. A station's angle ``a`` (degrees) is measured about the
table's vertical axis (+y) from +x, counter-clockwise seen from above (the
right-handed sense about +y, as :func:`unseeable.domain.rot_y`): the camera
stands at ``pivot + (r cos a, h, -r sin a)``. So 90° puts it on the -z side
of the table, 180° on the -x side. The default stations 90°, 120°, 150°,
180°, 210° are the five of the paper's corpus, spanning 120° of the arm's
180° swing.

Examples
--------
>>> arm = PendulumArm()
>>> cam = arm.camera(90.0)
>>> np.round(cam.centre).tolist()
[0.0, 785.0, -900.0]
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field, replace

import numpy as np

from unseeable.camera import Camera
from unseeable.domain import Extent, GridPose, LogGeometry, Structure, rot_y
from unseeable.errors import InputError
from unseeable.render.settings import RenderSettings, SceneParams
from unseeable.render.view import View, ViewTruth, shown_structure

__all__ = ["PendulumArm", "Workspace", "default_pose", "jitter_camera", "DEFAULT_STATIONS"]

logger = logging.getLogger(__name__)

#: The paper's corpus: five stations of the pendulum arm (degrees).
DEFAULT_STATIONS = (90.0, 120.0, 150.0, 180.0, 210.0)


def _positive(name: str, value, *, allow_zero: bool = False) -> float:
    ok = isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool) \
        and np.isfinite(value) and (value >= 0 if allow_zero else value > 0)
    if not ok:
        raise InputError("must be a positive finite number", field=name, value=value)
    return float(value)


@dataclass(frozen=True)
class PendulumArm:
    """A camera on an arm that swings about the table's vertical axis.

    Parameters
    ----------
    radius_mm : float
        Horizontal distance of the camera from the pivot (the vertical through
        ``look_at``).
    elevation_deg : float or None
        Elevation of the camera seen from ``look_at``: the camera stands at
        height ``look_at[1] + radius_mm * tan(elevation)``. Give this or
        ``height_mm``.
    height_mm : float or None
        Height of the camera above the table (overrides ``elevation_deg``).
    look_at : (3,) float
        World point (mm) the camera looks at from every station.
    width, height : int
        Image size in pixels.
    fov_deg : float
        Horizontal field of view (square pixels, principal point at the
        image centre).
    stations_deg : tuple of float
        The arm's stations (see the module's angle convention).
    dist : (5,) float or None
        Lens distortion (OpenCV ``k1, k2, p1, p2, k3``).

    Notes
    -----
    The defaults (radius 900 mm, elevation 40°, 50° field of view, looking at
    30 mm above the table's centre) keep a whole 8×8×8 assembly centred on
    the table, at any yaw, inside a 640×480 image from every angle, with a
    margin of about 50 pixels.
    """

    radius_mm: float = 900.0
    elevation_deg: float | None = 40.0
    height_mm: float | None = None
    look_at: tuple[float, float, float] = (0.0, 30.0, 0.0)
    width: int = 640
    height: int = 480
    fov_deg: float = 50.0
    stations_deg: tuple[float, ...] = DEFAULT_STATIONS
    dist: tuple[float, ...] | None = None

    def __post_init__(self) -> None:
        _positive("radius_mm", self.radius_mm)
        if self.height_mm is None and self.elevation_deg is None:
            raise InputError("give elevation_deg or height_mm", field="elevation_deg",
                             value=None)
        if self.height_mm is not None:
            _positive("height_mm", self.height_mm)
        elif not -80.0 <= float(self.elevation_deg) <= 89.0:
            raise InputError("must be in [-80, 89] degrees", field="elevation_deg",
                             value=self.elevation_deg)
        look = tuple(float(v) for v in self.look_at)
        if len(look) != 3 or not np.all(np.isfinite(look)):
            raise InputError("must be three finite numbers (mm)", field="look_at",
                             value=self.look_at)
        object.__setattr__(self, "look_at", look)
        for name in ("width", "height"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not 1 <= v <= 20000:
                raise InputError("must be a whole number of pixels in 1..20000", field=name,
                                 value=v)
        if not 1.0 < float(self.fov_deg) < 179.0:
            raise InputError("must be in (1, 179) degrees", field="fov_deg", value=self.fov_deg)
        stations = tuple(float(a) for a in self.stations_deg)
        if not stations or not np.all(np.isfinite(stations)):
            raise InputError("must be a non-empty list of angles in degrees",
                             field="stations_deg", value=self.stations_deg)
        object.__setattr__(self, "stations_deg", stations)

    @property
    def camera_height_mm(self) -> float:
        """Height of the camera above the table."""
        if self.height_mm is not None:
            return float(self.height_mm)
        return self.look_at[1] + self.radius_mm * float(np.tan(np.deg2rad(self.elevation_deg)))

    def camera_centre(self, angle_deg: float) -> np.ndarray:
        """World position (mm) of the camera at ``angle_deg``, ``(3,)``."""
        angle = _angle(angle_deg)
        pivot = np.array([self.look_at[0], 0.0, self.look_at[2]])
        offset = rot_y(np.deg2rad(angle)) @ np.array([self.radius_mm, 0.0, 0.0])
        return pivot + offset + np.array([0.0, self.camera_height_mm, 0.0])

    def camera(self, angle_deg: float) -> Camera:
        """The calibrated camera at station angle ``angle_deg``."""
        return Camera.look_at(eye=self.camera_centre(angle_deg), target=self.look_at,
                              width=self.width, height=self.height, fov_deg=self.fov_deg,
                              dist=None if self.dist is None else np.asarray(self.dist))

    def cameras(self) -> list[Camera]:
        """The cameras at every station."""
        return [self.camera(a) for a in self.stations_deg]

    def with_size(self, width: int, height: int) -> PendulumArm:
        """The same arm with another image size (same field of view)."""
        return replace(self, width=width, height=height)


def _angle(value) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)) \
            or not np.isfinite(value):
        raise InputError("must be a finite angle in degrees", field="angle", value=value)
    return float(value)


def default_pose(extent: Extent, geometry: LogGeometry = LogGeometry(),
                 yaw_deg: float = 0.0) -> GridPose:
    """The pose that centres ``extent``'s footprint on the table (at yaw ``yaw_deg``).

    Examples
    --------
    >>> default_pose(Extent(3, 2, 5))
    GridPose(x=-64.0, z=-128.0, yaw_deg=0.0)
    """
    centre = np.array([(extent.I - 1) * geometry.l1 / 2, 0.0, (extent.K - 1) * geometry.l1 / 2])
    origin = -rot_y(np.deg2rad(yaw_deg)) @ centre
    return GridPose(float(origin[0]) + 0.0, float(origin[2]) + 0.0, float(yaw_deg))


def jitter_camera(camera: Camera, rng: np.random.Generator, *, position_mm: float,
                  rotation_deg: float) -> Camera:
    """``camera`` moved by Gaussian noise: ``position_mm`` and ``rotation_deg`` per axis (1σ)."""
    if position_mm == 0 and rotation_deg == 0:
        return camera
    dpos = rng.normal(0.0, position_mm, size=3)
    w = np.deg2rad(rng.normal(0.0, rotation_deg, size=3))
    import cv2

    d_r, _ = cv2.Rodrigues(w.reshape(3, 1))
    R = d_r @ camera.R
    centre = camera.centre + dpos
    return Camera(camera.width, camera.height, camera.K, R, -R @ centre, camera.dist)


@dataclass(frozen=True, eq=False)
class _Observation:
    view: View
    truth: ViewTruth
    angle_deg: float
    seed: int


@dataclass(eq=False)
class Workspace:
    """A simulated robot workspace with an assembly on its table.

    Parameters
    ----------
    structure : Structure
        The assembly.
    pose : GridPose, optional
        Where it stands; default :func:`default_pose` (footprint centred).
    arm : PendulumArm
    settings : RenderSettings
        With ``settings.randomisation`` set, the scene's look is drawn once
        from ``seed`` (the same table and lights in every view) and every
        view's camera is jittered: the view records the arm's nominal camera,
        its truth the camera that really took the photograph.
    seed : int
        Seeds the scene and, with the number of the observation, each render.

    Examples
    --------
    >>> from unseeable.domain import Extent, Log, Structure
    >>> s = Structure(Extent(2, 1, 1), [Log(layer=0, at=(0, 0), notches=2)])
    >>> ws = Workspace(s, arm=PendulumArm(width=40, height=30), settings=RenderSettings(spp=2))
    >>> view = ws.observe(90.0)
    >>> view.image.shape, bool(ws.truth(view).present.any())
    ((30, 40, 3), True)
    """

    structure: Structure
    pose: GridPose | None = None
    arm: PendulumArm = field(default_factory=PendulumArm)
    settings: RenderSettings = field(default_factory=RenderSettings)
    seed: int = 0

    def __post_init__(self) -> None:
        if not isinstance(self.structure, Structure):
            raise InputError("must be a Structure", field="structure",
                             value=type(self.structure).__name__)
        if self.pose is None:
            self.pose = default_pose(self.structure.extent, self.settings.geometry)
        self._removed: set[int] = set()
        self._observations: list[_Observation] = []
        self.look: SceneParams = self.settings.scene_for(self.seed)

    # -- the removal arm ---------------------------------------------------
    @property
    def removed(self) -> frozenset[int]:
        """Indices (into ``structure.logs``) of the logs the arm has taken off the table."""
        return frozenset(self._removed)

    def remove_logs(self, logs) -> None:
        """Take the logs with these indices off the table."""
        ids = {int(n) for n in logs}
        bad = sorted(n for n in ids if not 0 <= n < len(self.structure.logs))
        if bad:
            raise InputError(f"no such log (the assembly has {len(self.structure.logs)})",
                             field="logs", value=bad)
        self._removed |= ids

    def remove_from_layer(self, layer: int) -> None:
        """Take every log at layers ``>= layer`` off the table."""
        self.remove_logs(n for n, log in enumerate(self.structure.logs) if log.layer >= layer)

    def restore(self) -> None:
        """Put every removed log back."""
        self._removed.clear()

    def on_table(self, removed_from_layer: int | None = None) -> Structure:
        """The logs on the table (optionally also without layers ``>= removed_from_layer``)."""
        return shown_structure(self.structure, removed_from_layer, tuple(self._removed))

    # -- the camera arm ----------------------------------------------------
    def observe(self, angle_deg: float, *, removed_from_layer: int | None = None) -> View:
        """Photograph the table from the arm's station at ``angle_deg``.

        Parameters
        ----------
        angle_deg : float
            Arm angle (any angle; see the module's convention).
        removed_from_layer : int, optional
            For this photograph, the arm first takes off every log at layers
            ``>= removed_from_layer`` (on top of :attr:`removed`) and puts
            them back afterwards.

        Returns
        -------
        View
            The image, the arm's camera, the extent, the pose and the removal;
            :meth:`truth` gives its ground truth.
        """
        from unseeable.render.renderer import render
        from unseeable.render.truth import feature_truth

        angle = _angle(angle_deg)
        if removed_from_layer is not None and (
                isinstance(removed_from_layer, bool)
                or not isinstance(removed_from_layer, (int, np.integer))
                or removed_from_layer < 0):
            raise InputError("must be a layer number >= 0", field="removed_from_layer",
                             value=removed_from_layer)
        count = len(self._observations)
        seed = int(np.random.SeedSequence([int(self.seed), count]).generate_state(1)[0])
        nominal = self.arm.camera(angle)
        actual = nominal
        rand = self.settings.randomisation
        if rand is not None:
            actual = jitter_camera(nominal, np.random.default_rng([seed, 5]),
                                   position_mm=rand.camera_position_mm,
                                   rotation_deg=rand.camera_rotation_deg)
        removed_logs = tuple(sorted(self._removed))
        shown_ids = [n for n, log in enumerate(self.structure.logs)
                     if n not in self._removed
                     and (removed_from_layer is None or log.layer < removed_from_layer)]
        shown = self.structure.with_logs(self.structure.logs[n] for n in shown_ids)
        result = render(shown, self.pose, actual, settings=self.settings, seed=seed,
                        look=self.look)
        # ids index the shown structure's logs: map them to the whole assembly's.
        lut = np.array(shown_ids + [-1], dtype=np.int32)
        ids = lut[result.ids]  # -1 indexes the appended -1
        present, visible, source = feature_truth(
            shown, self.pose, actual, result.ids, geometry=self.settings.geometry)
        view = View(result.image, nominal, self.structure.extent, self.pose,
                    removed_from_layer, removed_logs=removed_logs or None)
        truth = ViewTruth(self.structure, self.pose, actual, present, visible, ids,
                          result.depth, removed_from_layer, removed_logs, source,
                          self.look.to_json())
        self._observations.append(_Observation(view, truth, angle, seed))
        logger.info("observed at %.1f deg (%d logs on the table) in %.2f s", angle,
                    len(shown.logs), result.seconds)
        return view

    def truth(self, view: View) -> ViewTruth:
        """The ground truth of a view this workspace returned."""
        for obs in self._observations:
            if obs.view is view:
                return obs.truth
        raise InputError("this view was not taken in this workspace", field="view")

    @property
    def observations(self) -> list[tuple[View, ViewTruth]]:
        """Every view taken so far, with its truth, in order."""
        return [(o.view, o.truth) for o in self._observations]
