"""Run in each worker process of a local cluster as it starts (a Dask worker preload).

A terminal's Ctrl-C goes to every process of its process group: the driver and the local
cluster's worker processes alike. A worker interrupted that way died in the middle of Dask's
own shutdown and printed five tracebacks, while the driver was already closing the cluster in
order (the finished cases recorded, ``--resume`` to finish). So a worker ignores SIGINT: the
driver alone decides, and closes its workers. SIGTERM keeps its default (a worker whose driver
was killed must still be stoppable).

The scheduler of a local cluster lives in the driver and goes away only when the driver ends
the study. A worker's heartbeat that meets it closing (a race a loaded machine makes likely)
is logged by Dask as an error with a traceback, on the user's terminal; it says nothing the
study does not already say, so a worker drops it (:class:`GoneScheduler`).
"""

from __future__ import annotations

import logging
import signal
import threading
from typing import Any

#: What Dask's worker logs when a heartbeat finds no scheduler (``distributed.worker``).
HEARTBEAT_FAILED = "Failed to communicate with scheduler during heartbeat"


class GoneScheduler(logging.Filter):
    """Drops the worker's report of a heartbeat that found the scheduler gone."""

    def filter(self, record: logging.LogRecord) -> bool:
        return not str(record.msg).startswith(HEARTBEAT_FAILED)


def dask_setup(worker: Any) -> None:
    """Dask's preload hook: called once in the worker process, before it takes tasks."""
    del worker
    logging.getLogger("distributed.worker").addFilter(GoneScheduler())
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)
