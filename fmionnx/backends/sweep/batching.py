"""How many cases one Dask task runs: batches of short cases, shrinking as the study drains,
each cut short on the worker once it has run for half a second.

A task costs the study a few milliseconds whatever it runs (the scheduler's round trip, the
transfer of its arguments and outcome, the driver's bookkeeping), and on a small machine the
driver and the scheduler take that time from the same cores as the workers. A case of a
millisecond sent as a task of its own is mostly that cost; sent with others in one task, the
cost is shared. So the engine batches:

* **Fixed** when asked (``--batch N``; ``--batch 1`` is one case per task, no batching): every
  task runs its N cases.
* **Adaptive** otherwise, with nothing to measure first. Each new task takes a share of the
  cases not yet handed out -- ``1 / (TASKS_PER_THREAD x worker threads)`` of them, at most
  :data:`MAX_BATCH` -- so the first tasks are large and the last ones small, and the workers
  finish together instead of one waiting for the other's long last batch (guided
  self-scheduling). The study's first message is **one task per thread**, the cases split
  evenly between them (at most :data:`MAX_BATCH` each; above that, as many such tasks as
  the threads hold): the scheduler assigns tasks sent together at once, so a second task per
  thread in that message would be queued behind the first with nothing left to balance, and
  would only add a task's cost on the driver, the scheduler and the worker (about 3 ms of
  the driver's CPU and 5 ms of the worker's per task on the 2-core benchmark machine,
  docs/sweep.md). Equal tasks keep the workers' shares equal whichever worker the scheduler
  gives each. A task cut short by its budget hands its rest back, and later tasks are sized
  as above. Once case times are known, a task is never less than :data:`MIN_TASK_SECONDS`
  of work: on a machine whose cores all run workers, every task also costs the workers time
  in the driver and scheduler, more than tiny tasks at the end would gain in balance. When
  fewer cases are left than such a task per thread, they go out as one equal share per
  thread.
  Case times differ (a case of seconds, the reference scenario), so a task also carries a
  **budget** (:data:`TASK_SECONDS`): the worker runs its cases in order and stops after the
  first one that ends past the budget, returning what it ran; the driver hands the rest out
  again. Long cases thus end up one per task, as they ran before batching, and short ones fill
  about half a second at most.

Earlier versions ran a few single-case *probe* tasks first and sized batches from their times.
On a small machine every probe is a round trip of 5-10 ms through Dask's batched messages, and
waiting for them left the workers idle for much of a short study.
"""

from __future__ import annotations

import math
import statistics
from collections import deque
from dataclasses import dataclass, field

#: Seconds of work after which a task stops taking its next case: long beside a task's own
#: cost (milliseconds), short enough that an interruption loses little and the progress shown
#: moves.
TASK_SECONDS = 0.5
#: Each new task takes ``1 / (TASKS_PER_THREAD x threads)`` of the cases not yet handed out.
TASKS_PER_THREAD = 2
#: The most cases in one task, whatever their time.
MAX_BATCH = 500
#: Once case times are known, the least work one task gets (unless fewer cases are left).
#: Measured per task on two busy cores: a few milliseconds of the driver's and the
#: scheduler's time, which the workers lose; 50 ms keeps that near a tenth at most.
MIN_TASK_SECONDS = 0.05
#: Case times the estimate keeps (the most recent ones).
KEPT_TIMES = 101


def batch_size(waiting: int, threads: int, per_case: float | None = None) -> int:
    """Cases for the next task: ``waiting`` cases not yet handed out, ``threads`` worker
    threads, ``per_case`` the typical seconds of a case (None: not known yet)."""
    guided = math.ceil(waiting / (TASKS_PER_THREAD * max(1, threads)))
    return max(1, min(max(guided, least_cases(per_case)), MAX_BATCH, waiting))


def least_cases(per_case: float | None) -> int:
    """The fewest cases a task gets: :data:`MIN_TASK_SECONDS` of them (1 while unknown)."""
    return 1 if not per_case or per_case <= 0 else math.ceil(MIN_TASK_SECONDS / per_case)


@dataclass
class BatchSizer:
    """The engine's running choice of batch size for one study."""

    threads: int
    #: A size the user fixed (None: adaptive).
    fixed: int | None = None
    _times: deque[float] = field(default_factory=lambda: deque(maxlen=KEPT_TIMES))
    #: Once the cases left are fewer than a least-sized task per thread: their equal share.
    _tail: int | None = None

    @property
    def budget(self) -> float | None:
        """Seconds after which a task stops taking cases (None: it runs all it was given)."""
        return None if self.fixed is not None else TASK_SECONDS

    @property
    def per_case(self) -> float | None:
        """Median wall time of the recent cases (None before one finished). A worker's first
        case also pays for reading the system and loading the models; the median leaves
        such outliers out once a few cases are known, and until then only keeps tasks small."""
        return statistics.median(self._times) if self._times else None

    def observe(self, wall_time: float) -> None:
        """A case finished in ``wall_time`` seconds."""
        self._times.append(wall_time)

    def size(self, waiting: int) -> int:
        """Cases for the next task, ``waiting`` cases not yet handed out."""
        if self.fixed is not None:
            return max(1, min(self.fixed, waiting))
        per_case = self.per_case
        threads = max(1, self.threads)
        if self._tail is None and per_case and waiting <= threads * least_cases(per_case):
            # The last cases: one equal task per thread, not one large task for a single
            # thread while the others wait (nor ever smaller pieces of it).
            self._tail = math.ceil(waiting / threads)
        if self._tail is not None:
            return max(1, min(self._tail, waiting))
        return batch_size(waiting, self.threads, per_case)

    def first_size(self, waiting: int) -> int:
        """Cases for each task of the study's first message, ``waiting`` cases in all: an even
        share per thread (see the module's docstring)."""
        if self.fixed is not None:
            return self.size(waiting)
        return max(1, min(math.ceil(waiting / max(1, self.threads)), MAX_BATCH))
