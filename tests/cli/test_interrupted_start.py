"""A Ctrl-C while a command starts ends it with one line, never a traceback.

A terminal's Ctrl-C goes to its whole foreground process group. The plot worker a run starts
leaves it to its parent, but ignored SIGINT only once its own code ran: a Ctrl-C during its
imports (a third of a second) printed a ``KeyboardInterrupt`` traceback. It now runs in a
process group of its own. And in the command's process, a stop request landing inside the import of a C extension
(onnxruntime's, while its models load) came out as ``ImportError: initialization failed``
with a traceback; it now ends the command as the stop it is.
"""

from __future__ import annotations

import os
import signal
import sys
import time
from pathlib import Path

import pytest

from fmionnx import cli
from fmionnx.results import plotworker
from fmionnx.runtime.stopping import StopRequested, stop_behind


def _interrupted_import() -> ImportError:
    try:
        try:
            raise StopRequested(signal.SIGINT)
        except KeyboardInterrupt:
            raise ImportError("initialization failed")  # noqa: B904 - implicit, as from C
    except ImportError as exc:
        return exc


def _replaced_on_purpose() -> ValueError:
    try:
        try:
            raise StopRequested(signal.SIGINT)
        except KeyboardInterrupt:
            raise ValueError("replaced on purpose") from None
    except ValueError as exc:
        return exc


def test_the_stop_behind_an_error_is_found() -> None:
    wrapped = _interrupted_import()
    assert isinstance(stop_behind(wrapped), StopRequested)
    caused = RuntimeError("wrapped")
    caused.__cause__ = wrapped
    assert isinstance(stop_behind(caused), StopRequested)
    assert stop_behind(ValueError("plain")) is None
    assert stop_behind(_replaced_on_purpose()) is None
    looped = ValueError("a")
    other = ValueError("b")
    looped.__context__, other.__context__ = other, looped
    assert stop_behind(looped) is None


def test_a_stop_inside_an_import_ends_the_command_as_stopped(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from fmionnx.pipeline import run

    def interrupted(*args: object, **kwargs: object) -> None:
        raise _interrupted_import()

    monkeypatch.setattr(run, "execute", interrupted)
    monkeypatch.setattr(sys, "argv", ["fmionnx", "run", "systems/sign_follower.yaml", "-q"])
    with pytest.raises(SystemExit) as stopped:
        cli.main()
    assert stopped.value.code == 128 + signal.SIGINT
    err = capsys.readouterr().err
    last = err.strip().splitlines()[-1]
    assert last == "error: interrupted by SIGINT (ImportError: initialization failed)"
    assert "Traceback" not in err


def test_another_error_still_propagates(monkeypatch: pytest.MonkeyPatch) -> None:
    from fmionnx.pipeline import run

    def broken(*args: object, **kwargs: object) -> None:
        raise ImportError("a real one")

    monkeypatch.setattr(run, "execute", broken)
    monkeypatch.setattr(sys, "argv", ["fmionnx", "run", "systems/sign_follower.yaml", "-q"])
    with pytest.raises(ImportError, match="a real one"):
        cli.main()


def _ignored(pid: int) -> int:
    """The signals process ``pid`` ignores, as a bit mask (``/proc/PID/status``)."""
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("SigIgn:"):
            return int(line.split()[1], 16)
    return 0


def test_the_plot_worker_is_out_of_the_terminals_group_and_its_job_control() -> None:
    """Out of the terminal's process group, Ctrl-C does not reach it; in a background group,
    ``stty tostop`` would stop it at its first write to the terminal, unless it ignores
    SIGTTOU (and SIGTTIN), which it does once it runs."""
    worker = plotworker.PlotWorker()
    assert worker._process is not None
    pid = worker._process.pid
    try:
        assert os.getpgid(pid) == pid != os.getpgrp()
        wanted = (1 << (signal.SIGTTOU - 1)) | (1 << (signal.SIGTTIN - 1))
        deadline = time.monotonic() + 60
        while _ignored(pid) & wanted != wanted and time.monotonic() < deadline:
            time.sleep(0.05)
        assert _ignored(pid) & wanted == wanted
    finally:
        worker.close()
