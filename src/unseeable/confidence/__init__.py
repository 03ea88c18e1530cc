"""Structure-estimation confidence by estimation tolerance (paper §4, DESIGN.md §4)."""

from unseeable.confidence.readings import (
    READING_SHIFT,
    ReadingTest,
    assess_readings,
    reading_tolerance,
    seen_support,
)
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

__all__ = ["DELTA_STAR", "MAX_DELTA", "READING_SHIFT", "Confidence", "ReadingTest",
           "assess_confidence", "assess_readings", "crossing_shift", "reading_tolerance",
           "seen_support",
           "estimate_changes", "estimation_tolerance", "occluded_features", "rival_under_shift",
           "shifted_term"]
