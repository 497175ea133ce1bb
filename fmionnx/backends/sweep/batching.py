"""How many cases one Dask task runs: batches of short cases, sized from measured case times.

A task costs the study a few milliseconds whatever it runs (the scheduler's round trip, the
transfer of its arguments and outcome, the driver's bookkeeping), and on a small machine the
driver and the scheduler take that time from the same cores as the workers. A case of a few
milliseconds sent as a task of its own is mostly that cost; sent with others in one task, the
cost is shared. So the engine sizes its tasks:

* **Fixed** when asked (``--batch N``; ``--batch 1`` is one case per task, no batching).
* **Adaptive** otherwise. The first cases run one per task (a few per worker thread: the
  *probe*). A worker's first case is left out of the estimate, since it also pays for
  receiving the models and reading the compiled system. From the others' mean wall time
  (measured on the workers), a task gets as many cases as fill :data:`TASK_SECONDS`, at
  least 1 and at most :data:`MAX_BATCH` -- and never so many that the cases not yet finished
  would make fewer than :data:`TASKS_LEFT_PER_THREAD` tasks per worker thread. That last bound
  shrinks the tasks as the study drains, so the last tasks are small and every worker stays
  busy to the end instead of one waiting for the other's long last batch.

Cases of seconds (the reference scenario) stay one per task: the rule only ever groups cases
shorter than :data:`TASK_SECONDS`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

#: Seconds of work one task aims at: long beside a task's own cost (milliseconds), short
#: enough that an interruption loses little and the last tasks balance well.
TASK_SECONDS = 0.5
#: The cases not yet finished always make at least this many tasks per worker thread.
TASKS_LEFT_PER_THREAD = 4
#: The most cases in one task, whatever their time.
MAX_BATCH = 500
#: Single-case tasks in flight per worker thread while no case time is known yet.
PROBES_PER_THREAD = 2


def batch_size(per_case: float, unfinished: int, threads: int) -> int:
    """Cases for the next task: ``per_case`` seconds each, ``unfinished`` cases not yet
    finished (running or waiting), ``threads`` worker threads."""
    by_time = MAX_BATCH if per_case <= 0 else int(TASK_SECONDS / per_case)
    by_balance = unfinished // (TASKS_LEFT_PER_THREAD * max(1, threads))
    return max(1, min(by_time, by_balance, MAX_BATCH))


@dataclass
class BatchSizer:
    """The engine's running choice of batch size for one study."""

    threads: int
    #: A size the user fixed (None: adaptive).
    fixed: int | None = None
    _workers: set[str] = field(default_factory=set)
    _seconds: float = 0.0
    _counted: int = 0

    @property
    def ready(self) -> bool:
        """Whether sizes are known (fixed, or at least one case time measured)."""
        return self.fixed is not None or self._counted > 0

    @property
    def probes(self) -> int:
        """Tasks in flight while probing."""
        return PROBES_PER_THREAD * max(1, self.threads)

    @property
    def per_case(self) -> float | None:
        """Mean wall time of a case (a worker's first case left out), None before one."""
        return self._seconds / self._counted if self._counted else None

    def observe(self, worker: str, wall_time: float) -> None:
        """A case finished on ``worker`` in ``wall_time`` seconds."""
        if worker not in self._workers:  # its first case: paid for the models, not typical
            self._workers.add(worker)
            return
        self._seconds += wall_time
        self._counted += 1

    def size(self, unfinished: int) -> int:
        """Cases for the next task."""
        if self.fixed is not None:
            return max(1, self.fixed)
        per_case = self.per_case
        if per_case is None:
            return 1
        return batch_size(per_case, unfinished, self.threads)
