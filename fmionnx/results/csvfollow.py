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
  at the end is at most one), in a thread of low priority, until the job arrives.
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
from fmionnx.core.switches import switched_on
from fmionnx.results.csvahead import SWITCH, CsvAhead, allowed

if TYPE_CHECKING:
    from fmionnx.runtime.published import Published

LOG = logging.getLogger("fmionnx.results")

#: The smallest piece while following: each piece costs a few calls per column.
MIN_PIECE_ROWS = 1024
#: The largest piece while following: the job waits for the piece under way when it comes,
#: formatted by a thread of low priority (about 30 ms of CPU for 2 048 rows of 30 columns).
MAX_PIECE_ROWS = 2048
#: The follower thread's nice value: it yields to the run (and to anything else busy), yet
#: finishes the piece under way soon when the job comes. At ``SCHED_IDLE`` a loaded machine
#: could leave it a fraction of a percent of a core for that piece (the job waits for it),
#: and a thread cannot be given its priority back once lowered.
FOLLOWER_NICE = 10
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
        :data:`MAX_PIECE_ROWS`."""
        rows = self.steps // max(1, self.every) + 1
        return max(MIN_PIECE_ROWS, min(MAX_PIECE_ROWS, rows // PIECES_PER_RUN))


def wanted() -> bool:
    """Whether an in-process run's plot worker (where it has one: a second core, plots to
    draw) follows its rows: ``FMIONNX_CSV_AHEAD=0`` never, ``=1`` whatever the cores, unset
    with :data:`MIN_CORES` usable cores or more. Never without a shared file to record into
    (Linux's ``memfd_create``: the guardian's)."""
    from fmionnx.runtime.guardian import available

    if not allowed() or available() is not None:
        return False
    return switched_on(SWITCH) or usable_cores() >= MIN_CORES


def follow_until_readable(message: FollowRows, fd: int) -> CsvAhead | None:
    """Format the rows published into ``message.fd`` until ``fd`` (the worker's stdin) is
    readable: the job came, or the run's process closed it. None when the rows cannot be
    followed (the file is not sealed); the caller then waits for the job as usual.

    The formatting runs in a thread of low priority (:data:`FOLLOWER_NICE`): it yields to
    the run's processes. The thread has ended when this returns: the worker then forks its
    drawing copies, which a running thread could leave with a lock held.
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
    """The follower thread's body: :func:`format_published` at low priority."""
    lower_priority()
    format_published(ahead, published, stop)


def format_published(ahead: CsvAhead, published: Published, stop: threading.Event) -> None:
    """Format a piece whenever the rows for one are published, until ``stop`` is set."""
    try:
        while not stop.is_set():
            if not ahead.follow(published):
                stop.wait(POLL)
    except Exception:  # whatever went wrong, the job still comes; its rows are formatted then
        LOG.debug("results.csv: following the run's rows failed", exc_info=True)


def lower_priority() -> None:
    """Give the calling thread the nice value :data:`FOLLOWER_NICE` (Linux's nice values are
    per thread); the rest of its process keeps its own."""
    with contextlib.suppress(OSError, AttributeError):
        os.setpriority(os.PRIO_PROCESS, threading.get_native_id(), FOLLOWER_NICE)


__all__ = ["FollowRows", "follow_until_readable", "format_published", "lower_priority", "wanted"]
