"""Independent tasks spread over worker processes (the corpus build, the experiments,
``unseeable calibrate``)."""

from __future__ import annotations

import multiprocessing
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
