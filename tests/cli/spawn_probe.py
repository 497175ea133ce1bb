"""What a process spawned by ``multiprocessing`` from the console script has imported (run
by tests/cli/test_spawned_children.py)."""

from __future__ import annotations

import sys
from multiprocessing.queues import Queue


def report(queue: Queue[bool]) -> None:
    """In the spawned process: whether the command line's package was imported."""
    queue.put("fmionnx.cli" in sys.modules)


def sigint_ignored(queue: Queue[bool]) -> None:
    """In the spawned process: whether SIGINT is ignored (before Dask's preload would)."""
    import signal

    queue.put(signal.getsignal(signal.SIGINT) is signal.SIG_IGN)
