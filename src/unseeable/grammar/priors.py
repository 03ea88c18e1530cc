"""The prior over structures, as one named, validated choice.

The paper gives every valid structure the same prior. Builders do not build at
random: they bridge joints with whole logs, stagger joints from course to
course and rest logs on every notch they can. Where no camera sees, that
knowledge is the only evidence there is, so the shipped default ("builder")
charges a few nats for each thing builders avoid (:func:`~unseeable.grammar.
joint_prior`, :func:`~unseeable.grammar.stacked_joint_prior`,
:func:`~unseeable.grammar.unsupported_notch_prior`). ``"uniform"`` is the
paper's prior. Exact ties that remain (hidden courses nothing tells apart)
are broken by :attr:`StructurePrior.ties` (:mod:`unseeable.solve.ties`),
which never changes a structure's probability.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from unseeable.domain.grid import Extent
from unseeable.errors import InputError
from unseeable.grammar.objective import (
    Factor,
    check_prior_cost,
    joint_prior,
    seen_joints,
    stacked_joint_prior,
    unsupported_notch_prior,
)

__all__ = ["StructurePrior", "PRIOR_NAMES", "TIE_POLICY", "TIE_POLICY_NAMES"]

#: Of equally probable structures, the one with the fewest logs, then the longest:
#: hidden parts are built as walls are, of whole long logs.
TIE_POLICY = "fewest"
#: Every tie policy (:mod:`unseeable.solve.ties`): "any" keeps whichever the solver finds
#: (the paper's plain MAP), "emptiest" the fewest positions plus logs.
TIE_POLICY_NAMES = ("any", "emptiest", "fewest")

#: The named priors :meth:`StructurePrior.named` knows.
PRIOR_NAMES = ("builder", "uniform")

_COSTS = ("joint_cost", "stacked_joint_cost", "unsupported_notch_cost")


@dataclass(frozen=True)
class StructurePrior:
    """A prior over structures: the nats each builder's habit costs when broken.

    Attributes
    ----------
    joint_cost : float
        Nats a joint (two logs end to end on a line) costs, charged only where a
        camera sees the joint's edges (:func:`~unseeable.grammar.seen_joints`):
        elsewhere :attr:`ties` settles it.
    stacked_joint_cost : float
        Nats a joint straight above another on the same wall (two layers up) costs,
        seen or not.
    unsupported_notch_cost : float
        Nats a notch above layer 0 with nothing below it costs.
    ties : {"fewest", "emptiest", "any"}
        Which of exactly tied structures to keep (:class:`~unseeable.solve.
        StructureSolver`).

    Every cost is a number in ``[0, MAX_PRIOR_COST]``; all zero is the paper's uniform
    prior.

    Examples
    --------
    >>> StructurePrior.named("uniform").is_uniform
    True
    >>> from unseeable.domain import Extent
    >>> len(StructurePrior().factors(Extent(3, 1, 1)))  # two joints a line of 3 can have
    2
    """

    joint_cost: float = 1.0
    stacked_joint_cost: float = 1.0
    unsupported_notch_cost: float = 1.0
    ties: str = TIE_POLICY

    def __post_init__(self) -> None:
        for name in _COSTS:
            object.__setattr__(self, name, check_prior_cost(getattr(self, name), field=name))
        if self.ties not in TIE_POLICY_NAMES:
            raise InputError(f"must be one of {list(TIE_POLICY_NAMES)}", field="ties",
                             value=self.ties)

    @classmethod
    def named(cls, name: str, **overrides: Any) -> StructurePrior:
        """The prior called ``name`` (:data:`PRIOR_NAMES`), with some fields overridden.

        ``"builder"``: one nat for each of the three habits (the default). ``"uniform"``:
        every cost 0, the paper's prior.
        """
        if name == "builder":
            base = cls()
        elif name == "uniform":
            base = cls(joint_cost=0.0, stacked_joint_cost=0.0, unsupported_notch_cost=0.0)
        else:
            raise InputError(f"must be one of {', '.join(PRIOR_NAMES)}", field="prior",
                             value=name)
        fields = {**base.to_json(), **{k: v for k, v in overrides.items() if v is not None}}
        return cls(**fields)

    @property
    def is_uniform(self) -> bool:
        return all(getattr(self, name) == 0 for name in _COSTS)

    def factors(self, extent: Extent, *, seen: np.ndarray | None = None
                ) -> tuple[Factor, ...]:
        """The prior's factors on ``extent``; the joint cost only on joints after the
        positions ``seen`` ((I, J, K) bool, e.g. :func:`~unseeable.grammar.seen_joints`;
        default: every joint)."""
        return (joint_prior(extent, self.joint_cost, seen=seen)
                + stacked_joint_prior(extent, self.stacked_joint_cost)
                + unsupported_notch_prior(extent, self.unsupported_notch_cost))

    def given_visibility(
            self, extent: Extent
    ) -> Callable[[np.ndarray | Sequence[np.ndarray]], tuple[Factor, ...]] | tuple:
        """The prior as the visibility fixpoint takes it: a callable from a visibility
        (one ``(N,) bool`` per view) to the factors, the joint cost charged on the joints
        that visibility sees; ``()`` for the uniform prior."""
        if self.is_uniform:
            return ()
        fixed = self.factors(extent, seen=np.zeros(extent.shape, dtype=bool))

        def prior(visibility):
            return joint_prior(extent, self.joint_cost,
                               seen=seen_joints(extent, visibility)) + fixed
        return prior

    def to_json(self) -> dict[str, Any]:
        return {"joint_cost": self.joint_cost, "stacked_joint_cost": self.stacked_joint_cost,
                "unsupported_notch_cost": self.unsupported_notch_cost, "ties": self.ties}
