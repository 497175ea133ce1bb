"""Run in each worker process of a local cluster as it starts (a Dask worker preload).

A terminal's Ctrl-C goes to every process of its process group: the driver and the local
cluster's worker processes alike. A worker interrupted that way died in the middle of Dask's
own shutdown and printed five tracebacks, while the driver was already closing the cluster in
order (the finished cases recorded, ``--resume`` to finish). So a worker ignores SIGINT: the
driver alone decides, and closes its workers. SIGTERM keeps its default (a worker whose driver
was killed must still be stoppable).
"""

from __future__ import annotations

import signal
import threading
from typing import Any


def dask_setup(worker: Any) -> None:
    """Dask's preload hook: called once in the worker process, before it takes tasks."""
    del worker
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)
