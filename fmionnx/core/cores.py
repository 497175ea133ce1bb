"""How many cores this process may use: the one count a study's workers, the plot worker and
its drawing copies are sized by."""

from __future__ import annotations

import os


def usable_cores() -> int:
    """The cores this process may run on (its CPU affinity; the machine's count elsewhere)."""
    ids = usable_core_ids()
    return max(1, len(ids) if ids is not None else os.cpu_count() or 1)


def usable_core_ids() -> list[int] | None:
    """The numbers of the cores this process may run on, in order; None where the system
    does not say (not Linux)."""
    try:
        return sorted(os.sched_getaffinity(0))
    except AttributeError:
        return None
