"""The in-process backend: one Python process, a deterministic co-simulation master."""

from __future__ import annotations

from fmionnx.compile.ir import CompiledSystem
from fmionnx.core.diagnostics import Diagnostic, make
from fmionnx.runtime.result import Backend, RunOptions, RunResult
from fmionnx.runtime.runners import RUNNER_FACTORIES


class InProcessBackend(Backend):
    """Runs every component in this process with :class:`~.master.Master`."""

    name = "inprocess"

    def validate(self, system: CompiledSystem) -> list[Diagnostic]:
        """Every component kind needs a runner; external components cannot run here."""
        problems = []
        for component in system.components:
            if component.kind not in RUNNER_FACTORIES:
                problems.append(
                    make("E014", f"component `{component.name}`: no in-process runner for kind "
                         f"`{component.kind}`", component.span)
                )
            if component.spec.external:
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
