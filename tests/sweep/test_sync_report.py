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

busy = threading.Event()
runner.loop.add_callback(busy.wait, 30)  # sync's call cannot start before the Ctrl-C is taken
threading.Timer(0.1, os.kill, (os.getpid(), signal.SIGINT)).start()
try:
    sync(runner.loop, never)
except KeyboardInterrupt:
    print("interrupted", file=sys.stderr)
busy.set()  # now the loop starts sync's call, then runs its cancel
time.sleep(0.5)
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


def _cancel_report(filename: str) -> logging.LogRecord:
    """tornado's report of a ``cancel`` of ``filename`` reading an unbound ``future``."""
    namespace: dict[str, object] = {}
    exec(compile("def cancel():\n    return future\n", filename, "exec"), namespace)
    try:
        namespace["cancel"]()  # type: ignore[operator]
    except NameError as error:
        info = (NameError, error, error.__traceback__)
    return logging.LogRecord(LOGGER, logging.ERROR, __file__, 1, "callback", None, info)


def test_the_filter_drops_a_name_error_of_dasks_cancel_only() -> None:
    """The same report made here: a ``cancel`` of a file named as Dask's ``utils``."""
    dropping = UnstartedCancel()
    assert not dropping.filter(_cancel_report("/site-packages/distributed/utils.py"))
    assert dropping.filter(_cancel_report("/site-packages/mine/utils.py"))


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
