"""Corpus-wide jobs whose records are cached on disk, run by an executor (worker processes
or a Dask cluster)."""

from __future__ import annotations

import hashlib
from collections.abc import Callable, Iterator, Sequence
from typing import Any

import numpy as np

from unseeable.errors import InputError, UnseeableError
from unseeable.executor import Executor
from unseeable.fileio import read_json, write_json
from unseeable.pipeline.search_cache import pose_searches_cached

__all__ = ["run_cached", "evaluate_and_write", "selected_items", "structure_rng",
           "without_timings"]


def selected_items(corpus: Sequence[Any], only: Sequence[str] | None) -> Iterator[Any]:
    """The corpus's entries, or those named in ``only`` (all when it is empty or None)."""
    return (item for item in corpus if not only or item.name in only)


def structure_rng(seed: int, name: str) -> np.random.Generator:
    """A random generator seeded by ``seed`` and a structure's name: the same draws for a
    structure whichever others an experiment holds, and in every experiment (the
    several-views and active-vision experiments' first draw, the order of starting
    stations, is the same)."""
    digest = int(hashlib.sha256(f"{seed}:{name}".encode()).hexdigest()[:8], 16)
    return np.random.default_rng(digest)


def run_cached(jobs: Sequence[Any], run: Callable[[Any], tuple[Any, dict]], settings: Any, *,
               digest: str, record_format: str, executor: Executor,
               revision: str | None = None,
               progress: Callable[[int, int], None] | None = None) -> list[dict]:
    """Every job's record, in job order: read back from ``job.out`` when it was made with
    the same settings (``digest``), format and (when given) ``revision``, else made by
    ``run((job, settings))`` on ``executor`` (``run`` writes it to ``job.out`` and returns
    ``(job, record)``), so that an interrupted experiment resumes where it stopped. The
    records are in job order whichever executor made them and in whatever order."""
    records: dict[Any, dict] = {}
    todo = []
    for job in jobs:
        if job.out.exists():
            try:
                rec = read_json(job.out)
                if rec.get("settings") == digest and rec.get("format") == record_format \
                        and (revision is None or rec.get("revision") == revision):
                    records[job.out] = rec
                    continue
            except InputError:
                pass
        todo.append(job)
    if progress:
        progress(len(records), len(jobs))
    for job, rec in executor.map_unordered(run, [(job, settings) for job in todo]):
        records[job.out] = rec
        if progress:
            progress(len(records), len(jobs))
    return [records[job.out] for job in jobs]


def evaluate_and_write(evaluate: Callable[[Any, Any], dict], args: tuple[Any, Any], *,
                       failed: Callable[[Any, Any, UnseeableError], dict] | None = None
                       ) -> tuple[Any, dict]:
    """``evaluate(job, settings)``'s record, written to ``job.out``: a task of
    :func:`run_cached` as ``functools.partial(evaluate_and_write, evaluate)`` (both
    module-level, so a worker process or a Dask worker can unpickle it), with pose
    searches cached in ``settings.pose_searches`` when it names a folder. With
    ``failed``, an :class:`~unseeable.errors.UnseeableError` becomes the record
    ``failed(job, settings, error)`` instead of stopping the experiment."""
    job, settings = args
    try:
        with pose_searches_cached(getattr(settings, "pose_searches", None)):
            record = evaluate(job, settings)
    except UnseeableError as err:
        if failed is None:
            raise
        record = failed(job, settings, err)
    write_json(job.out, record)
    return job, record


def without_timings(record: Any) -> Any:
    """``record`` without what the clock decides (every ``…seconds…`` field and
    ``timings``, at any depth): what two runs of an experiment must agree on, whichever
    executor made them and whatever was cached.

    >>> without_timings({"errors": 2, "seconds": 1.5, "steps": [{"seconds_with": 3, "n": 1}]})
    {'errors': 2, 'steps': [{'n': 1}]}
    """
    if isinstance(record, dict):
        return {k: without_timings(v) for k, v in record.items()
                if "seconds" not in k and k != "timings"}
    if isinstance(record, list):
        return [without_timings(v) for v in record]
    return record
