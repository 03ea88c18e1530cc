"""Shared fixtures of the render tests: small scenes rendered once per session."""

from __future__ import annotations

import pytest

from unseeable.domain import Extent, Log, Structure


def cabin() -> Structure:
    """A 3x6x3 log cabin with a door in the front wall and a window in the left wall (i = 0)."""
    L = Log
    logs = [
        L(0, (0, 0), 1), L(0, (2, 0), 1), L(0, (0, 2), 3),
        L(1, (0, 0), 3), L(1, (2, 0), 3),
        L(2, (0, 0), 1), L(2, (2, 0), 1), L(2, (0, 2), 3),
        L(3, (0, 0), 1), L(3, (0, 2), 1), L(3, (2, 0), 3),
        L(4, (0, 0), 3), L(4, (0, 2), 3),
        L(5, (0, 0), 3), L(5, (2, 0), 3),
    ]
    return Structure(Extent(3, 6, 3), logs)


@pytest.fixture(scope="session")
def cabin_structure() -> Structure:
    return cabin()
