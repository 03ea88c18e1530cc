"""Every setting of an estimate, in one frozen, validated record.

:class:`EstimateSettings` is the one place where the estimator's defaults live.
The library, the command line and the experiments build it once and pass it on
whole; its sub-records group what belongs together (the structure prior, the
solver, the pose rule, the detections, the confidence test).
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from typing import Any

from unseeable.confidence.readings import MAX_READING_SHIFT, READING_SHIFT
from unseeable.confidence.tolerance import DELTA_STAR, MAX_DELTA
from unseeable.errors import InputError, check_seconds, check_whole_number
from unseeable.grammar.priors import StructurePrior

__all__ = ["EstimateSettings", "SolverSettings", "PoseRuleSettings", "DetectionSettings",
           "ConfidenceSettings"]

#: Seconds one solve may take, and the visibility fixpoint's budget for starting estimates.
TIME_LIMIT = 60.0


@dataclass(frozen=True)
class SolverSettings:
    """How the MAP structure is solved for.

    Attributes
    ----------
    backend : {"cpsat", "bnb", "toulbar2"}
    time_limit : float
        Seconds per solve; also the visibility fixpoint's budget: it starts no new
        estimate after this many seconds.
    workers : int
        Solver threads (1: deterministic).
    """

    backend: str = "cpsat"
    time_limit: float = TIME_LIMIT
    workers: int = 1

    def __post_init__(self) -> None:
        from unseeable.solve.api import available_backends

        known = ("cpsat", "bnb", "toulbar2")
        if self.backend not in known:
            raise InputError(f"must be one of {', '.join(known)} (installed: "
                             f"{', '.join(available_backends())})", field="backend",
                             value=self.backend)
        object.__setattr__(self, "time_limit", check_seconds(self.time_limit,
                                                             field="time_limit"))
        object.__setattr__(self, "workers", check_whole_number(self.workers, field="workers",
                                                               minimum=1))


@dataclass(frozen=True)
class PoseRuleSettings:
    """How a view's pose is found (:func:`~unseeable.pipeline.find_pose`).

    Attributes
    ----------
    strict : bool
        An estimated pose that the image contradicts (wood well outside the extent's
        box) is an error (:class:`~unseeable.errors.VisionError`); False uses it. A
        fit that is only weak is used either way, its quality recorded (``pose_poor``).
    refine : bool
        Polish a given pose on the image's edges before detecting features (an
        estimated one is aligned on them already).
    threads : int
        Threads for the pose search, the choice among its candidates, the detectors'
        ends and segments side by side, and the rays of the visibility and of what lies
        behind each feature (the pose, the detections and the estimate are the same for
        any number).
    independent : bool
        Several views whose frames are not shared (the paper's setting): each view's pose
        is found alone and registered to the reference view by symbolic orientation.
        False: the cameras share one table frame and the assembly did not move, so its
        pose is one.
    """

    strict: bool = True
    refine: bool = True
    threads: int = 1
    independent: bool = False

    def __post_init__(self) -> None:
        object.__setattr__(self, "threads", check_whole_number(self.threads, field="threads",
                                                               minimum=1))


@dataclass(frozen=True)
class DetectionSettings:
    """How the features' evidence is read off a photograph.

    Attributes
    ----------
    calibration : str, Calibration or None
        The detectors' score → probability maps: a calibration file, a loaded
        :class:`~unseeable.vision.Calibration`, or None for the shipped one.
    background : bool
        Re-weigh detections by what lies behind each feature under the current
        estimate (wood or table), when the calibration has context models.
    presence_shift : bool
        Shift every detection's log-odds by the amount that makes them agree best with
        the estimate, and estimate again (the calibration adapted to the photograph's
        look).
    lines_once : bool
        Count the edge of an image line that several segment features share once under
        each estimate.

    The three switches exist for ablations; the command line does not offer them.
    """

    calibration: Any = None
    background: bool = True
    presence_shift: bool = True
    lines_once: bool = True

    def __post_init__(self) -> None:
        if isinstance(self.calibration, (str, Path)):
            path = Path(self.calibration).absolute()
            if not path.is_file():
                raise InputError("no such file", file=path)
            object.__setattr__(self, "calibration", str(path))

    def loaded_calibration(self):
        """The calibration to detect with (None: the shipped one, loaded where used)."""
        if isinstance(self.calibration, str):

            return _load_calibration_once(self.calibration)
        if self.calibration is not None and not hasattr(self.calibration, "pose_quality"):
            # Checked here rather than at construction: vision is loaded only when used.
            raise InputError("must be a calibration file or a Calibration",
                             field="calibration", value=type(self.calibration).__name__)
        return self.calibration

    def calibration_label(self) -> str:
        if self.calibration is None:
            return "shipped"
        if isinstance(self.calibration, str):
            return self.calibration
        return "custom"


def _load_calibration_once(path: str):
    from unseeable.vision.calibration import load_calibration

    cached = _CALIBRATIONS.get(path)
    if cached is None:
        cached = _CALIBRATIONS[path] = load_calibration(path)
    return cached


_CALIBRATIONS: dict[str, Any] = {}


@dataclass(frozen=True)
class ConfidenceSettings:
    """The confidence test (paper §4).

    Attributes
    ----------
    enabled : bool
        Run it at all.
    delta_star : float
        The tolerance threshold δ*: confident when the estimate survives every
        unseen feature's prior shifted this far from ½ against it.
    tolerance : bool
        Also find the estimation tolerance δ (the shift at which the estimate gives
        way).
    reading_shift : float or None
        s*, log-odds: an estimate that passes the δ* test must also stay the MAP with
        every seen feature's reading moved this far against it (at most erased) — the
        reading test (:func:`~unseeable.confidence.assess_readings`), so that a
        confident estimate does not rest on a few misread features. None: the δ*
        test alone (the paper's).
    """

    enabled: bool = True
    delta_star: float = DELTA_STAR
    tolerance: bool = True
    reading_shift: float | None = READING_SHIFT

    def __post_init__(self) -> None:
        d = self.delta_star
        if isinstance(d, bool) or not isinstance(d, (int, float)) or not math.isfinite(d) \
                or not 0 < d <= MAX_DELTA:
            raise InputError(f"must be a number in (0, {MAX_DELTA}]", field="delta_star",
                             value=d)
        object.__setattr__(self, "delta_star", float(d))
        r = self.reading_shift
        if r is not None:
            if isinstance(r, bool) or not isinstance(r, (int, float)) \
                    or not math.isfinite(r) or not 0 <= r <= MAX_READING_SHIFT:
                raise InputError(f"must be a number in [0, {MAX_READING_SHIFT:g}] or none",
                                 field="reading_shift", value=r)
            object.__setattr__(self, "reading_shift", float(r))


_SUB_RECORDS = {"prior": StructurePrior, "solver": SolverSettings, "pose": PoseRuleSettings,
                "detection": DetectionSettings, "confidence": ConfidenceSettings}


@dataclass(frozen=True)
class EstimateSettings:
    """Everything an estimate is made with; the defaults are the shipped estimator.

    Attributes
    ----------
    prior : StructurePrior
        The prior over structures and the tie policy
        (:class:`~unseeable.grammar.priors.StructurePrior`; ``"builder"`` by default).
    solver : SolverSettings
    pose : PoseRuleSettings
    detection : DetectionSettings
    confidence : ConfidenceSettings

    Examples
    --------
    >>> s = EstimateSettings.from_options(prior="uniform", backend="bnb", delta_star=0.1)
    >>> s.prior.is_uniform, s.solver.backend, s.confidence.delta_star
    (True, 'bnb', 0.1)
    >>> EstimateSettings.from_json(s.to_json()) == s
    True
    """

    prior: StructurePrior = field(default_factory=StructurePrior)
    solver: SolverSettings = field(default_factory=SolverSettings)
    pose: PoseRuleSettings = field(default_factory=PoseRuleSettings)
    detection: DetectionSettings = field(default_factory=DetectionSettings)
    confidence: ConfidenceSettings = field(default_factory=ConfidenceSettings)

    def __post_init__(self) -> None:
        for name, cls in _SUB_RECORDS.items():
            if not isinstance(getattr(self, name), cls):
                raise InputError(f"must be a {cls.__name__}", field=name,
                                 value=type(getattr(self, name)).__name__)

    @classmethod
    def from_options(cls, *, prior: str = "builder", **options: Any) -> EstimateSettings:
        """Settings from flat options, as a command line gives them: ``prior`` names the
        structure prior (``"builder"`` or ``"uniform"``); every other keyword is a field
        of one sub-record (``joint_cost``, ``ties``, ``backend``, ``time_limit``,
        ``strict``, ``threads``, ``calibration``, ``delta_star``, …). None leaves a
        field at its default."""
        options = {k: v for k, v in options.items() if v is not None}
        prior_fields = {f.name for f in fields(StructurePrior)}
        structure_prior = StructurePrior.named(
            prior, **{k: options.pop(k) for k in list(options) if k in prior_fields})
        parts: dict[str, Any] = {"prior": structure_prior}
        for name, sub in _SUB_RECORDS.items():
            if name == "prior":
                continue
            names = {f.name for f in fields(sub)}
            chosen = {k: options.pop(k) for k in list(options) if k in names}
            parts[name] = sub(**chosen)
        if options:
            raise InputError("unknown setting", field=next(iter(options)),
                             value=options[next(iter(options))])
        return cls(**parts)

    def replace(self, **options: Any) -> EstimateSettings:
        """These settings with some fields of the sub-records changed (flat names, as
        :meth:`from_options` takes them)."""
        parts = {name: getattr(self, name) for name in _SUB_RECORDS}
        for name, sub in _SUB_RECORDS.items():
            names = {f.name for f in fields(sub)}
            chosen = {k: options.pop(k) for k in list(options) if k in names}
            if chosen:
                parts[name] = replace(parts[name], **chosen)
        if options:
            raise InputError("unknown setting", field=next(iter(options)),
                             value=options[next(iter(options))])
        return EstimateSettings(**parts)

    def to_json(self) -> dict[str, Any]:
        d = self.detection
        return {
            "prior": self.prior.to_json(),
            "solver": {"backend": self.solver.backend, "time_limit": self.solver.time_limit,
                       "workers": self.solver.workers},
            "pose": {"strict": self.pose.strict, "refine": self.pose.refine,
                     "threads": self.pose.threads, "independent": self.pose.independent},
            "detection": {"calibration": d.calibration_label(), "background": d.background,
                          "presence_shift": d.presence_shift, "lines_once": d.lines_once},
            "confidence": {"enabled": self.confidence.enabled,
                           "delta_star": self.confidence.delta_star,
                           "tolerance": self.confidence.tolerance,
                           "reading_shift": self.confidence.reading_shift},
        }

    @classmethod
    def from_json(cls, data: Any, *, file: Any = None) -> EstimateSettings:
        """Settings from :meth:`to_json`'s form (a ``"shipped"`` calibration is the
        default; ``"custom"`` cannot be read back and is refused)."""
        if not isinstance(data, dict):
            raise InputError("must be an object", file=file, field="settings", value=data)
        parts: dict[str, Any] = {}
        for name, sub in _SUB_RECORDS.items():
            raw = data.get(name, {})
            if not isinstance(raw, dict):
                raise InputError("must be an object", file=file, field=f"settings.{name}",
                                 value=raw)
            raw = dict(raw)
            if name == "detection":
                cal = raw.get("calibration", "shipped")
                if cal == "custom":
                    raise InputError("was a calibration made in memory; it cannot be read "
                                     "back", file=file, field="settings.detection.calibration",
                                     value=cal)
                raw["calibration"] = None if cal == "shipped" else cal
            if name == "confidence":
                # Written before the reading test existed: the δ* test alone.
                raw.setdefault("reading_shift", None)
            names = {f.name for f in fields(sub)}
            unknown = set(raw) - names
            if unknown:
                raise InputError("unknown setting", file=file,
                                 field=f"settings.{name}.{sorted(unknown)[0]}")
            try:
                parts[name] = sub(**raw)
            except InputError as err:
                raise InputError(err.message, file=file,
                                 field=f"settings.{name}.{err.field}", value=err.value) \
                    from None
        return cls(**parts)

    def digest(self) -> str:
        """A short hash of these settings (and a calibration file's contents), for caches."""
        data = self.to_json()
        cal = self.detection.calibration
        if isinstance(cal, str):
            data["detection"]["calibration"] = hashlib.sha256(
                Path(cal).read_bytes()).hexdigest()
        return hashlib.sha256(json.dumps(data, sort_keys=True).encode()).hexdigest()[:16]
