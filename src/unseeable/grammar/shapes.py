"""Walls, doors and windows as shapes on the occupancy grid (DESIGN.md §4 "Language").

Every shape is a rectangle of grid points in a vertical plane, its
*placement* (:class:`Placement`): a wall along ``i`` stands in a plane of
fixed ``k`` and its logs run on the even layers; a wall along ``k`` stands in a
plane of fixed ``i`` and its logs run on the odd layers (the *wall-axis*
layers). With ``c`` a position along the wall:

* **wall**: every grid point of the rectangle occupied; at least
  :data:`WALL_MIN_WIDTH` positions wide (so that its direction is defined) and
  :data:`WALL_MIN_HEIGHT` layers high.
* **door**: an opening one position wide at ``c`` (under the support
  constraints (c)/(d) a wider opening cannot carry its mantel), from layer 0
  up: every grid point of the opening EMPTY; the *mantel*, on the wall-axis
  layer just above the opening, one 3-notch log from ``c - 1`` to ``c + 1``;
  the *posts*, on every wall-axis layer inside the opening, the positions
  ``c - 1`` and ``c + 1`` occupied, each the end of its log on the opening's
  side (a 1-notch log qualifies). At least one post layer. The opening leads
  through the wall: the grid points in front of and behind it (across the
  plane, on the opening's layers) are EMPTY too, or outside the grid, so a gap
  between two logs' ends closed off front and back (a hollow in a tower's core)
  is no door.
* **window**: as a door, but its threshold, the wall-axis layer just below the
  opening, holds one 3-notch log from ``c - 1`` to ``c + 1``; it need not be
  at the bottom.

Each shape is a conjunction of literals ``Z_q ∈ codes`` (:func:`conditions`);
that list is the one definition, and everything else derives from it:
:func:`holds` checks it on an occupancy with numpy, :func:`shape_expr` states
it as a solver-neutral expression (one selector per placement lets a backend
solve "some door holds"), :func:`find_shapes` lists the placements that hold
in a structure, and the corpus's designer (:mod:`unseeable.corpus.plan`)
cuts doors and windows from the same conditions.

Examples
--------
A door one position wide between two 1-notch posts, under a 3-notch mantel:

>>> from unseeable.domain import Extent, Log, Structure
>>> logs = [Log(layer=j, at=(i, 0), notches=1) for j in (0, 1) for i in (0, 2)]
>>> s = Structure(Extent(3, 3, 1), [*logs, Log(layer=2, at=(0, 0), notches=3)])
>>> [p.to_json() for p in find_shapes(s)]
[{'kind': 'door', 'along': 'i', 'plane': 0, 'at': 1, 'layers': [0, 1]}]
>>> holds(Placement("door", "i", 0, 1, 0, 1), s)
True
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np

from unseeable.domain.grid import NUM_VALUES, Extent, occupancy_code
from unseeable.domain.structure import Log, Structure
from unseeable.errors import InputError
from unseeable.grammar.expr import (
    FIRST_NOTCH_CODES,
    LAST_NOTCH_CODES,
    NONEMPTY,
    And,
    Expr,
    Occ,
)

__all__ = [
    "SHAPE_KINDS",
    "WALL_MIN_WIDTH",
    "WALL_MIN_HEIGHT",
    "Placement",
    "Condition",
    "conditions",
    "check_placement",
    "placements",
    "holds",
    "find_shapes",
    "shape_expr",
    "span_logs",
]

#: The nouns of the language that are shapes.
SHAPE_KINDS = ("wall", "door", "window")
#: Fewest positions along a wall: one column has no direction (it lies in two planes).
WALL_MIN_WIDTH = 2
#: Fewest layers of a wall: a single course is a row of logs, not a wall.
WALL_MIN_HEIGHT = 2

_PARITY = {"i": 0, "k": 1}  # wall-axis layers: even for walls along i, odd along k
_EMPTY_CODES = frozenset({0})
_SPAN3 = tuple(frozenset({occupancy_code(3, n)}) for n in range(3))  # (3,0), (3,1), (3,2)

Position = tuple[int, int, int]


@dataclass(frozen=True)
class Placement:
    """Where a wall, door or window lies: a rectangle of grid points in a vertical plane.

    Attributes
    ----------
    kind : {"wall", "door", "window"}
    along : {"i", "k"}
        Direction of the wall's logs: ``"i"`` for a plane of fixed ``k`` (logs on
        even layers), ``"k"`` for a plane of fixed ``i`` (logs on odd layers).
    plane : int
        The plane's fixed coordinate (``k`` for ``along="i"``, ``i`` for ``"k"``).
    at : int
        First position along the wall the rectangle covers; for a door or window,
        the opening's position.
    bottom, top : int
        First and last layer of the rectangle: a wall's occupied layers, an
        opening's EMPTY ones.
    width : int
        Positions along the wall (1 for a door or window).

    Examples
    --------
    >>> p = Placement("window", "k", 0, 2, 2, 4)
    >>> p.threshold, p.mantel, list(p.positions)
    (1, 5, [2])
    """

    kind: str
    along: str
    plane: int
    at: int
    bottom: int
    top: int
    width: int = 1

    def __post_init__(self) -> None:
        if self.kind not in SHAPE_KINDS:
            raise InputError(f"must be one of {', '.join(SHAPE_KINDS)}", field="kind",
                             value=self.kind)
        if self.along not in _PARITY:
            raise InputError('must be "i" or "k"', field="along", value=self.along)
        for name in ("plane", "at", "bottom", "top", "width"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
                raise InputError("must be a whole number", field=name, value=value)
            object.__setattr__(self, name, int(value))

    @property
    def positions(self) -> range:
        """Positions along the wall the rectangle covers."""
        return range(self.at, self.at + self.width)

    @property
    def layers(self) -> range:
        """Layers the rectangle covers."""
        return range(self.bottom, self.top + 1)

    @property
    def mantel(self) -> int | None:
        """Layer of a door's or window's mantel log (None for a wall)."""
        return None if self.kind == "wall" else self.top + 1

    @property
    def threshold(self) -> int | None:
        """Layer of a window's threshold log (None for a wall or a door)."""
        return self.bottom - 1 if self.kind == "window" else None

    def point(self, t: int, j: int) -> Position:
        """The grid point ``(i, j, k)`` at position ``t`` along the wall on layer ``j``."""
        return (t, j, self.plane) if self.along == "i" else (self.plane, j, t)

    def to_json(self) -> dict[str, Any]:
        """``{"kind", "along", "plane", "at", "layers": [bottom, top]}``; a wall gives
        ``"positions": [first, last]`` instead of ``"at"``."""
        if self.kind == "wall":
            return {"kind": self.kind, "along": self.along, "plane": self.plane,
                    "positions": [self.at, self.at + self.width - 1],
                    "layers": [self.bottom, self.top]}
        return {"kind": self.kind, "along": self.along, "plane": self.plane, "at": self.at,
                "layers": [self.bottom, self.top]}


@dataclass(frozen=True)
class Condition:
    """One literal of a shape: ``Z_q ∈ codes``.

    Attributes
    ----------
    part : {"wall", "opening", "mantel", "threshold", "post", "side"}
        Which part of the shape the grid point belongs to ("side": in front of or
        behind an opening, across the wall's plane; may lie outside the grid).
    q : (i, j, k)
    codes : frozenset of int
        Allowed occupancy codes.
    """

    part: str
    q: Position
    codes: frozenset


def _shape_problem(p: Placement) -> str | None:
    """Why ``p`` is no shape whatever the grid (None when it is one)."""
    if p.bottom < 0 or p.top < p.bottom:
        return "its layers must run upwards from layer 0 or above"
    if p.kind == "wall":
        if p.width < WALL_MIN_WIDTH or p.top - p.bottom + 1 < WALL_MIN_HEIGHT:
            return (f"a wall is at least {WALL_MIN_WIDTH} positions wide and "
                    f"{WALL_MIN_HEIGHT} layers high")
        return None
    parity = _PARITY[p.along]
    if p.width != 1:
        return f"a {p.kind} is one position wide"
    if p.kind == "door" and p.bottom != 0:
        return "a door's opening starts on layer 0"
    if p.kind == "window" and p.bottom < 1:
        return "a window's threshold log lies below its opening"
    if p.mantel % 2 != parity or (p.kind == "window" and p.threshold % 2 != parity):
        return (f"the mantel and threshold of a {p.kind} in a wall along {p.along} lie on "
                f"{'even' if parity == 0 else 'odd'} layers")
    if not any(j % 2 == parity for j in p.layers):
        return f"the {p.kind} has no post layer (no layer of the wall's logs inside it)"
    return None


def check_placement(placement: Placement, extent: Extent | None = None) -> Placement:
    """``placement`` when it is a shape (inside ``extent``, when given); else InputError.

    Parameters
    ----------
    placement : Placement
    extent : Extent, optional
        The shape and the logs it needs (mantel, threshold, posts) must lie inside it.

    Returns
    -------
    Placement

    Raises
    ------
    InputError
        Naming the rule the placement breaks.

    Examples
    --------
    >>> try:
    ...     check_placement(Placement("door", "k", 0, 1, 0, 0))
    ... except InputError as err:
    ...     print(err.message)
    the door has no post layer (no layer of the wall's logs inside it)
    """
    problem = _shape_problem(placement)
    if problem is None and extent is not None:
        # The points beside an opening may lie outside the grid (EMPTY there).
        if any(not extent.contains(c.q) for c in conditions(placement) if c.part != "side"):
            problem = f"the {placement.kind} and its logs do not fit the grid {extent.shape}"
    if problem is not None:
        p = placement
        raise InputError(problem, field="placement",
                         value=f"{p.kind} along {p.along}, plane {p.plane}, at {p.at}"
                               + (f"..{p.at + p.width - 1}" if p.width > 1 else "")
                               + f", layers {p.bottom}-{p.top}")
    return placement


@lru_cache(maxsize=65536)
def conditions(placement: Placement) -> tuple[Condition, ...]:
    """The literals whose conjunction is the shape: the one definition of each kind.

    Parameters
    ----------
    placement : Placement

    Returns
    -------
    tuple of Condition
        In the order: wall points; or opening points (bottom up), threshold log,
        mantel log, posts (bottom up, low side first), the points beside the
        opening (bottom up, the lower plane first).

    Examples
    --------
    >>> [(c.part, c.q, sorted(c.codes)) for c in conditions(Placement("door", "i", 0, 1, 0, 1))
    ...  ][:3]
    [('opening', (1, 0, 0), [0]), ('opening', (1, 1, 0), [0]), ('mantel', (0, 2, 0), [4])]
    """
    problem = _shape_problem(placement)
    if problem is not None:
        check_placement(placement)  # raises with the placement named
    p = placement
    if p.kind == "wall":
        return tuple(Condition("wall", p.point(t, j), NONEMPTY)
                     for j in p.layers for t in p.positions)
    c = p.at
    out = [Condition("opening", p.point(c, j), _EMPTY_CODES) for j in p.layers]
    spans = ([("threshold", p.threshold)] if p.kind == "window" else []) + [("mantel", p.mantel)]
    for part, j in spans:
        out += [Condition(part, p.point(c - 1 + n, j), _SPAN3[n]) for n in range(3)]
    parity = _PARITY[p.along]
    for j in p.layers:
        if j % 2 == parity:
            # Each post is the end of its log on the opening's side.
            out += [Condition("post", p.point(c - 1, j), LAST_NOTCH_CODES),
                    Condition("post", p.point(c + 1, j), FIRST_NOTCH_CODES)]
    # The opening leads through the wall: EMPTY in front of and behind it.
    for j in p.layers:
        i, _, k = p.point(c, j)
        for side in (-1, 1):
            q = (i, j, k + side) if p.along == "i" else (i + side, j, k)
            out.append(Condition("side", q, _EMPTY_CODES))
    return tuple(out)


def span_logs(placement: Placement) -> tuple[tuple[str, Log], ...]:
    """The 3-notch logs a door or window needs, as ``(part, log)``: threshold, mantel.

    Examples
    --------
    >>> span_logs(Placement("door", "k", 3, 2, 0, 2))
    (('mantel', Log(layer=3, at=(3, 1), notches=3)),)
    """
    out = []
    for cond in conditions(placement):
        if cond.part in ("threshold", "mantel") and cond.codes == _SPAN3[0]:
            i, j, k = cond.q
            out.append((cond.part, Log(layer=j, at=(i, k), notches=3)))
    return tuple(out)


def _line_lengths(extent: Extent, along: str) -> tuple[int, int]:
    """(number of planes, positions along a wall) for walls along ``along``."""
    return (extent.K, extent.I) if along == "i" else (extent.I, extent.K)


@lru_cache(maxsize=256)
def _placements(extent: Extent, kind: str) -> tuple[Placement, ...]:
    out: list[Placement] = []
    J = extent.J
    for along in ("i", "k"):
        planes, length = _line_lengths(extent, along)
        parity = _PARITY[along]
        axis_layers = [j for j in range(J) if j % 2 == parity]
        for plane in range(planes):
            if kind == "wall":
                out += [Placement("wall", along, plane, at, bottom, top, width)
                        for at in range(length)
                        for width in range(WALL_MIN_WIDTH, length - at + 1)
                        for bottom in range(J)
                        for top in range(bottom + WALL_MIN_HEIGHT - 1, J)]
                continue
            for at in range(1, length - 1):
                for mantel in axis_layers:
                    lows = [0] if kind == "door" else [t + 1 for t in axis_layers if t < mantel]
                    for bottom in lows:
                        p = Placement(kind, along, plane, at, bottom, mantel - 1)
                        if _shape_problem(p) is None:
                            out.append(p)
    return tuple(sorted(out, key=_order))


def _order(p: Placement) -> tuple:
    return (p.along, p.plane, p.at, p.bottom, p.top, SHAPE_KINDS.index(p.kind), p.width)


def _as_extent(extent: Extent | tuple[int, int, int]) -> Extent:
    return extent if isinstance(extent, Extent) else Extent(*extent)


def placements(extent: Extent | tuple[int, int, int], kind: str) -> tuple[Placement, ...]:
    """Every placement of a ``kind`` of shape that fits ``extent``.

    Parameters
    ----------
    extent : Extent or (I, J, K)
    kind : {"wall", "door", "window"}

    Returns
    -------
    tuple of Placement
        In plane order: walls along ``i`` first, then by plane, position and layers.

    Examples
    --------
    >>> [(p.at, p.mantel) for p in placements((3, 5, 1), "door")]
    [(1, 2), (1, 4)]
    >>> len(placements((3, 5, 1), "window")), len(placements((3, 2, 1), "wall"))
    (1, 3)
    """
    if kind not in SHAPE_KINDS:
        raise InputError(f"must be one of {', '.join(SHAPE_KINDS)}", field="kind", value=kind)
    return _placements(_as_extent(extent), kind)


def _occupancy(structure_or_occupancy: Structure | np.ndarray) -> np.ndarray:
    if isinstance(structure_or_occupancy, Structure):
        return structure_or_occupancy.occupancy
    z = np.asarray(structure_or_occupancy)
    if z.ndim < 3 or not np.issubdtype(z.dtype, np.integer):
        raise InputError("must be a Structure or an integer occupancy (..., I, J, K)",
                         field="occupancy", value=getattr(z, "shape", None))
    return z


@lru_cache(maxsize=65536)
def _literal_arrays(placement: Placement) -> tuple[np.ndarray, np.ndarray]:
    """(N, 3) positions and (N, 7) allowed-code masks of the shape's literals."""
    conds = conditions(placement)
    q = np.array([c.q for c in conds], dtype=np.intp).reshape(-1, 3)
    mask = np.zeros((len(conds), NUM_VALUES), dtype=bool)
    for n, c in enumerate(conds):
        mask[n, list(c.codes)] = True
    q.setflags(write=False)
    mask.setflags(write=False)
    return q, mask


def _literals_hold(q: np.ndarray, mask: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Truth of each literal under ``z`` (..., I, J, K): (..., N) bool; outside the
    grid a position is EMPTY."""
    shape = np.array(z.shape[-3:])
    inside = ((q >= 0) & (q < shape)).all(axis=1)
    qi = np.where(inside[:, None], q, 0)
    codes = z[..., qi[:, 0], qi[:, 1], qi[:, 2]]
    codes = np.where(inside, codes, 0)
    return mask[np.arange(len(q)), codes]


def holds(placement: Placement, structure_or_occupancy: Structure | np.ndarray
          ) -> bool | np.ndarray:
    """Whether the shape stands at ``placement`` in a structure (or a batch of occupancies).

    Parameters
    ----------
    placement : Placement
    structure_or_occupancy : Structure or (..., I, J, K) int
        Positions outside the grid are EMPTY.

    Returns
    -------
    bool, or (...) bool for a batch of occupancies

    Examples
    --------
    >>> import numpy as np
    >>> z = np.zeros((3, 2, 1), dtype=np.int8)
    >>> holds(Placement("wall", "i", 0, 0, 0, 1, width=3), z)
    False
    >>> holds(Placement("wall", "i", 0, 0, 0, 1, width=3), z + 1)
    True
    """
    z = _occupancy(structure_or_occupancy)
    q, mask = _literal_arrays(placement)
    out = _literals_hold(q, mask, z).all(axis=-1)
    return bool(out) if out.ndim == 0 else out


def _kinds(kind: str | Iterable[str] | None) -> tuple[str, ...]:
    if kind is None:
        return SHAPE_KINDS
    kinds = (kind,) if isinstance(kind, str) else tuple(kind)
    for k in kinds:
        if k not in SHAPE_KINDS:
            raise InputError(f"must be one of {', '.join(SHAPE_KINDS)}", field="kind", value=k)
    return kinds


@lru_cache(maxsize=256)
def _compiled(extent: Extent, kind: str) -> tuple[tuple[Placement, ...], np.ndarray,
                                                   np.ndarray, np.ndarray]:
    """All placements of a kind with their literals stacked: (P placements, (M, 3)
    positions, (M, 7) masks, (M,) placement index of each literal)."""
    ps = _placements(extent, kind)
    arrays = [_literal_arrays(p) for p in ps]
    if not ps:
        return ps, np.zeros((0, 3), np.intp), np.zeros((0, NUM_VALUES), bool), np.zeros(0, np.intp)
    q = np.concatenate([a[0] for a in arrays])
    mask = np.concatenate([a[1] for a in arrays])
    owner = np.repeat(np.arange(len(ps)), [len(a[0]) for a in arrays])
    return ps, q, mask, owner


def _maximal(found: list[Placement]) -> list[Placement]:
    """The walls no other wall of the same plane contains."""
    if not found:
        return found
    key = np.array([(0 if p.along == "i" else 1, p.plane) for p in found])
    lo = np.array([(p.at, p.bottom) for p in found])
    hi = np.array([(p.at + p.width - 1, p.top) for p in found])
    same = (key[:, None, :] == key[None, :, :]).all(axis=2)
    # contains[a, b]: wall a contains wall b.
    contains = same & (lo[:, None, :] <= lo[None, :, :]).all(axis=2) & (
        hi[:, None, :] >= hi[None, :, :]).all(axis=2)
    np.fill_diagonal(contains, False)
    return [p for p, inside in zip(found, contains.any(axis=0)) if not inside]


def find_shapes(structure: Structure, kind: str | Iterable[str] | None = None, *,
                maximal_walls: bool = True) -> list[Placement]:
    """Every placement of a shape that holds in ``structure``.

    Parameters
    ----------
    structure : Structure
    kind : {"wall", "door", "window"}, iterable of them, or None
        Which shapes to look for (None: all three).
    maximal_walls : bool
        Keep only the walls that no other wall found in the same plane contains
        (every sub-rectangle of a wall is a wall too). Doors and windows never
        contain one another.

    Returns
    -------
    list of Placement
        In plane order (walls along ``i`` first, then by plane, position and
        layers; a wall before an opening at the same place).

    Examples
    --------
    >>> from unseeable.domain import Extent, Log, Structure
    >>> s = Structure(Extent(2, 2, 1), [Log(layer=0, at=(0, 0), notches=2),
    ...                                 Log(layer=1, at=(0, 0), notches=1),
    ...                                 Log(layer=1, at=(1, 0), notches=1)])
    >>> [p.to_json() for p in find_shapes(s, "wall")]
    [{'kind': 'wall', 'along': 'i', 'plane': 0, 'positions': [0, 1], 'layers': [0, 1]}]
    """
    z = structure.occupancy
    found: list[Placement] = []
    for k in _kinds(kind):
        ps, q, mask, owner = _compiled(structure.extent, k)
        if not ps:
            continue
        failed = ~_literals_hold(q, mask, z)
        ok = np.bincount(owner, weights=failed, minlength=len(ps)) == 0
        hits = [p for p, good in zip(ps, ok) if good]
        found += _maximal(hits) if k == "wall" and maximal_walls else hits
    return sorted(found, key=_order)


def shape_expr(placement: Placement) -> Expr:
    """The shape as a solver-neutral expression over the occupancy: ``And`` of its literals.

    ``evaluate(shape_expr(p), occupancy) == holds(p, occupancy)`` for every
    placement and occupancy. "Some door holds" is ``Or`` over
    :func:`placements` (with a :class:`~unseeable.grammar.expr.Choice` per
    placement where the solver must say which).

    Examples
    --------
    >>> from unseeable.grammar.expr import evaluate
    >>> import numpy as np
    >>> e = shape_expr(Placement("wall", "k", 0, 0, 0, 1, width=2))
    >>> bool(evaluate(e, np.ones((1, 2, 2), dtype=np.int8)))
    True
    """
    return And(*(Occ(c.q, c.codes) for c in conditions(placement)))
