"""The native loop: a schedule that is one native group runs many steps per C call.

Each comparison runs the same system with the native loop and with ``FMIONNX_NATIVE=0`` (the
Python loop and runners), and compares the recorded signals byte for byte, the steps done and
the progress calls. The runs are long enough for the tracks to grow past their first chunk of
rows (:data:`fmionnx.runtime.recorder.CHUNK_ROWS`) and for the loop to go through many of its
chunks. Faults, crashes, hangs and stop requests of single FMUs, which now run in this loop,
are covered where they were before (``test_native_group.py``, ``test_guardian.py``,
``tests/cli/test_lone_fmu_default.py``, ``test_model_termination.py``).
"""

from __future__ import annotations

from pathlib import Path

import pytest

import fmionnx
from fmionnx.runtime.native import bulk
from fmionnx.runtime.recorder import CHUNK_ROWS
from fmionnx.runtime.result import RunResult, RunStatus

#: Base steps of the long runs: more rows than one chunk of a track.
STEPS = CHUNK_ROWS + 4_321


def _lone_integrator(fixture_fmu, write_system, steps: int = STEPS) -> Path:
    integrator = fixture_fmu("Integrator")
    return write_system(
        f"""
fmionnx: 1
name: lone
run: {{stop: {steps * 0.01:.2f}, step: 0.01}}
components:
  integ: {{kind: fmu, path: {integrator}, parameters: {{u: 0.3, x0: 0.1}}}}
record: [integ.u, integ.x]
"""
    )


def _chain(fixture_fmu, write_system) -> Path:
    """Two FMUs of one rate with a scaled, converted connection: one group, due every step."""
    gain, integrator = fixture_fmu("Gain"), fixture_fmu("Integrator")
    return write_system(
        f"""
fmionnx: 1
name: chain
run: {{stop: {STEPS * 0.01:.2f}, step: 0.01}}
components:
  src: {{kind: fmu, path: {gain}, parameters: {{k: 1.3, u: 0.2, v: [0.1, 0.2, 0.3]}}}}
  integ: {{kind: fmu, path: {integrator}}}
connections:
  - {{from: 'src.w[1]', to: integ.u, factor: -0.7, offset: 0.11}}
record: [src.y, src.w, integ.u, integ.x]
"""
    )


def _run(path: Path, monkeypatch: pytest.MonkeyPatch, native: str, **settings: object):
    calls: list[tuple[int, int, float]] = []

    def progress(done: int, total: int, time: float) -> None:
        calls.append((done, total, time))

    with monkeypatch.context() as patch:
        patch.setenv("FMIONNX_NATIVE", native)
        result = fmionnx.load(path).run(progress=progress, **settings)  # type: ignore[arg-type]
    return result, calls


def _assert_same(a: RunResult, b: RunResult) -> None:
    assert a.status is b.status
    assert a.steps_done == b.steps_done
    assert list(a.signals) == list(b.signals)
    for name, values in b.signals.items():
        assert a.signals[name].tobytes() == values.tobytes(), name


@pytest.mark.parametrize("maker", [_lone_integrator, _chain], ids=["lone", "chain"])
def test_the_native_loop_gives_the_python_loops_results_and_progress(
    fixture_fmu, write_system, monkeypatch: pytest.MonkeyPatch, maker
) -> None:
    path = maker(fixture_fmu, write_system)
    native, native_calls = _run(path, monkeypatch, "1", isolate="none")
    python, python_calls = _run(path, monkeypatch, "0", isolate="none")
    assert native.details["native_loop"] is True
    assert python.details["native_loop"] is False
    assert native.status is RunStatus.COMPLETED
    assert native.steps_done == STEPS
    _assert_same(native, python)
    assert native_calls == python_calls
    assert len(native_calls) > STEPS // 1000  # the callback really ran along the run
    assert len(set(native.signals["integ.x"].tolist())) > STEPS // 2  # the values move


def test_the_native_loop_under_the_guardian_publishes_the_same_rows(
    fixture_fmu, write_system, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The guardian's shared tracks: their counts are published by the kernel, and they grow
    (in shared memory) between two of its calls."""
    path = _lone_integrator(fixture_fmu, write_system)
    guarded, _ = _run(path, monkeypatch, "1", isolate="guardian")
    python, _ = _run(path, monkeypatch, "0", isolate="none")
    assert guarded.details["native_loop"] is True
    assert guarded.details["isolate"] == "guardian"
    _assert_same(guarded, python)


def test_chunks_end_at_the_wall_time_budget(
    fixture_fmu, write_system, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A budget of no time makes every call return after one step: the loop then goes
    through a chunk per step, and still gives the same results."""
    path = _lone_integrator(fixture_fmu, write_system, steps=2_000)
    calls: list[tuple[int, int]] = []
    real_run = bulk.BulkLoop.run

    def counted(self: bulk.BulkLoop, first: int, last: int) -> tuple[int, int]:
        code, next_step = real_run(self, first, last)
        calls.append((first, next_step))
        return code, next_step

    with monkeypatch.context() as patch:
        patch.setattr(bulk, "CHUNK_SECONDS", 0.0)
        patch.setattr(bulk.BulkLoop, "run", counted)
        chunked, _ = _run(path, monkeypatch, "1", isolate="none")
    python, _ = _run(path, monkeypatch, "0", isolate="none")
    assert chunked.details["native_loop"] is True
    assert calls == [(n, n + 1) for n in range(2_000)]
    _assert_same(chunked, python)


def test_a_schedule_of_several_works_keeps_the_per_step_loop(
    fixture_fmu, write_system, monkeypatch: pytest.MonkeyPatch
) -> None:
    gain, integrator = fixture_fmu("Gain"), fixture_fmu("Integrator")
    path = write_system(
        f"""
fmionnx: 1
name: two_rates
run: {{stop: 1.0, step: 0.01}}
components:
  src: {{kind: fmu, path: {gain}, parameters: {{u: 0.5}}}}
  slow: {{kind: fmu, path: {integrator}, period: 0.02}}
connections:
  - src.y -> slow.u
"""
    )
    result, _ = _run(path, monkeypatch, "1", isolate="none")
    assert result.status is RunStatus.COMPLETED
    assert result.details["native"] is True
    assert result.details["native_loop"] is False
