"""The campaign's scheduler: priorities on a busy worker, follow-ups queued by handlers, failures reported."""

from __future__ import annotations

import pytest

from workflow.scheduler import Scheduler


def square(x: int) -> int:
    return x * x


def fail(x: int) -> int:
    raise RuntimeError(f"task {x} broke")


@pytest.fixture(scope="module")
def client():
    from dask.distributed import Client, LocalCluster
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                      dashboard_address="127.0.0.1:0") as cluster, \
            Client(cluster) as client:
        yield client


def test_one_worker_runs_the_highest_priority_first_and_a_handler_s_follow_ups_next(client):
    done: list[tuple[str, str, int]] = []
    errors: list[tuple[str, str, str]] = []

    def on_run(name: str, result: int) -> None:
        done.append(("run", name, result))
        if name == "b":        # a follow-up of higher priority than the queued "a" goes first
            scheduler.submit("train", "t", square, 5, priority=5)

    scheduler = Scheduler(client, {"run": on_run, "train": lambda name, result: done.append(("train", name, result))},
                          lambda kind, name, error: errors.append((kind, name, str(error))))
    scheduler.submit("run", "a", square, 2, priority=0)
    scheduler.submit("run", "b", square, 3, priority=2)
    scheduler.submit("run", "c", fail, 4, priority=1)
    scheduler.submit("run", "d", square, 6, priority=1, order=-1)    # ties: the lowest order first
    scheduler.run()
    assert done == [("run", "b", 9), ("train", "t", 25), ("run", "d", 36), ("run", "a", 4)]
    assert errors == [("run", "c", "task 4 broke")]
    with pytest.raises(ValueError, match="no handler for tasks of kind 'report'"):
        scheduler.submit("report", "r", square, 1, priority=0)
