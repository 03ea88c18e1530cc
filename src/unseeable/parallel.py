"""Independent tasks spread over worker processes (the local executor of
:mod:`unseeable.executor`, which runs the corpus build, the experiments and ``unseeable
calibrate``; the calibration's network fits) or over threads within one image (the pose
search), and the BLAS kept to one thread while they run."""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, ThreadPoolExecutor, wait
from typing import Any

__all__ = ["run_in_processes", "map_in_threads", "map_in_stages", "single_blas_thread"]

_blas_lock = threading.Lock()
_blas_depth = 0
_blas_limits: Any = None


@contextlib.contextmanager
def single_blas_thread() -> Iterator[None]:
    """Keep the BLAS libraries (numpy's, OpenCV's OpenBLAS) to one thread meanwhile.

    The estimator's matrix products are small (points by 3×3 frames), and
    its parallelism is its own (:func:`map_in_threads`, worker processes).
    OpenBLAS still splits the larger of those products over every core and
    then keeps its threads spinning, taking the cores the estimator's own
    threads need: one photograph estimated with the pose search on two
    threads used 16 % more processor time and took 4 % longer (40 corpus
    views, identical estimates; docs/decisions.md). The limit is the process's
    (BLAS has no other), taken by the outermost caller and given back when it
    ends; nested and concurrent callers share it. Usable as a decorator.
    OpenBLAS takes the limit when it is set from the main thread (the CLI's,
    a worker process's); set from another thread it was ignored (OpenBLAS
    0.3.31), and that caller's products may use more threads.

    Examples
    --------
    >>> import numpy as np
    >>> with single_blas_thread():
    ...     float((np.ones((200, 3)) @ np.eye(3)).sum())
    600.0
    """
    global _blas_depth, _blas_limits
    with _blas_lock:
        if _blas_depth == 0:
            from threadpoolctl import threadpool_limits

            _blas_limits = threadpool_limits(limits=1, user_api="blas")
        _blas_depth += 1
    try:
        yield
    finally:
        with _blas_lock:
            _blas_depth -= 1
            if _blas_depth == 0:
                _blas_limits.restore_original_limits()
                _blas_limits = None


#: Seconds between a worker's checks that the process which started it is alive.
PARENT_POLL_S = 1.0


def _watch_parent(parent: int) -> None:
    while True:
        time.sleep(PARENT_POLL_S)
        if os.getppid() != parent:
            # Orphaned (the parent was killed without closing the pool): a worker left
            # running would hold a core and memory until the machine restarts.
            os._exit(1)


def _exit_with_parent(parent: int) -> None:
    """A worker's initializer: end this process when ``parent`` ends (POSIX; a spawned
    child's parent is re-assigned when the parent dies)."""
    if os.name == "posix":
        threading.Thread(target=_watch_parent, args=(parent,), daemon=True,
                         name="unseeable-parent-watch").start()


def run_in_processes(fn: Callable[[Any], Any], tasks: Sequence[Any], *,
                     workers: int) -> Iterator[Any]:
    """``fn(task)`` for every task, yielded as each finishes.

    In this process, in order, when ``workers <= 1`` or there is a single
    task; else in ``workers`` spawned processes, in the order they finish
    (``fn`` must be importable and the tasks picklable). Spawned, not forked:
    a forked child of a process that has already rendered would inherit the
    renderer's JIT (Dr.Jit/LLVM) thread state. Tasks not started when the
    caller stops iterating are cancelled, and the workers end within
    :data:`PARENT_POLL_S` seconds of this process being killed.

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
    with ProcessPoolExecutor(max_workers=workers, mp_context=context,
                             initializer=_exit_with_parent,
                             initargs=(os.getpid(),)) as pool:
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


def map_in_stages(first: Callable[[Any], Any], second: Callable[[Any, Any], Any],
                  items: Sequence[Any], *, threads: int) -> list[Any]:
    """``[second(item, first(item)) for item in items]``, on up to ``threads`` threads.

    Each item's second stage is queued as soon as its first ends, so that
    the threads stay busy to the end: three items of two stages each on two
    threads take about three stage-lengths, where :func:`map_in_threads` of
    the whole would take four (the third item alone at the end). Worth it
    when one stage holds the GIL and the other does not (the pose choice's
    detections and its CP-SAT solves). The results are in the items' order,
    the same for any number of threads.

    Examples
    --------
    >>> map_in_stages(lambda x: x + 1, lambda x, y: (x, y), [1, 2, 3], threads=2)
    [(1, 2), (2, 3), (3, 4)]
    """
    if threads <= 1 or len(items) <= 1:
        return [second(item, first(item)) for item in items]
    results: list[Any] = [None] * len(items)
    pool = ThreadPoolExecutor(max_workers=min(threads, 2 * len(items)))
    try:
        stage_one = {pool.submit(first, item): n for n, item in enumerate(items)}
        stage_two: dict = {}
        pending = set(stage_one)
        while pending:
            done, pending = wait(pending, return_when=FIRST_COMPLETED)
            for future in done:
                if future in stage_one:
                    n = stage_one[future]
                    follow = pool.submit(second, items[n], future.result())
                    stage_two[follow] = n
                    pending.add(follow)
                else:
                    results[stage_two[future]] = future.result()
    finally:
        pool.shutdown(wait=True, cancel_futures=True)
    return results
