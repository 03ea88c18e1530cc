"""Brute-force references for tiny extents, independent of the package's grammar code.

Valid structures are enumerated as every way to tile each line with
1-, 2- and 3-notch logs (or nothing), kept when the domain's own
``is_valid`` accepts them. Scores use ``Evidence.log_probability``.
"""

from __future__ import annotations

import itertools
from functools import lru_cache

import numpy as np
from hypothesis import strategies as st

from unseeable.domain import Extent, Structure, is_valid
from unseeable.domain.grid import occupancy_code


def _line_tilings(length: int) -> list[tuple[int, ...]]:
    if length == 0:
        return [()]
    out = []
    for m in (0, 1, 2, 3):
        step = max(m, 1)
        if step > length:
            continue
        head = (0,) if m == 0 else tuple(occupancy_code(m, n) for n in range(m))
        out.extend(head + rest for rest in _line_tilings(length - step))
    return out


def _lines(extent: Extent) -> list[list[tuple[int, int, int]]]:
    I, J, K = extent.shape
    lines = []
    for j in range(J):
        if j % 2 == 0:
            lines += [[(i, j, k) for i in range(I)] for k in range(K)]
        else:
            lines += [[(i, j, k) for k in range(K)] for i in range(I)]
    return lines


@lru_cache(maxsize=64)
def valid_occupancies(extent: Extent) -> np.ndarray:
    """Every valid occupancy of ``extent``: ``(M, I, J, K) int8``."""
    lines = _lines(extent)
    found = []
    for combo in itertools.product(*(_line_tilings(len(line)) for line in lines)):
        z = np.zeros(extent.shape, dtype=np.int8)
        for line, values in zip(lines, combo):
            for q, v in zip(line, values):
                z[q] = v
        if is_valid(Structure.from_occupancy(extent, z)):
            found.append(z)
    out = np.array(found)
    out.setflags(write=False)
    return out


def scores(terms: list, occupancies: np.ndarray) -> np.ndarray:
    """Log-probability of each occupancy under evidence terms (Evidence, removed_from_layer)."""
    total = np.zeros(len(occupancies))
    for evidence, removed in terms:
        for n, z in enumerate(occupancies):
            zz = z.copy()
            if removed is not None:
                zz[:, removed:, :] = 0
            total[n] += evidence.log_probability(zz)
    return total


@st.composite
def tiny_extents(draw, max_positions: int = 8) -> Extent:
    """Extents of at most ``max_positions`` positions (any shape)."""
    while True:
        dims = draw(st.tuples(st.integers(1, 8), st.integers(1, 8), st.integers(1, 8)))
        if int(np.prod(dims)) <= max_positions:
            return Extent(*dims)


def random_priors(extent: Extent, rng: np.random.Generator, occluded: float = 0.4) -> np.ndarray:
    from unseeable.domain import feature_index

    n = len(feature_index(extent))
    p = rng.uniform(0.03, 0.97, n)
    p[rng.random(n) < occluded] = 0.5
    return p
