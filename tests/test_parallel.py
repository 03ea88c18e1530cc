"""The parallel helpers: results in order, and the BLAS held to one thread meanwhile."""

from __future__ import annotations

import numpy as np
import pytest
from threadpoolctl import threadpool_info, threadpool_limits

from unseeable.parallel import map_in_threads, single_blas_thread


def _blas_threads() -> list[int]:
    return [lib["num_threads"] for lib in threadpool_info() if lib["user_api"] == "blas"]


@pytest.fixture
def two_blas_threads():
    """Every BLAS library at two threads (whatever the machine), as a user's process may be."""
    np.ones((2, 2)) @ np.ones((2, 2))  # numpy's BLAS is loaded
    if not _blas_threads():
        pytest.skip("no BLAS library that threadpoolctl can limit")
    with threadpool_limits(limits=2, user_api="blas"):
        yield


def test_single_blas_thread_limits_and_restores(two_blas_threads):
    assert set(_blas_threads()) == {2}
    with single_blas_thread():
        assert set(_blas_threads()) == {1}
        with single_blas_thread():  # nested: the outer keeps the limit
            assert set(_blas_threads()) == {1}
        assert set(_blas_threads()) == {1}
    assert set(_blas_threads()) == {2}


def test_single_blas_thread_restores_after_an_error(two_blas_threads):
    with pytest.raises(ValueError), single_blas_thread():
        raise ValueError("boom")
    assert set(_blas_threads()) == {2}


def test_single_blas_thread_as_decorator_and_in_threads(two_blas_threads):
    @single_blas_thread()
    def limited() -> set[int]:
        return set(_blas_threads())

    assert limited() == {1}
    assert set(_blas_threads()) == {2}
    # The pipeline's threads (the pose search's) run under the limit their caller took.
    with single_blas_thread():
        assert map_in_threads(lambda _: set(_blas_threads()), list(range(8)), threads=4) == \
            [{1}] * 8
    assert set(_blas_threads()) == {2}


def test_map_in_threads_keeps_order():
    assert map_in_threads(lambda x: x * x, list(range(20)), threads=3) == \
        [x * x for x in range(20)]
