"""The persistent worker pool: results in order, errors raised, the calling thread used."""

from __future__ import annotations

import threading
import time

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


@pytest.mark.parametrize("failing", [0, 1])
def test_a_failure_propagates_after_every_task_has_ended(failing):
    ended = []

    def task(k):
        if k == failing:
            raise ValueError(f"task {k}")
        time.sleep(0.05)
        ended.append(k)
        return k

    with pytest.raises(ValueError, match=f"task {failing}"):
        run_in_threads(task, [(0,), (1,), (2,)])
    assert sorted(ended) == sorted({0, 1, 2} - {failing})


def test_callers_in_several_threads_at_once_each_get_their_results():
    from concurrent.futures import ThreadPoolExecutor

    def call(k):  # some callers need a larger pool than others
        return run_in_threads(lambda a, b: a * b, [(k, j) for j in range(1 + k % 3)])

    with ThreadPoolExecutor(4) as callers:
        results = list(callers.map(call, range(40)))
    assert results == [[k * j for j in range(1 + k % 3)] for k in range(40)]


def test_tasks_that_run_tasks_do_not_wait_for_ever():
    """More outer tasks than pool threads, each running inner tasks: on a pool thread the inner
    tasks run in order there, so no pool thread waits for a task queued behind it."""
    from concurrent.futures import ThreadPoolExecutor

    from stereo_obstacles.thread_pool import MIN_POOL_THREADS

    def outer(k):
        time.sleep(0.01)
        return sum(run_in_threads(lambda a, b: a * b, [(k, 1), (k, 2)]))

    watchdog = ThreadPoolExecutor(1)
    future = watchdog.submit(run_in_threads, outer, [(k,) for k in range(3 * MIN_POOL_THREADS)])
    try:
        assert future.result(timeout=30) == [3 * k for k in range(3 * MIN_POOL_THREADS)]
    finally:
        watchdog.shutdown(wait=False)  # a deadlocked call must not hang the test run as well
