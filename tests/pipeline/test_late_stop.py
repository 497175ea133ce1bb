"""A stop signal after a run's last step cuts nothing off (a bug hunt found results lost).

SIGTERM from a CI runner or a container runtime can come while a finished run writes its
results and checks. It used to raise wherever the main thread was: results.csv without
run.json (or plots only), no ownership record (the next run into the folder was refused),
and the command said "interrupted before the run started". From the run's last step on, a
stop signal is held and never raised; the run says it came.
"""

from __future__ import annotations

import json
import logging
import os
import shutil
import signal
from collections.abc import Callable, Sequence
from pathlib import Path

import pytest

from fmionnx.pipeline.observers import RunObserver
from fmionnx.pipeline.outcome import RunOutcome
from fmionnx.pipeline.request import build_request
from fmionnx.pipeline.run import execute
from fmionnx.runtime.stopping import StopRequested, stop_on_signals, stops_held

SYSTEM = """\
fmionnx: 1
name: chain
run: {stop: 0.05, step: 0.01}
components:
  a: {kind: fmu, path: Gain.fmu, parameters: {u: 1.0}}
  b: {kind: fmu, path: Gain.fmu}
connections:
  - a.y -> b.u
plots:
  - {y: [b.y], file: gain}
"""


#: What a run says of a stop signal after its last step.
LATE = (
    "SIGTERM came after the run's last step: it was not cut off, and its results are "
    "written in full"
)


def _run_chain(
    tmp_path: Path,
    fixture_fmu: Callable[[str], Path],
    isolate: str,
    observers: Sequence[RunObserver] = (),
) -> RunOutcome:
    """The two-gain system run through the pipeline into ``tmp_path/out``, under the CLI's
    stop signals."""
    shutil.copy(fixture_fmu("Gain"), tmp_path / "Gain.fmu")
    (tmp_path / "system.yaml").write_text(SYSTEM, encoding="utf-8")
    request = build_request(tmp_path / "system.yaml", out=tmp_path / "out", isolate=isolate)
    with stop_on_signals():
        return execute(request, observers)


def _let_the_handler_run() -> None:
    for _ in range(1000):  # Python runs a signal handler at one of these statements
        pass


class _StopAfterTheRun(RunObserver):
    """Sends this process SIGTERM as the backend returns: the run's results are not written."""

    def after_run(self) -> None:
        os.kill(os.getpid(), signal.SIGTERM)
        _let_the_handler_run()


@pytest.mark.parametrize("isolate", ["none", "fmus"])
def test_a_stop_after_the_last_step_leaves_the_results_whole(
    tmp_path: Path,
    fixture_fmu: Callable[[str], Path],
    caplog: pytest.LogCaptureFixture,
    isolate: str,
) -> None:
    out = tmp_path / "out"
    with caplog.at_level(logging.WARNING):
        outcome = _run_chain(tmp_path, fixture_fmu, isolate, [_StopAfterTheRun()])
    assert outcome.result.status.value == "completed"
    assert outcome.exit_status == 0
    assert sorted(p.name for p in out.iterdir()) == [
        ".fmionnx-owned", "gain.png", "results.csv", "run.json",
    ]  # fmt: skip
    assert json.loads((out / "run.json").read_text(encoding="utf-8"))["status"] == "completed"
    assert LATE in caplog.messages


def test_a_held_stop_is_not_raised_and_is_named_when_the_hold_ends() -> None:
    with stop_on_signals() as received:
        with stops_held() as late:
            os.kill(os.getpid(), signal.SIGINT)
            _let_the_handler_run()
        assert late == ["SIGINT"]
        assert received == [signal.SIGINT]
        os.kill(os.getpid(), signal.SIGTERM)  # a later one: ignored, as after any stop
        _let_the_handler_run()


def test_a_hold_without_a_stop_names_none_and_without_a_hold_the_stop_stops() -> None:
    with stop_on_signals(), stops_held() as late:
        pass
    assert late == []
    stopped = None
    try:
        with stop_on_signals():
            os.kill(os.getpid(), signal.SIGTERM)
            _let_the_handler_run()
    except StopRequested as exc:
        stopped = exc.signal_name
    assert stopped == "SIGTERM"


def test_a_stop_while_the_models_terminate_leaves_the_run_completed(
    tmp_path: Path, fixture_fmu: Callable[[str], Path], monkeypatch: pytest.MonkeyPatch
) -> None:
    """The master's own end: a signal while its models are freed (the last thing before its
    result exists) is held there, and the result says it came."""
    from fmionnx.kinds.fmu.runner import FmuRunner

    terminate = FmuRunner.terminate

    def signalling_terminate(self: FmuRunner) -> None:
        os.kill(os.getpid(), signal.SIGTERM)
        _let_the_handler_run()
        terminate(self)

    monkeypatch.setattr(FmuRunner, "terminate", signalling_terminate)
    outcome = _run_chain(tmp_path, fixture_fmu, "none")
    assert outcome.result.status.value == "completed"
    assert outcome.result.interrupted_by is None
    assert outcome.result.warnings == [LATE]
    run_json = json.loads((tmp_path / "out" / "run.json").read_text(encoding="utf-8"))
    assert run_json["warnings"] == outcome.result.warnings


def test_under_the_guardian_a_stop_while_the_childs_result_is_taken_is_held(
    tmp_path: Path, fixture_fmu: Callable[[str], Path], monkeypatch: pytest.MonkeyPatch
) -> None:
    """The guardian's child has stepped to the end; the parent then reaps it and unpickles
    its result (megabytes for a long run): a stop there lost everything (found in review)."""
    from fmionnx.runtime import guardian

    unpickle = guardian._unpickle

    def signalling_unpickle(*args: object) -> object:
        os.kill(os.getpid(), signal.SIGTERM)
        _let_the_handler_run()
        return unpickle(*args)  # type: ignore[arg-type]

    monkeypatch.setattr(guardian, "_unpickle", signalling_unpickle)
    outcome = _run_chain(tmp_path, fixture_fmu, "guardian")
    assert outcome.result.status.value == "completed"
    assert outcome.result.warnings == [LATE]
    assert (tmp_path / "out" / "run.json").exists()


def test_a_hold_inside_a_shield_leaves_the_stop_to_the_shield() -> None:
    """A shield delays a stop and never drops it: a hold nested in one hands the signal on."""
    from fmionnx.runtime.stopping import shield_begin, shield_end

    stopped = None
    try:
        with stop_on_signals():
            shield_begin()
            with stops_held() as late:
                os.kill(os.getpid(), signal.SIGTERM)
                _let_the_handler_run()
            assert late == []
            shield_end()
    except StopRequested as exc:
        stopped = exc.signal_name
    assert stopped == "SIGTERM"
