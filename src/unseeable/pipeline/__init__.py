"""The estimator, end to end: photographs or evidence in, an :class:`Estimate` out.

* :mod:`~unseeable.pipeline.settings` — :class:`EstimateSettings`, where every default lives;
* :mod:`~unseeable.pipeline.observation` — :class:`Observation`, one photograph;
* :mod:`~unseeable.pipeline.posing` — :func:`find_pose`, the one rule that chooses a pose;
* :mod:`~unseeable.pipeline.core` — :func:`estimate` (and :func:`estimate_view`,
  :func:`estimate_evidence`);
* :mod:`~unseeable.pipeline.joint` — one estimate from several photographs (one table
  frame, or independent views registered by symbolic orientation);
* :mod:`~unseeable.pipeline.record` — the typed :class:`Estimate` and its file,
  ``unseeable/estimate@2``;
* :mod:`~unseeable.pipeline.files` — estimates from files, against the truth, as pictures;
* :mod:`~unseeable.pipeline.demo` — the built-in demonstration.

Examples
--------
>>> from unseeable.pipeline import EstimateSettings, estimate_evidence
>>> from unseeable.domain import Extent, Log, Structure, simulate_evidence
>>> truth = Structure(Extent(2, 1, 2), [Log(0, (0, 0), 2), Log(0, (0, 1), 2)])
>>> est = estimate_evidence(simulate_evidence(truth, accuracy=1.0, occluded_fraction=0.0,
...                                           seed=0), EstimateSettings())
>>> est.structure == truth
True
"""

from unseeable.pipeline.core import estimate, estimate_evidence, estimate_view, extend_estimate
from unseeable.pipeline.demo import DemoResult, run_demo
from unseeable.pipeline.evidence_checks import (
    EDGE_ENDS_ABSENT_MIN,
    EDGE_ENDS_ABSENT_SHARE,
    PRESENCE_SHIFT_DOUBT,
    boundary_ends,
    line_aliases,
    log_support,
)
from unseeable.pipeline.files import (
    compare_with_truth,
    errors_against_truth,
    estimate_file,
    estimate_files,
    write_view_pictures,
)
from unseeable.pipeline.observation import Observation
from unseeable.pipeline.posing import PoseFinding, PoseReport, StructureAtPose, find_pose
from unseeable.pipeline.record import (
    ESTIMATE_FORMAT,
    Estimate,
    EstimateFile,
    EstimateModel,
    ViewRecord,
    estimate_schema,
    estimate_to_json,
    load_estimate,
    write_estimate,
)
from unseeable.pipeline.settings import (
    ConfidenceSettings,
    DetectionSettings,
    EstimateSettings,
    PoseRuleSettings,
    SolverSettings,
)

__all__ = [
    "estimate", "estimate_view", "estimate_evidence", "extend_estimate", "find_pose", "Observation",
    "EstimateSettings", "SolverSettings", "PoseRuleSettings", "DetectionSettings",
    "ConfidenceSettings", "Estimate", "ViewRecord", "EstimateModel", "PoseFinding",
    "PoseReport", "StructureAtPose", "ESTIMATE_FORMAT", "EstimateFile", "estimate_to_json",
    "write_estimate", "load_estimate", "estimate_schema", "estimate_file", "estimate_files",
    "write_view_pictures", "compare_with_truth", "errors_against_truth", "run_demo",
    "DemoResult", "log_support", "boundary_ends", "line_aliases", "EDGE_ENDS_ABSENT_MIN",
    "EDGE_ENDS_ABSENT_SHARE", "PRESENCE_SHIFT_DOUBT",
]
