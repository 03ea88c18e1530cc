"""Image features tied to the grid (DESIGN.md §2): log ends and log segments.

Every feature is a deterministic function g_f(Z) of the occupancy. Features
of an extent are numbered once, in a fixed order, by :func:`feature_index`:
all ``end-``, then ``end+`` (layers 0..J-1), then ``u``, ``v``, ``w``
(layers 0..J+1), each kind in C order over ``(i, j, k)``. Every array of
per-feature values (priors, visibility, presence) uses that order.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from unseeable.domain.geometry import LogGeometry
from unseeable.domain.grid import EMPTY, FIRST_NOTCH, LAST_NOTCH, SPANS_NEXT, Extent
from unseeable.errors import InputError

__all__ = [
    "FeatureKind",
    "FeatureIndex",
    "feature_index",
    "feature_values",
    "feature_axes",
]


class FeatureKind(enum.IntEnum):
    """The five feature kinds; the value is the kind's code in index arrays."""

    END_MINUS = 0  # log end on the low-index side of a first notch, at q - l3
    END_PLUS = 1  # log end on the high-index side of a last notch, at q + l3
    U = 2  # bottom edge segment [q - l3, q]
    V = 3  # bottom edge segment [q, q + l3]
    W = 4  # bottom edge segment [q + l3, n(q) - l3]

    @property
    def label(self) -> str:
        return _LABELS[self]

    @classmethod
    def parse(cls, text: object, *, field: str = "kind", file: object = None) -> FeatureKind:
        for kind, label in _LABELS.items():
            if text == label:
                return kind
        raise InputError(f"unknown feature kind; expected one of {list(_LABELS.values())}",
                         file=file, field=field, value=text)

    @property
    def is_end(self) -> bool:
        return self in (FeatureKind.END_MINUS, FeatureKind.END_PLUS)


_LABELS = {
    FeatureKind.END_MINUS: "end-",
    FeatureKind.END_PLUS: "end+",
    FeatureKind.U: "u",
    FeatureKind.V: "v",
    FeatureKind.W: "w",
}


@dataclass(frozen=True, eq=False)
class FeatureIndex:
    """All features of an extent, numbered.

    Attributes
    ----------
    extent : Extent
    kind : (N,) int8
        :class:`FeatureKind` codes.
    at : (N, 3) int
        Grid position ``(i, j, k)`` of each feature; segment features reach
        layers J and J+1 (the tops of the two highest layers).
    """

    extent: Extent
    kind: np.ndarray
    at: np.ndarray

    def __len__(self) -> int:
        return len(self.kind)

    def offset(self, kind: FeatureKind) -> int:
        """Index of the first feature of ``kind``."""
        I, J, K = self.extent.shape
        ends = I * J * K
        segs = I * (J + 2) * K
        return [0, ends, 2 * ends, 2 * ends + segs, 2 * ends + 2 * segs][kind]

    def lookup(self, kind: FeatureKind, at: tuple[int, int, int]) -> int:
        """Index of the feature of ``kind`` at grid position ``at``.

        Raises
        ------
        InputError
            When no such feature exists for this extent.
        """
        I, J, K = self.extent.shape
        layers = J if FeatureKind(kind).is_end else J + 2
        i, j, k = (int(a) for a in at)
        if not (0 <= i < I and 0 <= j < layers and 0 <= k < K):
            raise InputError(f"no {FeatureKind(kind).label} feature there in extent "
                             f"{self.extent} (layers 0..{layers - 1})", field="at",
                             value=[i, j, k])
        return self.offset(kind) + (i * layers + j) * K + k

    def lookup_many(self, kind: np.ndarray, at: np.ndarray) -> np.ndarray:
        """Vectorised :meth:`lookup` without range checks: ``kind (M,)``, ``at (M, 3)``."""
        kind = np.asarray(kind)
        at = np.asarray(at)
        I, J, K = self.extent.shape
        layers = np.where(kind <= FeatureKind.END_PLUS, J, J + 2)
        offsets = np.array([self.offset(FeatureKind(c)) for c in range(5)])
        return offsets[kind] + (at[:, 0] * layers + at[:, 1]) * K + at[:, 2]


@lru_cache(maxsize=64)
def feature_index(extent: Extent) -> FeatureIndex:
    """Number the features of ``extent`` (cached; arrays are read-only).

    Examples
    --------
    >>> idx = feature_index(Extent(2, 1, 1))
    >>> len(idx)  # 2 ends * 2 positions + 3 segments * 2 * 3 layers
    22
    """
    I, J, K = extent.shape
    kinds, ats = [], []
    for kind in FeatureKind:
        layers = J if kind.is_end else J + 2
        grid = np.stack(np.meshgrid(np.arange(I), np.arange(layers), np.arange(K),
                                    indexing="ij"), axis=-1).reshape(-1, 3)
        kinds.append(np.full(len(grid), kind, dtype=np.int8))
        ats.append(grid)
    kind_arr = np.concatenate(kinds)
    at_arr = np.concatenate(ats).astype(np.int64)
    kind_arr.setflags(write=False)
    at_arr.setflags(write=False)
    return FeatureIndex(extent, kind_arr, at_arr)


def _padded(z: np.ndarray) -> np.ndarray:
    """Occupancy with two layers below (EMPTY), two above, and one EMPTY column beyond I and K."""
    I, J, K = z.shape
    p = np.zeros((I + 1, J + 4, K + 1), dtype=z.dtype)
    p[:I, 2 : J + 2, :K] = z
    return p


def feature_values(extent: Extent, occupancy: np.ndarray) -> np.ndarray:
    """g_f(Z) for every feature of ``extent``, in :func:`feature_index` order.

    Parameters
    ----------
    extent : Extent
    occupancy : (I, J, K) int
        Occupancy codes.

    Returns
    -------
    (N,) bool
        Whether each feature is present under ``occupancy``.

    Examples
    --------
    >>> from unseeable.domain.structure import Structure, Log
    >>> s = Structure(Extent(2, 1, 1), [Log(layer=0, at=(0, 0), notches=2)])
    >>> int(feature_values(s.extent, s.occupancy).sum())  # 2 ends; 2 u, 2 v, 1 w below and above
    12
    """
    z = np.asarray(occupancy)
    if z.shape != extent.shape:
        raise InputError(f"occupancy must have shape {extent.shape}", field="occupancy",
                         value=z.shape)
    I, J, K = extent.shape
    p = _padded(z)
    here = p[:I, 2 : J + 2, :K]
    ends_minus = FIRST_NOTCH[here]
    ends_plus = LAST_NOTCH[here]
    # Segment layers 0..J+1: the position itself and the one two layers below.
    seg_here = p[:I, 2 : J + 4, :K]
    seg_below2 = p[:I, 0:J + 2, :K]
    occ = (seg_here != EMPTY) | (seg_below2 != EMPTY)
    span = SPANS_NEXT[seg_here] | SPANS_NEXT[seg_below2]
    return np.concatenate([
        ends_minus.ravel(), ends_plus.ravel(), occ.ravel(), occ.ravel(), span.ravel(),
    ])


def feature_axes(extent: Extent, geometry: LogGeometry = LogGeometry()) -> np.ndarray:
    """Where each feature sits on its layer's log axis, in the grid frame (mm).

    Grid point (i, j, k) is at ``(i*l1, y_j, k*l1)`` with ``y_j`` the layer height.

    Returns
    -------
    (N, 2, 3) float
        For a segment, the two ends of its stretch of log axis (the feature is
        that stretch's bottom edge as seen from a camera, see
        :func:`unseeable.domain.frames.lower_silhouette`). For a log end, the end
        disc's centre (row 0) and the centre moved one unit along the outward
        normal (row 1), so ``row1 - row0`` is the disc's outward normal.
    """
    g = geometry
    idx = feature_index(extent)
    at = idx.at.astype(float)
    kind = idx.kind
    layer = idx.at[:, 1]
    centre = np.stack([at[:, 0] * g.l1, g.layer_height(layer), at[:, 2] * g.l1], axis=1)
    axis = np.zeros_like(centre)
    even = layer % 2 == 0
    axis[even, 0] = 1.0
    axis[~even, 2] = 1.0
    out = np.empty((len(kind), 2, 3))
    # start/end offsets along the axis, per kind
    start = np.select(
        [kind == FeatureKind.END_MINUS, kind == FeatureKind.END_PLUS, kind == FeatureKind.U,
         kind == FeatureKind.V, kind == FeatureKind.W],
        [-g.l3, g.l3, -g.l3, 0.0, g.l3])
    stop = np.select(
        [kind == FeatureKind.END_MINUS, kind == FeatureKind.END_PLUS, kind == FeatureKind.U,
         kind == FeatureKind.V, kind == FeatureKind.W],
        [-g.l3 - 1.0, g.l3 + 1.0, 0.0, g.l3, g.l1 - g.l3])
    out[:, 0] = centre + start[:, None] * axis
    out[:, 1] = centre + stop[:, None] * axis
    return out
