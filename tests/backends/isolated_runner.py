"""One FMU of a one-component system behind an :class:`IsolatedRunner`, driven step by step
by a test (the spin and zygote tests talk to the real child process directly)."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

import numpy as np

import fmionnx
from fmionnx.api import System
from fmionnx.core.runner import Wiring
from fmionnx.runtime.isolated.proxy import IsolatedRunner, IsolationSettings
from fmionnx.runtime.result import RunOptions, RunResult, RunStatus


def lone_component(fixture_fmu, write_system, name: str, parameters: str = "") -> object:
    """The compiled component ``m``: test FMU ``name`` with ``parameters`` (``", ..."``)."""
    system = fmionnx.load(
        write_system(
            f"""
fmionnx: 1
name: lone
run: {{stop: 1.0, step: 0.01}}
components:
  m: {{kind: fmu, path: {fixture_fmu(name)}{parameters}}}
"""
        )
    )
    (component,) = system.compiled.components
    return component


def unstarted(component: object, timeout: float | None = 30.0) -> IsolatedRunner:
    """An isolated runner of ``component`` (input ``u`` driven), its process not started."""
    return IsolatedRunner(
        component,  # type: ignore[arg-type]
        Wiring(driven=frozenset({"u"})),
        IsolationSettings(step_timeout=timeout),
    )


@contextmanager
def isolated(component: object, timeout: float | None = 30.0) -> Iterator[IsolatedRunner]:
    """``component`` set up in its own process (input ``u`` driven), terminated after."""
    runner = unstarted(component, timeout)
    try:
        runner.instantiate()
        runner.setup(0.0, 1.0)
        yield runner
    finally:
        runner.terminate()


def isolated_chain(fixture_fmu, write_system) -> tuple[System, RunOptions]:
    """Three FMUs in a loop with a branch (an ME integrator between two Gains), and the run
    options that isolate all three."""
    system = fmionnx.load(
        write_system(
            f"""
fmionnx: 1
name: chain
run: {{stop: 1.0, step: 0.001}}
components:
  a: {{kind: fmu, path: {fixture_fmu("Gain")}, parameters: {{k: 0.5}}}}
  b: {{kind: fmu, path: {fixture_fmu("Integrator")}, interface: me}}
  c: {{kind: fmu, path: {fixture_fmu("Gain")}, parameters: {{k: -1.5}}}}
connections:
  - a.y -> b.u
  - b.x -> a.u
  - b.x -> c.u
"""
        )
    )
    return system, RunOptions(isolate=frozenset({"a", "b", "c"}))


def assert_completed_alike(expected: RunResult, result: RunResult) -> None:
    """``result`` completed with the signals of ``expected``, byte for byte."""
    assert result.status is RunStatus.COMPLETED
    assert list(result.signals) == list(expected.signals)
    for name, values in expected.signals.items():
        assert np.asarray(values).tobytes() == np.asarray(result.signals[name]).tobytes()
