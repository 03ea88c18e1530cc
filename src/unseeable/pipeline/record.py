"""The estimate as a typed record (:class:`Estimate`) and as a file (``unseeable/estimate@2``).

An :class:`Estimate` holds the joint structure with its log-probability and proven
bound, one :class:`ViewRecord` per photograph (pose, how it was found, visibility,
detections, doubts), the confidence, the settings it was made with, timings, and
what is needed to continue from it (:class:`EstimateModel`: the observations, the
kept solver and the objective's terms).

The file form is defined by the pydantic models below (:class:`EstimateFile`),
written by :func:`write_estimate` and validated by :func:`load_estimate`;
``estimate_schema()`` returns its JSON schema.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from unseeable.domain.features import FeatureKind, feature_index, feature_values
from unseeable.domain.frames import GridPose
from unseeable.domain.io import structure_to_json
from unseeable.domain.structure import Structure
from unseeable.errors import InputError
from unseeable.fileio import read_json, write_json
from unseeable.pipeline.evidence_checks import log_support
from unseeable.pipeline.posing import PoseReport
from unseeable.pipeline.settings import EstimateSettings

__all__ = ["Estimate", "ViewRecord", "EstimateModel", "ESTIMATE_FORMAT", "EstimateFile",
           "estimate_to_json", "write_estimate", "load_estimate", "estimate_schema"]

ESTIMATE_FORMAT = "unseeable/estimate@2"


@dataclass(frozen=True, eq=False)
class ViewRecord:
    """What one photograph contributed to an estimate.

    Attributes
    ----------
    source : str or None
        The view file.
    pose : GridPose or None
        The pose its detections were made at (None for bare evidence).
    pose_report : PoseReport or None
        How the pose was found.
    orientation : int
        Quarter turns of this view's grid relative to the reference (first) view's.
    removed_from_layer : int or None
    priors : (N,) float
        The evidence the kept structure was estimated under in this view (½: occluded
        or not judged).
    visible : (N,) bool or None
        The visibility used (None for bare evidence).
    detection : FeatureDetection or None
        The detections (scores, priors, projection) at :attr:`pose`.
    presence_shift : float
        The shift of the detections' log-odds the estimate was made under.
    edge_ends_judged, edge_ends_absent : int
        Log ends the estimate puts on the extent's boundary that were judged, and
        judged absent (:func:`~unseeable.pipeline.boundary_ends`).
    extent_doubt : bool
        Those ends say the assembly may go on beyond the extent, or the grid be off it.
    evidence_doubt : bool
        The detections had to be shifted far towards absent to agree with the
        estimate: the image shows more than it builds.
    features_outside_image : int
        Features of the extent the camera's frame cuts off (counted as unseen).
    pose_offset : (float, float)
        How far this view's own edges moved the shared pose (mm, degrees; several views
        in one table frame).
    disagrees : bool
        That move was too far: the view's camera or the assembly's placement is not what
        the reference view says.
    registration_margin : float or None
        Nats by which this view's symbolic orientation beat the runner-up (independent
        views).
    registration_doubt : bool
        That margin was a near tie.
    """

    source: str | None
    pose: GridPose | None
    pose_report: PoseReport | None
    priors: np.ndarray
    visible: np.ndarray | None = None
    orientation: int = 0
    removed_from_layer: int | None = None
    detection: Any = None
    presence_shift: float = 0.0
    edge_ends_judged: int = 0
    edge_ends_absent: int = 0
    extent_doubt: bool = False
    evidence_doubt: bool = False
    features_outside_image: int = 0
    pose_offset: tuple[float, float] = (0.0, 0.0)
    disagrees: bool = False
    registration_margin: float | None = None
    registration_doubt: bool = False

    @property
    def pose_ambiguous(self) -> bool:
        return self.pose_report is not None and self.pose_report.ambiguous

    @property
    def pose_poor(self) -> bool:
        """The view's pose was estimated with a fit quality below
        ``PoseSettings.min_quality``: a weak fit, or one the image contradicts used as
        asked (``--force-pose``)."""
        r = self.pose_report
        if r is None or r.source != "estimated" or r.quality is None:
            return False
        from unseeable.vision.pose.settings import PoseSettings  # (only for estimated poses)

        return r.quality < PoseSettings().min_quality

    @property
    def in_doubt(self) -> bool:
        """The view's pose choice was ambiguous or its pose fits poorly, its extent or
        evidence is in doubt, or it disagrees with the shared pose."""
        return (self.pose_ambiguous or self.pose_poor or self.extent_doubt
                or self.evidence_doubt or self.disagrees or self.registration_doubt)


@dataclass(frozen=True, eq=False)
class EstimateModel:
    """What an estimate needs to go on: its observations (None for bare evidence), the
    kept solver (its model re-solves with a changed objective) and the objective's
    terms of the kept structure (evidence and prior)."""

    observations: tuple
    solver: Any
    terms: list
    constraints: tuple = ()


@dataclass(frozen=True, eq=False)
class Estimate:
    """A structure estimate with everything needed to judge, explain and continue it.

    Attributes
    ----------
    result : SolveResult
        The MAP solve that produced the structure.
    views : tuple of ViewRecord
        One per photograph, the reference (first) view first; one record without a
        pose for bare evidence.
    confidence : Confidence or None
        The δ* test and the estimation tolerance over the features no view saw.
    settings : EstimateSettings
    iterations, converged, cycle_length, history
        Of the visibility fixpoint (1, True, 0, [] without one).
    timings : dict
        Seconds per stage.
    model : EstimateModel or None
    description : dict or None
        The English description the estimate was constrained by: its ``sentences`` and,
        per entity, the ``placements`` the estimate chose (a shape's ``to_json``).
    """

    result: Any
    views: tuple[ViewRecord, ...]
    confidence: Any = None
    settings: EstimateSettings = field(default_factory=EstimateSettings)
    iterations: int = 1
    converged: bool = True
    cycle_length: int = 0
    history: list = field(default_factory=list)
    timings: dict = field(default_factory=dict)
    model: EstimateModel | None = None
    description: dict | None = None

    @property
    def structure(self) -> Structure | None:
        return self.result.structure

    @property
    def pose(self) -> GridPose | None:
        """The reference (first) view's pose."""
        return self.views[0].pose if self.views else None

    @property
    def priors(self) -> np.ndarray:
        """The reference view's evidence (½: occluded or not judged)."""
        return self.views[0].priors

    @property
    def visible(self) -> np.ndarray | None:
        """The reference view's visibility."""
        return self.views[0].visible

    @property
    def confident(self) -> bool | None:
        """The δ* test passed and no view is in doubt: its pose choice was not a near
        coin toss, the log ends it puts on the extent's boundary were not seen to be
        missing, and its detections did not have to be shifted far towards absent to
        agree with the estimate. An estimate can be sure of its unseen logs only as far
        as it is sure where the grid lies. Nor is an estimate from photographs that
        builds nothing (:attr:`builds_nothing`). None without a confidence test."""
        if self.confidence is None:
            return None
        return bool(self.confidence.confident) and not self._in_doubt()

    @property
    def confident_by_delta_star(self) -> bool | None:
        """:attr:`confident` with the δ* test alone (the paper's), whether or not the
        reading test was run and passed. None without a confidence test."""
        if self.confidence is None:
            return None
        return self.confidence.passes_delta_star and not self._in_doubt()

    @property
    def builds_nothing(self) -> bool:
        """The estimate has no log though it was made from photographs. They show an
        assembly on its extent, so the grid (or the extent) must be off it: seen at a
        pose a few centimetres off, a small assembly's features all look absent, and an
        empty grid explains that view as well as any. (Bare evidence may be empty.)"""
        s = self.structure
        return (s is not None and not s.logs
                and any(v.pose is not None for v in self.views))

    def _in_doubt(self) -> bool:
        return self.builds_nothing or any(v.in_doubt for v in self.views)

    def logs_seen(self) -> np.ndarray:
        """Per log of the structure, whether some view judged one of its own features."""
        s = self.structure
        if s is None:
            return np.zeros(0, dtype=bool)
        seen = np.zeros(len(s.logs), dtype=bool)
        for v in self.views:  # every view's priors are in the reference view's grid
            seen |= log_support(s, v.priors)
        return seen


# ---- the file ---------------------------------------------------------------------------

class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid")


class PoseJSON(_Model):
    x: float = Field(description="mm, table frame")
    z: float = Field(description="mm, table frame")
    yaw_deg: float


class PoseFitJSON(_Model):
    source: Literal["given", "estimated", "shared"]
    quality: float | None = Field(None, description="pose fit quality in [0, 1]")
    choice_margin: float | None = Field(
        None, description="how clearly the structure choice picked the pose among the "
                          "grid's aliases")
    ambiguous: bool = False
    rival: PoseJSON | None = None
    searched_again: bool = False
    changed_by_second_search: bool = False
    polish_gain: tuple[float, float] | None = None
    moved_by_polish: bool = False


class ViewJSON(_Model):
    source: str | None = Field(None, description="the view file")
    pose: PoseJSON | None = None
    orientation: int = Field(0, description="quarter turns relative to the reference view")
    removed_from_layer: int | None = None
    pose_fit: PoseFitJSON | None = None
    visible_features: int | None = Field(None, description="features visible and judged")
    presence_shift: float = 0.0
    edge_ends_judged: int = 0
    edge_ends_absent: int = 0
    extent_doubt: bool = False
    evidence_doubt: bool = False
    features_outside_image: int = 0
    pose_offset: tuple[float, float] = Field(
        (0.0, 0.0), description="mm and degrees this view's own edges moved the shared pose")
    disagrees: bool = False
    registration_margin: float | None = Field(
        None, description="nats the chosen orientation beat the runner-up by")
    registration_doubt: bool = False


class ReadingTestJSON(_Model):
    confident: bool = Field(description="the estimate stays the MAP with every seen "
                                        "feature's reading moved `shift` against it")
    shift: float = Field(description="s*, log-odds")
    delta: float
    tolerance: float | None
    resolves: int


class ConfidenceJSON(_Model):
    confident: bool = Field(description="the δ* test, and the reading test when it was run "
                                        "(the estimate's `confident` also needs no view in "
                                        "doubt)")
    tolerance: float | None
    delta_star: float
    occluded_features: int
    readings: ReadingTestJSON | None = Field(
        default=None, description="the reading test, run when the δ* test passed")


class LogJSON(_Model):
    notches: int
    layer: int
    at: tuple[int, int]


class StructureJSON(_Model):
    format: Literal["unseeable/structure@1"]
    extent: tuple[int, int, int]
    logs: list[LogJSON]


class FeatureJSON(_Model):
    kind: Literal["end-", "end+", "u", "v", "w"]
    at: tuple[int, int, int]
    p: float = Field(description="the evidence in the reference view (0.5: none)")
    value: bool = Field(description="the feature's value under the estimate")
    visible: bool | None = None


class FixpointJSON(_Model):
    iterations: int
    converged: bool
    cycle_length: int
    history: list[dict[str, Any]] = []


class PlacementJSON(_Model):
    kind: Literal["wall", "door", "window"]
    along: Literal["i", "k"]
    plane: int
    at: int | None = None
    positions: tuple[int, int] | None = None
    layers: tuple[int, int]


class DescriptionJSON(_Model):
    sentences: list[str]
    placements: dict[str, PlacementJSON] = Field(
        description="per entity of the description, the placement the estimate chose")


class EstimateFile(_Model):
    """``unseeable/estimate@2``: what ``unseeable estimate`` writes."""

    format: Literal["unseeable/estimate@2"]
    status: Literal["optimal", "feasible", "infeasible", "timeout"]
    structure: StructureJSON | None
    log_probability: float | None = Field(description="null when no structure was found")
    bound: float | None = Field(description="proven upper bound (null: none proven)")
    backend: str
    pose: PoseJSON | None = Field(None, description="the reference (first) view's pose")
    confident: bool | None = None
    confidence: ConfidenceJSON | None = None
    settings: dict[str, Any]
    views: list[ViewJSON]
    fixpoint: FixpointJSON
    timings: dict[str, Any]
    choices: dict[str, bool] = {}
    description: DescriptionJSON | None = None
    logs_seen: list[bool] = []
    features: list[FeatureJSON] = []


def _finite(x: float) -> float | None:
    return float(x) if np.isfinite(x) else None


def _pose_json(pose: GridPose | None) -> dict | None:
    return None if pose is None else pose.to_json()


def _view_json(v: ViewRecord) -> dict[str, Any]:
    fit = None if v.pose_report is None else v.pose_report.to_json()
    return {"source": v.source, "pose": _pose_json(v.pose), "orientation": v.orientation,
            "removed_from_layer": v.removed_from_layer, "pose_fit": fit,
            "visible_features": None if v.visible is None
            else int(np.count_nonzero(v.visible & (v.priors != 0.5))),
            "presence_shift": float(v.presence_shift),
            "edge_ends_judged": int(v.edge_ends_judged),
            "edge_ends_absent": int(v.edge_ends_absent),
            "extent_doubt": bool(v.extent_doubt), "evidence_doubt": bool(v.evidence_doubt),
            "features_outside_image": int(v.features_outside_image),
            "pose_offset": [float(x) for x in v.pose_offset], "disagrees": bool(v.disagrees),
            "registration_margin": v.registration_margin,
            "registration_doubt": bool(v.registration_doubt)}


def estimate_to_json(estimate: Estimate, *, features: bool = True) -> dict[str, Any]:
    """The estimate file's content (``unseeable/estimate@2``, :class:`EstimateFile`)."""
    r = estimate.result
    c = estimate.confidence
    data: dict[str, Any] = {
        "format": ESTIMATE_FORMAT,
        "status": r.status.value,
        "structure": None if r.structure is None else structure_to_json(r.structure),
        "log_probability": _finite(r.log_probability),
        "bound": _finite(r.bound),
        "backend": r.backend,
        "pose": _pose_json(estimate.pose),
        "confident": estimate.confident,
        "confidence": None if c is None else {
            "confident": bool(c.confident), "tolerance": c.tolerance,
            "delta_star": c.delta_star, "occluded_features": int(c.occluded),
            "readings": None if c.readings is None else c.readings.to_json()},
        "settings": estimate.settings.to_json(),
        "views": [_view_json(v) for v in estimate.views],
        "fixpoint": {"iterations": estimate.iterations, "converged": estimate.converged,
                     "cycle_length": estimate.cycle_length, "history": estimate.history},
        "timings": {**estimate.timings, "solver": r.timings},
        "choices": dict(r.choices),
        "description": estimate.description,
    }
    if r.structure is not None:
        data["logs_seen"] = estimate.logs_seen().tolist()
    if features and r.structure is not None:
        s = r.structure
        idx = feature_index(s.extent)
        value = feature_values(s.extent, s.occupancy)
        vis = estimate.visible
        p = estimate.priors
        labels = [FeatureKind(int(k)).label for k in idx.kind]
        data["features"] = [
            {"kind": labels[n], "at": idx.at[n].tolist(), "p": float(p[n]),
             "value": bool(value[n]), **({} if vis is None else {"visible": bool(vis[n])})}
            for n in range(len(idx))]
    return data


def _validated(data: Any, *, file: Any) -> EstimateFile:
    if isinstance(data, dict) and data.get("format") not in (None, ESTIMATE_FORMAT):
        raise InputError(f"must be {ESTIMATE_FORMAT!r}", file=file, field="format",
                         value=data.get("format"))
    try:
        return EstimateFile.model_validate(data)
    except ValidationError as err:
        first = err.errors()[0]
        where = ".".join(str(part) for part in first["loc"]) or "(top level)"
        raise InputError(first["msg"].lower(), file=file, field=where,
                         value=first.get("input")) from None


def write_estimate(estimate: Estimate, out_dir: str | Path) -> Path:
    """Write ``out_dir/estimate.json`` atomically (checked against the schema first) and
    return its path."""
    path = Path(out_dir) / "estimate.json"
    data = estimate_to_json(estimate)
    _validated(data, file=path)
    write_json(path, data, indent=1)
    return path


def load_estimate(path: str | Path) -> EstimateFile:
    """Read an estimate file and validate it against ``unseeable/estimate@2``.

    Raises
    ------
    InputError
        Naming the file, the field and the value at fault.
    """
    return _validated(read_json(path), file=path)


def estimate_schema() -> dict[str, Any]:
    """The JSON schema of ``unseeable/estimate@2``."""
    return EstimateFile.model_json_schema()
