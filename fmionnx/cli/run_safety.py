"""What ``fmionnx run`` does so that a misbehaving model never costs the user the run.

- ``--isolate`` (default: every FMU) runs models in processes of their own: a crash, abort,
  exit or hang becomes a fault naming the component, the FMI function and the time.
- ``--step-timeout`` bounds every step; a component in this process that overruns it has
  the run abandoned with its results written (:mod:`fmionnx.runtime.watchdog`).
- Checkpoints rewrite ``results.csv`` and ``run.json`` (status ``running``) every few seconds,
  so even SIGKILL loses only the last seconds.

The decisions behind the defaults are in ``docs/security.md``.
"""

from __future__ import annotations

import dataclasses
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from fmionnx.cli.app import fail

#: Seconds of wall time between checkpoints (at least; they never cost more than a tenth).
CHECKPOINT_EVERY = 10.0


@dataclass(frozen=True)
class RunSafety:
    """The run command's isolation, timeout and checkpoint choices."""

    isolate: list[str] = field(default_factory=lambda: ["fmus"])
    sandbox: bool = False
    step_timeout: float | None = 60.0
    checkpoint_every: float = CHECKPOINT_EVERY
    plot_signals: bool = False
    #: ``parallel`` or ``sequential`` (``--schedule``; docs/execution.md, "Parallel schedule").
    schedule: str = "parallel"

    @property
    def guardian(self) -> bool:
        """``--isolate guardian``: the whole run in one guarded child process."""
        from fmionnx.runtime.guardian import GUARDIAN

        return GUARDIAN in self.isolate

    def guard(self, system: Any, run_fn: Any, *, record: bool) -> Any:
        """``run_fn`` under the guardian when ``--isolate guardian`` asks for it."""
        if not self.guardian:
            return run_fn
        from fmionnx.runtime.guardian import available, guard

        problem = available()
        if problem is not None:
            raise fail(f"--isolate guardian: {problem}")
        if record:
            raise fail("--isolate guardian does not combine with --record (the frames would "
                       "be recorded in the guarded process); isolate components by name instead")  # fmt: skip
        return guard(system.compiled, run_fn)

    def options(self, options: Any, system: Any, out: Path | None, console: Any) -> Any:
        """``options`` with isolation, the step timeout and the checkpoint/abandon writers."""
        from fmionnx.runtime.guardian import GUARDIAN
        from fmionnx.runtime.isolated.factory import isolation_targets

        words = [w for w in self.isolate if w != GUARDIAN]
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

        def checkpoint(result: Any) -> None:
            from fmionnx.results import write_results

            assert out is not None
            write_results(result, compiled, out, aliases=aliases, checkpoint=True)

        guarded = self.guardian

        def abandon(result: Any) -> None:
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
