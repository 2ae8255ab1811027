"""A priority queue of tasks in front of a Dask client, with one handler per task kind.

A task is queued once its inputs exist and handed to Dask only when a worker thread is free, highest priority
first (ties: the lowest ``order``), so that no task waits behind another on a busy worker. When a task finishes,
the handler of its kind gets its name and result (and may queue follow-ups) before the freed thread is handed
the next task; a task that raised is reported by ``on_error`` and has no follow-ups.
"""

from __future__ import annotations

import heapq
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

Handler = Callable[[str, Any], None]


@dataclass(order=True)
class Task:
    priority: int                                  # negated: heapq pops the smallest
    order: int
    kind: str = field(compare=False)
    name: str = field(compare=False)
    function: Callable[..., Any] = field(compare=False)
    args: tuple = field(compare=False)


class Scheduler:
    """Tasks of named kinds on the workers of ``client``; ``handlers[kind](name, result)`` on each success."""

    def __init__(self, client: Any, handlers: Mapping[str, Handler], on_error: Callable[[str, str, BaseException], None]):
        from dask.distributed import as_completed
        self.client = client
        self.handlers = handlers
        self.on_error = on_error
        self.capacity = max(sum(client.nthreads().values()), 1)
        self.queue: list[Task] = []
        self.running: dict[Any, tuple[str, str]] = {}      # future -> (kind, name)
        self.completed = as_completed()
        self.queued = 0

    def submit(self, kind: str, name: str, function: Callable[..., Any], *args: Any, priority: int,
               order: int | None = None) -> None:
        """Queue a task; ``order`` breaks ties of priority (default: first queued, first served)."""
        if kind not in self.handlers:
            raise ValueError(f"no handler for tasks of kind '{kind}'")
        heapq.heappush(self.queue, Task(-priority, self.queued if order is None else order, kind, name, function,
                                        args))
        self.queued += 1

    def dispatch(self) -> None:
        """Hand queued tasks to Dask while worker threads are free."""
        while self.queue and sum(not future.done() for future in self.running) < self.capacity:
            task = heapq.heappop(self.queue)
            future = self.client.submit(task.function, *task.args, key=f"{task.kind}-{task.name}-{time.time_ns()}",
                                        pure=False)
            self.running[future] = (task.kind, task.name)
            self.completed.add(future)

    def run(self, after: Callable[[], None] = lambda: None) -> None:
        """Dispatch what is queued and handle every task as it finishes, until none is left; ``after`` runs once
        the freed workers have their next tasks (for slow side work, such as an interim report)."""
        self.dispatch()
        for future in self.completed:
            kind, name = self.running.pop(future)
            try:   # the finished task's follow-ups are queued before its worker is handed the next task
                if future.status == "error":
                    self.on_error(kind, name, future.exception())
                else:
                    self.handlers[kind](name, future.result())
            finally:
                self.dispatch()
            after()
