"""A Ctrl-C while a command starts ends it with one line, never a traceback.

A terminal's Ctrl-C goes to its whole foreground process group. The helper processes a run
starts (the plot worker, the isolated models' zygote, a child spawned without one) leave it
to their parent, but each ignored SIGINT only once its own code ran: a Ctrl-C during their
imports printed a ``KeyboardInterrupt`` traceback. They now run in process groups of their
own. And in the command's process, a stop request landing inside the import of a C extension
(onnxruntime's, while its models load) came out as ``ImportError: initialization failed``
with a traceback; it now ends the command as the stop it is.
"""

from __future__ import annotations

import os
import signal
import sys

import pytest

from fmionnx import cli
from fmionnx.results import plotworker
from fmionnx.runtime.isolated.launcher import Zygote
from fmionnx.runtime.stopping import StopRequested, stop_behind


def _interrupted_import() -> ImportError:
    try:
        try:
            raise StopRequested(signal.SIGINT)
        except KeyboardInterrupt:
            raise ImportError("initialization failed")  # noqa: B904 - implicit, as from C
    except ImportError as exc:
        return exc


def test_the_stop_behind_an_error_is_found() -> None:
    wrapped = _interrupted_import()
    assert isinstance(stop_behind(wrapped), StopRequested)
    caused = RuntimeError("wrapped")
    caused.__cause__ = wrapped
    assert isinstance(stop_behind(caused), StopRequested)
    assert stop_behind(ValueError("plain")) is None
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
    assert err.strip().splitlines()[-1] == "error: interrupted by SIGINT"
    assert "Traceback" not in err


def test_another_error_still_propagates(monkeypatch: pytest.MonkeyPatch) -> None:
    from fmionnx.pipeline import run

    def broken(*args: object, **kwargs: object) -> None:
        raise ImportError("a real one")

    monkeypatch.setattr(run, "execute", broken)
    monkeypatch.setattr(sys, "argv", ["fmionnx", "run", "systems/sign_follower.yaml", "-q"])
    with pytest.raises(ImportError, match="a real one"):
        cli.main()


def test_the_plot_worker_and_the_zygote_are_out_of_the_terminals_group() -> None:
    worker = plotworker.PlotWorker()
    zygote = Zygote()
    try:
        for pid in (worker._process.pid, zygote.pid):  # type: ignore[union-attr]
            assert os.getpgid(pid) == pid != os.getpgrp()
    finally:
        worker.close()
        zygote.close()
