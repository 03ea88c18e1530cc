"""Evaluation: the paper's error metric, error histograms and confidence outcomes."""

from unseeable.evaluate.metric import (
    ERROR_KINDS,
    Comparison,
    ErrorGroup,
    compare_structures,
    count_errors,
    error_histogram,
    match_features,
    snapped_pose,
)

__all__ = ["Comparison", "ERROR_KINDS", "ErrorGroup", "compare_structures", "count_errors",
           "error_histogram", "match_features", "snapped_pose"]
