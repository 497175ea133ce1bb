"""What ``fmionnx run`` does so that a misbehaving model never costs the user the run.

- ``--isolate`` runs models in processes of their own: a crash, abort, exit or hang becomes a
  fault naming the component and the time. Its default depends on the system
  (:meth:`RunSafety.resolved`): a lone FMU runs under the guardian (the whole run in one
  guarded child process, about as fast as in-process), anything else with every FMU in a process
  of its own (``fmus``), which also names the FMI function and can ``--sandbox`` a model.
- ``--step-timeout`` bounds every step; a component in this process that overruns it has
  the run abandoned with its results written (:mod:`fmionnx.runtime.watchdog`).
- Checkpoints rewrite ``results.csv`` and ``run.json`` (status ``running``) every few seconds,
  so even SIGKILL loses only the last seconds.

The decisions behind the defaults are in ``docs/security.md``.
"""

from __future__ import annotations

import dataclasses
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from fmionnx.cli.app import fail

#: Seconds of wall time between checkpoints (at least; they never cost more than a tenth).
CHECKPOINT_EVERY = 10.0


@dataclass(frozen=True)
class RunSafety:
    """The run command's isolation, timeout and checkpoint choices."""

    #: The ``--isolate`` words; None: not given, chosen per system by :meth:`resolved`.
    isolate: list[str] | None = None
    sandbox: bool = False
    step_timeout: float | None = 60.0
    checkpoint_every: float = CHECKPOINT_EVERY
    plot_signals: bool = False
    #: ``parallel`` or ``sequential`` (``--schedule``; docs/execution.md, "Parallel schedule").
    schedule: str = "parallel"
    #: Whether ``isolate`` is the default (chosen by :meth:`resolved`), not the user's words.
    by_default: bool = False

    def resolved(self, compiled: Any, *, record: bool) -> RunSafety:
        """The safety with ``--isolate``'s default chosen for ``compiled`` when not given.

        A system whose only component is one FMU runs under the guardian when it can (Linux,
        no ``--sandbox``, no ``--record``): its child process *is* the model's process, so a
        crash keeps every completed step and names the component and time, and a hang is
        abandoned at the step timeout with the results written, all at the cost of one
        ``fork`` instead of a pipe round trip per step (2.4x ``fmpy simulate`` for a fast
        FMU). Anything else keeps every FMU in a process of its own (``fmus``): with several
        components only that tells which one crashed inside a native group, and ``--sandbox``
        confines only models in processes of their own. See docs/decisions.md.
        """
        if self.isolate is not None:
            return self
        words = [lone_fmu_default(compiled, sandbox=self.sandbox, record=record)]
        return dataclasses.replace(self, isolate=words, by_default=True)

    @property
    def words(self) -> list[str]:
        """The ``--isolate`` words in force (``fmus`` until :meth:`resolved` chose)."""
        return ["fmus"] if self.isolate is None else self.isolate

    @property
    def guardian(self) -> bool:
        """``--isolate guardian``: the whole run in one guarded child process."""
        from fmionnx.runtime.guardian import GUARDIAN

        return GUARDIAN in self.words

    def details(self) -> dict[str, str | bool]:
        """run.json's ``execution.isolate`` (the words in force) and whether by default."""
        return {"isolate": ",".join(self.words), "isolate_default": self.by_default}

    def csv_ahead(self, system: Any, out: Path | None) -> Any:
        """A :class:`~fmionnx.results.csvahead.CsvAhead` for a guarded run with an output
        folder (its ``results.csv`` formatted while the run goes on), else None."""
        if not self.guardian or out is None:
            return None
        from fmionnx.results.csvahead import CsvAhead

        return CsvAhead(system.compiled)

    def guard(self, system: Any, run_fn: Any, *, record: bool, ahead: Any = None) -> Any:
        """``run_fn`` under the guardian when ``--isolate guardian`` asks for it (or the
        default chose it); either way the result's ``details`` say how the run was isolated.
        ``ahead`` (:meth:`csv_ahead`) formats results.csv while the guarded run goes on."""
        inner = run_fn
        if self.guardian:
            from fmionnx.runtime.guardian import available, guard

            problem = available()
            if problem is not None:
                raise fail(f"--isolate guardian: {problem}")
            if record:
                raise fail("--isolate guardian does not combine with --record (the frames would "
                           "be recorded in the guarded process); isolate components by name "
                           "instead")  # fmt: skip
            inner = guard(system.compiled, run_fn, follower=ahead)
        details = self.details()

        def described(*, options: Any) -> Any:
            result = inner(options=options)
            result.details.update(details)
            return result

        return described

    def options(self, options: Any, system: Any, out: Path | None, console: Any) -> Any:
        """``options`` with isolation, the step timeout and the checkpoint/abandon writers."""
        from fmionnx.runtime.guardian import GUARDIAN
        from fmionnx.runtime.isolated.factory import isolation_targets

        words = [w for w in self.words if w != GUARDIAN]
        chosen, unknown = isolation_targets(system.compiled, words)
        if unknown:
            names = ", ".join(f"`{c.name}`" for c in system.compiled.components)
            raise fail(
                f"--isolate: no component named {', '.join(f'`{u}`' for u in unknown)}; "
                f"use `fmus`, `all`, `none`, `guardian` or one of {names}"
            )
        if self.sandbox and not chosen:
            raise fail("--sandbox confines isolated models, and --isolate selects none")
        compiled, aliases = system.compiled, dict(system.aliases)
        details = self.details()

        def checkpoint(result: Any) -> None:
            from fmionnx.results import write_results

            assert out is not None
            result.details.update(details)
            write_results(result, compiled, out, aliases=aliases, checkpoint=True)

        guarded = self.guardian

        def abandon(result: Any) -> None:
            result.details.update(details)
            if out is not None:
                from fmionnx.results import write_results

                write_results(
                    result, compiled, out, aliases=aliases, plot_signals=self.plot_signals
                )
            shown = console
            if guarded:  # in the guarded child: the parent's console may be locked for good
                from rich.console import Console

                shown = Console(stderr=True, highlight=False)
            shown.print(f"[bold red]fault:[/] {result.error}")
            if out is not None:
                print(f"Results: {out}")
            sys.stdout.flush()

        return dataclasses.replace(
            options,
            isolate=chosen,
            sandbox=self.sandbox,
            step_timeout=self.step_timeout,
            checkpoint=checkpoint if out is not None else None,
            checkpoint_every=self.checkpoint_every,
            abandon=abandon,
            schedule=self.schedule,
        )


def lone_fmu_default(compiled: Any, *, sandbox: bool, record: bool) -> str:
    """``--isolate``'s default word for ``compiled``: ``guardian`` or ``fmus`` (see
    :meth:`RunSafety.resolved` for why)."""
    from fmionnx.kinds.base import FMI
    from fmionnx.kinds.registry import has_capability
    from fmionnx.runtime.guardian import GUARDIAN, available

    components = list(compiled.components)
    lone_fmu = len(components) == 1 and has_capability(components[0], FMI)
    if lone_fmu and not sandbox and not record and available() is None:
        return GUARDIAN
    return "fmus"
