"""Tasks in worker processes: every result comes back, and workers share the cores out."""

import operator

import numba

from unseeable.parallel import _cores, run_in_processes


def test_every_task_comes_back_once_in_processes_and_in_order_here():
    assert sorted(run_in_processes(abs, [-3, 1, -2], workers=2)) == [1, 2, 3]
    assert list(run_in_processes(abs, [-3, 1, -2], workers=1)) == [3, 1, 2]


def test_workers_split_the_kernel_threads_so_they_do_not_contend_for_cores():
    threads = list(run_in_processes(operator.call, [numba.get_num_threads] * 2, workers=2))
    assert threads == [max(1, _cores() // 2)] * 2
