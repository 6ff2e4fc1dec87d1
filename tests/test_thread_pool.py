"""The persistent worker pool: results in order, errors raised, the calling thread used."""

from __future__ import annotations

import threading

import pytest

from stereo_obstacles.thread_pool import run_in_threads


def test_results_in_argument_order_and_first_task_on_the_caller():
    names = run_in_threads(lambda k: (k, threading.current_thread().name), [(0,), (1,), (2,)])
    assert [k for k, _ in names] == [0, 1, 2]
    assert names[0][1] == threading.current_thread().name
    assert all(name.startswith("gcs-band") for _, name in names[1:])
    assert run_in_threads(pow, []) == []
    assert run_in_threads(pow, [(2, 5)]) == [32]


def test_errors_of_pool_tasks_reach_the_caller():
    def fail(k):
        if k == 1:
            raise ValueError("task 1")
        return k

    with pytest.raises(ValueError, match="task 1"):
        run_in_threads(fail, [(0,), (1,)])
