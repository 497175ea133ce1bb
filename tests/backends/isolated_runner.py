"""One FMU of a one-component system behind an :class:`IsolatedRunner`, driven step by step
by a test (the spin and zygote tests talk to the real child process directly)."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

import fmionnx
from fmionnx.core.runner import Wiring
from fmionnx.runtime.isolated.proxy import IsolatedRunner, IsolationSettings


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


@contextmanager
def isolated(component: object, timeout: float | None = 30.0) -> Iterator[IsolatedRunner]:
    """``component`` set up in its own process (input ``u`` driven), terminated after."""
    runner = IsolatedRunner(
        component,  # type: ignore[arg-type]
        Wiring(driven=frozenset({"u"})),
        IsolationSettings(step_timeout=timeout),
    )
    try:
        runner.instantiate()
        runner.setup(0.0, 1.0)
        yield runner
    finally:
        runner.terminate()
