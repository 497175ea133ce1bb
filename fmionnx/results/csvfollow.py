"""``results.csv`` formatted by the plot worker while an in-process run goes on.

Formatting the table's numbers costs about as much as drawing a figure (16 000 rows of 30
columns: ~0.25 s here) and grows with the run: a ten-times longer run spends seconds on it
after its last step. A run under the guardian has its table formatted ahead by the guardian
(:mod:`.csvahead`); a run in this process has its loop on this process's thread, so the
work goes to the process that is idle while the run goes on anyway: the plot worker
(:mod:`.plotworker`), which has imported matplotlib by then and waits for the result.

- The run records into a sealed memfd (:class:`~fmionnx.runtime.guardian.RowsShared`, the
  guardian child's recorder), which the worker inherits.
- The worker's first message is a :class:`FollowRows`; it then formats the rows published
  so far in pieces (:class:`~fmionnx.results.csvahead.CsvAhead`, small pieces: what is left
  at the end is at most one), on CPU time nothing else wants, until the job arrives.
- With the job (``PlotJob.results_csv``) the worker writes ``results.csv`` itself, through
  :func:`~fmionnx.results.csvfile.write_csv` with the pieces whose values are the result's
  bit for bit (the rest formatted then), beside its figures. If it cannot, the run's
  process writes the file as before: the bytes are the same either way.
"""

from __future__ import annotations

import contextlib
import logging
import os
import select
import threading
from dataclasses import dataclass
from typing import TYPE_CHECKING

from fmionnx.core.cores import usable_cores
from fmionnx.core.switches import switched_off, switched_on
from fmionnx.results.csvahead import PIECE_ROWS, SWITCH, CsvAhead

if TYPE_CHECKING:
    from fmionnx.runtime.published import Published

LOG = logging.getLogger("fmionnx.results")

#: The smallest piece while following: each piece costs a few calls per column.
MIN_PIECE_ROWS = 1024
#: Pieces per run at least (fewer rows each, down to :data:`MIN_PIECE_ROWS`), so that the
#: rows left for the end are a small share of a short run's.
PIECES_PER_RUN = 32
#: Usable cores a run needs for its plot worker to follow it by default: on two, the
#: reference scenario's loop and MuJoCo's software renderer keep both busy, and following
#: slowed the loop by as much as it saved after it (measured: docs/performance.md).
MIN_CORES = 3
#: Seconds the follower waits when no piece was ready (rows come in at the loop's pace).
POLL = 0.05


@dataclass(frozen=True)
class FollowRows:
    """The worker's first message: follow the rows recorded into ``fd`` (inherited)."""

    fd: int
    steps: int
    start: float
    step: float
    every: int

    @property
    def piece_rows(self) -> int:
        """Rows per piece: a 32nd of the table, between :data:`MIN_PIECE_ROWS` and
        :data:`~fmionnx.results.csvahead.PIECE_ROWS`."""
        rows = self.steps // max(1, self.every) + 1
        return max(MIN_PIECE_ROWS, min(PIECE_ROWS, rows // PIECES_PER_RUN))


def wanted() -> bool:
    """Whether an in-process run's plot worker follows its rows: ``FMIONNX_CSV_AHEAD=0``
    never, ``=1`` always, unset with :data:`MIN_CORES` usable cores or more."""
    if switched_off(SWITCH):
        return False
    return switched_on(SWITCH) or usable_cores() >= MIN_CORES


def follow_until_readable(message: FollowRows, fd: int) -> CsvAhead | None:
    """Format the rows published into ``message.fd`` until ``fd`` (the worker's stdin) is
    readable: the job came, or the run's process closed it. None when the rows cannot be
    followed (the file is not sealed); the caller then waits for the job as usual.

    The formatting runs in a thread of the lowest priority (``SCHED_IDLE``): it takes only
    CPU time nothing else wants. Where the run keeps every core busy (on two cores the loop
    and MuJoCo's software renderer do) a worker formatting at normal priority slowed the
    loop by as much as it saved after it; there, the rows are formatted at the end as
    before. The thread has ended when this returns: the worker then forks its drawing copies.
    """
    from fmionnx.runtime.guardian import follow_rows

    published = follow_rows(message.fd, message.steps)
    if published is None:
        return None
    ahead = CsvAhead(message.start, message.step, message.every, piece_rows=message.piece_rows)
    stop = threading.Event()
    thread = threading.Thread(
        target=_follow, args=(ahead, published, stop), name="csv-follow", daemon=True
    )
    thread.start()
    try:
        select.select([fd], [], [])
    finally:
        stop.set()
        thread.join()
        published.close()
    return ahead


def _follow(ahead: CsvAhead, published: Published, stop: threading.Event) -> None:
    """The follower thread's body: :func:`format_published` at the lowest priority."""
    idle()
    format_published(ahead, published, stop)


def format_published(ahead: CsvAhead, published: Published, stop: threading.Event) -> None:
    """Format a piece whenever the rows for one are published, until ``stop`` is set."""
    try:
        while not stop.is_set():
            if not ahead.follow(published):
                stop.wait(POLL)
    except Exception:  # whatever went wrong, the job still comes; its rows are formatted then
        LOG.debug("results.csv: following the run's rows failed", exc_info=True)


def idle() -> None:
    """Give the calling thread the lowest priority there is (``SCHED_IDLE``, else nice 19);
    the rest of its process keeps its own."""
    tid = threading.get_native_id()
    try:
        os.sched_setscheduler(tid, os.SCHED_IDLE, os.sched_param(0))
    except (OSError, AttributeError):
        with contextlib.suppress(OSError, AttributeError):
            os.setpriority(os.PRIO_PROCESS, tid, 19)


__all__ = ["FollowRows", "follow_until_readable", "format_published", "idle", "wanted"]
