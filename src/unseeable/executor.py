"""Where corpus-wide jobs run: local processes, or a Dask distributed cluster.

Every corpus-wide job (the corpus build, the calibration's training scenes,
the experiments) hands its independent tasks to an :class:`Executor`, one
interface whatever runs them:

``processes:N`` (the default, with N the command's ``--workers``)
    N spawned processes on this machine (:func:`unseeable.parallel.run_in_processes`).
``local:N``
    A Dask ``LocalCluster`` of N worker processes (one thread each), started
    for the job and closed after it.
``tcp://HOST:PORT`` (or ``tls://``)
    A running Dask scheduler (``dask scheduler``, with ``dask worker``\\ s
    attached, or any Dask deployment). Its workers need this package
    installed at the same version and the corpus, cache and results folders
    at the same paths (a shared file system): a task reads its inputs and
    writes its record there itself.

The tasks are deterministic for their inputs (seeded), so the results do
not depend on the executor; callers that keep results in order put them
back in their tasks' order. Dask is imported only when a Dask executor is
opened.
"""

from __future__ import annotations

import contextlib
import logging
import re
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

from unseeable.errors import InputError, check_whole_number
from unseeable.parallel import run_in_processes

__all__ = ["Executor", "Processes", "DaskCluster", "ExecutorSpec", "open_executor",
           "executor_or_processes", "CONNECT_TIMEOUT", "MAX_WORKERS"]

logger = logging.getLogger(__name__)

#: Seconds to wait for a Dask scheduler (``tcp://``) to answer before giving up.
CONNECT_TIMEOUT = 10.0
#: Most local workers accepted (``processes:N``, ``local:N``).
MAX_WORKERS = 256

_LOCAL = re.compile(r"(processes|local):(\d+)")
_ADDRESS = re.compile(r"(tcp|tls)://([^\s/:]+|\[[0-9A-Fa-f:.]+\]):(\d+)/?")
_FORMS = "processes:N, local:N or tcp://HOST:PORT"


@runtime_checkable
class Executor(Protocol):
    """Runs independent tasks and yields their results as they finish.

    Attributes
    ----------
    workers : int
        How many tasks run at once (the cluster's worker threads for Dask).
    description : str
        What runs them, for logs and reports, e.g. ``"2 local processes"``.
    """

    workers: int
    description: str

    def map_unordered(self, fn: Callable[[Any], Any], tasks: Iterable[Any]) -> Iterator[Any]:
        """``fn(task)`` for every task, yielded in the order they finish.

        ``fn`` must be importable by name (a module-level function) and the
        tasks picklable. An error raised by a task is raised here; the tasks
        not started when the caller stops iterating are cancelled.
        """
        ...


@dataclass(frozen=True)
class Processes:
    """Tasks in ``workers`` spawned processes on this machine (in this process, in
    order, when ``workers`` is 1).

    Examples
    --------
    >>> list(Processes(1).map_unordered(abs, [-1, 2]))
    [1, 2]
    """

    workers: int = 1

    def __post_init__(self) -> None:
        check_whole_number(self.workers, field="workers", minimum=1)

    @property
    def description(self) -> str:
        return "1 local process" if self.workers == 1 else f"{self.workers} local processes"

    def map_unordered(self, fn: Callable[[Any], Any], tasks: Iterable[Any]) -> Iterator[Any]:
        yield from run_in_processes(fn, list(tasks), workers=self.workers)


@dataclass(frozen=True)
class DaskCluster:
    """Tasks on a Dask distributed cluster, through a connected ``distributed.Client``.

    Made by :func:`open_executor`, which also closes it; or from a client of
    one's own (``DaskCluster.from_client``).
    """

    client: Any
    workers: int
    description: str

    @classmethod
    def from_client(cls, client: Any, *, description: str | None = None) -> DaskCluster:
        """The executor of a connected client; ``workers`` is its cluster's thread count
        when made."""
        workers = max(1, sum(client.nthreads().values()))
        return cls(client, workers,
                   description or f"Dask cluster at {client.scheduler.address} "
                                  f"({workers} worker threads)")

    def map_unordered(self, fn: Callable[[Any], Any], tasks: Iterable[Any]) -> Iterator[Any]:
        from distributed import as_completed

        tasks = list(tasks)
        if not tasks:
            return
        # pure=False: every task runs, none is taken for another with equal arguments.
        futures = self.client.map(fn, tasks, pure=False)
        try:
            for future in as_completed(futures, loop=self.client.loop):
                yield future.result()
        finally:
            self.client.cancel([f for f in futures if not f.done()])


@dataclass(frozen=True)
class ExecutorSpec:
    """A parsed executor spec (``--scheduler``): what :func:`open_executor` opens.

    Attributes
    ----------
    kind : str
        ``"processes"``, ``"local"`` (a Dask LocalCluster) or ``"scheduler"``.
    workers : int
        Local processes or LocalCluster workers (0 for a scheduler: its own).
    address : str or None
        The scheduler's address (``kind == "scheduler"``).

    Examples
    --------
    >>> ExecutorSpec.parse("local:2")
    ExecutorSpec(kind='local', workers=2, address=None)
    >>> ExecutorSpec.parse(None, workers=3)
    ExecutorSpec(kind='processes', workers=3, address=None)
    >>> ExecutorSpec.parse("tcp://10.0.0.5:8786").address
    'tcp://10.0.0.5:8786'
    >>> try:
    ...     ExecutorSpec.parse("dask", field="--scheduler")
    ... except InputError as err:
    ...     print(err.field, err.message)
    --scheduler must be processes:N, local:N or tcp://HOST:PORT
    """

    kind: str
    workers: int
    address: str | None = None

    @classmethod
    def parse(cls, text: str | None, *, workers: int = 1,
              field: str = "scheduler") -> ExecutorSpec:
        """The spec of ``text``; None or empty: ``workers`` local processes.

        Raises
        ------
        InputError
            Naming ``field`` and ``text`` when it is none of the forms, or its count
            or port is out of range.
        """
        if text is None or not str(text).strip():
            return cls("processes", check_whole_number(workers, field="workers", minimum=1))
        text = str(text).strip()
        local = _LOCAL.fullmatch(text)
        if local:
            return cls(local[1], _check_count(int(local[2]), field=field, value=text))
        address = _ADDRESS.fullmatch(text)
        if address and 1 <= int(address[3]) <= 65535:
            return cls("scheduler", 0, text.rstrip("/"))
        raise InputError(f"must be {_FORMS}", field=field, value=text)


def _check_count(n: int, *, field: str, value: str) -> int:
    if not 1 <= n <= MAX_WORKERS:
        raise InputError(f"N, the workers, must be in 1..{MAX_WORKERS}", field=field, value=value)
    return n


@contextlib.contextmanager
def open_executor(spec: str | ExecutorSpec | None = None, *, workers: int = 1,
                  field: str = "scheduler",
                  connect_timeout: float | None = None) -> Iterator[Executor]:
    """The executor of ``spec``, open for the duration of the block.

    Parameters
    ----------
    spec : str or ExecutorSpec, optional
        ``processes:N``, ``local:N``, ``tcp://HOST:PORT``; None: ``workers`` local
        processes.
    workers : int
        Local processes when ``spec`` is None.
    field : str
        The option named in errors (the command line's ``--scheduler``).
    connect_timeout : float, optional
        Seconds to wait for a scheduler (default :data:`CONNECT_TIMEOUT`).

    Yields
    ------
    Executor
        :class:`Processes`, or a :class:`DaskCluster` (its LocalCluster started here
        and closed on leaving; a scheduler's connection closed on leaving).

    Raises
    ------
    InputError
        Naming ``field`` and ``spec``: a malformed spec, or a scheduler that does not
        answer within ``connect_timeout`` (nothing has run then).

    Examples
    --------
    >>> with open_executor(None, workers=1) as executor:
    ...     sorted(executor.map_unordered(abs, [-1, 2]))
    [1, 2]
    """
    if not isinstance(spec, ExecutorSpec):
        spec = ExecutorSpec.parse(spec, workers=workers, field=field)
    if spec.kind == "processes":
        yield Processes(spec.workers)
        return
    if spec.kind == "local":
        with _local_cluster(spec.workers) as executor:
            yield executor
        return
    with _scheduler(spec.address, field=field,
                    timeout=CONNECT_TIMEOUT if connect_timeout is None else connect_timeout
                    ) as executor:
        yield executor


#: Dask settings of the LocalClusters started here (see :func:`_local_cluster`).
LOCAL_CLUSTER_CONFIG = {
    # Dask's nannies set MALLOC_TRIM_THRESHOLD_ in their workers' environment, which turns
    # off glibc's adaptive mmap threshold: every array over 128 KiB is then mapped and
    # unmapped afresh, and an image's evaluation took 40 % more processor time (5 corpus
    # views, one process each way, 2026-12-06). The BLAS and OpenMP limits are kept.
    "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None,
    # The worker's sampling profiler takes the GIL every 10 ms; no dashboard shows it.
    "distributed.worker.profile.enabled": False,
}


@contextlib.contextmanager
def _local_cluster(workers: int) -> Iterator[DaskCluster]:
    import os

    import dask
    from distributed import Client, LocalCluster

    environ = dict(os.environ)
    with _quiet_dask():
        try:
            # One single-threaded worker process per task slot, as the local processes (the
            # tasks hold the GIL for much of their time); no dashboard (the scheduler's
            # HTTP routes on a free port, not Dask's usual 8787, which another may hold).
            with dask.config.set(LOCAL_CLUSTER_CONFIG):
                cluster = LocalCluster(n_workers=workers, threads_per_worker=1,
                                       processes=True, dashboard_address=None,
                                       scheduler_kwargs={"dashboard": False,
                                                         "dashboard_address": ":0"},
                                       silence_logs=logging.ERROR)
        finally:
            # The nannies set their workers' environment in this process's own, and leave
            # it: the processes this one starts later must not inherit it.
            os.environ.clear()
            os.environ.update(environ)
        with cluster, Client(cluster, set_as_default=False) as client:
            logger.info("started a Dask LocalCluster of %d workers at %s", workers,
                        cluster.scheduler_address)
            yield DaskCluster(client, workers, f"Dask LocalCluster of {workers} workers")


@contextlib.contextmanager
def _quiet_dask() -> Iterator[None]:
    """Dask's own messages at WARNING and above only, meanwhile: its scheduler and nannies
    in this process report every worker's start and end at INFO (printed when the
    application's logging sends them to its handlers, as the command line's does)."""
    dask_logger = logging.getLogger("distributed")
    level = dask_logger.level
    if dask_logger.getEffectiveLevel() < logging.WARNING:
        dask_logger.setLevel(logging.WARNING)
    try:
        yield
    finally:
        dask_logger.setLevel(level)


@contextlib.contextmanager
def _scheduler(address: str, *, field: str, timeout: float) -> Iterator[DaskCluster]:
    from distributed import Client

    with _quiet_dask():
        try:
            client = Client(address, timeout=timeout, set_as_default=False)
        except (OSError, TimeoutError) as err:
            logger.debug("Dask scheduler %s: %s", address, err)
            raise InputError(f"no Dask scheduler answered there within {timeout:g} s",
                             field=field, value=address) from None
        try:
            executor = DaskCluster.from_client(client)
            if not client.nthreads():
                logger.warning("the Dask scheduler at %s has no workers yet: the jobs wait "
                               "for one", address)
            logger.info("running on the %s", executor.description)
            yield executor
        finally:
            client.close()


def executor_or_processes(executor: Executor | None, workers: int) -> Executor:
    """``executor``, or ``workers`` local processes when it is None (the library's
    default)."""
    return Processes(workers) if executor is None else executor
