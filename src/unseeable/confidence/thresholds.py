"""The confidence tests' thresholds, shared by the δ* test and the reading test."""

from __future__ import annotations

__all__ = ["DELTA_STAR", "MAX_DELTA", "CHANGE_EPSILON"]

#: The paper's tolerance threshold δ*.
DELTA_STAR = 0.2
#: Largest shift tried: priors stay inside (0, 1).
MAX_DELTA = 0.499
#: Objective improvement that counts as a change (log-probability units).
CHANGE_EPSILON = 1e-7
