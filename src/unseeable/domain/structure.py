"""Structures: a set of logs on the grid, and the same as a 7-valued occupancy array.

A :class:`Structure` is the unit every stage exchanges. It is immutable and
always satisfies the grid constraints (logs on the grid, not overlapping);
grammar validity (support, constraints (c)–(d)) is checked by
:func:`grammar_violations` / :func:`is_valid` and enforced when loading files.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from unseeable.domain.grid import (
    EMPTY,
    NOTCH_INDEX,
    NOTCHES,
    Extent,
    occupancy_code,
)
from unseeable.errors import InputError

__all__ = ["Log", "Structure", "grammar_violations", "is_valid", "supported_mask"]


@dataclass(frozen=True, order=True)
class Log:
    """One log: ``notches`` (1–3) on ``layer`` j with notch 0 at grid ``at = (i, k)``.

    The log occupies ``(i + n, j, k)`` for n < notches on even layers and
    ``(i, j, k + n)`` on odd layers.
    """

    layer: int
    at: tuple[int, int]
    notches: int

    def __post_init__(self) -> None:
        if isinstance(self.notches, bool) or self.notches not in (1, 2, 3):
            raise InputError("a log has 1, 2 or 3 notches", field="notches", value=self.notches)
        object.__setattr__(self, "at", (int(self.at[0]), int(self.at[1])))
        object.__setattr__(self, "layer", int(self.layer))
        object.__setattr__(self, "notches", int(self.notches))

    def positions(self) -> list[tuple[int, int, int]]:
        """Grid positions of the notches, from notch 0."""
        i, k = self.at
        j = self.layer
        if j % 2 == 0:
            return [(i + n, j, k) for n in range(self.notches)]
        return [(i, j, k + n) for n in range(self.notches)]

    def describe(self) -> str:
        return f"{self.notches}-notch log on layer {self.layer} at [{self.at[0]}, {self.at[1]}]"


def _sorted_logs(logs) -> tuple[Log, ...]:
    return tuple(sorted(logs))


@dataclass(frozen=True, eq=False)
class Structure:
    """A Lincoln Log assembly on a grid of a given extent.

    Parameters
    ----------
    extent : Extent
    logs : sequence of Log
        Kept sorted (layer, at, notches), so equal structures compare equal.

    Raises
    ------
    InputError
        When a log runs off the grid or two logs overlap; the message names the log.

    Examples
    --------
    >>> s = Structure(Extent(3, 1, 1), [Log(layer=0, at=(0, 0), notches=3)])
    >>> s.occupancy[:, 0, 0].tolist()
    [4, 5, 6]
    >>> Structure.from_occupancy(s.extent, s.occupancy) == s
    True
    """

    extent: Extent
    logs: tuple[Log, ...] = field(default=())

    def __post_init__(self) -> None:
        object.__setattr__(self, "logs", _sorted_logs(self.logs))
        owner: dict[tuple[int, int, int], int] = {}
        for idx, log in enumerate(self.logs):
            for q in log.positions():
                if not self.extent.contains(q):
                    raise InputError(f"runs off the grid (extent {self.extent})",
                                     field=f"logs[{idx}]", value=log.describe())
                if q in owner:
                    other = self.logs[owner[q]]
                    raise InputError(f"overlaps {other.describe()} at {list(q)}",
                                     field=f"logs[{idx}]", value=log.describe())
                owner[q] = idx

    # -- conversions -------------------------------------------------------
    @cached_property
    def occupancy(self) -> np.ndarray:
        """Occupancy codes, ``(I, J, K) int8`` (read-only)."""
        z = np.zeros(self.extent.shape, dtype=np.int8)
        for log in self.logs:
            for n, q in enumerate(log.positions()):
                z[q] = occupancy_code(log.notches, n)
        z.setflags(write=False)
        return z

    @classmethod
    def from_occupancy(cls, extent: Extent, occupancy: np.ndarray) -> Structure:
        """Read logs off an ``(I, J, K)`` occupancy array.

        Raises
        ------
        InputError
            When the array has the wrong shape or values, or a log's notches are
            incomplete (e.g. a (2,0) whose next position is not (2,1)).
        """
        z = np.asarray(occupancy)
        if z.shape != extent.shape:
            raise InputError(f"occupancy must have shape {extent.shape}", field="occupancy",
                             value=z.shape)
        if z.size and (z.min() < 0 or z.max() > 6):
            raise InputError("occupancy codes are 0..6", field="occupancy",
                             value=int(z.min() if z.min() < 0 else z.max()))
        # The logs the first notches start; when they give z back, z is sound.
        starts = np.argwhere((z > 0) & (NOTCH_INDEX[np.clip(z, 0, 6)] == 0))
        logs = [Log(layer=j, at=(i, k), notches=m) for (i, j, k), m
                in zip(starts.tolist(), NOTCHES[z[tuple(starts.T)]].tolist())]
        try:
            s = cls(extent, logs)
        except InputError:  # a log off the grid or over another: incomplete, named below
            s = None
        if s is not None and np.array_equal(s.occupancy, z):
            return s
        # Not sound: name the first fault.
        for log in logs:
            for n, p in enumerate(log.positions()):
                if not extent.contains(p) or z[p] != occupancy_code(log.notches, n):
                    raise InputError(f"incomplete {log.notches}-notch log starting at "
                                     f"{list(log.positions()[0])}", field="occupancy")
        bad = np.argwhere(s.occupancy != z)[0]
        raise InputError(f"notch without its log's first notch at {bad.tolist()}",
                         field="occupancy")

    # -- comparisons -------------------------------------------------------
    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Structure):
            return NotImplemented
        return self.extent == other.extent and self.logs == other.logs

    def __hash__(self) -> int:
        return hash((self.extent, self.logs))

    def __len__(self) -> int:
        return len(self.logs)

    def with_logs(self, logs) -> Structure:
        return Structure(self.extent, tuple(logs))

    def removed_from_layer(self, layer: int) -> Structure:
        """The structure after the arm removed every log on layers ``>= layer``."""
        return self.with_logs(log for log in self.logs if log.layer < layer)

    def in_extent(self, extent: Extent) -> Structure:
        """The same logs on another (e.g. larger) grid."""
        return Structure(extent, self.logs)

    def __repr__(self) -> str:
        return f"Structure(extent={self.extent}, logs={len(self.logs)})"


def supported_mask(z: np.ndarray) -> np.ndarray:
    """Positions with something directly below them (layer 0: the table).

    Parameters
    ----------
    z : (I, J, K) int
        Occupancy codes.

    Returns
    -------
    (I, J, K) bool
    """
    support = np.ones(z.shape, dtype=bool)
    support[:, 1:, :] = z[:, :-1, :] != EMPTY
    return support


def grammar_violations(structure: Structure) -> list[str]:
    """Logs that break support constraints (c) or (d), each as one message.

    (a) and (b) hold by construction for a :class:`Structure`.
    """
    sup = supported_mask(structure.occupancy)
    problems = []
    for idx, log in enumerate(structure.logs):
        if log.layer == 0:
            continue
        held = sum(bool(sup[q]) for q in log.positions())
        need = 2 if log.notches == 3 else log.notches
        if held < need:
            problems.append(
                f"logs[{idx}]: {log.describe()} is supported at {held} of its notches "
                f"(needs {need})"
            )
    return problems


def is_valid(structure: Structure) -> bool:
    """Whether ``structure`` satisfies the grammar Φ (constraints (a)–(d)).

    Examples
    --------
    >>> e = Extent(2, 2, 2)
    >>> is_valid(Structure(e, [Log(layer=1, at=(0, 0), notches=1)]))
    False
    """
    return not grammar_violations(structure)
