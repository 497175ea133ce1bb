"""The in-process backend: one Python process, a deterministic co-simulation master."""

from __future__ import annotations

from fmionnx.compile.ir import CompiledSystem
from fmionnx.core.diagnostics import Diagnostic, make
from fmionnx.runtime.result import Backend, RunOptions, RunResult


class InProcessBackend(Backend):
    """Runs every component in this process with :class:`~.master.Master`."""

    name = "inprocess"

    def validate(self, system: CompiledSystem) -> list[Diagnostic]:
        """External components cannot run here (every kind has a runner: the kind table)."""
        problems = []
        for component in system.components:
            if component.external:
                problems.append(
                    make(
                        "E018",
                        f"component `{component.name}` is `external: true`, which only the ROS 2 "
                        "backend can provide",
                        component.span,
                        hint="run with the ROS 2 backend, or remove `external`",
                    )
                )
        return problems

    def run(self, system: CompiledSystem, options: RunOptions | None = None) -> RunResult:
        """Run ``system`` to its stop time; faults and Ctrl-C end in the result's status."""
        from fmionnx.runtime.master import Master

        return Master(system, options).run()
