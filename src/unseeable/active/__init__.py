"""Active vision (paper §5): choose the next view or disassembly that most changes the
estimate, until it is sure.

:func:`plan_action` finds, among candidate :class:`Action` s, the one with the smallest
δ′ (the least imagined evidence in its photograph that would change the estimate);
:func:`run_active` is the loop, with a simulated robot (:class:`WorkspaceSource`) or a
pool of photographs (:class:`PhotographPool`) to execute the actions.
"""

from unseeable.active.actions import Action, revealed_features, unseen_features
from unseeable.active.files import (
    ACTIVE_FORMAT,
    active_from_files,
    active_in_workspace,
    active_strip,
    crop_to_assembly,
    write_active,
)
from unseeable.active.planner import (
    RESOLUTION,
    ActionBounds,
    ActionPlan,
    per_action_search,
    plan_action,
)
from unseeable.active.run import STOP_REASONS, ActiveRun, ActiveStep, run_active
from unseeable.active.sources import ActionSource, PhotographPool, WorkspaceSource, pool_actions

__all__ = ["ACTIVE_FORMAT", "Action", "ActionBounds", "ActionPlan", "ActionSource",
           "ActiveRun", "ActiveStep", "PhotographPool", "RESOLUTION", "STOP_REASONS",
           "WorkspaceSource", "active_from_files", "active_in_workspace", "active_strip",
           "crop_to_assembly", "per_action_search", "plan_action", "pool_actions",
           "revealed_features", "run_active", "unseen_features", "write_active"]
