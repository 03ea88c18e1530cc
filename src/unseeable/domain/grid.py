"""The symbolic grid (DESIGN.md §2): extents, occupancy codes, neighbours.

Occupancy codes are small integers so that whole structures are ``int8``
arrays of shape ``(I, J, K)``:

====  ========  =====================
code  (m, n)    meaning
====  ========  =====================
0     EMPTY     no log
1     (1, 0)    1-notch log
2     (2, 0)    first notch of a 2-notch log
3     (2, 1)    second notch of a 2-notch log
4     (3, 0)    first notch of a 3-notch log
5     (3, 1)    middle notch of a 3-notch log
6     (3, 2)    last notch of a 3-notch log
====  ========  =====================
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from unseeable.errors import InputError

__all__ = [
    "Extent",
    "EMPTY",
    "OCCUPANCY",
    "NUM_VALUES",
    "NOTCHES",
    "NOTCH_INDEX",
    "FIRST_NOTCH",
    "LAST_NOTCH",
    "SPANS_NEXT",
    "occupancy_code",
    "MAX_DIM",
    "MAX_POSITIONS",
]

EMPTY = 0
#: (m, n) for each code; EMPTY is (0, 0).
OCCUPANCY: tuple[tuple[int, int], ...] = ((0, 0), (1, 0), (2, 0), (2, 1), (3, 0), (3, 1), (3, 2))
NUM_VALUES = len(OCCUPANCY)
#: number of notches of the log at each code (0 for EMPTY), shape (7,)
NOTCHES = np.array([m for m, _ in OCCUPANCY], dtype=np.int8)
#: notch index of each code (-1 for EMPTY), shape (7,)
NOTCH_INDEX = np.array([n if m else -1 for m, n in OCCUPANCY], dtype=np.int8)
#: codes that are a log's first notch (log end on the low-index side), shape (7,) bool
FIRST_NOTCH = np.array([False, True, True, False, True, False, False])
#: codes that are a log's last notch (log end on the high-index side), shape (7,) bool
LAST_NOTCH = np.array([False, True, False, True, False, False, True])
#: codes whose log continues to n(q), shape (7,) bool
SPANS_NEXT = np.array([False, False, True, False, True, True, False])

#: Largest accepted size of one grid dimension.
MAX_DIM = 64
#: Largest accepted number of grid positions (I*J*K).
MAX_POSITIONS = 4096


def occupancy_code(notches: int, notch: int) -> int:
    """Code of the ``notch``-th notch (from 0) of a ``notches``-notch log.

    Examples
    --------
    >>> occupancy_code(3, 1)
    5
    """
    try:
        return OCCUPANCY.index((int(notches), int(notch)))
    except ValueError:
        raise InputError("no such occupancy (m, n)", value=(notches, notch)) from None


@dataclass(frozen=True)
class Extent:
    """Size of the symbolic grid: ``I`` and ``K`` horizontal, ``J`` layers.

    Layer ``j``'s logs run along ``i`` when ``j`` is even and along ``k`` when
    ``j`` is odd.

    Examples
    --------
    >>> e = Extent(4, 3, 5)
    >>> e.shape, e.positions
    ((4, 3, 5), 60)
    >>> e.axis(0), e.axis(1)
    (0, 2)
    """

    I: int
    J: int
    K: int

    def __post_init__(self) -> None:
        for name in ("I", "J", "K"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
                raise InputError("must be a whole number", field=f"extent.{name}", value=value)
            if not 1 <= value <= MAX_DIM:
                raise InputError(f"must be between 1 and {MAX_DIM}",
                                 field=f"extent.{name}", value=value)
            object.__setattr__(self, name, int(value))
        if self.I * self.J * self.K > MAX_POSITIONS:
            raise InputError(f"has more than {MAX_POSITIONS} grid positions",
                             field="extent", value=[self.I, self.J, self.K])

    @classmethod
    def parse(cls, value: object, *, field: str = "extent", file: object = None) -> Extent:
        """Build an extent from ``[I, J, K]`` or ``"I,J,K"``, with a clear error."""
        items = value
        if isinstance(value, str):
            items = [s.strip() for s in value.replace("x", ",").split(",")]
            try:
                items = [int(s) for s in items]
            except ValueError:
                raise InputError("must be three whole numbers I,J,K", file=file, field=field,
                                 value=value) from None
        if not isinstance(items, (list, tuple)) or len(items) != 3:
            raise InputError("must be three whole numbers [I, J, K]", file=file, field=field,
                             value=value)
        try:
            return cls(*items)
        except InputError as err:
            raise InputError(err.message, file=file, field=err.field, value=err.value) from None

    @property
    def shape(self) -> tuple[int, int, int]:
        return (self.I, self.J, self.K)

    @property
    def positions(self) -> int:
        return self.I * self.J * self.K

    def as_list(self) -> list[int]:
        return [self.I, self.J, self.K]

    @staticmethod
    def axis(j: int) -> int:
        """Index (0 for i, 2 for k) of the axis along which layer ``j``'s logs run."""
        return 0 if j % 2 == 0 else 2

    def contains(self, q: tuple[int, int, int]) -> bool:
        i, j, k = q
        return 0 <= i < self.I and 0 <= j < self.J and 0 <= k < self.K

    @staticmethod
    def next(q: tuple[int, int, int]) -> tuple[int, int, int]:
        """n(q): the next position along the layer's axis."""
        i, j, k = q
        return (i + 1, j, k) if j % 2 == 0 else (i, j, k + 1)

    @staticmethod
    def below(q: tuple[int, int, int], levels: int = 1) -> tuple[int, int, int]:
        """b(q) (``levels=1``) or b(b(q)) (``levels=2``)."""
        i, j, k = q
        return (i, j - levels, k)

    def iter_positions(self) -> Iterator[tuple[int, int, int]]:
        for i in range(self.I):
            for j in range(self.J):
                for k in range(self.K):
                    yield (i, j, k)

    def __str__(self) -> str:
        return f"{self.I}x{self.J}x{self.K}"
