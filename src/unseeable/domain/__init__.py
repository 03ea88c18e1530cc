"""The Lincoln Log domain: log geometry, the grid, structures, features, frames."""

from unseeable.domain.evidence import (
    Evidence,
    load_evidence,
    save_evidence,
    simulate_evidence,
)
from unseeable.domain.features import (
    FeatureIndex,
    FeatureKind,
    feature_axes,
    feature_index,
    feature_values,
)
from unseeable.domain.frames import (
    GridPose,
    half_turn_structure,
    lower_silhouette,
    rot_y,
    symbolic_orientations,
)
from unseeable.domain.geometry import LogGeometry
from unseeable.domain.grid import EMPTY, OCCUPANCY, Extent, occupancy_code
from unseeable.domain.io import (
    load_structure,
    save_structure,
    structure_from_json,
    structure_to_json,
)
from unseeable.domain.structure import Log, Structure, grammar_violations, is_valid

__all__ = [
    "EMPTY", "OCCUPANCY", "Extent", "occupancy_code", "LogGeometry", "Log", "Structure",
    "grammar_violations", "is_valid", "FeatureKind", "FeatureIndex", "feature_index",
    "feature_values", "feature_axes", "GridPose", "rot_y", "symbolic_orientations",
    "half_turn_structure", "lower_silhouette", "load_structure", "save_structure",
    "structure_from_json", "structure_to_json", "Evidence", "load_evidence", "save_evidence",
    "simulate_evidence",
]
