"""The parallel helpers: results in order, and the BLAS held to one thread meanwhile."""

from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np
import pytest
from threadpoolctl import threadpool_info, threadpool_limits

from unseeable.parallel import map_in_stages, map_in_threads, single_blas_thread


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


@pytest.mark.parametrize("threads", [1, 2, 3])
def test_map_in_stages_gives_the_serial_results_in_order(threads):
    rng = np.random.default_rng(threads)
    waits = rng.uniform(0.0, 0.005, size=(12, 2))

    def first(n: int) -> int:
        time.sleep(waits[n, 0])  # stages finishing out of order
        return n * n

    def second(n: int, square: int) -> tuple[int, int]:
        time.sleep(waits[n, 1])
        return n, square + 1

    assert map_in_stages(first, second, list(range(12)), threads=threads) == \
        [(n, n * n + 1) for n in range(12)]


def test_map_in_stages_raises_a_stage_error():
    def first(n: int) -> int:
        if n == 3:
            raise ValueError("bad item 3")
        return n

    with pytest.raises(ValueError, match="bad item 3"):
        map_in_stages(first, lambda n, x: x, list(range(6)), threads=2)


def _children(pid: int) -> list[int]:
    """The worker processes (spawned by multiprocessing) whose parent is ``pid``."""
    found = []
    for proc in Path("/proc").iterdir():
        if not proc.name.isdigit():
            continue
        try:
            ppid = int((proc / "stat").read_text().rsplit(")", 1)[1].split()[1])
            cmdline = (proc / "cmdline").read_bytes()
        except (OSError, IndexError, ValueError):
            continue
        if ppid == pid and b"spawn_main" in cmdline:
            found.append(int(proc.name))
    return found


def _alive(pid: int) -> bool:
    try:
        state = (Path("/proc") / str(pid) / "stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


@pytest.mark.skipif(not os.path.exists("/proc/self/stat"), reason="needs /proc")
def test_workers_end_when_their_parent_is_killed():
    # A corpus job killed from outside (kill -9, a cluster's time limit) must not leave its
    # workers holding the cores.
    import contextlib
    import signal
    import subprocess
    import sys

    parent = subprocess.Popen(
        [sys.executable, "-c", "import time\nfrom unseeable.parallel import run_in_processes\n"
         "list(run_in_processes(time.sleep, [120, 120], workers=2))"])
    workers: list[int] = []
    try:
        deadline = time.monotonic() + 60
        while len(workers := _children(parent.pid)) < 2 and time.monotonic() < deadline:
            time.sleep(0.2)
        assert len(workers) == 2
        parent.send_signal(signal.SIGKILL)
        parent.wait()
        deadline = time.monotonic() + 10
        while any(map(_alive, workers)) and time.monotonic() < deadline:
            time.sleep(0.2)
        assert not any(map(_alive, workers))
    finally:
        parent.kill()
        for pid in workers:
            with contextlib.suppress(OSError):
                os.kill(pid, signal.SIGKILL)
