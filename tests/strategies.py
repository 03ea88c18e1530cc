"""Hypothesis strategies shared by the tests: extents and random valid structures."""

from __future__ import annotations

import numpy as np
from hypothesis import strategies as st

from unseeable.domain import Extent, Log, Structure, is_valid


def build_random_structure(extent: Extent, seed: int, density: float = 0.7) -> Structure:
    """A random valid structure, grown layer by layer with supported logs only."""
    rng = np.random.default_rng(seed)
    logs: list[Log] = []
    for j in range(extent.J):
        cross = extent.K if j % 2 == 0 else extent.I
        along = extent.I if j % 2 == 0 else extent.K
        for c in range(cross):
            pos = 0
            while pos < along:
                if rng.random() > density:
                    pos += 1
                    continue
                m = int(rng.integers(1, 4))
                at = (pos, c) if j % 2 == 0 else (c, pos)
                candidate = Log(layer=j, at=at, notches=m)
                try:
                    s = Structure(extent, [*logs, candidate])
                except ValueError:
                    pos += 1
                    continue
                if is_valid(s):
                    logs.append(candidate)
                    pos += m
                else:
                    pos += 1
    return Structure(extent, logs)


@st.composite
def extents(draw, max_positions: int = 64, max_dim: int = 5) -> Extent:
    while True:
        i = draw(st.integers(1, max_dim))
        j = draw(st.integers(1, max_dim))
        k = draw(st.integers(1, max_dim))
        if i * j * k <= max_positions:
            return Extent(i, j, k)


@st.composite
def structures(draw, max_positions: int = 64, max_dim: int = 5) -> Structure:
    extent = draw(extents(max_positions=max_positions, max_dim=max_dim))
    seed = draw(st.integers(0, 2**31 - 1))
    density = draw(st.sampled_from([0.3, 0.7, 1.0]))
    return build_random_structure(extent, seed, density)
