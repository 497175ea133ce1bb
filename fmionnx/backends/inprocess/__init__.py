"""The in-process backend: one Python process, a deterministic co-simulation master.

Its options say how models are kept from taking the run down (``isolate``, ``sandbox``),
how steps are scheduled (``schedule``) and whether they are paced to the wall clock (``rtf``,
:mod:`fmionnx.runtime.pacing`). ``isolate`` left unset is chosen per system by
:meth:`InProcessBackend.prepare` (docs/security.md, docs/decisions.md):

- a system whose only component is one FMU runs under the **guardian** (the whole run in one
  forked child, about as fast as in-process), when a fork is safe here: Linux, no
  ``sandbox``, no recording or live view, and no other Python thread in this process (a thread holding a
  lock at the fork would leave it held in the child for good: a notebook, a program with
  threads of its own);
- anything else runs every FMU in a process of its own (``fmus``): with several components
  only that tells which one crashed inside a native group, and ``sandbox`` confines only
  models in processes of their own.
"""

from __future__ import annotations

import contextlib
import dataclasses
import threading
from collections.abc import Mapping
from typing import Self

from fmionnx.compile.ir import CompiledSystem
from fmionnx.core import codes
from fmionnx.core.diagnostics import Diagnostic, make
from fmionnx.runtime.backend import (
    Backend,
    BackendOptions,
    OptionsError,
    RunContext,
    checked_rtf,
)
from fmionnx.runtime.result import RunOptions, RunResult, Schedule

#: The ``isolate`` word that runs the whole run in one guarded child process.
GUARDIAN = "guardian"
#: The ``isolate`` words besides component names (``runtime.isolated.factory``'s and the guardian).
ISOLATE_WORDS = ("fmus", "all", "none", GUARDIAN)
SCHEDULES: tuple[Schedule, ...] = ("parallel", "sequential")


def isolate_words(value: object) -> tuple[str, ...]:
    """``isolate`` as words: a string (comma-separated) or a sequence of them."""
    items = [value] if isinstance(value, str) else value
    if not isinstance(items, list | tuple | frozenset | set) or not all(
        isinstance(item, str) for item in items
    ):
        msg = "--isolate takes words: `fmus`, `all`, `none`, `guardian` or component names"
        raise OptionsError(msg)
    return tuple(w.strip() for item in items for w in str(item).split(",") if w.strip())


@dataclasses.dataclass(frozen=True)
class InProcessOptions(BackendOptions):
    """``isolate`` (None: chosen per system), ``sandbox``, ``schedule``, ``rtf``."""

    #: The ``--isolate`` words; None until :meth:`InProcessBackend.prepare` chose.
    isolate: tuple[str, ...] | None = None
    sandbox: bool = False
    schedule: Schedule = "parallel"
    #: Whether ``isolate`` was chosen by default, not given (run.json says so).
    isolate_default: bool = False
    #: Pace the master to this many times real time (0: as fast as it goes; runtime.pacing).
    rtf: float = 0.0

    @classmethod
    def checked(cls, given: Mapping[str, object]) -> Self:
        """Words split at commas; ``schedule`` one of :data:`SCHEDULES`."""
        if "isolate_default" in given:
            msg = "--isolate-default does not apply: it says whether --isolate was given"
            raise OptionsError(msg)
        isolate = given.get("isolate")
        words = None if isolate is None else isolate_words(isolate)
        for alone in ("none", GUARDIAN):
            if words is not None and alone in words and set(words) != {alone}:
                others = ", ".join(f"`{w}`" for w in dict.fromkeys(words) if w != alone)
                msg = f"--isolate `{alone}` stands alone: it cannot be given with {others}"
                raise OptionsError(msg)
        schedule = given.get("schedule", "parallel")
        if schedule is None:
            schedule = "parallel"
        if schedule not in SCHEDULES:
            msg = f"--schedule must be `parallel` or `sequential`, not `{schedule}`"
            raise OptionsError(msg)
        sandbox = given.get("sandbox", False)
        if not isinstance(sandbox, bool):
            msg = "--sandbox is true or false"
            raise OptionsError(msg)
        chosen: Schedule = "sequential" if schedule == "sequential" else "parallel"
        rtf = checked_rtf(given.get("rtf", 0.0))
        return cls(isolate=words, sandbox=sandbox, schedule=chosen, rtf=rtf)

    @property
    def words(self) -> tuple[str, ...]:
        """The ``isolate`` words in force (``fmus`` until chosen)."""
        return ("fmus",) if self.isolate is None else self.isolate

    @property
    def guarded(self) -> bool:
        """The whole run in one guarded child process (``isolate`` holds ``guardian``)."""
        return GUARDIAN in self.words

    @property
    def publishes_rows(self) -> bool:
        """A guarded run publishes its rows in shared memory while it goes."""
        return self.guarded

    def how(self) -> str:
        """`` in a guarded process`` (and whether by default), else nothing."""
        if not self.guarded:
            return ""
        return " in a guarded process" + (
            ", the default for a lone FMU" if self.isolate_default else ""
        )

    def where(self) -> str:
        """`` at 1x real time`` for a paced run, else nothing."""
        return f" at {self.rtf:g}x real time" if self.rtf > 0 else ""

    def details(self) -> dict[str, str | bool]:
        """run.json's ``execution.isolate`` (the words in force) and whether by default."""
        return {"isolate": ",".join(self.words), "isolate_default": self.isolate_default}


def fork_is_safe() -> str | None:
    """Why forking this process for the guardian is not safe, or None."""
    from fmionnx.runtime.guardian import available
    from fmionnx.runtime.watchdog import watch_thread

    problem = available()
    if problem is not None:
        return problem
    ours = {threading.main_thread(), watch_thread()}  # the watch thread is fork-safe
    if any(thread not in ours for thread in threading.enumerate()):
        return "this process runs other threads"
    return None


def default_isolation(system: CompiledSystem, *, sandbox: bool, recording: bool) -> str:
    """``isolate``'s default word for ``system``: ``guardian`` or ``fmus`` (module docstring)."""
    from fmionnx.kinds.base import FMI
    from fmionnx.kinds.registry import has_capability

    components = list(system.components)
    lone_fmu = len(components) == 1 and has_capability(components[0], FMI)
    if lone_fmu and not sandbox and not recording and fork_is_safe() is None:
        return GUARDIAN
    return "fmus"


class InProcessBackend(Backend):
    """Runs every component in this process with :class:`~.master.Master`."""

    name = "inprocess"
    summary = "one deterministic process"
    options_type = InProcessOptions

    def prepare(
        self, system: CompiledSystem, options: BackendOptions, context: RunContext
    ) -> InProcessOptions:
        """``isolate``'s default chosen, the words checked against the system."""
        from fmionnx.runtime.isolated.factory import isolation_targets

        assert isinstance(options, InProcessOptions)
        if options.isolate is None:
            watched = context.recording or context.viewing  # frames leave the loop's process
            word = default_isolation(system, sandbox=options.sandbox, recording=watched)
            options = dataclasses.replace(options, isolate=(word,), isolate_default=True)
        chosen, unknown = isolation_targets(system, _component_words(options))
        if unknown:
            names = ", ".join(f"`{c.name}`" for c in system.components)
            msg = (
                f"--isolate: no component named {', '.join(f'`{u}`' for u in unknown)}; "
                f"use `fmus`, `all`, `none`, `guardian` or one of {names}"
            )
            raise OptionsError(msg)
        if options.sandbox and not chosen:
            msg = "--sandbox confines isolated models, and --isolate selects none"
            raise OptionsError(msg)
        if options.guarded:
            from fmionnx.runtime.guardian import available

            problem = available()
            if problem is not None:
                msg = f"--isolate guardian: {problem}"
                raise OptionsError(msg)
            if context.recording:
                msg = (
                    "--isolate guardian does not combine with --record (the frames would be "
                    "recorded in the guarded process); isolate components by name instead"
                )
                raise OptionsError(msg)
            if context.viewing:
                msg = (
                    "--isolate guardian does not combine with --view or --rrd (the frames and "
                    "rows would stay in the guarded process); isolate components by name instead"
                )
                raise OptionsError(msg)
        return options

    def validate(self, system: CompiledSystem, options: BackendOptions) -> list[Diagnostic]:
        """External components cannot run here (every kind has a runner: the kind table)."""
        del options
        problems = []
        for component in system.components:
            if component.external:
                problems.append(
                    make(
                        codes.UNKNOWN_OPTION,
                        f"component `{component.name}` is `external: true`, which only the ROS 2 "
                        "backend can provide",
                        component.span,
                        hint="run with the ROS 2 backend, or remove `external`",
                    )
                )
        return problems

    def start_helpers(self, system: CompiledSystem, options: BackendOptions) -> None:
        """The isolated models' zygote (:func:`~fmionnx.runtime.isolated.launcher.prestart`),
        when the run isolates a model outside the guardian."""
        from fmionnx.runtime.isolated.factory import isolation_targets

        assert isinstance(options, InProcessOptions)
        chosen, _ = isolation_targets(system, _component_words(options))
        if chosen and not options.guarded:
            from fmionnx.runtime.isolated.launcher import prestart

            prestart(fork=not options.sandbox)

    def run(self, system: CompiledSystem, options: BackendOptions, run: RunOptions) -> RunResult:
        """Run ``system`` to its stop time; faults and Ctrl-C end in the result's status."""
        from fmionnx.runtime.isolated.factory import isolation_targets
        from fmionnx.runtime.master import Master

        assert isinstance(options, InProcessOptions)
        chosen, _ = isolation_targets(system, _component_words(options))
        run = dataclasses.replace(
            run, isolate=chosen, sandbox=options.sandbox, schedule=options.schedule,
            rtf=options.rtf,
        )  # fmt: skip

        def plain(*, options: RunOptions) -> RunResult:
            return Master(system, options).run()

        # unless the pipeline did: the zygote's imports go on while the models load
        self.start_helpers(system, options)
        if options.guarded:
            from fmionnx.runtime.guardian import run_guarded

            result = run_guarded(system, plain, run, run.follower)
        else:
            from fmionnx.runtime.lifetime import models_here
            from fmionnx.runtime.stopping import late_stop_text, stops_held

            late: list[str] = []
            # What a model in this process starts ends with the run (models_here); the hold,
            # entered after the loop on the outer stack, is left after that end.
            with contextlib.ExitStack() as after_loop, models_here():
                result = plain(options=run)
                late = after_loop.enter_context(stops_held())
            if late:
                result.warnings.append(late_stop_text(late[0]))
        result.details.update(options.details())
        return result


def _component_words(options: InProcessOptions) -> list[str]:
    return [w for w in options.words if w != GUARDIAN]
