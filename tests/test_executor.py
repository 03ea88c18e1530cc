"""The executors: one interface for local processes and Dask clusters, the same results on
each, and a spec or a scheduler that will not do refused before any work."""

from __future__ import annotations

import functools
import os
import socket
import subprocess
import sys
from pathlib import Path

import pytest

from unseeable.errors import InputError, check_whole_number
from unseeable.evaluate.jobs import without_timings
from unseeable.executor import (
    DaskCluster,
    Executor,
    ExecutorSpec,
    Processes,
    open_executor,
)


def unused_port() -> int:
    """A local TCP port nothing listens on."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.mark.parametrize("text, kind, workers, address", [
    (None, "processes", 3, None),
    ("", "processes", 3, None),
    ("processes:2", "processes", 2, None),
    ("local:4", "local", 4, None),
    ("tcp://10.0.0.5:8786", "scheduler", 0, "tcp://10.0.0.5:8786"),
    ("tcp://scheduler.lab:8786/", "scheduler", 0, "tcp://scheduler.lab:8786"),
    ("tls://[::1]:8786", "scheduler", 0, "tls://[::1]:8786"),
])
def test_specs_name_where_the_jobs_run(text, kind, workers, address):
    assert ExecutorSpec.parse(text, workers=3) == ExecutorSpec(kind, workers, address)


@pytest.mark.parametrize("text", ["dask", "local", "local:", "local:0", "local:two",
                                  "processes:300", "tcp://host", "tcp://:8786",
                                  "tcp://host:0", "tcp://host:99999", "http://host:8786",
                                  "host:8786"])
def test_a_malformed_spec_names_the_option_and_the_value(text):
    with pytest.raises(InputError) as caught:
        ExecutorSpec.parse(text, field="--scheduler")
    assert caught.value.field == "--scheduler" and caught.value.value == text


def test_a_bad_worker_count_names_workers():
    with pytest.raises(InputError, match=r"workers: must be a whole number >= 1 \(got 0\)"):
        ExecutorSpec.parse(None, workers=0)
    with pytest.raises(InputError, match="workers"):
        Processes(0)


def test_local_processes_yield_every_result():
    with open_executor("processes:2") as executor:
        assert isinstance(executor, Executor) and executor.workers == 2
        assert sorted(executor.map_unordered(abs, [-3, 1, -2])) == [1, 2, 3]
    assert list(Processes(1).map_unordered(abs, [-1, -2])) == [1, 2]  # here, in order


def test_an_unreachable_scheduler_is_refused_at_once():
    address = f"tcp://127.0.0.1:{unused_port()}"
    with pytest.raises(InputError) as caught:
        with open_executor(address, field="--scheduler", connect_timeout=1.0):
            pytest.fail("no executor for a scheduler that does not answer")
    assert caught.value.field == "--scheduler" and caught.value.value == address
    assert "no Dask scheduler answered" in str(caught.value)


def test_dask_is_imported_only_for_a_dask_executor():
    code = ("import sys; from unseeable.executor import open_executor\n"
            "with open_executor('processes:1') as e: list(e.map_unordered(abs, [-1]))\n"
            "assert 'distributed' not in sys.modules and 'dask' not in sys.modules")
    subprocess.run([sys.executable, "-c", code], check=True)


def test_a_local_cluster_runs_the_tasks_and_a_tasks_error_reaches_the_caller():
    environ = dict(os.environ)
    with open_executor("local:2") as executor:
        # Its workers keep glibc's adaptive allocator (40 % faster here) and one BLAS
        # thread; this process's environment, which later processes inherit, is left as is.
        assert list(executor.map_unordered(os.getenv, ["MALLOC_TRIM_THRESHOLD_"])) == [None]
        assert list(executor.map_unordered(os.getenv, ["OPENBLAS_NUM_THREADS"])) == ["1"]
        assert dict(os.environ) == environ
        assert isinstance(executor, DaskCluster) and executor.workers == 2
        assert "LocalCluster of 2 workers" in executor.description
        # Equal tasks are each run (not taken for one another).
        assert sorted(executor.map_unordered(abs, [-1, -1, 2, -3])) == [1, 1, 2, 3]
        assert list(executor.map_unordered(abs, [])) == []
        with pytest.raises(TypeError):
            list(executor.map_unordered(abs, ["not a number"]))
        # The package's own errors arrive whole, for the command line's one line.
        check = functools.partial(check_whole_number, field="n", minimum=1)
        with pytest.raises(InputError, match=r"^n: must be a whole number >= 1 \(got 0\)$"):
            list(executor.map_unordered(check, [0]))
        # Leaving early cancels the rest; the cluster still runs the next job.
        for _ in executor.map_unordered(abs, range(20)):
            break
        assert sorted(executor.map_unordered(abs, [-5, 4])) == [4, 5]


@pytest.mark.slow
def test_an_experiment_gives_the_same_records_on_processes_and_on_a_local_cluster(
        tiny_corpus, tmp_path):
    from unseeable.evaluate.experiments import EvaluationSettings, evaluate_corpus
    from unseeable.pipeline import EstimateSettings

    settings = EvaluationSettings(estimate=EstimateSettings.from_options(time_limit=30.0),
                                  known_pose=True)
    runs = {}
    for spec in ("processes:2", "local:2"):
        with open_executor(spec) as executor:
            runs[spec] = evaluate_corpus(tiny_corpus, tmp_path / spec.replace(":", ""),
                                         settings=settings, executor=executor)
    processes, cluster = (without_timings(r) for r in runs.values())
    assert len(processes) == 2 and not any(r["failed"] for r in processes)
    assert processes == cluster


@pytest.mark.slow
def test_a_corpus_build_renders_the_same_views_on_processes_and_on_a_local_cluster(tmp_path):
    from unseeable.corpus.build import build_corpus
    from unseeable.render.settings import RenderSettings

    options = dict(angles=[90, 150], size=(80, 60), settings=RenderSettings(spp=2), seed=3,
                   only=["tower-3-L3"])
    for spec in ("processes:2", "local:2"):
        with open_executor(spec) as executor:
            report = build_corpus(tmp_path / spec.replace(":", ""), executor=executor,
                                  **options)
        assert len(report.rendered) == 2
    a, b = tmp_path / "processes2", tmp_path / "local2"
    files = sorted(p.relative_to(a) for p in a.rglob("*") if p.is_file())
    assert files == sorted(p.relative_to(b) for p in b.rglob("*") if p.is_file())
    for name in files:
        assert (a / name).read_bytes() == (b / name).read_bytes(), name
    assert any(Path(n).suffix == ".png" for n in files)


@pytest.mark.slow
def test_calibrate_judges_its_scenes_on_a_local_cluster_to_the_same_calibration(tmp_path):
    from dataclasses import replace

    import numpy as np

    from unseeable.training import calibrate
    from unseeable.training.scenes import VALIDATION
    from unseeable.vision.calibration import GROUPS

    spec = replace(VALIDATION, name="raster-executor-test", renderer="raster", width=320,
                   height=240)
    runs = []
    for executor_spec in ("processes:1", "local:2"):
        with open_executor(executor_spec) as executor:
            runs.append(calibrate(4, spec=spec, cache=tmp_path, pose=False, max_iter=20,
                                  executor=executor))
    for g in GROUPS:
        for kind in ("models", "context_models"):
            here, cluster = (getattr(c, kind)[g] for c in runs)
            assert np.array_equal(here.w1, cluster.w1) and here.b2 == cluster.b2
    assert runs[0].info == runs[1].info
