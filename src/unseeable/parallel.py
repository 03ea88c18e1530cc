"""Independent tasks spread over worker processes (the corpus build, the experiments,
``unseeable calibrate``) or over threads within one image (the pose search)."""

from __future__ import annotations

import multiprocessing
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, ThreadPoolExecutor, wait
from typing import Any

__all__ = ["run_in_processes", "map_in_threads"]


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
    with ProcessPoolExecutor(max_workers=workers, mp_context=context) as pool:
        pending = {pool.submit(fn, task) for task in tasks}
        try:
            while pending:
                done, pending = wait(pending, return_when=FIRST_COMPLETED)
                for future in done:
                    yield future.result()
        finally:
            for future in pending:
                future.cancel()


def map_in_threads(fn: Callable[[Any], Any], items: Sequence[Any], *,
                   threads: int) -> list[Any]:
    """``[fn(item) for item in items]``, on up to ``threads`` threads.

    The results are in the items' order whatever order they finish in, so a
    caller that reduces them in order gets what the plain loop gives: the
    same result for any number of threads. Worth it when ``fn`` spends its
    time outside the GIL (numba kernels compiled ``nogil``, OpenCV, CP-SAT).

    Examples
    --------
    >>> map_in_threads(abs, [-1, 2, -3], threads=2)
    [1, 2, 3]
    """
    if threads <= 1 or len(items) <= 1:
        return [fn(item) for item in items]
    with ThreadPoolExecutor(max_workers=min(threads, len(items))) as pool:
        return list(pool.map(fn, items))
