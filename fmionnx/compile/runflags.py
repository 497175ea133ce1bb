"""Run settings from the command line (``--start-time``, ``--step``, and ``--stop-time`` given
with ``--start-time``): applied before compiling.

Unlike ``--stop-time`` and ``--param`` (:mod:`.overrides`, which act on a compiled system), a
new base step or start time changes what the compiler checks and derives: every component's
period in base steps, the physics timestep check, the default period, whether the run is a
whole number of steps. So they replace the system file's ``run.start``/``run.step`` in the raw
spec and the system is compiled with them, every check included; ``run.json`` records them as
coming from the command line. They apply to every system file (YAML, SSP) alike.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import TYPE_CHECKING

from fmionnx.compile.ir import CompiledSystem, Origin
from fmionnx.core import codes
from fmionnx.core.diagnostics import DiagnosticBag, Span
from fmionnx.core.steps import time_flags_problem

if TYPE_CHECKING:  # a lone model (`run model.fmu`) never loads a system file's types
    from fmionnx.spec.yaml import LoadedSpec


@dataclass(frozen=True)
class RunFlags:
    """``--start-time``, ``--step`` and a ``--stop-time`` given with them (None: the system
    file's, or what the compiler derives)."""

    start: float | None = None
    step: float | None = None
    #: ``--stop-time`` given with ``--start-time`` (or ``fmionnx.load(stop=...)``): applied
    #: with it, so a start past the file's stop compiles (the command line's ``--stop-time``
    #: alone is an override of the compiled system, :mod:`.overrides`).
    stop: float | None = None

    @property
    def keys(self) -> tuple[str, ...]:
        """The run settings these flags set, as ``run.json``'s ``settings_origin`` names them."""
        named = (("start", self.start), ("step", self.step), ("stop", self.stop))
        return tuple(k for k, v in named if v is not None)


def apply_run_flags(loaded: LoadedSpec, flags: RunFlags, bag: DiagnosticBag) -> LoadedSpec:
    """``loaded`` with the flags' run settings; E040 (at the system file) for a bad value."""
    from fmionnx.spec.yaml import LoadedSpec

    spec = loaded.spec
    if spec is None or not flags.keys:
        return loaded
    where = Span(loaded.path)
    problem = time_flags_problem(flags.start, flags.step, flags.stop)
    if problem is None:
        problem = _order_problem(spec.run.start, spec.run.stop, flags)
    if problem is not None:  # said of the flags: the compiler's E040 pointed at the file
        bag.emit(codes.RUN_SETTINGS, problem, where)
        return LoadedSpec(None, loaded.sources, loaded.path)
    update = {key: getattr(flags, key) for key in flags.keys}
    run = spec.run.model_copy(update=update)
    return LoadedSpec(spec.model_copy(update={"run": run}), loaded.sources, loaded.path)


def _order_problem(start: float, stop: float | None, flags: RunFlags) -> str | None:
    """Why the run would not end after it starts when one of ``--start-time``/``--stop-time``
    meets the system file's other end (None: it would; both given, ``time_flags_problem``)."""
    if flags.start is not None and flags.stop is None and stop is not None and stop <= flags.start:
        return (
            f"--start-time {flags.start} is not before the system's stop time {stop} "
            "(`run.stop`); give --stop-time too"
        )
    if flags.stop is not None and flags.start is None and flags.stop <= start:
        return (
            f"--stop-time {flags.stop} is not after the system's start time {start} (`run.start`)"
        )
    return None


def mark_command_line(system: CompiledSystem, flags: RunFlags) -> CompiledSystem:
    """The compiled system with the flags' settings recorded as coming from the command line."""
    if not flags.keys:
        return system
    run = system.run
    origins = (
        *((k, o) for k, o in run.origins if k not in flags.keys),
        *((k, Origin.COMMAND_LINE) for k in flags.keys),
    )
    return dataclasses.replace(system, run=dataclasses.replace(run, origins=origins))
