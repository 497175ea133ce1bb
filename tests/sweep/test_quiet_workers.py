"""A local cluster's workers leave Ctrl-C to the driver and say nothing of a scheduler that
the driver closed under a heartbeat (fmionnx.backends.sweep.quiet)."""

from __future__ import annotations

import logging
import sys

from fmionnx.backends.sweep.quiet import HEARTBEAT_FAILED, GoneScheduler


def _record(message: str) -> logging.LogRecord:
    return logging.LogRecord("distributed.worker", logging.ERROR, __file__, 1, message, (), None)


def test_a_heartbeat_that_found_the_scheduler_gone_is_dropped_and_nothing_else() -> None:
    gone = GoneScheduler()
    assert not gone.filter(_record(HEARTBEAT_FAILED + "."))
    assert gone.filter(_record("Unexpected exception during heartbeat. Closing worker."))
    assert gone.filter(_record("Could not find data: %s"))


def test_every_worker_of_a_local_cluster_has_the_filter() -> None:
    import cloudpickle

    from fmionnx.backends.sweep.engine import open_client

    cloudpickle.register_pickle_by_value(sys.modules[__name__])  # the workers cannot import us
    with open_client(workers=2) as client:
        found = client.run(_worker_filters)
    assert len(found) == 2
    assert all("GoneScheduler" in names for names in found.values())


def _worker_filters() -> list[str]:
    """On a worker: the filters of Dask's worker logger."""
    return [type(f).__name__ for f in logging.getLogger("distributed.worker").filters]
