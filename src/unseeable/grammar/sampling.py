"""Random valid structures, for simulations and benchmarks."""

from __future__ import annotations

import numpy as np

from unseeable.domain.grid import Extent
from unseeable.domain.structure import Log, Structure
from unseeable.errors import InputError
from unseeable.grammar.rules import line_positions

__all__ = ["random_structure", "full_structure"]


def random_structure(extent: Extent, *, density: float = 0.5,
                     seed: int | np.random.Generator | None = None) -> Structure:
    """A random structure that satisfies the grammar Φ.

    Layers are laid bottom-up, each line from its low end: at a free position,
    with probability ``density`` a log starts there, its length drawn
    uniformly among the lengths that fit on the line and are supported
    (every notch for 1- and 2-notch logs, two of three for a 3-notch log);
    otherwise, or when no length is possible, the position stays EMPTY.

    Parameters
    ----------
    extent : Extent
    density : float in [0, 1]
        Chance of trying to start a log at each free position; 0 gives the
        empty structure, 1 packs every supported position.
    seed : int, Generator or None

    Returns
    -------
    Structure
        Always valid (``is_valid`` holds).

    Examples
    --------
    >>> from unseeable.domain import Extent, is_valid
    >>> s = random_structure(Extent(4, 3, 4), density=0.6, seed=1)
    >>> is_valid(s)
    True
    """
    if not 0.0 <= float(density) <= 1.0:
        raise InputError("must be in [0, 1]", field="density", value=density)
    rng = np.random.default_rng(seed)
    occupied = np.zeros(extent.shape, dtype=bool)
    logs = []
    for line in line_positions(extent):
        j = line[0][1]
        held = [j == 0 or bool(occupied[i, j - 1, k]) for (i, _, k) in line]
        pos = 0
        while pos < len(line):
            if rng.random() >= density:
                pos += 1
                continue
            lengths = []
            for m in (1, 2, 3):
                if pos + m > len(line):
                    break
                need = 2 if m == 3 else m
                if sum(held[pos:pos + m]) >= need:
                    lengths.append(m)
            if not lengths:
                pos += 1
                continue
            m = int(rng.choice(lengths))
            i, _, k = line[pos]
            logs.append(Log(layer=j, at=(i, k), notches=m))
            for q in line[pos:pos + m]:
                occupied[q] = True
            pos += m
    return Structure(extent, logs)


def full_structure(extent: Extent) -> Structure:
    """Every position occupied: each row of 3-notch logs, ended by a 2- or 1-notch log.

    Valid under the grammar (every notch above layer 0 rests on a full layer);
    the densest structure of an extent, used by benchmarks and tests.

    Examples
    --------
    >>> s = full_structure(Extent(4, 2, 3))
    >>> bool((s.occupancy != 0).all()), len(s.logs)
    (True, 10)
    """
    logs = []
    I, J, K = extent.shape
    for j in range(J):
        length, rows = (I, K) if j % 2 == 0 else (K, I)
        for row in range(rows):
            start = 0
            while start < length:
                m = min(3, length - start)
                logs.append(Log(layer=j, at=(start, row) if j % 2 == 0 else (row, start),
                                notches=m))
                start += m
    return Structure(extent, logs)

