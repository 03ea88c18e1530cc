"""Exact number of valid structures of an extent.

A transfer-matrix ("broken profile") dynamic programme sweeps the grid in
line order (:func:`unseeable.grammar.rules.line_positions`). The state is one
occupancy bit per column (i, k) — the layer below for columns the sweep has
not reached in the current layer, the current layer for the others — plus
the state of the log being laid along the current line (which notch comes
next, how many of a 3-notch log's notches are supported so far). Counts are
kept modulo a few primes near 2^58 (numpy int64, additions only) and
recombined exactly with the Chinese remainder theorem, so the answer is an
exact Python int however large.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from functools import cache, lru_cache

import numpy as np

from unseeable.domain.grid import Extent
from unseeable.errors import InputError
from unseeable.grammar.rules import line_positions

__all__ = ["count_valid", "count_line_tilings", "MAX_PROFILE_BITS", "MAX_COUNT_BYTES"]

#: Largest number of columns I*K the profile DP accepts when J > 1 (2^bits states).
MAX_PROFILE_BITS = 20
#: Most memory the profile DP's tables may take (bytes): two tables of P primes ×
#: 2^(I*K) profiles × 7 line states of int64.
MAX_COUNT_BYTES = 2 << 30

# Line states: which notch must come next, and for a 3-notch log how many of
# its notches so far rest on something.
_FREE, _NEED21, _NEED31_0, _NEED31_1, _NEED32_0, _NEED32_1, _NEED32_2 = range(7)
_NUM_STATES = 7


def _transitions(supported: int, layer0: bool) -> list[tuple[int, int, int]]:
    """(from_state, to_state, new_bit) moves at a position whose column bit is ``supported``."""
    sup = 1 if layer0 else supported
    moves = [(_FREE, _FREE, 0)]  # EMPTY
    if sup:
        moves += [(_FREE, _FREE, 1), (_FREE, _NEED21, 1), (_NEED21, _FREE, 1)]  # (1,0) (2,0) (2,1)
    moves.append((_FREE, _NEED31_0 + sup, 1))  # (3,0)
    moves += [(_NEED31_0, _NEED32_0 + sup, 1), (_NEED31_1, _NEED32_1 + sup, 1)]  # (3,1)
    for s in range(3):  # (3,2): at least two notches supported (always on layer 0)
        if layer0 or s + sup >= 2:
            moves.append((_NEED32_0 + s, _FREE, 1))
    return moves


@cache
def count_line_tilings(length: int) -> int:
    """Number of ways to lay 1-, 2- and 3-notch logs (or nothing) along a free line.

    f(n) = 2 f(n-1) + f(n-2) + f(n-3): EMPTY or a 1-notch log, a 2-notch
    log, a 3-notch log at the first position.

    Examples
    --------
    >>> [count_line_tilings(n) for n in range(5)]
    [1, 2, 5, 13, 33]
    """
    f = [1, 2, 5]
    while len(f) <= length:
        f.append(2 * f[-1] + f[-2] + f[-3])
    return f[length]


def _is_prime(n: int) -> bool:
    if n < 2:
        return False
    small = (2, 3, 5, 7, 11, 13, 17, 19, 23, 29, 31, 37)
    for p in small:
        if n % p == 0:
            return n == p
    d, s = n - 1, 0
    while d % 2 == 0:
        d //= 2
        s += 1
    for a in small:  # deterministic for n < 3.3e24
        x = pow(a, d, n)
        if x in (1, n - 1):
            continue
        for _ in range(s - 1):
            x = x * x % n
            if x == n - 1:
                break
        else:
            return False
    return True


@lru_cache(maxsize=1)
def _primes(count: int = 64) -> tuple[int, ...]:
    # Below 2^58, so a sum of up to 32 residues stays below 2^63.
    out, n = [], (1 << 58) - 1
    while len(out) < count:
        if _is_prime(n):
            out.append(n)
        n -= 2
    return tuple(out)


def _sum_mod(values: np.ndarray, mods: np.ndarray) -> np.ndarray:
    """Row sums of ``(P, n)`` residues modulo ``mods`` without int64 overflow (pairwise)."""
    v = values
    while v.shape[1] > 1:
        if v.shape[1] % 2:
            v = np.concatenate([v, np.zeros((v.shape[0], 1), dtype=v.dtype)], axis=1)
        v = (v[:, 0::2] + v[:, 1::2]) % mods[:, None]
    return v[:, 0]


def count_valid(extent: Extent, *, progress: Callable[[int, int], None] | None = None) -> int:
    """Exact number of occupancies of ``extent`` that satisfy the grammar Φ.

    The empty structure counts. Runs in ``O(positions · P · 2^(I·K))`` for P
    primes (more for taller grids); every position costs the same, so the
    time left is the time so far over the positions done times those left.
    Under load (10 on 2 cores, 2026-12-06) 2^16 profiles (4x4x4) took 0.08 s
    per position, 2^20 (4x2x5, 4x4x5) 0.65-0.86 s.

    Parameters
    ----------
    extent : Extent
    progress : callable, optional
        Called as ``progress(done, total)`` with the positions swept so far
        (from 0); it may raise to stop the count (e.g. at a time limit).

    Returns
    -------
    int

    Raises
    ------
    InputError
        When ``J > 1`` and a layer has more than :data:`MAX_PROFILE_BITS`
        positions (the profile would not fit in memory).

    Examples
    --------
    >>> from unseeable.domain import Extent
    >>> count_valid(Extent(2, 1, 1)), count_valid(Extent(1, 2, 1))
    (5, 3)
    """
    I, J, K = extent.shape
    lines = line_positions(extent)
    total_positions = extent.positions
    if J == 1:  # no support: lines are independent
        total = math.prod(count_line_tilings(len(line)) for line in lines)
        if progress is not None:
            progress(total_positions, total_positions)
        return total
    bits = I * K
    if bits > MAX_PROFILE_BITS:
        raise InputError(f"counting needs 2^(I*K) states; I*K must be at most "
                         f"{MAX_PROFILE_BITS} when J > 1", field="extent",
                         value=extent.as_list())
    # Upper bound (support ignored) tells how many primes make the CRT exact.
    bound = math.prod(count_line_tilings(len(line)) for line in lines)
    primes, modulus = [], 1
    for p in _primes():
        primes.append(p)
        modulus *= p
        if modulus > bound:
            break
    mods = np.array(primes, dtype=np.int64)
    P = len(primes)
    needed = 2 * P * (1 << bits) * _NUM_STATES * 8
    if needed > MAX_COUNT_BYTES:
        raise InputError(f"counting would need {needed / 2**30:.1f} GiB of memory "
                         f"({P} primes for a count of up to {bound.bit_length()} bits); at "
                         f"most {MAX_COUNT_BYTES / 2**30:g} GiB is allowed: give fewer layers "
                         "or a smaller I*K", field="extent", value=extent.as_list())
    if progress is not None:
        progress(0, total_positions)
    counts = np.zeros((P, 1 << bits, _NUM_STATES), dtype=np.int64)
    counts[:, (1 << bits) - 1, _FREE] = 1  # the table supports everything under layer 0
    done = 0
    for line in lines:
        for pos, (i, j, k) in enumerate(line):
            c = i * K + k
            view = counts.reshape(P, 1 << (bits - c - 1), 2, 1 << c, _NUM_STATES)
            new = np.zeros_like(view)
            for below in (0, 1):
                src = view[:, :, below]
                for s_from, s_to, bit in _transitions(below, j == 0):
                    new[:, :, bit, :, s_to] += src[:, :, :, s_from]
            new %= mods[:, None, None, None, None]
            counts = new.reshape(P, 1 << bits, _NUM_STATES)
            if pos == len(line) - 1:  # a log may not run off the end of its line
                counts[:, :, _FREE + 1:] = 0
            done += 1
            if progress is not None:
                progress(done, total_positions)
    residues = [int(r) for r in _sum_mod(counts.reshape(P, -1), mods)]
    # Chinese remainder theorem
    total = 0
    for r, p in zip(residues, primes):
        m = modulus // p
        total += r * m * pow(m, -1, p)
    return total % modulus
