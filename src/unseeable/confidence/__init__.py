"""Structure-estimation confidence by estimation tolerance (paper §4, DESIGN.md §4)."""

from unseeable.confidence.tolerance import (
    DELTA_STAR,
    Confidence,
    assess_confidence,
    estimate_changes,
    estimation_tolerance,
    occluded_features,
    shifted_term,
)

__all__ = ["DELTA_STAR", "Confidence", "assess_confidence", "estimate_changes",
           "estimation_tolerance", "occluded_features", "shifted_term"]
