"""A Ctrl-C that comes before Dask's client loop has started a call printed Dask's traceback
(``NameError`` in ``distributed.utils.sync``'s ``cancel``) on a study that was stopping
cleanly: rare, more so on a loaded machine (``tests/sweep/test_clean_ends.py`` met it in CI).
Here the loop is kept busy so that it happens every time."""

from __future__ import annotations

import logging
import subprocess
import sys

import pytest

from fmionnx.backends.sweep.syncreport import LOGGER, UnstartedCancel

SCRIPT = """\
import asyncio, logging, os, signal, sys, threading, time
if sys.argv[1] == "ours":
    import fmionnx.backends.sweep.engine  # what a study imports
from distributed.utils import LoopRunner, sync

logging.basicConfig(level=logging.INFO)
runner = LoopRunner(asynchronous=False)
runner.start()

async def never():
    await asyncio.sleep(10)

runner.loop.add_callback(time.sleep, 0.5)  # busy: sync's call has not started at the Ctrl-C
threading.Timer(0.1, os.kill, (os.getpid(), signal.SIGINT)).start()
try:
    sync(runner.loop, never)
except KeyboardInterrupt:
    print("interrupted", file=sys.stderr)
time.sleep(0.8)  # the loop runs sync's cancel meanwhile
runner.stop()
"""


def _interrupted(which: str) -> str:
    done = subprocess.run(
        [sys.executable, "-c", SCRIPT, which],
        capture_output=True, text=True, timeout=60, check=False,
    )  # fmt: skip
    assert "interrupted" in done.stderr, done.stderr
    return done.stderr


def test_dasks_report_of_a_cancel_before_the_call_started_is_dropped() -> None:
    plain = _interrupted("plain")
    if "NameError" not in plain:
        pytest.skip("this Dask binds the future before cancelling: the filter is not needed")
    assert "sync.<locals>.cancel" in plain
    assert "Traceback" not in _interrupted("ours")


def test_other_reports_of_tornado_pass() -> None:
    dropping = UnstartedCancel()

    def fail(error: BaseException) -> None:
        raise error

    def record(error: BaseException) -> logging.LogRecord:
        try:
            fail(error)
        except BaseException as raised:
            info = (type(raised), raised, raised.__traceback__)
        return logging.LogRecord(LOGGER, logging.ERROR, __file__, 1, "boom", None, info)

    assert dropping.filter(record(NameError("a name of ours")))  # raised here, not in Dask
    assert dropping.filter(record(RuntimeError("x")))
    assert dropping.filter(logging.LogRecord(LOGGER, logging.ERROR, __file__, 1, "m", None, None))
