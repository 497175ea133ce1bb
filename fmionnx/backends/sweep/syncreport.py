"""Drops Dask's report of its own failed clean-up after a Ctrl-C, in any study of this process.

``distributed.utils.sync`` (every blocking call of a Dask client) schedules a ``cancel``
callback on the client's loop when a Ctrl-C interrupts the wait. When the Ctrl-C comes before
the loop has started the call (a busy loop, a loaded machine), ``cancel`` reads a variable
that is not bound yet, and tornado logs ``NameError: cannot access free variable 'future'``
with its traceback, on the terminal of a study that was stopping cleanly
(``tests/sweep/test_sync_report.py`` makes it happen). The callback runs on the loop's thread
at a moment of its own, possibly after the study's own filters are gone, so this one is
installed for the process, and it drops that report only: a ``NameError`` raised in a
function named ``cancel`` of ``distributed/utils.py``.
"""

from __future__ import annotations

import logging
import traceback

#: tornado's logger of exceptions raised in loop callbacks.
LOGGER = "tornado.application"


class UnstartedCancel(logging.Filter):
    """Drops the report of ``sync``'s ``cancel`` meeting a call not started yet."""

    def filter(self, record: logging.LogRecord) -> bool:
        error = record.exc_info[1] if record.exc_info else None
        if not isinstance(error, NameError) or error.__traceback__ is None:
            return True
        last = traceback.extract_tb(error.__traceback__)[-1]
        where = last.filename.replace("\\", "/")
        return not (last.name == "cancel" and where.endswith("distributed/utils.py"))


def install() -> None:
    """Add the filter to tornado's logger, once per process."""
    logger = logging.getLogger(LOGGER)
    if not any(isinstance(f, UnstartedCancel) for f in logger.filters):
        logger.addFilter(UnstartedCancel())
