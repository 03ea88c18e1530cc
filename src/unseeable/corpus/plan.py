"""Readable building blocks for designed structures: walls, doors, windows, blocks.

A :class:`Plan` collects *regions* — walls (a rectangle of grid points in a
vertical plane), solid blocks (a box of grid points, e.g. a crib, a hearth or a
roof deck) — and the *openings* cut into walls (doors, windows). Its
:meth:`Plan.build` turns the occupied grid points into logs:

* every occupied grid point belongs to exactly one region (its *owner*): the
  first declared region whose logs run along that layer's axis there, else the
  first declared region containing it (then it is a *cross* point of a wall,
  held by a 1-notch log crossing the wall, as in real Lincoln Log walls);
* each layer's lines are cut into runs of consecutive points of one owner, and
  each run is split into 1-, 2- and 3-notch logs: every split keeps the
  grammar's support constraints (c)/(d), honours forced logs (mantels and
  window thresholds), staggers joints against the same line two layers below
  (as a builder would) and uses as few logs as the stagger allows.

A region declared ``removable`` is left out when the support of the *other*
regions' logs is checked, so ``plan.build(without=(name,))`` — the same logs
minus that region's — is valid too (an inner wall that can be taken out).

Walls follow DESIGN.md §4 "Language": a wall along ``i`` lies in the plane of
fixed ``k`` and its logs run on the even layers; a wall along ``k`` lies in the
plane of fixed ``i`` and its logs run on the odd layers. A door is an opening
one position wide from layer 0 up to a mantel log spanning post to post; a
window is the same above a threshold log. Under constraints (c)/(d) an
opening is one position wide: the mantel's middle notch rests on nothing, so
it must be a 3-notch log held at its two ends.

Examples
--------
>>> plan = Plan((5, 6, 4))
>>> cabin(plan, layers=range(6))
>>> door(plan, "front", at=2, mantel=4)
>>> s = plan.build()
>>> s.extent.shape, s.occupancy[2, :4, 0].tolist()
((5, 6, 4), [0, 0, 0, 0])
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from unseeable.domain import Extent, Log, Structure, grammar_violations
from unseeable.errors import InputError
from unseeable.grammar.shapes import Placement, check_placement, conditions, holds, span_logs

__all__ = [
    "Plan",
    "wall",
    "cabin",
    "block",
    "door",
    "window",
    "truncate",
    "tight",
]

#: Axis index of a wall's logs: "i" walls (plane of fixed k) run along i on even layers.
_AXES = {"i": 0, "k": 2}


@dataclass
class _Region:
    name: str
    cells: np.ndarray  # (I, J, K) bool
    axis: int | None  # 0: wall along i, 2: wall along k, None: solid block
    removable: bool

    def runs_along(self, j: int) -> bool:
        """Whether this region's own logs run along layer ``j``'s axis."""
        return self.axis is None or self.axis == Extent.axis(j)


@dataclass
class _Forced:
    owner: str
    log: Log
    why: str


class Plan:
    """A structure under design: regions, openings and forced logs on a grid.

    Parameters
    ----------
    extent : (I, J, K) or Extent

    Attributes
    ----------
    extent : Extent
    regions : list
        Walls and blocks, in declaration order (earlier ones own shared points).
    opening : (I, J, K) bool
        Grid points cut out by doors and windows (EMPTY whatever the regions say).
    forced : list
        Logs that must appear as given (mantels and window thresholds).
    shapes : list of (str, Placement)
        The doors and windows cut, with the wall each is in; :meth:`build` checks
        that each holds (:func:`unseeable.grammar.shapes.holds`) in what it builds.
    """

    def __init__(self, extent: Extent | tuple[int, int, int]) -> None:
        self.extent = extent if isinstance(extent, Extent) else Extent(*extent)
        self.regions: list[_Region] = []
        self.forced: list[_Forced] = []
        self.shapes: list[tuple[str, Placement]] = []
        self.opening = np.zeros(self.extent.shape, dtype=bool)

    # -- declaration -------------------------------------------------------
    def add(self, name: str, cells: np.ndarray, axis: int | None, *,
            removable: bool = False) -> None:
        if any(r.name == name for r in self.regions):
            raise InputError("a region of this name exists already", field="name", value=name)
        if not cells.any():
            raise InputError("covers no grid point", field=name)
        self.regions.append(_Region(name, cells, axis, removable))

    def region(self, name: str) -> _Region:
        for r in self.regions:
            if r.name == name:
                return r
        raise InputError("no such region", field="wall", value=name)

    def force(self, owner: str, log: Log, why: str) -> None:
        for q in log.positions():
            if not self.extent.contains(q):
                raise InputError(f"{why} runs off the grid", value=log.describe())
        self.forced.append(_Forced(owner, log, why))

    # -- building ----------------------------------------------------------
    def occupied(self) -> np.ndarray:
        """Occupied grid points, ``(I, J, K) bool``."""
        occ = np.zeros(self.extent.shape, dtype=bool)
        for r in self.regions:
            occ |= r.cells
        return occ & ~self.opening

    def owners(self) -> np.ndarray:
        """Index of each occupied point's region (-1 where empty), ``(I, J, K) int``."""
        owner = np.full(self.extent.shape, -1, dtype=int)
        occ = self.occupied()
        # Cross points first (any containing region), then overwrite with the
        # first region running along the layer's axis there — declared order wins,
        # hence the reversed loops.
        for n in reversed(range(len(self.regions))):
            owner[self.regions[n].cells & occ] = n
        for n in reversed(range(len(self.regions))):
            r = self.regions[n]
            along = np.zeros(self.extent.shape, dtype=bool)
            for j in range(self.extent.J):
                if r.runs_along(j):
                    along[:, j, :] = True
            owner[r.cells & occ & along] = n
        return owner

    def build(self, *, without: tuple[str, ...] = ()) -> Structure:
        """Split the occupied points into logs; leave out the logs of ``without``.

        Raises
        ------
        InputError
            When no split of some run into logs satisfies the grammar, a forced
            log does not fit its run, or the result (with or without the
            removable regions) violates the grammar.
        """
        logs, owner_of = self._tile()
        names = {r.name for r in self.regions}
        for name in without:
            if name not in names:
                raise InputError("no such region", field="without", value=name)
            if not self.region(name).removable:
                raise InputError("is not declared removable", field="without", value=name)
        kept = [log for log, o in zip(logs, owner_of) if self.regions[o].name not in without]
        structure = Structure(self.extent, kept)
        problems = grammar_violations(structure)
        if problems:
            raise InputError(f"the plan violates the grammar: {problems[0]}",
                             value=f"without={list(without)}")
        for wall_name, placement in self.shapes:
            if wall_name not in without and not holds(placement, structure):
                # A guard: what the tiler builds must be the door or window the shapes define.
                raise InputError(f"the {placement.kind} in wall {wall_name!r} does not hold "
                                 "in the logs built", value=placement.to_json())
        return structure

    def _support(self, owner_index: int, occ: np.ndarray, owner: np.ndarray) -> np.ndarray:
        """Points that count as support for ``owner_index``'s logs, ``(I, J, K) bool``.

        Removable regions other than the owner itself do not count, so taking
        one out leaves everything else standing.
        """
        removable = np.array([r.removable for r in self.regions] + [False])
        counts = occ & (~removable[owner] | (owner == owner_index))
        return counts

    def _tile(self) -> tuple[list[Log], list[int]]:
        ext = self.extent
        occ = self.occupied()
        owner = self.owners()
        region_index = {r.name: n for n, r in enumerate(self.regions)}
        forced_at: dict[tuple[int, int, int], tuple[int, int]] = {}  # start → (notches, owner)
        forced_cover = np.zeros(ext.shape, dtype=bool)
        for f in self.forced:
            qs = f.log.positions()
            o = region_index[f.owner]
            for q in qs:
                if not occ[q] or owner[q] != o:
                    raise InputError(f"{f.why} needs its grid points in wall {f.owner!r}, "
                                     "not in an opening or another region",
                                     value=f.log.describe())
                if forced_cover[q]:
                    raise InputError(f"{f.why} overlaps another forced log",
                                     value=f.log.describe())
                forced_cover[q] = True
            forced_at[qs[0]] = (f.log.notches, o)
        supports = {n: self._support(n, occ, owner) for n in range(len(self.regions))}
        logs: list[Log] = []
        owner_of: list[int] = []
        joints: dict[tuple[int, int], set[int]] = {}
        for j in range(ext.J):
            axis = ext.axis(j)
            length = ext.I if axis == 0 else ext.K
            crosses = ext.K if axis == 0 else ext.I
            for c in range(crosses):
                def pos(t: int, j: int = j, c: int = c, axis: int = axis) -> tuple[int, int, int]:
                    return (t, j, c) if axis == 0 else (c, j, t)

                line_joints: set[int] = set()
                t = 0
                while t < length:
                    if not occ[pos(t)]:
                        t += 1
                        continue
                    o = owner[pos(t)]
                    start = t
                    while t < length and occ[pos(t)] and owner[pos(t)] == o:
                        t += 1
                    cells = [pos(s) for s in range(start, t)]
                    held = [j == 0 or bool(supports[o][q[0], j - 1, q[2]]) for q in cells]
                    forced = {s - start: forced_at[q][0] for s, q in zip(range(start, t), cells)
                              if q in forced_at}
                    covered = [bool(forced_cover[q]) for q in cells]
                    parts = _split_run(held, forced, covered,
                                       below=joints.get((j - 2, c), set()), offset=start,
                                       prefer_long_first=(j // 2 + c) % 2 == 0)
                    if parts is None:
                        raise InputError(
                            f"no split into logs of the run {[list(q) for q in cells]} "
                            f"of region {self.regions[o].name!r} keeps every log supported",
                            value=[list(q) for q in cells])
                    s = start
                    for m in parts:
                        q = pos(s)
                        logs.append(Log(layer=j, at=(q[0], q[2]), notches=m))
                        owner_of.append(int(o))
                        s += m
                        if s < t:
                            line_joints.add(s)
                joints[(j, c)] = line_joints
        return logs, owner_of


def _compositions(n: int):
    """All ways to write ``n`` as an ordered sum of 1, 2 and 3."""
    if n == 0:
        yield ()
        return
    for m in (1, 2, 3):
        if m <= n:
            for rest in _compositions(n - m):
                yield (m, *rest)


def _split_run(held: list[bool], forced: dict[int, int], covered: list[bool], *,
               below: set[int], offset: int, prefer_long_first: bool) -> tuple[int, ...] | None:
    """Choose how a run of grid points is split into logs.

    Parameters
    ----------
    held : list of bool
        Whether each point of the run has support below it.
    forced : dict
        Run offset → notches of a log that must start there.
    covered : list of bool
        Whether each point lies in a forced log.
    below : set of int
        Joint positions (the axis coordinate where a log starts right after
        another ends) on the same line two layers below.
    offset : int
        Axis coordinate of the run's first point.
    prefer_long_first : bool
        Tie-break between otherwise equal splits (alternated between lines
        and courses, so the two ends of a wall look different).

    Returns
    -------
    tuple of int or None
        Notches of each log, in order; None when no split is valid.
    """
    n = len(held)
    best = None
    for parts in _compositions(n):
        s = 0
        ok = True
        for m in parts:
            if s in forced and forced[s] != m:
                ok = False
                break
            if s not in forced and any(covered[s:s + m]):
                ok = False
                break
            support = sum(held[s:s + m])
            if support < (2 if m == 3 else m):
                ok = False
                break
            s += m
        if not ok:
            continue
        starts = np.cumsum((0, *parts))[1:-1] + offset
        clashes = sum(int(x) in below for x in starts)
        key = (clashes, len(parts))
        tie = tuple(-m for m in parts) if prefer_long_first else parts
        if best is None or (key, tie) < best[0]:
            best = ((key, tie), parts)
    return None if best is None else best[1]


# -- readable helpers ------------------------------------------------------
def _as_range(value: range, *, field: str, limit: int) -> range:
    if not isinstance(value, range) or value.step != 1 or len(value) == 0:
        raise InputError("must be a non-empty range with step 1", field=field, value=value)
    if value.start < 0 or value.stop > limit:
        raise InputError(f"must lie within 0..{limit - 1}", field=field, value=value)
    return value


def wall(plan: Plan, name: str, *, along: str, at: int, span: range, layers: range,
         removable: bool = False) -> None:
    """Add a wall: every grid point of a vertical rectangle occupied.

    Parameters
    ----------
    plan : Plan
    name : str
        Used by :func:`door`, :func:`window` and ``Plan.build(without=...)``.
    along : {"i", "k"}
        Direction of the wall's logs. A wall along ``i`` stands in the plane
        ``k = at`` (its logs on even layers); along ``k``, in the plane ``i = at``
        (its logs on odd layers).
    at : int
        The plane's fixed coordinate.
    span : range
        Positions along the wall.
    layers : range
        Layers the wall covers.
    removable : bool
        Whether the rest of the structure must stand without this wall.
    """
    if along not in _AXES:
        raise InputError('must be "i" or "k"', field="along", value=along)
    ext = plan.extent
    axis = _AXES[along]
    layers = _as_range(layers, field="layers", limit=ext.J)
    span = _as_range(span, field="span", limit=ext.I if axis == 0 else ext.K)
    if not 0 <= at < (ext.K if axis == 0 else ext.I):
        raise InputError("plane lies outside the grid", field="at", value=at)
    cells = np.zeros(ext.shape, dtype=bool)
    if axis == 0:
        cells[span.start:span.stop, layers.start:layers.stop, at] = True
    else:
        cells[at, layers.start:layers.stop, span.start:span.stop] = True
    plan.add(name, cells, axis, removable=removable)


def cabin(plan: Plan, *, layers: range, i: range | None = None, k: range | None = None) -> None:
    """Four walls round the rectangle ``i`` × ``k`` (default: the whole footprint).

    The walls are named ``front`` (along i at the lowest k), ``back`` (along i
    at the highest k), ``left`` (along k at the lowest i) and ``right``.
    """
    i = range(plan.extent.I) if i is None else i
    k = range(plan.extent.K) if k is None else k
    wall(plan, "front", along="i", at=k.start, span=i, layers=layers)
    wall(plan, "back", along="i", at=k.stop - 1, span=i, layers=layers)
    wall(plan, "left", along="k", at=i.start, span=k, layers=layers)
    wall(plan, "right", along="k", at=i.stop - 1, span=k, layers=layers)


def block(plan: Plan, name: str, *, i: range, k: range, layers: range,
          removable: bool = False) -> None:
    """Add a solid box of logs (a crib, a hearth, a roof deck): every point occupied."""
    ext = plan.extent
    i = _as_range(i, field="i", limit=ext.I)
    k = _as_range(k, field="k", limit=ext.K)
    layers = _as_range(layers, field="layers", limit=ext.J)
    cells = np.zeros(ext.shape, dtype=bool)
    cells[i.start:i.stop, layers.start:layers.stop, k.start:k.stop] = True
    plan.add(name, cells, None, removable=removable)


def _wall_placement(r: _Region, kind: str, *, at: int, bottom: int, top: int) -> Placement:
    plane = np.argwhere(r.cells)
    fixed = int(plane[0, 2 if r.axis == 0 else 0])
    return Placement(kind, "i" if r.axis == 0 else "k", fixed, at, bottom, top)


def _cut(plan: Plan, wall_name: str, placement: Placement) -> None:
    """Cut a door or window (:mod:`unseeable.grammar.shapes`) into a wall: its opening
    EMPTY, its threshold and mantel logs forced."""
    r = plan.region(wall_name)
    what = placement.kind
    along = np.argwhere(r.cells)[:, r.axis]
    at = placement.at
    if not (along.min() <= at - 1 and at + 1 <= along.max()):
        raise InputError(f"a {what} needs a post position on each side inside the wall",
                         field="at", value=at)
    for j in placement.layers:
        if not 0 <= j < plan.extent.J:
            raise InputError(f"the {what} reaches beyond the grid's layers", field="layers",
                             value=j)
    check_placement(placement, plan.extent)
    for cond in conditions(placement):
        if cond.part == "opening":
            plan.opening[cond.q] = True
    for part, log in span_logs(placement):
        plan.force(wall_name, log, f"the {what}'s {part}")
    plan.shapes.append((wall_name, placement))


def _check_wall_layer(r: _Region, layer: int, field: str) -> None:
    if r.axis is None:
        raise InputError("an opening needs a wall, not a block", field="wall", value=r.name)
    if Extent.axis(layer) != r.axis:
        raise InputError(f"must be a layer on which wall {r.name!r}'s logs run "
                         f"({'even' if r.axis == 0 else 'odd'} layers)", field=field,
                         value=layer)
    if not r.cells[:, layer, :].any():
        raise InputError(f"wall {r.name!r} does not reach this layer", field=field, value=layer)


def door(plan: Plan, wall_name: str, *, at: int, mantel: int) -> None:
    """Cut a door into a wall: an opening at position ``at`` from layer 0 to the mantel.

    The door is :mod:`unseeable.grammar.shapes`'s: the grid points at ``at`` on
    layers ``0 .. mantel-1`` are EMPTY (the threshold is on layer 0, the bottom of
    the structure); the logs beside it end there (the posts); a 3-notch log spans
    post to post on layer ``mantel``, which must be one of the wall's layers, with
    at least one of them below it.
    """
    r = plan.region(wall_name)
    _check_wall_layer(r, mantel, "mantel")
    if mantel < 1:
        raise InputError("the door needs at least one layer of opening", field="mantel",
                         value=mantel)
    _cut(plan, wall_name, _wall_placement(r, "door", at=at, bottom=0, top=mantel - 1))


def window(plan: Plan, wall_name: str, *, at: int, sill: int, lintel: int) -> None:
    """Cut a window into a wall: an opening at position ``at`` between two logs.

    The window is :mod:`unseeable.grammar.shapes`'s: a 3-notch threshold log on
    layer ``sill`` and a 3-notch mantel log on layer ``lintel`` span post to post;
    the grid points at ``at`` between them are EMPTY. Both layers must be the
    wall's, at least 4 layers apart so the window has posts.
    """
    r = plan.region(wall_name)
    _check_wall_layer(r, sill, "sill")
    _check_wall_layer(r, lintel, "lintel")
    if lintel - sill < 4:
        raise InputError("the lintel must be at least 4 layers above the sill (so the "
                         "window has posts)", field="lintel", value=lintel)
    _cut(plan, wall_name, _wall_placement(r, "window", at=at, bottom=sill + 1, top=lintel - 1))


def truncate(structure: Structure, layer: int) -> Structure:
    """The structure with every log on layers ``>= layer`` removed, on a grid ``layer`` high.

    This is what the arm leaves after a partial disassembly down to ``layer``
    (the extent shrinks to the layers that remain).

    Examples
    --------
    >>> s = Structure(Extent(1, 2, 1), [Log(layer=0, at=(0, 0), notches=1),
    ...                                 Log(layer=1, at=(0, 0), notches=1)])
    >>> truncate(s, 1).extent.shape, len(truncate(s, 1))
    ((1, 1, 1), 1)
    """
    ext = structure.extent
    if not 1 <= layer < ext.J:
        raise InputError(f"must be between 1 and {ext.J - 1}", field="layer", value=layer)
    return Structure(Extent(ext.I, layer, ext.K),
                     [log for log in structure.logs if log.layer < layer])


def tight(structure: Structure) -> Structure:
    """The same logs on the smallest grid from the origin that holds them.

    The grid's origin stays (so the structure's pose on the table stays); only
    empty far sides are dropped.

    Examples
    --------
    >>> s = Structure(Extent(3, 2, 4), [Log(layer=0, at=(0, 1), notches=2)])
    >>> tight(s).extent.shape
    (2, 1, 2)
    """
    z = structure.occupancy
    if not structure.logs:
        raise InputError("has no logs", field="structure")
    top = [int(np.nonzero(z.any(axis=tuple(a for a in range(3) if a != axis)))[0].max()) + 1
           for axis in range(3)]
    return Structure(Extent(*top), structure.logs)
