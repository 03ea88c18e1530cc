"""The active-vision loop (paper §5): estimate → confident? stop : plan → act → re-estimate.

:func:`run_active` starts from one or more photographs, and while the estimate is not
confident it plans the next action (:func:`~unseeable.active.plan_action`: smallest
δ′), has the source execute it (the simulated robot renders it, a pool reads the
chosen file), adds the photograph to the joint estimate
(:func:`~unseeable.pipeline.extend_estimate`: the views taken keep their pose and
detections) and judges it again. It stops when the estimate is confident (the δ* test
over the features unseen in every view, no view in doubt), when no action has a
finite δ′ (nothing left to learn), or after ``max_actions``. Every step is recorded.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from unseeable.active.planner import RESOLUTION, ActionPlan, plan_action
from unseeable.errors import InputError, check_whole_number

__all__ = ["ActiveStep", "ActiveRun", "run_active", "STOP_REASONS"]

logger = logging.getLogger(__name__)

#: Why a run ended.
STOP_REASONS = ("confident", "nothing to learn", "max actions", "no actions")


@dataclass(frozen=True, eq=False)
class ActiveStep:
    """One step: the estimate after it, and the plan that chose the next action.

    Attributes
    ----------
    number : int
        0 for the starting photographs, then 1, 2, … per action taken.
    action : Action or None
        The action whose photograph this step added (None for step 0).
    estimate : Estimate
        The joint estimate after it.
    errors : int or None
        Against the truth, when known.
    plan : ActionPlan or None
        The plan made from this estimate (None when the run stopped here without one).
    seconds : float
        Estimating and planning in this step (not the source's rendering or reading).
    """

    number: int
    action: Any
    estimate: Any
    errors: int | None
    plan: ActionPlan | None
    seconds: float

    @property
    def confident(self) -> bool:
        return bool(self.estimate.confident)

    def to_json(self) -> dict:
        conf = self.estimate.confidence
        return {"step": self.number,
                "action": None if self.action is None else self.action.name,
                "station": None if self.action is None else self.action.station,
                "removed_from_layer": None if self.action is None
                else self.action.removed_from_layer,
                "logs": None if self.estimate.structure is None
                else len(self.estimate.structure.logs),
                "errors": self.errors, "confident": self.confident,
                "tolerance": None if conf is None else conf.tolerance,
                "plan": None if self.plan is None else self.plan.to_json(),
                "seconds": self.seconds}


@dataclass(frozen=True, eq=False)
class ActiveRun:
    """The outcome of :func:`run_active`: every step, why it stopped, the final estimate."""

    steps: tuple[ActiveStep, ...]
    stopped: str

    @property
    def estimate(self):
        return self.steps[-1].estimate

    @property
    def actions(self) -> list:
        return [s.action for s in self.steps[1:]]

    def to_json(self) -> dict:
        last = self.steps[-1]
        return {"format": "unseeable/active@1", "stopped": self.stopped,
                "actions_taken": len(self.steps) - 1, "confident": last.confident,
                "errors": last.errors, "steps": [s.to_json() for s in self.steps]}


def run_active(start: Sequence[Any], source, settings=None, *, max_actions: int = 10,
               truth=None, truth_pose=None, resolution: float = RESOLUTION,
               on_step: Callable[[ActiveStep], None] | None = None,
               first=None) -> ActiveRun:
    """Estimate, and take actions until the estimate is confident.

    Parameters
    ----------
    start : sequence of Observation
        The photographs taken before planning (the first is the reference view).
    source : ActionSource
        Lists the actions and executes the chosen one
        (:class:`~unseeable.active.WorkspaceSource`,
        :class:`~unseeable.active.PhotographPool`).
    settings : EstimateSettings, optional
        The estimator's (the shipped defaults); the confidence test must be on.
    max_actions : int
        Actions at most (>= 0).
    truth : Structure, optional
        To count each step's errors (never used to plan).
    truth_pose : GridPose, optional
        Where the truth stands (else where each estimate puts it).
    resolution : float
        δ′ closer than this are tied (:func:`~unseeable.active.plan_action`).
    on_step : callable, optional
        Called with each step as it completes (progress).
    first : Estimate, optional
        The estimate from ``start`` when the caller has made it already.

    Returns
    -------
    ActiveRun
    """
    from unseeable.pipeline import EstimateSettings, estimate, extend_estimate
    from unseeable.pipeline.files import errors_against_truth

    settings = EstimateSettings() if settings is None else settings
    if not settings.confidence.enabled:
        raise InputError("active vision needs the confidence test", field="confidence",
                         value="disabled")
    max_actions = check_whole_number(max_actions, field="max_actions", minimum=0)

    def errors_of(est) -> int | None:
        if truth is None:
            return None
        return errors_against_truth(est, truth, truth_pose=truth_pose)

    steps: list[ActiveStep] = []
    t0 = time.perf_counter()
    est = first if first is not None else estimate(list(start), settings)
    action = None
    while True:
        number = len(steps)
        plan = None
        stopped = None
        if est.structure is None:
            stopped = "nothing to learn"
        elif est.confident:
            stopped = "confident"
        elif number >= max_actions:
            stopped = "max actions"
        else:
            actions = source.available()
            if not actions:
                stopped = "no actions"
            else:
                plan = plan_action(est, actions, resolution=resolution)
                if plan.chosen is None:
                    stopped = "nothing to learn"
        step = ActiveStep(number, action, est, errors_of(est), plan,
                          time.perf_counter() - t0)
        steps.append(step)
        if on_step is not None:
            on_step(step)
        logger.info("step %d: %s, %d logs%s", number,
                    "confident" if step.confident else "not confident",
                    0 if est.structure is None else len(est.structure.logs),
                    "" if step.errors is None else f", {step.errors} errors")
        if stopped is not None:
            return ActiveRun(tuple(steps), stopped)
        action = plan.action
        observation = source.take(action)
        t0 = time.perf_counter()
        est = extend_estimate(est, [observation])
