"""Solver-neutral Boolean expressions over the occupancy grid (a small CPMpy-like layer).

Every hard constraint (the grammar Φ, several views, disassembly, language) and
every feature g_f(Z) is an :class:`Expr`. Backends compile expressions; they
never see where an expression came from, so new kinds of evidence or
constraints are added here, not in the backends.

Leaves
------
``Occ(q, values)``
    The literal "Z_q ∈ values" for a grid position ``q = (i, j, k)`` and a set
    of occupancy codes (0..6). A position outside the grid is EMPTY, so there
    the literal is a constant (:func:`simplify` folds it).
``Choice(name)``
    A Boolean the solver picks (e.g. "the door is at placement 17").
``TRUE``, ``FALSE``
    Constants.

Connectives
-----------
``Not``, ``And``, ``Or``, ``Implies``, ``Iff``, ``AtLeast(k, xs)``,
``AtMost(k, xs)``, ``Exactly(k, xs)``; also ``a & b``, ``a | b``, ``~a``,
``a.implies(b)``, ``a.iff(b)``.

Expressions are immutable, hashable and compare structurally. They have no
truth value of their own (``if expr:`` raises), use :func:`evaluate`.

Examples
--------
>>> from unseeable.domain import Extent
>>> e = Extent(2, 1, 1)
>>> door = Or(Choice("left") & occupied((0, 0, 0)), Choice("right") & occupied((1, 0, 0)))
>>> simplify(Occ((5, 0, 0), {0}), e)   # outside the grid: EMPTY
TRUE
>>> import numpy as np
>>> bool(evaluate(door, np.array([[[1]], [[0]]]), {"left": True, "right": False}))
True
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np

from unseeable.domain.grid import NUM_VALUES, Extent
from unseeable.errors import InputError

__all__ = [
    "Expr", "Const", "TRUE", "FALSE", "Occ", "Choice", "Not", "And", "Or", "Implies", "Iff",
    "AtLeast", "AtMost", "Exactly", "occupied", "empty", "ALL_CODES", "NONEMPTY",
    "FIRST_NOTCH_CODES", "LAST_NOTCH_CODES", "SPAN_CODES", "simplify", "negate", "evaluate",
    "truth_table", "scope", "as_expr", "leaf_table",
]

#: every occupancy code
ALL_CODES = frozenset(range(NUM_VALUES))
#: codes of an occupied position
NONEMPTY = frozenset(range(1, NUM_VALUES))
#: first notch of a log (a log end at q - l3): (1,0), (2,0), (3,0)
FIRST_NOTCH_CODES = frozenset({1, 2, 4})
#: last notch of a log (a log end at q + l3): (1,0), (2,1), (3,2)
LAST_NOTCH_CODES = frozenset({1, 3, 6})
#: the log continues to n(q): (2,0), (3,0), (3,1)
SPAN_CODES = frozenset({2, 4, 5})

Position = tuple[int, int, int]


class Expr:
    """Base class of all expressions (immutable, hashable, structural equality)."""

    __slots__ = ("_hash",)

    def _key(self) -> tuple:  # pragma: no cover - abstract
        raise NotImplementedError

    def __hash__(self) -> int:
        return self._hash

    def __eq__(self, other: object) -> bool:
        if self is other:
            return True
        if type(other) is not type(self):
            return NotImplemented
        return self._hash == other._hash and self._key() == other._key()

    def __bool__(self) -> bool:
        raise TypeError("an expression has no truth value of its own; combine it with "
                        "And/Or/Not or use unseeable.grammar.evaluate")

    def __and__(self, other: Any) -> Expr:
        return And(self, other)

    def __rand__(self, other: Any) -> Expr:
        return And(other, self)

    def __or__(self, other: Any) -> Expr:
        return Or(self, other)

    def __ror__(self, other: Any) -> Expr:
        return Or(other, self)

    def __invert__(self) -> Expr:
        return Not(self)

    def implies(self, other: Any) -> Expr:
        """``self → other``."""
        return Implies(self, other)

    def iff(self, other: Any) -> Expr:
        """``self ↔ other``."""
        return Iff(self, other)


def as_expr(value: Any) -> Expr:
    """``value`` as an expression (Python and numpy booleans become constants)."""
    if isinstance(value, Expr):
        return value
    if isinstance(value, (bool, np.bool_)):
        return TRUE if value else FALSE
    raise InputError("expected an expression (Occ, Choice, And, ...) or a bool", field="expr",
                     value=value)


def _exprs(items: Iterable[Any]) -> tuple[Expr, ...]:
    if isinstance(items, Expr):
        return (items,)
    return tuple(as_expr(x) for x in items)


def _varargs(args: tuple) -> tuple[Expr, ...]:
    # And(a, b, c) and And([a, b, c]) both work.
    if len(args) == 1 and not isinstance(args[0], (Expr, bool, np.bool_)):
        return _exprs(args[0])
    return _exprs(args)


class Const(Expr):
    """A constant; use :data:`TRUE` and :data:`FALSE`."""

    __slots__ = ("value",)

    def __init__(self, value: bool) -> None:
        self.value = bool(value)
        self._hash = hash(("Const", self.value))

    def _key(self) -> tuple:
        return (self.value,)

    def __repr__(self) -> str:
        return "TRUE" if self.value else "FALSE"


TRUE = Const(True)
FALSE = Const(False)


class Occ(Expr):
    """The literal ``Z_q ∈ values``.

    Parameters
    ----------
    q : (i, j, k)
        Grid position; may lie outside the grid (then Z_q is EMPTY).
    values : iterable of int
        Occupancy codes 0..6.
    """

    __slots__ = ("q", "values")

    def __init__(self, q: Sequence[int], values: Iterable[int]) -> None:
        if len(q) != 3:
            raise InputError("a grid position is (i, j, k)", field="q", value=q)
        position = (int(q[0]), int(q[1]), int(q[2]))
        # The grammar's own code sets are frozensets of ints already: not rebuilt.
        vals = values if type(values) is frozenset else frozenset(int(v) for v in values)
        if not vals <= ALL_CODES:
            raise InputError("occupancy codes are 0..6", field="values", value=sorted(vals))
        self._set(position, vals)

    def _set(self, q: Position, values: frozenset) -> None:
        self.q: Position = q
        self.values = values
        self._hash = hash(("Occ", q, values))

    @classmethod
    def _checked(cls, q: Position, values: frozenset) -> Occ:
        """From a position and a code set already checked (simplification makes tens of
        thousands of literals; the checks were most of their cost)."""
        occ = object.__new__(cls)
        occ._set(q, values)
        return occ

    def _key(self) -> tuple:
        return (self.q, self.values)

    def __repr__(self) -> str:
        return f"Occ({list(self.q)}, {sorted(self.values)})"


def occupied(q: Sequence[int]) -> Occ:
    """``Z_q ≠ EMPTY``."""
    return Occ(q, NONEMPTY)


def empty(q: Sequence[int]) -> Occ:
    """``Z_q = EMPTY``."""
    return Occ(q, (0,))


class Choice(Expr):
    """A Boolean the solver chooses, identified by ``name``."""

    __slots__ = ("name",)

    def __init__(self, name: str) -> None:
        if not isinstance(name, str) or not name:
            raise InputError("a choice needs a non-empty name", field="name", value=name)
        self.name = name
        self._hash = hash(("Choice", name))

    def _key(self) -> tuple:
        return (self.name,)

    def __repr__(self) -> str:
        return f"Choice({self.name!r})"


class Not(Expr):
    __slots__ = ("arg",)

    def __init__(self, arg: Any) -> None:
        self.arg = as_expr(arg)
        self._hash = hash(("Not", self.arg))

    def _key(self) -> tuple:
        return (self.arg,)

    def __repr__(self) -> str:
        return f"Not({self.arg!r})"


class _Nary(Expr):
    __slots__ = ("args",)

    def __init__(self, *args: Any) -> None:
        self.args = _varargs(args)
        self._hash = hash((type(self).__name__, self.args))

    def _key(self) -> tuple:
        return self.args

    def __repr__(self) -> str:
        return f"{type(self).__name__}({', '.join(map(repr, self.args))})"


class And(_Nary):
    """All of the arguments hold (``And()`` is TRUE)."""

    __slots__ = ()


class Or(_Nary):
    """At least one argument holds (``Or()`` is FALSE)."""

    __slots__ = ()


class Implies(Expr):
    __slots__ = ("a", "b")

    def __init__(self, a: Any, b: Any) -> None:
        self.a, self.b = as_expr(a), as_expr(b)
        self._hash = hash(("Implies", self.a, self.b))

    def _key(self) -> tuple:
        return (self.a, self.b)

    def __repr__(self) -> str:
        return f"Implies({self.a!r}, {self.b!r})"


class Iff(Expr):
    __slots__ = ("a", "b")

    def __init__(self, a: Any, b: Any) -> None:
        self.a, self.b = as_expr(a), as_expr(b)
        self._hash = hash(("Iff", self.a, self.b))

    def _key(self) -> tuple:
        return (self.a, self.b)

    def __repr__(self) -> str:
        return f"Iff({self.a!r}, {self.b!r})"


class _Card(Expr):
    __slots__ = ("k", "args")

    def __init__(self, k: int, args: Iterable[Any]) -> None:
        if isinstance(k, bool) or not isinstance(k, (int, np.integer)):
            raise InputError("the count must be a whole number", field="k", value=k)
        self.k = int(k)
        self.args = _exprs(args)
        self._hash = hash((type(self).__name__, self.k, self.args))

    def _key(self) -> tuple:
        return (self.k, self.args)

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.k}, [{', '.join(map(repr, self.args))}])"


class AtLeast(_Card):
    """At least ``k`` of ``args`` hold."""

    __slots__ = ()


class AtMost(_Card):
    """At most ``k`` of ``args`` hold."""

    __slots__ = ()


class Exactly(_Card):
    """Exactly ``k`` of ``args`` hold."""

    __slots__ = ()


# ---------------------------------------------------------------------------
# Folding constructors: take already simplified arguments, return a
# simplified expression. Shared by simplify() and negate().


def _dedupe(args: Iterable[Expr]) -> list[Expr]:
    seen: set[Expr] = set()
    out = []
    for a in args:
        if a not in seen:
            seen.add(a)
            out.append(a)
    return out


def _make_and(args: Iterable[Expr]) -> Expr:
    flat: list[Expr] = []
    for a in args:
        if isinstance(a, Const):
            if not a.value:
                return FALSE
            continue
        if isinstance(a, And):
            flat.extend(a.args)
        else:
            flat.append(a)
    flat = _dedupe(flat)
    if not flat:
        return TRUE
    if len(flat) == 1:
        return flat[0]
    return And(*flat)


def _make_or(args: Iterable[Expr]) -> Expr:
    flat: list[Expr] = []
    for a in args:
        if isinstance(a, Const):
            if a.value:
                return TRUE
            continue
        if isinstance(a, Or):
            flat.extend(a.args)
        else:
            flat.append(a)
    flat = _dedupe(flat)
    if not flat:
        return FALSE
    if len(flat) == 1:
        return flat[0]
    return Or(*flat)


def _split_constants(args: Iterable[Expr]) -> tuple[int, list[Expr]]:
    true_count, rest = 0, []
    for a in args:
        if isinstance(a, Const):
            true_count += a.value
        else:
            rest.append(a)
    return true_count, rest


def _make_atleast(k: int, args: Iterable[Expr]) -> Expr:
    t, rest = _split_constants(args)
    k -= t
    if k <= 0:
        return TRUE
    if k > len(rest):
        return FALSE
    if k == 1:
        return _make_or(rest)
    if k == len(rest):
        return _make_and(rest)
    return AtLeast(k, rest)


def _make_atmost(k: int, args: Iterable[Expr]) -> Expr:
    t, rest = _split_constants(args)
    k -= t
    if k < 0:
        return FALSE
    if k >= len(rest):
        return TRUE
    if k == 0:
        return _make_and(negate(a) for a in rest)
    return AtMost(k, rest)


def _make_exactly(k: int, args: Iterable[Expr]) -> Expr:
    t, rest = _split_constants(args)
    k -= t
    if k < 0 or k > len(rest):
        return FALSE
    if k == 0:
        return _make_and(negate(a) for a in rest)
    if k == len(rest):
        return _make_and(rest)
    return Exactly(k, rest)


def _make_occ(q: Position, values: frozenset) -> Expr:
    """``Z_q ∈ values`` from a checked position and a subset of :data:`ALL_CODES`."""
    if not values:
        return FALSE
    if values == ALL_CODES:
        return TRUE
    return Occ._checked(q, values)


def negate(e: Expr) -> Expr:
    """``¬e`` with the negation pushed inwards (expects a simplified ``e``).

    Examples
    --------
    >>> negate(Occ((0, 0, 0), {0}))
    Occ([0, 0, 0], [1, 2, 3, 4, 5, 6])
    """
    if isinstance(e, Const):
        return FALSE if e.value else TRUE
    if isinstance(e, Occ):
        return _make_occ(e.q, ALL_CODES - e.values)
    if isinstance(e, Choice):
        return Not(e)
    if isinstance(e, Not):
        return e.arg
    if isinstance(e, And):
        return _make_or(negate(a) for a in e.args)
    if isinstance(e, Or):
        return _make_and(negate(a) for a in e.args)
    if isinstance(e, Implies):
        return _make_and([e.a, negate(e.b)])
    if isinstance(e, Iff):
        return _make_iff(e.a, negate(e.b))
    if isinstance(e, AtLeast):
        return _make_atmost(e.k - 1, e.args)
    if isinstance(e, AtMost):
        return _make_atleast(e.k + 1, e.args)
    if isinstance(e, Exactly):
        return _make_or([_make_atmost(e.k - 1, e.args), _make_atleast(e.k + 1, e.args)])
    raise TypeError(f"not an expression: {e!r}")


def _make_implies(a: Expr, b: Expr) -> Expr:
    if isinstance(a, Const):
        return b if a.value else TRUE
    if isinstance(b, Const):
        return TRUE if b.value else negate(a)
    if a == b:
        return TRUE
    return Implies(a, b)


def _make_iff(a: Expr, b: Expr) -> Expr:
    if isinstance(a, Const):
        return b if a.value else negate(b)
    if isinstance(b, Const):
        return a if b.value else negate(a)
    if a == b:
        return TRUE
    return Iff(a, b)


def simplify(e: Any, extent: Extent, *, removed_from_layer: int | None = None,
             occupancy: np.ndarray | None = None,
             choices: Mapping[str, bool] | None = None) -> Expr:
    """Fold constants; the result mentions only positions inside the grid.

    Parameters
    ----------
    e : Expr
    extent : Extent
        Positions outside it are EMPTY.
    removed_from_layer : int, optional
        Positions on layers ``>= removed_from_layer`` are EMPTY too (the
        assembly after the arm took those logs off).
    occupancy : (I, J, K) int, optional
        Substitute a full occupancy (every ``Occ`` becomes a constant).
    choices : mapping name -> bool, optional
        Substitute these choices.

    Returns
    -------
    Expr
        Equivalent expression: no constants inside connectives, no ``Occ``
        outside the grid, nested ``And``/``Or`` flattened, negations pushed
        onto ``Choice`` leaves.
    """
    cache: dict[Expr, Expr] = {}
    I, J, K = extent.shape
    top = J if removed_from_layer is None else min(J, max(0, int(removed_from_layer)))
    occ = None if occupancy is None else np.asarray(occupancy)

    def go(x: Expr) -> Expr:
        hit = cache.get(x)
        if hit is not None:
            return hit
        if isinstance(x, Const):
            out: Expr = x
        elif isinstance(x, Occ):
            i, j, k = x.q
            if not (0 <= i < I and 0 <= j < top and 0 <= k < K):
                out = TRUE if 0 in x.values else FALSE
            elif occ is not None:
                out = TRUE if int(occ[i, j, k]) in x.values else FALSE
            else:
                out = x if x.values and x.values != ALL_CODES else _make_occ(x.q, x.values)
        elif isinstance(x, Choice):
            if choices is not None and x.name in choices:
                out = TRUE if choices[x.name] else FALSE
            else:
                out = x
        elif isinstance(x, Not):
            out = negate(go(x.arg))
        elif isinstance(x, And):
            out = _make_and(go(a) for a in x.args)
        elif isinstance(x, Or):
            out = _make_or(go(a) for a in x.args)
        elif isinstance(x, Implies):
            out = _make_implies(go(x.a), go(x.b))
        elif isinstance(x, Iff):
            out = _make_iff(go(x.a), go(x.b))
        elif isinstance(x, AtLeast):
            out = _make_atleast(x.k, [go(a) for a in x.args])
        elif isinstance(x, AtMost):
            out = _make_atmost(x.k, [go(a) for a in x.args])
        elif isinstance(x, Exactly):
            out = _make_exactly(x.k, [go(a) for a in x.args])
        else:
            raise InputError("not an expression", field="expr", value=x)
        cache[x] = out
        return out

    return go(as_expr(e))


def scope(e: Expr) -> tuple[frozenset, frozenset]:
    """Positions and choice names an expression mentions: ``(positions, names)``."""
    positions: set[Position] = set()
    names: set[str] = set()
    stack = [e]
    seen: set[int] = set()
    while stack:
        x = stack.pop()
        if id(x) in seen:
            continue
        seen.add(id(x))
        if isinstance(x, Occ):
            positions.add(x.q)
        elif isinstance(x, Choice):
            names.add(x.name)
        elif isinstance(x, Not):
            stack.append(x.arg)
        elif isinstance(x, (_Nary, _Card)):
            stack.extend(x.args)
        elif isinstance(x, (Implies, Iff)):
            stack.extend((x.a, x.b))
    return frozenset(positions), frozenset(names)


def _evaluate(e: Expr, leaf) -> Any:
    """Evaluate with numpy broadcasting; ``leaf(x)`` gives Occ/Choice values."""
    cache: dict[int, Any] = {}

    def go(x: Expr) -> Any:
        key = id(x)
        if key in cache:
            return cache[key]
        if isinstance(x, Const):
            out = np.bool_(x.value)
        elif isinstance(x, (Occ, Choice)):
            out = leaf(x)
        elif isinstance(x, Not):
            out = np.logical_not(go(x.arg))
        elif isinstance(x, And):
            out = np.bool_(True)
            for a in x.args:
                out = np.logical_and(out, go(a))
        elif isinstance(x, Or):
            out = np.bool_(False)
            for a in x.args:
                out = np.logical_or(out, go(a))
        elif isinstance(x, Implies):
            out = np.logical_or(np.logical_not(go(x.a)), go(x.b))
        elif isinstance(x, Iff):
            out = np.equal(go(x.a), go(x.b))
        elif isinstance(x, _Card):
            total = np.int64(0)
            for a in x.args:
                total = total + np.asarray(go(a), dtype=np.int64)
            if isinstance(x, AtLeast):
                out = total >= x.k
            elif isinstance(x, AtMost):
                out = total <= x.k
            else:
                out = total == x.k
        else:
            raise InputError("not an expression", field="expr", value=x)
        cache[key] = out
        return out

    return go(e)


def _membership(values: frozenset) -> np.ndarray:
    mask = np.zeros(NUM_VALUES, dtype=bool)
    mask[list(values)] = True
    return mask


def leaf_table(rows: Sequence[tuple[bool, Sequence[Occ]]], extent: Extent
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Arrays that evaluate many conjunctions or disjunctions of ``Occ`` leaves on an
    occupancy at once.

    Parameters
    ----------
    rows : sequence of (conjunction, leaves)
        ``conjunction`` True for an ``And`` of the leaves, False for an ``Or``; leaves
        inside ``extent``. A row without leaves is true as a conjunction, false as a
        disjunction.
    extent : Extent

    Returns
    -------
    conjunction : (R,) bool
    positions : (R, W) int64
        Each leaf's flat position ``(i * J + j) * K + k`` (W the most leaves of a row;
        padding at 0).
    masks : (R, W, NUM_VALUES) bool
        Whether each leaf holds for each code; padding leaves are neutral (true in a
        conjunction, false in a disjunction).

    Examples
    --------
    >>> extent = Extent(2, 1, 1)
    >>> conj, pos, masks = leaf_table([(True, (Occ((0, 0, 0), {1}), Occ((1, 0, 0), {0})))],
    ...                               extent)
    >>> z = np.array([1, 0])
    >>> bool(masks[0, np.arange(2), z[pos[0]]].all())
    True
    """
    _, J, K = extent.shape
    width = max((len(leaves) for _, leaves in rows), default=1) or 1
    conjunction = np.array([c for c, _ in rows], dtype=bool).reshape(len(rows))
    # Each leaf's values as a bit mask over the codes; padding is every code or none.
    bits = np.repeat(np.where(conjunction, (1 << NUM_VALUES) - 1, 0)[:, None], width, axis=1)
    positions = np.zeros((len(rows), width), np.int64)
    at_row, at_col, at_position, at_bits = [], [], [], []
    bits_of: dict[frozenset, int] = {}
    for row, (_, leaves) in enumerate(rows):
        for col, leaf in enumerate(leaves):
            i, j, k = leaf.q
            b = bits_of.get(leaf.values)
            if b is None:
                b = bits_of[leaf.values] = sum(1 << v for v in leaf.values)
            at_row.append(row)
            at_col.append(col)
            at_position.append((i * J + j) * K + k)
            at_bits.append(b)
    positions[at_row, at_col] = at_position
    bits[at_row, at_col] = at_bits
    masks = ((bits[:, :, None] >> np.arange(NUM_VALUES)) & 1).astype(bool)
    return conjunction, positions, masks


def evaluate(e: Any, occupancy: np.ndarray, choices: Mapping[str, Any] | None = None,
             *, removed_from_layer: int | None = None) -> np.ndarray:
    """Truth of ``e`` under an occupancy (optionally a batch of them).

    Parameters
    ----------
    e : Expr
    occupancy : (..., I, J, K) int
        Occupancy codes; leading axes are a batch.
    choices : mapping name -> bool (or bool array broadcasting to the batch)
    removed_from_layer : int, optional
        Evaluate against the occupancy with layers ``>=`` this one emptied.

    Returns
    -------
    (...) bool

    Raises
    ------
    InputError
        When ``e`` mentions a choice missing from ``choices``.
    """
    z = np.asarray(occupancy)
    if z.ndim < 3:
        raise InputError("occupancy must have shape (..., I, J, K)", field="occupancy",
                         value=z.shape)
    I, J, K = z.shape[-3:]
    top = J if removed_from_layer is None else min(J, max(0, int(removed_from_layer)))
    choices = {} if choices is None else choices

    def leaf(x: Expr) -> Any:
        if isinstance(x, Occ):
            i, j, k = x.q
            if 0 <= i < I and 0 <= j < top and 0 <= k < K:
                return _membership(x.values)[z[..., i, j, k]]
            return np.bool_(0 in x.values)
        if x.name not in choices:
            raise InputError("no value for this choice", field="choices", value=x.name)
        return np.asarray(choices[x.name], dtype=bool)

    out = np.asarray(_evaluate(as_expr(e), leaf), dtype=bool)
    return np.broadcast_to(out, z.shape[:-3]).copy() if out.shape != z.shape[:-3] else out


def truth_table(e: Expr, positions: Sequence[Position], names: Sequence[str] = ()) -> np.ndarray:
    """Truth of ``e`` for every joint value of ``positions`` (7 each) and ``names`` (2 each).

    ``e`` must mention no other positions or choices (simplify it first).

    Returns
    -------
    (7,)*len(positions) + (2,)*len(names) bool
    """
    axis_of_pos = {tuple(q): n for n, q in enumerate(positions)}
    axis_of_name = {name: len(positions) + n for n, name in enumerate(names)}
    ndim = len(positions) + len(names)
    shape = (NUM_VALUES,) * len(positions) + (2,) * len(names)

    def along(axis: int, vector: np.ndarray) -> np.ndarray:
        s = [1] * ndim
        s[axis] = len(vector)
        return vector.reshape(s)

    def leaf(x: Expr) -> Any:
        if isinstance(x, Occ):
            if x.q not in axis_of_pos:
                raise InputError("expression mentions a position outside the table's scope",
                                 field="positions", value=list(x.q))
            return along(axis_of_pos[x.q], _membership(x.values))
        if x.name not in axis_of_name:
            raise InputError("expression mentions a choice outside the table's scope",
                             field="names", value=x.name)
        return along(axis_of_name[x.name], np.array([False, True]))

    return np.broadcast_to(_evaluate(e, leaf), shape).copy()
