"""Structure-estimation confidence by estimation tolerance (paper §4, DESIGN.md §4)."""

from unseeable.confidence.tolerance import (
    DELTA_STAR,
    MAX_DELTA,
    Confidence,
    assess_confidence,
    crossing_shift,
    estimate_changes,
    estimation_tolerance,
    occluded_features,
    rival_under_shift,
    shifted_term,
)

__all__ = ["DELTA_STAR", "MAX_DELTA", "Confidence", "assess_confidence", "crossing_shift",
           "estimate_changes", "estimation_tolerance", "occluded_features", "rival_under_shift",
           "shifted_term"]
