"""Evaluation: the paper's error metric, error histograms and confidence outcomes."""

from unseeable.evaluate.metric import (
    Comparison,
    compare_structures,
    count_errors,
    error_histogram,
    match_features,
)

__all__ = ["Comparison", "compare_structures", "count_errors", "error_histogram", "match_features"]
