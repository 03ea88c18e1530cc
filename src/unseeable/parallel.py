"""Independent tasks spread over worker processes (the corpus build, the experiments,
``unseeable calibrate``)."""

from __future__ import annotations

import multiprocessing
import os
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from typing import Any

__all__ = ["run_in_processes"]


def run_in_processes(fn: Callable[[Any], Any], tasks: Sequence[Any], *,
                     workers: int) -> Iterator[Any]:
    """``fn(task)`` for every task, yielded as each finishes.

    In this process, in order, when ``workers <= 1`` or there is a single
    task; else in ``workers`` spawned processes, in the order they finish
    (``fn`` must be importable and the tasks picklable). Spawned, not forked:
    a forked child of a process that has already rendered would inherit the
    renderer's JIT (Dr.Jit/LLVM) thread state. Tasks not started when the
    caller stops iterating are cancelled.

    Examples
    --------
    >>> list(run_in_processes(abs, [-1, 2], workers=1))
    [1, 2]
    """
    if workers <= 1 or len(tasks) <= 1:
        for task in tasks:
            yield fn(task)
        return
    context = multiprocessing.get_context("spawn")
    threads = max(1, _cores() // workers)
    with ProcessPoolExecutor(max_workers=workers, mp_context=context,
                             initializer=_set_kernel_threads, initargs=(threads,)) as pool:
        pending = {pool.submit(fn, task) for task in tasks}
        try:
            while pending:
                done, pending = wait(pending, return_when=FIRST_COMPLETED)
                for future in done:
                    yield future.result()
        finally:
            for future in pending:
                future.cancel()


def _set_kernel_threads(threads: int) -> None:
    """Worker initializer: at most ``threads`` threads for the numba kernels."""
    import numba

    numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))


def _cores() -> int:
    """The cores this process may run on."""
    if hasattr(os, "sched_getaffinity"):  # Linux: respects taskset and container limits
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1
